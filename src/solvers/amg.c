/* solvers/amg.c — solver=amg: PETSc's KSP CG preconditioned by hypre's
 * BoomerAMG (backend.h), set up once per channel material and reused for
 * every light and frame; distributed over the MPI ranks of an mpirun.
 *
 * Rank 0 runs the whole ohm pipeline (reads, voxelizes, assembles, computes
 * sources, writes); the other ranks only serve this backend (ohm_mpi_serve):
 * they wait for a command from rank 0 — set up a matrix, solve a block of
 * columns, destroy, exit — without spinning (a poll every millisecond, so an
 * idle worker leaves the core to rank 0's serial stages).  Each rank owns a
 * contiguous block of unknowns; the unknowns are numbered in cell order
 * (x fastest, z slowest), so a block is a slab of the object, balanced by
 * cell count.  Rank 0 sends each rank its rows of A, scatters each
 * right-hand side and gathers each solution; the backward-error check runs
 * on rank 0 against the whole A, as for every backend.
 *
 * MPI and PETSc are initialised once per process (that is what MPI allows):
 * at start under mpirun, else at the first solver=amg.  This file's one
 * static record (`proc`) is that process-wide state.  A PETSc error on one
 * rank of several cannot be reported without risking a hang in the others'
 * collectives, so it ends the whole run (MPI_Abort) after one line naming
 * the rank; with one process it is an ordinary ohm error.  Convergence
 * failures are seen alike by every rank and are ordinary errors.
 *
 * Built only with PETSc (OHM_HAVE_PETSC); without it the backend exists and
 * says how to get it. */
#include "solvers/backend.h"
#include "solvers/amg.h"

/* Bytes per cell one rank holds for its share of the cells: A in PETSc's
 * AIJ form and hypre's copy of it (7 entries a row, 12 bytes each), the
 * hierarchy and interpolation, and CG's vectors: with the rows in transit,
 * about 390 B per cell measured from 1e6 to 2.7e7 cells (docs/scale.md). */
static const double AMG_BYTES_PER_CELL = 300.0;

double ohm_amg_bytes_per_rank(int64_t n, double nnz_upper, int ranks)
{
    if (ranks < 1) ranks = 1;
    /* rank 0 also holds one rank's rows in transit (12 bytes per entry of
     * both triangles) while it sends them */
    return (AMG_BYTES_PER_CELL * (double)n + 12.0 * 2.0 * nnz_upper) / ranks;
}

#ifdef OHM_HAVE_PETSC

#include <petscksp.h>

#include "base/memory.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>

/* BoomerAMG settings for the 3-D network: HMIS coarsening with ext+i
 * interpolation truncated to 4 entries keeps the operator complexity low in
 * 3-D (De Sterck, Yang, Heys, SIAM J. Matrix Anal. Appl. 27, 2006; Yang,
 * "Parallel algebraic multigrid methods", 2006), a strong threshold of 0.5 is
 * hypre's advice for 3-D problems, and one level of aggressive coarsening
 * cuts the setup.  Forward Gauss-Seidel before the coarse grid and backward
 * after keeps the V-cycle symmetric, as CG needs, at half the sweeps of
 * symmetric SOR on both sides (PETSc's default): on a random block medium of
 * 1e6 cells with 1e6 contrasts, 91 ms per iteration against 111, 15
 * iterations against 14 (docs/scale.md).  Each sweep visits the cells in
 * their own order rather than C points first and F points after (hypre's
 * default "CF" order, a branch per row on a random C/F pattern): on the
 * same medium at 1.26e6 cells, 54 ms per iteration against 77, 16
 * iterations against 15; at 1.1e7 cells 8.0 s per light against 11.3.  The
 * user's petsc_options come after these and win
 * (-pc_hypre_boomeramg_no_CF false restores the CF order). */
static const char *const AMG_DEFAULTS[][2] = {
    {"-pc_hypre_boomeramg_coarsen_type", "HMIS"},
    {"-pc_hypre_boomeramg_interp_type", "ext+i"},
    {"-pc_hypre_boomeramg_P_max", "4"},
    {"-pc_hypre_boomeramg_strong_threshold", "0.5"},
    {"-pc_hypre_boomeramg_agg_nl", "1"},
    {"-pc_hypre_boomeramg_relax_type_down", "SOR/Jacobi"},
    {"-pc_hypre_boomeramg_relax_type_up", "backward-SOR/Jacobi"},
    {"-pc_hypre_boomeramg_no_CF", "true"},
};

