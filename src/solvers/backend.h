/* solvers/backend.h — the seam between the light-transport driver (solve.c,
 * with sources.c, batch.c and booking.c: solver_impl.h) and the linear
 * solvers behind it (docs/design.md §4).
 *
 * A backend solves A X = B for the network's matrix A (symmetric positive
 * definite) in the spirit of PETSc's KSP/PC: an object chosen at run time by
 * name, configured from one parameter block, set up once per distinct channel
 * material (`setup`), then asked to solve any number of blocks of right-hand
 * sides (`solve`) — the paper's point: a light change never sets up again.
 * A reaches it as an ohm_operator (below) in the one form it reads: CHOLMOD's
 * compressed columns (upper triangle, 64-bit indices) for the backends that
 * factor A or build a preconditioner from its entries, or the network's
 * 7-point stencil (network.h) for a matrix-free one (OHM_BACKEND_STENCIL).
 *
 *   direct  CHOLMOD's supernodal Cholesky factor (solvers/direct.c), the
 *           paper's factor-once; one symbolic analysis per grid.
 *   cg      MIC(0)-preconditioned conjugate gradients (solvers/cg.c): O(n)
 *           memory, warm-started from the caller's X.
 *   amg     PETSc KSP CG preconditioned by hypre BoomerAMG (solvers/amg.c),
 *           distributed over MPI ranks when ohm runs under mpirun.
 *   auto    chooses among direct, cg, amg and mg by memory, then predicted
 *           time (solvers/auto.c).
 *   mg      geometric multigrid on the voxel grid (solvers/mg.c), matrix-free
 *           on the stencil: O(n) memory and time, warm-started.
 *
 * Monte Carlo transport (solver=mc) is not a backend: it solves no matrix,
 * and the driver calls it through its own interface (solvers/transport.h).
 *
 * Every backend's solve leaves in *berr the largest scaled backward error
 * ||b - A x||_inf / (||A||_inf ||x||_inf + ||b||_inf) of its columns,
 * computed by ohm_backward_error (one definition for all), and fails with
 * OHM_ERR_NUMERIC rather than return an inaccurate X.  Ownership: a backend
 * never keeps A beyond the setup/solve calls that pass it, except that
 * `solve` is always called with the A of the latest `setup`. */
#ifndef OHM_SOLVERS_BACKEND_H
#define OHM_SOLVERS_BACKEND_H

#include <stddef.h>
#include <stdint.h>

#include <cholmod.h>

#include "base/log.h"
#include "base/ohm_error.h"
#include "device/request.h"
#include "solvers/grid_order.h"

/* What a backend did, summed over its setups and solves (the driver copies it
 * into the run's statistics). */
typedef struct ohm_backend_report {
    char solver[8];             /* direct | cg | amg | mg: what actually ran   */
    char reason[256];           /* why this backend (auto), or "asked for"     */
    int analyses;               /* symbolic analyses (direct)                  */
    int factors;                /* numeric factorizations (direct)             */
    int precond_setups;         /* preconditioner setups (cg, amg, mg)         */
    double t_analyze;           /* seconds: ordering + symbolic analysis       */
    double t_factor;            /* seconds: numeric factorizations             */
    double t_precond;           /* seconds: preconditioner setups              */
    double nnz_A, nnz_L, flops; /* direct: the factor's size and cost          */
    char ordering[16];          /* direct: metis | amd | nesdis | grid         */
    int64_t iterations;         /* iterative backends: summed over columns     */
    double relres;              /* iterative backends: largest final ||r||/||b|| */
    double tol;                 /* iterative backends: the ||r||/||b|| asked (cg_tol) */
    int64_t stalled;            /* iterative backends: columns accepted short of tol
                                   (at the iteration cap or a residual floor, their
                                   scaled backward error small): the driver warns */
    int refined;                /* direct: solves that took a refinement step  */
    double bytes;               /* memory the backend holds at most (estimate) */
    int ranks;                  /* MPI ranks that took part (amg), else 1      */
    int levels;                 /* mg: the hierarchy's levels                  */
    char device[96];            /* mg: the OpenCL device its cycle ran on; "": the host */
} ohm_backend_report;

