/* solvers/substitute.h — one right-hand side through CHOLMOD's supernodal
 * factor, P A P^T = L L^T, by forward and back substitution over the
 * factor's own arrays (docs/bench-notes.md).
 *
 * Why not cholmod_solve: for one column it makes a dense triangular solve
 * and a dense matrix-vector call into the BLAS for every supernode, and the
 * factor of a voxel grid has thousands of supernodes of a few columns each;
 * the calls, not the memory, then set the time (about 7x the bandwidth
 * bound at 28 000 cells, ohm bench).  Here each supernode is one pass over
 * its columns with a dense work vector: for column j, w[j] /= L[j][j] and
 * w[j+1..nsrow] -= L[j+1.., j] w[j] (contiguous, vectorizable), then one
 * scatter of the rows below the supernode; the back substitution mirrors
 * it with one gather and dot products.  L is read once each way, which is
 * the bandwidth bound's traffic.  Results agree with cholmod_solve to
 * rounding (tests/test_substitute.c); the caller keeps checking every
 * solve's backward error. */
#ifndef OHM_SOLVERS_SUBSTITUTE_H
#define OHM_SOLVERS_SUBSTITUTE_H

#include <stddef.h>

#include <cholmod.h>

/* Whether ohm_substitute can use this factor: a numeric supernodal LL^T
 * factor in double precision (cholmod_l_*). */
int ohm_substitute_supports(const cholmod_factor *L);

/* Doubles of work space ohm_substitute needs for L: n + the tallest
 * supernode's rows. */
size_t ohm_substitute_work_size(const cholmod_factor *L);

/* x = A^-1 b for one column, A = P^T L L^T P.  x and b have L->n entries
 * and may not overlap; work holds ohm_substitute_work_size(L) doubles. */
void ohm_substitute(double *x, const cholmod_factor *L, const double *b, double *work);

#endif