enum { CMD_SETUP = 1, CMD_SOLVE = 2, CMD_DESTROY = 3, CMD_EXIT = 4 };

typedef struct amg_cmd {
    int64_t op;
    int64_t n;        /* unknowns                         */
    int64_t ncols;    /* solve: columns                   */
    int64_t max_iter;
    int64_t opt_len;  /* setup: bytes of petsc_options + 1 */
    double tol;
} amg_cmd;

/* The process's MPI role (see the top of this file). */
static struct {
    int initialized; /* PETSc (and MPI) started by ohm      */
    int rank, size;
    MPI_Comm comm;   /* ohm's own duplicate of the world    */
    char msg[512];   /* the first message of the latest PETSc error */
} proc;

/* One rank's part of a set-up system. */
typedef struct amg_state {
    ohm_backend_config cfg;
    Mat A;
    KSP ksp;
    Vec x, b;
    PetscOptions opts;
    int64_t n, row0, rows;    /* global size; this rank's first row and count */
    int *counts, *displs;     /* rank 0: rows per rank, first row per rank     */
    int checked_options;      /* unused user options looked for (after a solve) */
    double norm_A;
    double t_rows, t_matrix, t_hierarchy; /* the latest setup's parts, seconds */
} amg_state;

static PetscErrorCode keep_message(MPI_Comm comm, int line, const char *fun, const char *file, PetscErrorCode n,
                                   PetscErrorType p, const char *mess, void *ctx)
{
    (void)comm, (void)line, (void)file, (void)ctx;
    if (p == PETSC_ERROR_INITIAL)
        snprintf(proc.msg, sizeof proc.msg, "PETSc: %s (in %s, error %d)", mess && *mess ? mess : "error", fun,
                 (int)n);
    return n;
}

/* A PETSc call that failed: an ohm error with one process; with several,
 * one line naming the rank and the end of the run (no rank may hang in a
 * collective the failed one never reaches). */
static int petsc_failed(ohm_error *err, const char *what)
{
    if (proc.size > 1) {
        fprintf(stderr, "ohm: error: solve: amg: rank %d: %s: %s\n", proc.rank, what, proc.msg);
        fflush(stderr);
        MPI_Abort(MPI_COMM_WORLD, 1);
    }
    return ohm_fail(err, OHM_ERR_NUMERIC, "solve: amg: %s: %s", what, proc.msg);
}

#define PCALL(what, call)                                                                                             \
    do {                                                                                                              \
        if ((call) != 0) return petsc_failed(err, what);                                                            \
    } while (0)

static int start(ohm_error *err)
{
    if (proc.initialized) return OHM_OK;
    /* ohm handles its own signals (SIGINT/TERM remove in-flight outputs) */
    PetscOptionsSetValue(NULL, "-no_signal_handler", NULL);
    if (PetscInitializeNoArguments() != 0)
        return ohm_fail(err, OHM_ERR_INTERNAL, "solve: amg: PETSc failed to start (MPI_Init)");
    PetscPushErrorHandler(keep_message, NULL);
    MPI_Comm_rank(PETSC_COMM_WORLD, &proc.rank);
    MPI_Comm_size(PETSC_COMM_WORLD, &proc.size);
    MPI_Comm_dup(PETSC_COMM_WORLD, &proc.comm);
    proc.initialized = 1;
    return OHM_OK;
}

int ohm_backend_amg_available(void) { return 1; }

int ohm_backend_amg_started(void) { return proc.initialized; }

int ohm_mpi_ranks(void) { return proc.initialized ? proc.size : 1; }