/* The network's matrix in the form the backend reads: A (assembled) or
 * stencil (OHM_BACKEND_STENCIL), the other NULL; n unknowns.  make_stencil
 * builds the stencil of the same matrix on demand, for a backend given A
 * that hands over to a stencil backend (auto choosing mg); it stays the
 * driver's, valid as long as A. */
typedef struct ohm_operator {
    int64_t n;
    cholmod_sparse *A;
    const ohm_stencil *stencil;
    int (*make_stencil)(void *maker, const ohm_stencil **out, ohm_error *err);
    void *maker;
} ohm_operator;

/* y = A x, whichever form op holds. */
void ohm_operator_apply(const ohm_operator *op, const double *x, double *y);

/* A's diagonal entry of row v. */
double ohm_operator_diag(const ohm_operator *op, int64_t v);

/* ||A||_inf. */
double ohm_operator_norm_inf(const ohm_operator *op);

/* Parameters of every backend; zero means the default. */
typedef struct ohm_backend_config {
    const char *ordering;      /* direct: auto | metis | amd | nesdis | grid | best */
    const ohm_grid_layout *layout; /* direct: the unknowns' grid cells (ordering=grid); may be NULL */
    double tol;                /* iterative: stop at ||b - A x|| <= tol ||b||; 0: 1e-10 */
    int64_t max_iter;          /* iterative: 0: 20000                            */
    const char *petsc_options; /* amg: passed to PETSc's options database         */
    double max_memory;         /* bytes the backend may take; 0: what the machine has */
    size_t batch;              /* most columns per solve call (for memory estimates) */
    double columns;            /* columns to be solved in all (auto's cost model) */
    int materials;             /* distinct channel materials = setups to come   */
    int from_scan;             /* direct, ordering=auto: the object is a scan's */
    ohm_device_request device; /* mg: where the solve runs (mg_device.h; zero: the host) */
    const ohm_log *log;
} ohm_backend_config;

typedef struct ohm_backend_ops {
    const char *name;
    int (*create)(void **state, const ohm_backend_config *cfg, ohm_error *err);
    /* Once per distinct channel material; A keeps its pattern from call to
     * call within one run (same grid), only its values change. */
    int (*setup)(void *state, const ohm_operator *op, ohm_backend_report *rep, ohm_error *err);
    /* X (n x ncols, column-major): on entry its first column holds a
     * starting guess (an iterative backend may use it; zeros are fine), and
     * the columns are consecutive frames, so it may start each later column
     * from the solution of the one before (cg does, amg measured no gain);
     * on return, the solutions. */
    int (*solve)(void *state, const ohm_operator *op, const double *B, double *X, size_t ncols, double *berr,
                 ohm_backend_report *rep, ohm_error *err);
    void (*destroy)(void *state); /* NULL is fine */
    /* Optional: drop what setup built, before the driver refills the
     * operator for the next channel and calls setup again, so that the old
     * set-up and the new assembly are not held at once.  NULL: setup
     * replaces it itself. */
    void (*release)(void *state);
    unsigned caps;                /* OHM_BACKEND_* below: what the driver may do */
    /* With OHM_BACKEND_CONCURRENT_SOLVES: only while the backend holds at
     * most this many bytes (its report's bytes, every set-up together) */
    double concurrent_max_bytes;
} ohm_backend_ops;

/* What a backend allows the driver (solve.c), asked instead of which backend
 * it is.
 *
 * OHM_BACKEND_CONCURRENT_SOLVES: solves with different set-ups may run on
 * separate threads at once — each touches only its own set-up's state and
 * work space, calls nothing that is not thread-safe, and (while the backend
 * holds at most concurrent_max_bytes) runs on one core, so two at once take
 * the time of about one.  direct: a substitution over a small factor
 * (OHM_SUBSTITUTE_MAX_BYTES, direct.h); a larger factor's solve already
 * runs on every core through the BLAS.  Not cg (it warm-starts a channel
 * from the channel solved before it), not amg (PETSc is not thread-safe),
 * not auto (it may switch backends inside a solve). */
