/* solvers/cg.h — the iterative alternative to the Cholesky factor: conjugate
 * gradients preconditioned with a modified incomplete Cholesky factor
 * (MIC(0)), for grids too big to factor or scenes with one light.
 *
 * It needs only A and five vectors (no fill), so its memory is O(n) where the
 * factor's is O(n^(4/3)); its time is O(n) per iteration, and the iteration
 * count grows with the condition number (MIC(0) brings kappa from O(h^-2) to
 * about O(h^-1) for diffusion matrices: Gustafsson 1978; Saad, "Iterative
 * Methods for Sparse Linear Systems", 2nd ed., section 10.3.5).  Every
 * solve starts from the caller's x (a warm start: the previous frame's
 * solution changes little when a light moves a little).
 *
 * The preconditioner is built in the D-ILU form M = (D + L) D^-1 (D + L^T),
 * L the strict lower triangle of A: the network couples only face
 * neighbours of a cubic grid, a bipartite graph with no triangles, so IC(0)
 * has no fill inside the pattern and only D needs computing. */
#ifndef OHM_CG_H
#define OHM_CG_H

#include <stdint.h>

#include <cholmod.h>

#include "base/log.h"
#include "base/ohm_error.h"

typedef struct ohm_cg {
    const cholmod_sparse *A; /* upper triangle, CSC, diagonal last in each column (not owned) */
    int64_t n;
    double *d;               /* MIC(0) pivots                                    */
    double *r, *z, *p, *q;   /* work vectors                                     */
    double omega;            /* modification weight (0 = IC(0), 1 = full MIC)    */
    double norm_A;           /* ||A||_inf, for the scaled backward error          */
    double t_setup;          /* seconds                                          */
    const ohm_log *log;      /* progress by residual, and cancellation checked
                                every iteration; NULL: neither                   */
} ohm_cg;

/* Build the preconditioner for A (the network's matrix: symmetric, upper
 * triangle stored, an M-matrix). */
int ohm_cg_setup(ohm_cg *cg, const cholmod_sparse *A, ohm_error *err);
void ohm_cg_free(ohm_cg *cg);

/* Solve A x = b from the x given; stop when ||b - A x||_2 <= tol ||b||_2.
 * A nearly singular A (almost no absorption and no leak) leaves a residual
 * floor of about kappa eps ||b|| that CG cannot pass; when CG stagnates there,
 * the solve is accepted if its scaled backward error ||b - A x||_inf /
 * (||A|| ||x|| + ||b||)_inf is below tol / 100 — as small as a converged
 * solve's (the same test the direct solver passes; solvers/direct.h).
 * *iters gets the iterations taken and *relres the final relative residual.
 * Fails (OHM_ERR_NUMERIC) otherwise. */
int ohm_cg_solve(ohm_cg *cg, double *x, const double *b, double tol, int64_t max_iter, int64_t *iters,
                 double *relres, ohm_error *err);

/* Bytes CG holds beside A for n unknowns (for the memory estimate). */
double ohm_cg_bytes(int64_t n);

#endif