int ohm_mpi_start(void)
{
    /* launched by mpirun (Open MPI, MPICH/PMI, PMIx): start now, so the
     * workers know they are workers */
    const char *vars[] = {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK"};
    int launched = 0;
    for (size_t i = 0; i < sizeof vars / sizeof vars[0]; ++i) launched |= getenv(vars[i]) != NULL;
    if (!launched) return 0;
    ohm_error err;
    ohm_error_clear(&err);
    if (start(&err)) {
        fprintf(stderr, "ohm: error: %s\n", err.msg);
        return -1;
    }
    return proc.rank > 0;
}

/* Rank 0 tells the workers (a nonblocking broadcast, which the workers'
 * polling receive matches). */
static void send_cmd(amg_cmd *cmd)
{
    MPI_Request req;
    MPI_Ibcast(cmd, (int)sizeof *cmd, MPI_BYTE, 0, proc.comm, &req);
    MPI_Wait(&req, MPI_STATUS_IGNORE);
}

static void recv_cmd(amg_cmd *cmd)
{
    MPI_Request req;
    MPI_Ibcast(cmd, (int)sizeof *cmd, MPI_BYTE, 0, proc.comm, &req);
    int done = 0;
    const struct timespec nap = {0, 1000000};
    for (;;) {
        MPI_Test(&req, &done, MPI_STATUS_IGNORE);
        if (done) return;
        nanosleep(&nap, NULL);
    }
}

void ohm_mpi_finish(void)
{
    if (!proc.initialized) return;
    if (proc.rank == 0 && proc.size > 1) {
        amg_cmd cmd = {.op = CMD_EXIT};
        send_cmd(&cmd);
    }
    MPI_Comm_free(&proc.comm);
    PetscFinalize();
    proc.initialized = 0;
}

/* ---- the collective parts, run alike by every rank ---------------------------- */

static void destroy_system(amg_state *s)
{
    if (s->ksp) KSPDestroy(&s->ksp);
    if (s->A) MatDestroy(&s->A);
    if (s->x) VecDestroy(&s->x);
    if (s->b) VecDestroy(&s->b);
    if (s->opts) PetscOptionsDestroy(&s->opts);
    s->ksp = NULL, s->A = NULL, s->x = NULL, s->b = NULL, s->opts = NULL;
}

static void partition(int64_t n, int rank, int size, int64_t *row0, int64_t *rows)
{
    int64_t a = n * rank / size, b = n * (rank + 1) / size;
    *row0 = a;
    *rows = b - a;
}

/* Rows [r0, r0 + m) of the full symmetric matrix, from its upper triangle
 * (CSC, diagonal last in each column) as CSR with global, ascending columns:
 * row i's lower part is stored column i of the upper triangle; its upper part
 * is the entries with row index i in later columns (at most `band` later). */
static int rows_of(PetscInt **ia_out, PetscInt **ja_out, PetscScalar **va_out, const cholmod_sparse *A, int64_t r0,
                   int64_t m, int64_t band)
{
    const int64_t *Ap = A->p, *Ai = A->i;
    const double *Ax = A->x;
    int64_t n = (int64_t)A->ncol, r1 = r0 + m;
    PetscInt *ia = calloc((size_t)m + 1, sizeof *ia);
    if (!ia) return -1;
    int64_t jend = r1 + band < n ? r1 + band : n;
    for (int64_t i = r0; i < r1; ++i) ia[i - r0 + 1] += (PetscInt)(Ap[i + 1] - Ap[i]);
    for (int64_t j = r0; j < jend; ++j)
        for (int64_t q = Ap[j]; q < Ap[j + 1]; ++q)
            if (Ai[q] >= r0 && Ai[q] < r1 && Ai[q] != j) ia[Ai[q] - r0 + 1]++;
    for (int64_t i = 0; i < m; ++i) ia[i + 1] += ia[i];
    PetscInt *ja = malloc(((size_t)ia[m] ? (size_t)ia[m] : 1) * sizeof *ja);
    PetscScalar *va = malloc(((size_t)ia[m] ? (size_t)ia[m] : 1) * sizeof *va);
    PetscInt *fill = malloc(((size_t)m ? (size_t)m : 1) * sizeof *fill);
    if (!ja || !va || !fill) {
        free(ia), free(ja), free(va), free(fill);
        return -1;
    }
    for (int64_t i = 0; i < m; ++i) { /* lower part and diagonal: ascending already */
        fill[i] = ia[i];
        for (int64_t q = Ap[r0 + i]; q < Ap[r0 + i + 1]; ++q) {
            ja[fill[i]] = (PetscInt)Ai[q];
            va[fill[i]++] = Ax[q];
        }
    }
    for (int64_t j = r0; j < jend; ++j) /* upper part: columns ascending */
        for (int64_t q = Ap[j]; q < Ap[j + 1]; ++q) {
            int64_t i = Ai[q];
            if (i >= r0 && i < r1 && i != j) {
                ja[fill[i - r0]] = (PetscInt)j;
                va[fill[i - r0]++] = Ax[q];
            }
        }
    free(fill);
    *ia_out = ia, *ja_out = ja, *va_out = va;
    return 0;
}

/* Every rank: the options database and the matrix from its rows. */
static int build_matrix(amg_state *s, const amg_cmd *cmd, const char *user_options, const PetscInt *ia,
                        const PetscInt *ja, const PetscScalar *va, ohm_error *err)
{
    destroy_system(s);
    s->n = cmd->n;
    partition(cmd->n, proc.rank, proc.size, &s->row0, &s->rows);
    PCALL("options", PetscOptionsCreate(&s->opts));
    PetscBool has_pc = PETSC_FALSE;
    if (user_options && *user_options) PCALL("petsc_options", PetscOptionsInsertString(s->opts, user_options));
    char pc_type[64] = "hypre";
    PCALL("options", PetscOptionsGetString(s->opts, NULL, "-pc_type", pc_type, sizeof pc_type, &has_pc));
    if (strcmp(pc_type, "hypre") == 0)
        for (size_t i = 0; i < sizeof AMG_DEFAULTS / sizeof AMG_DEFAULTS[0]; ++i) {
            PetscBool set = PETSC_FALSE;
            PCALL("options", PetscOptionsHasName(s->opts, NULL, AMG_DEFAULTS[i][0], &set));
            if (!set) PCALL("options", PetscOptionsSetValue(s->opts, AMG_DEFAULTS[i][0], AMG_DEFAULTS[i][1]));
        }
    PCALL("matrix", MatCreate(PETSC_COMM_WORLD, &s->A));
    PCALL("matrix", MatSetSizes(s->A, (PetscInt)s->rows, (PetscInt)s->rows, (PetscInt)s->n, (PetscInt)s->n));
    PCALL("matrix", MatSetType(s->A, MATAIJ));
    PCALL("matrix", MatSeqAIJSetPreallocationCSR(s->A, ia, ja, va));
    PCALL("matrix", MatMPIAIJSetPreallocationCSR(s->A, ia, ja, va));
    PCALL("matrix", MatSetOption(s->A, MAT_SPD, PETSC_TRUE));
    PCALL("matrix", MatSetOption(s->A, MAT_SYMMETRIC, PETSC_TRUE));
    PCALL("vectors", MatCreateVecs(s->A, &s->x, &s->b));
    return OHM_OK;
}

/* Every rank: CG with BoomerAMG (or what petsc_options chose), set up. */
static int setup_ksp(amg_state *s, const amg_cmd *cmd, ohm_error *err)
{
    PCALL("ksp", KSPCreate(PETSC_COMM_WORLD, &s->ksp));
    PCALL("ksp", PetscObjectSetOptions((PetscObject)s->ksp, s->opts));
    PCALL("ksp", KSPSetOperators(s->ksp, s->A, s->A));
    PCALL("ksp", KSPSetType(s->ksp, KSPCG));
    PC pc;
    PCALL("ksp", KSPGetPC(s->ksp, &pc));
    PCALL("ksp", PetscObjectSetOptions((PetscObject)pc, s->opts));
    PCALL("ksp", PCSetType(pc, PCHYPRE));
    PCALL("ksp", PCHYPRESetType(pc, "boomeramg"));
    /* the true residual ||b - A x||_2 <= tol ||b||_2, as solver=cg */
    PCALL("ksp", KSPSetNormType(s->ksp, KSP_NORM_UNPRECONDITIONED));
    PCALL("ksp", KSPSetTolerances(s->ksp, cmd->tol, 0.0, 1e30, (PetscInt)cmd->max_iter));
    /* every column starts from zero: a warm start from the frame before
     * saved BoomerAMG nothing (measured: 14.6 iterations per column over a
     * 12-frame orbit against 13.3 cold) and left the darkest cells' relative
     * error a little larger (tests/mpi_amg.sh) */
    PCALL("ksp", KSPSetInitialGuessNonzero(s->ksp, PETSC_FALSE));
    PCALL("petsc_options", KSPSetFromOptions(s->ksp));
    /* a direct solve through petsc_options (-ksp_type preonly, e.g. MUMPS's
     * Cholesky) has no residual norm of its own:
     * rank 0's backward-error check is its test */
    KSPType type;
    PCALL("ksp", KSPGetType(s->ksp, &type));
    if (strcmp(type, KSPPREONLY) == 0) PCALL("ksp", KSPSetNormType(s->ksp, KSP_NORM_NONE));
    PCALL("setup", KSPSetUp(s->ksp));
    return OHM_OK;
}

/* Every rank: the options, the matrix from its rows, the KSP set up.  The
 * rows (ia, ja, va) are freed as soon as PETSc has copied them, before
 * BoomerAMG builds its hierarchy: the peak is one copy of A lower. */
static int setup_collective(amg_state *s, const amg_cmd *cmd, const char *user_options, PetscInt *ia, PetscInt *ja,
                            PetscScalar *va, ohm_error *err)
{
    double t0 = ohm_now();
    int rc = build_matrix(s, cmd, user_options, ia, ja, va, err);
    free(ia), free(ja), free(va);
    if (rc) return rc;
    s->t_matrix = ohm_now() - t0;
    rc = setup_ksp(s, cmd, err);
    s->t_hierarchy = ohm_now() - t0 - s->t_matrix;
    return rc;
}

/* Every rank: column after column, scatter b, solve,
 * gather x (on rank 0, B and X are the whole n x ncols; elsewhere NULL);
 * the first column's KSP reason for stopping short of tol, if any, and how
 * many columns did. */
static int solve_collective(amg_state *s, int64_t ncols, const double *B, double *X, int64_t *iters, double *relres,
                            int *reason, int64_t *stopped_short, ohm_error *err)
{
    *iters = 0, *relres = 0, *reason = 0, *stopped_short = 0;
    for (int64_t j = 0; j < ncols; ++j) {
        size_t off = (size_t)j * (size_t)s->n;
        PetscScalar *pb;
        PCALL("vectors", VecGetArray(s->b, &pb));
        MPI_Scatterv(B ? B + off : NULL, s->counts, s->displs, MPI_DOUBLE, pb, (int)s->rows, MPI_DOUBLE, 0,
                     proc.comm);
        PCALL("vectors", VecRestoreArray(s->b, &pb));
        PCALL("solve", KSPSolve(s->ksp, s->b, s->x));
        PetscInt its;
        KSPConvergedReason why;
        PetscReal rnorm, bnorm;
        PCALL("solve", KSPGetIterationNumber(s->ksp, &its));
        PCALL("solve", KSPGetConvergedReason(s->ksp, &why));
        PCALL("solve", KSPGetResidualNorm(s->ksp, &rnorm));
        PCALL("solve", VecNorm(s->b, NORM_2, &bnorm));
        *iters += its;
        if (bnorm > 0 && rnorm / bnorm > *relres) *relres = rnorm / bnorm;
        if (why < 0 && *reason == 0) *reason = (int)why;
        *stopped_short += why < 0;
        const PetscScalar *cx;
        PCALL("vectors", VecGetArrayRead(s->x, &cx));
        MPI_Gatherv(cx, (int)s->rows, MPI_DOUBLE, X ? X + off : NULL, s->counts, s->displs, MPI_DOUBLE, 0, proc.comm);
        PCALL("vectors", VecRestoreArrayRead(s->x, &cx));
    }
    return OHM_OK;
}

/* ---- the workers ------------------------------------------------------------------- */

int ohm_mpi_serve(void)
{
    amg_state s;
    memset(&s, 0, sizeof s);
    ohm_error err;
    ohm_error_clear(&err);
    for (;;) {
        amg_cmd cmd;
        recv_cmd(&cmd);
        if (cmd.op == CMD_EXIT) break;
        if (cmd.op == CMD_DESTROY) {
            destroy_system(&s);
        } else if (cmd.op == CMD_SETUP) {
            char *opts = malloc((size_t)cmd.opt_len);
            int64_t row0, rows, nnz = 0;
            partition(cmd.n, proc.rank, proc.size, &row0, &rows);
            PetscInt *ia = malloc(((size_t)rows + 1) * sizeof *ia);
            if (!opts || !ia) {
                fprintf(stderr, "ohm: error: solve: amg: rank %d: out of memory for %lld rows\n", proc.rank,
                        (long long)rows);
                MPI_Abort(MPI_COMM_WORLD, 1);
            }
            MPI_Bcast(opts, (int)cmd.opt_len, MPI_CHAR, 0, proc.comm);
            MPI_Recv(ia, (int)rows + 1, MPIU_INT, 0, 1, proc.comm, MPI_STATUS_IGNORE);
            nnz = ia[rows];
            PetscInt *ja = malloc(((size_t)nnz ? (size_t)nnz : 1) * sizeof *ja);
            PetscScalar *va = malloc(((size_t)nnz ? (size_t)nnz : 1) * sizeof *va);
            if (!ja || !va) {
                fprintf(stderr, "ohm: error: solve: amg: rank %d: out of memory for %lld matrix entries\n",
                        proc.rank, (long long)nnz);
                MPI_Abort(MPI_COMM_WORLD, 1);
            }
            MPI_Recv(ja, (int)nnz, MPIU_INT, 0, 2, proc.comm, MPI_STATUS_IGNORE);
            MPI_Recv(va, (int)nnz, MPI_DOUBLE, 0, 3, proc.comm, MPI_STATUS_IGNORE);
            setup_collective(&s, &cmd, opts, ia, ja, va, &err); /* frees the rows; errors abort */
            free(opts);
        } else if (cmd.op == CMD_SOLVE) {
            int64_t its;
            double relres;
            int reason;
            int64_t stopped_short;
            solve_collective(&s, cmd.ncols, NULL, NULL, &its, &relres, &reason, &stopped_short, &err);
        }
    }
    destroy_system(&s);
    ohm_mpi_finish();
    return 0;
}

/* ---- rank 0: the backend ------------------------------------------------------------ */

static void amg_destroy(void *state)
{
    amg_state *s = state;
    if (!s) return;
    if (proc.initialized && proc.size > 1 && s->A) {
        amg_cmd cmd = {.op = CMD_DESTROY};
        send_cmd(&cmd);
    }
    destroy_system(s);
    free(s->counts);
    free(s->displs);
    free(s);
}

static int amg_create(void **state, const ohm_backend_config *cfg, ohm_error *err)
{
    int rc = start(err);
    if (rc) return rc;
    if (proc.rank != 0) return ohm_fail(err, OHM_ERR_INTERNAL, "solve: amg: a worker rank ran the pipeline");
    amg_state *s = calloc(1, sizeof *s);
    if (!s) return ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory");
    s->cfg = *cfg;
    if (!(s->cfg.tol > 0)) s->cfg.tol = 1e-10;
    /* BoomerAMG converges in tens of iterations; hundreds mean trouble */
    if (s->cfg.max_iter <= 0) s->cfg.max_iter = 1000;
    s->counts = calloc((size_t)proc.size, sizeof *s->counts);
    s->displs = calloc((size_t)proc.size, sizeof *s->displs);
    if (!s->counts || !s->displs) {
        amg_destroy(s);
        return ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory");
    }
    *state = s;
    return OHM_OK;
}

/* How far past column j the upper triangle's rows reach back: the matrix's
 * half bandwidth (for a grid, one layer of cells). */
static int64_t half_bandwidth(const cholmod_sparse *A)
{
    const int64_t *Ap = A->p, *Ai = A->i;
    int64_t band = 0;
    for (int64_t j = 0; j < (int64_t)A->ncol; ++j)
        if (Ap[j + 1] > Ap[j] && j - Ai[Ap[j]] > band) band = j - Ai[Ap[j]];
    return band;
}

static int amg_setup(void *state, const ohm_operator *op, ohm_backend_report *rep, ohm_error *err)
{
    cholmod_sparse *A = op->A;
    amg_state *s = state;
    double t0 = ohm_now();
    int64_t n = (int64_t)A->nrow;
    if (n > (int64_t)PETSC_MAX_INT)
        return ohm_fail(err, OHM_ERR_INVALID,
                        "solve: amg: %lld unknowns exceed this PETSc's 32-bit indices (%d); use a larger voxel=",
                        (long long)n, (int)PETSC_MAX_INT);
    /* the previous material's system goes first: its memory is this one's
     * (freed, but kept by the allocator, so the machine's free memory does
     * not show it: a system of the same size that was just set up fits) */
    int same_size = s->A && s->n == n;
    if (s->A) {
        if (proc.size > 1) {
            amg_cmd destroy = {.op = CMD_DESTROY};
            send_cmd(&destroy);
        }
        destroy_system(s);
    }
    int rc = OHM_OK;
    if (!same_size) {
        double per_rank = ohm_amg_bytes_per_rank(n, (double)A->nzmax, proc.size); /* before anything is built */
        char what[64];
        snprintf(what, sizeof what, "amg on %lld cells", (long long)n);
        rc = ohm_backend_check_memory(per_rank, s->cfg.max_memory, what, " per rank",
                                      "run on more ranks (mpirun -np), or use a smaller dim= or a larger voxel=", err);
        if (rc) return rc;
    }
    const char *user = s->cfg.petsc_options ? s->cfg.petsc_options : "";
    amg_cmd cmd = {.op = CMD_SETUP, .n = n, .max_iter = s->cfg.max_iter, .tol = s->cfg.tol,
                   .opt_len = (int64_t)strlen(user) + 1};
    int64_t band = half_bandwidth(A);
    for (int r = 0; r < proc.size; ++r) {
        int64_t r0, m;
        partition(n, r, proc.size, &r0, &m);
        s->counts[r] = (int)m;
        s->displs[r] = (int)r0;
    }
    if (proc.size > 1) {
        send_cmd(&cmd);
        MPI_Bcast((void *)user, (int)cmd.opt_len, MPI_CHAR, 0, proc.comm);
        for (int r = 1; r < proc.size; ++r) { /* one rank's rows at a time: rank 0 holds one block more */
            PetscInt *ia, *ja;
            PetscScalar *va;
            if (rows_of(&ia, &ja, &va, A, s->displs[r], s->counts[r], band)) {
                snprintf(proc.msg, sizeof proc.msg, "out of memory for rank %d's rows", r);
                return petsc_failed(err, "setup"); /* the workers wait for them: end the run */
            }
            MPI_Send(ia, s->counts[r] + 1, MPIU_INT, r, 1, proc.comm);
            MPI_Send(ja, (int)ia[s->counts[r]], MPIU_INT, r, 2, proc.comm);
            MPI_Send(va, (int)ia[s->counts[r]], MPI_DOUBLE, r, 3, proc.comm);
            free(ia), free(ja), free(va);
        }
    }
    PetscInt *ia, *ja;
    PetscScalar *va;
    if (rows_of(&ia, &ja, &va, A, 0, s->counts[0], band)) {
        snprintf(proc.msg, sizeof proc.msg, "out of memory for the matrix rows");
        return petsc_failed(err, "setup"); /* with several ranks the others wait: end the run */
    }
    s->t_rows = ohm_now() - t0;
    rc = setup_collective(s, &cmd, user, ia, ja, va, err); /* frees the rows */
    if (rc) return rc;
    s->norm_A = ohm_sym_upper_norm_inf(A);
    s->checked_options = 0;
    rep->t_precond += ohm_now() - t0;
    rep->precond_setups++;
    rep->nnz_A = (double)A->nzmax;
    rep->ranks = proc.size;
    snprintf(rep->solver, sizeof rep->solver, "amg");
    struct rusage ru;
    if (getrusage(RUSAGE_SELF, &ru) == 0 && 1024.0 * (double)ru.ru_maxrss > rep->bytes)
        rep->bytes = 1024.0 * (double)ru.ru_maxrss; /* rank 0's peak so far: PETSc's own memory included */
    ohm_log_info(s->cfg.log,
                 "solve: amg set up on %d rank(s) in %.2f s (%lld unknowns, %lld entries): rows %.2f s, PETSc matrix "
                 "%.2f s, KSP and BoomerAMG hierarchy %.2f s",
                 proc.size, ohm_now() - t0, (long long)n, (long long)A->nzmax, s->t_rows, s->t_matrix, s->t_hierarchy);
    return OHM_OK;
}

/* Options the user gave that PETSc never looked at: a typo, or an option of
 * another solver.  Looked for after the first solve (some, like -ksp_view,
 * are read only then). */
static int check_options_used(amg_state *s, ohm_error *err)
{
    PetscInt nleft = 0;
    char **names = NULL, **values = NULL;
    PCALL("options", PetscOptionsLeftGet(s->opts, &nleft, &names, &values));
    char first[128] = "";
    PetscInt unused = nleft; /* LeftRestore zeroes nleft */
    if (unused > 0) snprintf(first, sizeof first, "-%s", names[0]);
    PetscOptionsLeftRestore(s->opts, &nleft, &names, &values);
    s->checked_options = 1;
    if (unused > 0)
        return ohm_fail(err, OHM_ERR_USAGE,
                        "solve: petsc_options: '%s' was not used by PETSc (misspelt, or an option of another "
                        "solver)%s",
                        first, unused > 1 ? ", and others" : "");
    return OHM_OK;
}

static const char *reason_name(int reason)
{
    switch (reason) {
    case KSP_DIVERGED_ITS: return "the iteration limit was reached";
    case KSP_DIVERGED_BREAKDOWN: return "CG broke down";
    case KSP_DIVERGED_INDEFINITE_PC: return "the preconditioner is not positive definite";
    case KSP_DIVERGED_INDEFINITE_MAT: return "the matrix is not positive definite";
    case KSP_DIVERGED_NANORINF: return "the residual became NaN or infinite";
    case KSP_DIVERGED_DTOL: return "the residual grew";
    case KSP_DIVERGED_PC_FAILED: return "the preconditioner failed";
    default: return "it diverged";
    }
}

static int amg_solve(void *state, const ohm_operator *op, const double *B, double *X, size_t ncols, double *berr,
                     ohm_backend_report *rep, ohm_error *err)
{
    cholmod_sparse *A = op->A;
    amg_state *s = state;
    if (proc.size > 1) {
        amg_cmd cmd = {.op = CMD_SOLVE, .n = s->n, .ncols = (int64_t)ncols};
        send_cmd(&cmd);
    }
    int64_t its = 0, stopped_short = 0;
    double relres = 0;
    int reason = 0;
    int rc = solve_collective(s, (int64_t)ncols, B, X, &its, &relres, &reason, &stopped_short, err);
    if (rc) return rc;
    if (!s->checked_options && (rc = check_options_used(s, err))) {
        ohm_backend_book_columns(rep, its, relres, s->cfg.tol, 0);
        return rc;
    }
    *berr = ohm_backward_error(A, B, X, ncols, s->norm_A);
    /* a nearly singular A (almost no absorption, no leak) leaves a residual
     * floor of about kappa eps that CG cannot pass: accepted, as for
     * solver=cg, when the scaled backward error is as small as a converged
     * solve's, and the columns that stopped short booked (the driver says so) */
    int accepted = reason == 0 || *berr <= 0.01 * s->cfg.tol;
    ohm_backend_book_columns(rep, its, relres, s->cfg.tol, accepted ? stopped_short : 0);
    if (!accepted)
        return ohm_fail(err, OHM_ERR_NUMERIC,
                        "solve: amg did not converge: %s (relative residual %.3g after %lld iterations, "
                        "cg_tol=%.1g); use solver=direct, a looser cg_tol=, or other petsc_options=",
                        reason_name(reason), relres, (long long)its, s->cfg.tol);
    return OHM_OK;
}

const ohm_backend_ops ohm_backend_amg = {.name = "amg",
                                         .create = amg_create,
                                         .setup = amg_setup,
                                         .solve = amg_solve,
                                         .destroy = amg_destroy};

#else /* no PETSc */
int ohm_backend_amg_available(void) { return 0; }

int ohm_backend_amg_started(void) { return 0; }

static int amg_unavailable(void **state, const ohm_backend_config *cfg, ohm_error *err)
{
    (void)cfg;
    *state = NULL;
    return ohm_fail(err, OHM_ERR_USAGE,
                    "solve: solver=amg is unavailable: this ohm was built without PETSc (install libpetsc-real-dev "
                    "and libhypre-dev, scripts/install-deps.sh does, and rebuild)");
}

#include <stdio.h>
#include <stdlib.h>

static void amg_none(void *state) { (void)state; }

const ohm_backend_ops ohm_backend_amg = {.name = "amg", .create = amg_unavailable, .destroy = amg_none};


int ohm_mpi_start(void)
{
    /* under mpirun every rank would run the whole pipeline and write the
     * same files: refuse on every rank but the first, which says why */
    const char *size = getenv("OMPI_COMM_WORLD_SIZE"), *rank = getenv("OMPI_COMM_WORLD_RANK");
    if (!size || atoi(size) <= 1) return 0;
    if (!rank || atoi(rank) == 0)
        fprintf(stderr, "ohm: error: this ohm was built without PETSc/MPI: run it without mpirun\n");
    return -1;
}

int ohm_mpi_serve(void) { return 1; }

int ohm_mpi_ranks(void) { return 1; }

void ohm_mpi_finish(void) {}

#endif