enum { OHM_BACKEND_CONCURRENT_SOLVES = 1u << 0 };

/* OHM_BACKEND_WARM_START: solve uses X's first column as its starting
 * guess, so the driver fills it (ohm_warm_start: this frame of a channel
 * solved before, another colour of the same light); without it X is only
 * written.  cg and amg; auto passes it on to what it chose. */
enum { OHM_BACKEND_WARM_START = 1u << 1 };

/* OHM_BACKEND_STENCIL: matrix-free: the operator it is given holds the
 * network's stencil, not an assembled A (mg). */
enum { OHM_BACKEND_STENCIL = 1u << 3 };

extern const ohm_backend_ops ohm_backend_direct, ohm_backend_cg, ohm_backend_amg, ohm_backend_mg, ohm_backend_auto;

/* Whether this build has the amg backend (PETSc); when not, its create fails
 * with a message saying so.  Whether this process has started PETSc and MPI
 * already (under mpirun, or at an earlier solver=amg): the first start costs
 * a fixed ~0.3 s, which solver=auto counts. */
int ohm_backend_amg_available(void);
int ohm_backend_amg_started(void);

/* An iterative backend's configuration defaults: tol 1e-10, max_iter as
 * given (cfg's own when set). */
void ohm_backend_iterative_defaults(ohm_backend_config *cfg, int64_t max_iter);

/* One column of an iterative backend: x (its starting guess on entry) for b;
 * the iterations taken and the final relative residual. */
typedef int (*ohm_column_solver)(void *solver, double *x, const double *b, int64_t *iters, double *relres,
                                 ohm_error *err);

/* Columns an iterative backend solved, booked in rep: their iterations,
 * their largest final relative residual, the tolerance asked, and how many
 * of them were accepted short of it (rep->stalled; the driver warns). */
void ohm_backend_book_columns(ohm_backend_report *rep, int64_t iters, double relres, double tol, int64_t stopped_short);

/* The ncols columns of X (n each) one by one, each after the first started
 * from the solution of the one before (consecutive frames), each booked in
 * rep (ohm_backend_book_columns; a column left above tol stopped short). */
int ohm_backend_solve_columns(ohm_column_solver fn, void *solver, size_t n, const double *B, double *X, size_t ncols,
                              double tol, ohm_backend_report *rep, ohm_error *err);

/* OHM_OK when `need` bytes fit the limit (max_memory > 0, else what the
 * machine has available); else OHM_ERR_NOMEM with one message for every
 * backend: "solve: WHAT needs about X[DETAIL], more than the Y max_memory=
 * allows; ADVICE". */
int ohm_backend_check_memory(double need, double max_memory, const char *what, const char *detail,
                             const char *advice, ohm_error *err);

/* amg's memory per rank for n cells (nnz_upper entries in A's upper
 * triangle) on that many ranks, estimated before anything is built; and the
 * ranks this process solves with (1 until MPI has started). */
double ohm_amg_bytes_per_rank(int64_t n, double nnz_upper, int ranks);
int ohm_mpi_ranks(void);

/* The scaled backward error ||r||_inf / (normA ||x||_inf + ||b||_inf) of one
 * column whose residual r = b - A x is known (0 when both norms are 0). */
double ohm_scaled_backward_error(const double *b, const double *x, const double *r, size_t n, double normA);

/* Largest scaled backward error over ncols columns of A X = B (infinity
 * norms); normA: ||A||_inf, or <= 0 to compute it.  The same for an
 * assembled A. */
double ohm_operator_backward_error(const ohm_operator *op, const double *B, const double *X, size_t ncols,
                                   double normA);
double ohm_backward_error(cholmod_sparse *A, const double *B, const double *X, size_t ncols, double normA);

/* ||A||_inf of the upper-stored symmetric A (= ||A||_1). */
double ohm_sym_upper_norm_inf(const cholmod_sparse *A);

/* y = A x for the upper-stored symmetric A. */
void ohm_sym_upper_mult(const cholmod_sparse *A, const double *x, double *y);

#endif
