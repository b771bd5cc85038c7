/* solvers/mg.h — geometric multigrid on the voxel grid, matrix-free: the
 * hierarchy of solver=mg (backend.h), and its solve on the host.  The cycle
 * and the outer iteration are mg_cycle.c's, over the host's operations
 * (mg.c) or an OpenCL device's (mg_device.h).
 *
 * The unknowns are cells of a regular grid, so the grid shapes the
 * hierarchy: a coarse unknown is a part of a 2x2x2 block of the finer
 * level's grid (those of the block's unknowns that strong links join:
 * mg_coarsen.h, so that no coarse unknown straddles a jump in the medium;
 * an object's irregular edge, its holes, thin parts and separate pieces
 * need nothing special), numbered by the coarse grid's cell order.
 * Interpolation is piecewise constant, so the Galerkin product P^T A P is
 * exactly a sum of conductances: a coarse link's is the sum of the fine
 * links between the two groups, a coarse unknown's sink the sum of its
 * cells' sinks; each coarse level is a sparse matrix by rows (parts of one
 * block and of the blocks beside it are its neighbours) and conserves
 * power as the fine one does.  Piecewise-constant (unsmoothed)
 * aggregation alone loses its grip as grids grow (17 iterations at 8.8e5
 * cells, 79 at 1e8 in a prototype: docs/multigrid.md); the K-cycle of Notay and
 * Vassilevski ("Recursive Krylov-based multigrid cycles", Numer. Linear
 * Algebra Appl. 15, 2008) restores it: each coarse correction is up to two
 * steps of flexible CG preconditioned by the next level's cycle, as in
 * AGMG (Notay, "An aggregation-based algebraic multigrid method", ETNA 37,
 * 2010).  The smoother is two Chebyshev steps on D^-1 A; the coarsest level
 * (at most a few hundred cells) is solved by a dense Cholesky factor.
 *
 * The cycle runs in single precision, on the network's own stencil (its
 * links are single precision already, network.h) with its own inverse
 * diagonal: a preconditioner need only be near A^-1, and floats halve the
 * bytes its passes stream.  The outer iteration is flexible CG (the
 * K-cycle is not a fixed linear operator) in double precision on the same
 * stencil, stopping, like solver=cg, at ||b - A x||_2 <= tol ||b||_2 of the
 * true residual, and once the power balance holds to tol as well
 * (ohm_mg_solve): the solution and the books are as exact as a
 * double-precision cycle's.
 *
 * Memory per unknown: the network's stencil (20 B, the driver's, and its
 * runs), the inverse diagonal (4 B), the aggregate map (4 B), the outer
 * residual and A p in double and its direction in single (20 B), three of
 * the cycle's vectors in single (12 B: its right-hand side, its result, and
 * one temporary, the post-smoothing done in place), and the coarse levels
 * (a fifth to an eighth as many unknowns each, with their rows of about
 * eight links, 8 B each, their map and up to seven vectors): 79 and 85 B
 * per unknown in all, the stencil's included, on the scale study's and the
 * nine-level block media at 1e7 cells through a scan (the statistics'
 * solver_bytes; 69.8 with fixed blocks: docs/multigrid.md). */
#ifndef OHM_SOLVERS_MG_H
#define OHM_SOLVERS_MG_H

#include <stdint.h>

#include "base/log.h"
#include "base/ohm_error.h"
#include "physics/network.h"
#include "solvers/grid_order.h"
#include "solvers/mg_coarsen.h"
#include "solvers/mg_ops.h"

typedef struct ohm_mg ohm_mg;

/* The hierarchy for st (the network's stencil; it must outlive the
 * hierarchy, which reads it as its finest level), whose unknowns sit where
 * layout says.  threads: cores the cycle may use (<= 0: all usable). */
int ohm_mg_setup(ohm_mg **out, const ohm_stencil *st, const ohm_grid_layout *layout, int threads, ohm_error *err);

/* Solve A x = b from the x given (a warm start; zeros are fine); stop at
 * ||b - A x||_2 <= tol ||b||_2 with |sum(b - A x)| <= tol sum|b| (the
 * power balance: A's column sums are the sinks), or (a nearly singular A's
 * floor) at a
 * scaled backward error below tol / 100 once the residual stagnates.
 * *iters: iterations taken, *relres: the final relative residual.
 * OHM_ERR_NUMERIC when max_iter pass first; OHM_ERR_CANCELLED when log's
 * cancel flag is set (checked every iteration, progress reported by
 * residual). */
int ohm_mg_solve(ohm_mg *mg, double *x, const double *b, double tol, int64_t max_iter, const ohm_log *log,
                 int64_t *iters, double *relres, ohm_error *err);

/* The cores the cycle and the outer iteration use from now on (<= 0: all
 * usable).  The sums go in a fixed order on any number of cores, so a
 * solve's bits do not depend on it (stencil_rows.h). */
void ohm_mg_set_threads(ohm_mg *mg, int threads);

/* z = M r, one application of the preconditioner (one cycle, in single
 * precision), scaled to approximate A^-1 r: what each outer iteration
 * does, for measuring it (tests/bench_mg.c). */
void ohm_mg_precondition(ohm_mg *mg, const double *r, double *z);

/* The bytes one ohm_mg_precondition streams, counted kernel by kernel from
 * the levels' sizes (each array once per pass, as STREAM's triad counts):
 * its bandwidth bound at a measured triad rate. */
double ohm_mg_cycle_bytes(const ohm_mg *mg);

/* ||A||_inf of the network's stencil, as the solve's stopping tests use it. */
double ohm_mg_norm_inf(const ohm_mg *mg);

/* Levels, and cells summed over them (the finest included). */
int ohm_mg_levels(const ohm_mg *mg, int64_t *cells);

/* Bytes the hierarchy holds beside the fine stencil, as allocated. */
double ohm_mg_bytes(const ohm_mg *mg);

/* The estimate before anything is built, for n unknowns: the stencil's,
 * the hierarchy's and the outer vectors' bytes. */
double ohm_mg_bytes_estimate(int64_t n);

void ohm_mg_free(ohm_mg *mg); /* NULL is fine */

/* The hierarchy as built, read-only, for running its cycle elsewhere (an
 * OpenCL device: mg_device.h).  Level l's stencil (physics/stencil_form.h; level
 * 0's is the network's), its inverse diagonal, its map into level l + 1
 * (NULL at the coarsest) and whether the K-cycle solves it; the coarsest
 * level's dense lower Cholesky factor (ndense x ndense, row-major). */
typedef struct ohm_mg_level_view {
    int64_t n;
    const ohm_stencil *st;   /* level 0's, or NULL */
    const ohm_mg_sparse *sp; /* a coarse level's rows (mg_coarsen.h), or NULL */
    const float *invd;
    const int32_t *agg;
    int kcycle;
} ohm_mg_level_view;

typedef struct ohm_mg_view {
    const ohm_stencil *fine; /* the outer iteration's operator */
    double norm_A;
    int nlevels;
    ohm_mg_level_view lev[OHM_MG_LEVELS_MAX];
    const double *dense;
    int64_t ndense;
} ohm_mg_view;

void ohm_mg_view_of(const ohm_mg *mg, ohm_mg_view *view);

#endif
