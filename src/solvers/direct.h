/* solvers/direct.h — sparse Cholesky with CHOLMOD (64-bit cholmod_l_*), the
 * paper's precomputed quantity, and the `direct` backend over it
 * (backend.h).  One analysis (fill-reducing ordering + symbolic
 * factor) per grid, shared by every channel's numeric factorization; many
 * right-hand sides per solve; every solve checks its scaled backward error
 * ||Ax - b|| / (||A|| ||x|| + ||b||) (infinity norms), refines once when it is
 * above 1e-12, and fails when refinement leaves it above 1e-10 — because
 * CHOLMOD itself may return TRUE on an indefinite or singular matrix
 * (docs/design.md §3, "Numerical traps").  The solver owns its cholmod_common: no
 * global state. */
#ifndef OHM_SOLVERS_DIRECT_H
#define OHM_SOLVERS_DIRECT_H

#include <stddef.h>

#include <cholmod.h>

#include "base/log.h"
#include "base/ohm_error.h"
#include "solvers/backend.h"
#include "solvers/grid_order.h"

/* A solve of a few columns substitutes over the factor's arrays
 * (substitute.h) on one core while the factor's stored values take at most
 * this many bytes; above, cholmod_solve's BLAS calls run on every core.
 * tests/test_substitute time (best of 5, interleaved, this 2-core VM):
 * substitution took 0.38 / 5.7 / 21 ms where cholmod_solve took 0.76 / 8.3
 * / 30 ms for factors of 7 / 48 / 157 MB, but 102 against 89 ms at 894 MB. */
#define OHM_SUBSTITUTE_MAX_BYTES 256e6

typedef struct ohm_cholesky {
    cholmod_common cc;
    int started;
    cholmod_factor *symbolic;   /* from analyze; copied for each factorization */
    char ordering[16];          /* the ordering used: metis, amd, nesdis, grid  */
    double t_analyze;           /* seconds                                      */
    double nnz_L;               /* entries of L (from the analysis)             */
    double flops;               /* floating-point operations of one factorization */
    double nnz_A;               /* entries of A (upper triangle)                */
    double norm_A;              /* ||A||_inf of the last factorized matrix      */
    double *work;               /* substitution's work space (substitute.h)     */
    size_t work_size;           /* its doubles                                  */
} ohm_cholesky;

int ohm_cholesky_start(ohm_cholesky *s, ohm_error *err);
void ohm_cholesky_finish(ohm_cholesky *s); /* frees everything; fine on a zeroed solver */

/* What ordering=auto weighs: the work to come with this analysis. */
typedef struct ohm_ordering_costs {
    double factors;  /* numeric factorizations (distinct materials); 0: 1 */
    double columns;  /* right-hand sides to be solved; 0: 1               */
    double batch;    /* of them solved per call (the factor's memory); 0: 1 */
    double max_memory; /* bytes the factor may take; 0: what the machine has */
    int from_scan;   /* the object is a density volume's (thin shells and
                        convoluted surfaces: METIS leaves less fill than grid) */
} ohm_ordering_costs;

/* ordering: "metis" | "amd" | "nesdis" | "grid" (grid_order.h: needs the
 * unknowns' layout) | "best" (tries METIS, AMD and, given the layout, grid;
 * keeps the one with the smaller factor) | "auto" (grid, then METIS only
 * when the cost model predicts it pays for its own analysis over `costs`'
 * factorizations and solves; direct.c).  layout and costs may be NULL. */
int ohm_cholesky_analyze(ohm_cholesky *s, cholmod_sparse *A, const char *ordering, const ohm_grid_layout *layout,
                         const ohm_ordering_costs *costs, const ohm_log *log, ohm_error *err);

/* Numeric factor of A (same pattern as analysed): into *L when it holds an
 * earlier factor of this analysis (refactorized in place), else into a new
 * copy of the symbolic factor.  t: seconds.  On failure *L is freed.  log:
 * progress, and its cancellation stops the factorization (factor_watch.h). */
int ohm_cholesky_factorize(cholmod_factor **L, ohm_cholesky *s, cholmod_sparse *A, double *t, const ohm_log *log,
                           ohm_error *err);

/* Solve A X = B for ncols columns (column-major, n rows each): by
 * substitution over a supernodal factor for a few columns (substitute.h),
 * by cholmod_solve otherwise.  *berr gets the
 * largest scaled backward error over the columns, *refined whether a step of
 * iterative refinement was taken. */
int ohm_cholesky_solve(double *X, ohm_cholesky *s, cholmod_factor *L, cholmod_sparse *A, const double *B, size_t ncols,
                     double *berr, int *refined, ohm_error *err);

void ohm_cholesky_factor_free(cholmod_factor **L, ohm_cholesky *s);

#endif
