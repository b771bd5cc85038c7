/* bench.h — `ohm bench`: the seed paper's Table 2 (run-time statistics of the
 * Cholesky precomputation) for any mesh, measured against this machine.
 *
 * For each grid size the mesh's bounding box is fitted into that many cells,
 * as the paper did, and ohm_solve runs one light per frame (a directional
 * light orbiting the object) with one factorization per distinct channel.  The
 * table gives factor, source and solve times, nnz(A), nnz(L) and the paper's
 * "upper bound fill", the per-light update time, and two machine-relative
 * figures: each solve against the memory-bandwidth bound of reading L twice,
 * and each factorization's flop rate against dense dgemm, both measured in
 * the same run (a STREAM-like triad and a BLAS dgemm).  Markdown on stdout
 * (and md=), CSV with every raw figure (csv=), progress on stderr.
 *
 * Nothing here asserts a speed: it prints figures (tests never time
 * anything: speed is what benchmarks print). */
#ifndef OHM_BENCH_H
#define OHM_BENCH_H

/* argc/argv: the words after `bench` (key=value, or `help`).  Returns the
 * process exit code: 0 done, 1 a step failed, 2 bad usage (one line on stderr
 * naming the word). */
int ohm_bench_main(int argc, char **argv);

#endif
