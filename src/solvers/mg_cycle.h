/* solvers/mg_cycle.h — the multigrid's algorithm, written once over a
 * machine's operations (mg_ops.h): the smoother's coefficients, the
 * K-cycle, and the outer flexible CG of solver=mg, on the host (mg.c) and
 * on an OpenCL device (mg_device.c) alike.  The hierarchy and its
 * arithmetic: mg.h, docs/multigrid.md. */
#ifndef OHM_SOLVERS_MG_CYCLE_H
#define OHM_SOLVERS_MG_CYCLE_H

#include <stdint.h>

#include "base/log.h"
#include "base/ohm_error.h"
#include "solvers/mg_ops.h"

/* The Chebyshev smoother's two steps' coefficients (ohm_mg_ops' smooth):
 * the first step's weight w0; the second's a (on x1 - y) and a2 (on the
 * Jacobi residual). */
void ohm_mg_smoother(double *w0, double *a, double *a2);

/* s for the cycle's right-hand side s r: ||A||_inf / ||r||, so that it is
 * at most ||A||_inf (1 when r is 0). */
double ohm_mg_rhs_scale(double norm_A, double nr);

/* A machine of nlevels levels with these operations on self, for n
 * unknowns; then each level's shape and vectors: b, x, t, c1, v1, c2, rt
 * (ohm_mg_level_vecs' order). */
void ohm_mg_machine_init(ohm_mg_machine *mc, const ohm_mg_ops *ops, void *self, int64_t n, double norm_A,
                         int nlevels);
void ohm_mg_machine_level(ohm_mg_machine *mc, int l, int64_t n, int kcycle, const ohm_mg_vec vecs[7]);

/* Level 0's x = M b, its b already there: one cycle (the dense solve when
 * the hierarchy is one level). */
void ohm_mg_cycle_level0(const ohm_mg_machine *mc);

/* Solve A x = b on the machine from the x given: ohm_mg_solve's contract
 * (mg.h). */
int ohm_mg_fcg(const ohm_mg_machine *mc, double *x, const double *b, double tol, int64_t max_iter,
               const ohm_log *log, int64_t *iters, double *relres, ohm_error *err);

#endif
