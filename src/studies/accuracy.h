/* accuracy.h — `ohm accuracy`: the speed/accuracy trade of a scene, measured
 * (docs/accuracy.md): a resolution series per material against a finer reference and
 * its Richardson extrapolation, both solvers timed, depth bands against the
 * full solve, and the half-space scene against its exact solution.  Prints
 * figures; asserts nothing (tests/cli_accuracy.sh does, on a small run).  The
 * error measure and the scene's solve are outputs/exitance_probe.h's, shared
 * with -voxelize error= (steps/resolution.h). */
#ifndef OHM_ACCURACY_H
#define OHM_ACCURACY_H

/* argc/argv: the words after `accuracy`.  Returns the exit code: 0 done, 1 a
 * step failed, 2 bad usage. */
int ohm_accuracy_main(int argc, char **argv);

#endif
