/* solvers/direct.c — CHOLMOD's analysis, factor and solves (direct.h) and
 * the `direct` backend over them (backend.h). */
#define _GNU_SOURCE /* RTLD_DEFAULT */
#include "solvers/direct.h"

#include <dlfcn.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/log.h"
#include "solvers/factor_watch.h"
#include "base/memory.h"
#include "base/parallel.h"
#include "solvers/cg.h"
#include "solvers/substitute.h"

/* Thresholds on the scaled backward error (docs/design.md §3, "Numerical traps"). */
static const double BERR_REFINE = 1e-12;
static const double BERR_FAIL = 1e-10;

/* Up to this many columns a solve substitutes column by column over the
 * factor's arrays (substitute.h), while the factor is at most
 * OHM_SUBSTITUTE_MAX_BYTES (direct.h); more go to cholmod_solve, whose dense
 * BLAS-3 blocks then win (measured: ohm bench batch=). */
static const size_t SUBSTITUTE_MAX_COLUMNS = 4;

int ohm_cholesky_start(ohm_cholesky *s, ohm_error *err)
{
    memset(s, 0, sizeof *s);
    if (!cholmod_l_start(&s->cc)) return ohm_fail(err, OHM_ERR_INTERNAL, "CHOLMOD failed to start");
    s->started = 1;
    s->cc.print = 0;
    s->cc.error_handler = NULL; /* statuses are checked; nothing printed */
    return OHM_OK;
}

void ohm_cholesky_finish(ohm_cholesky *s)
{
    if (!s || !s->started) return;
    cholmod_l_free_factor(&s->symbolic, &s->cc);
    cholmod_l_finish(&s->cc);
    free(s->work);
    s->work = NULL;
    s->work_size = 0;
    s->started = 0;
}

void ohm_cholesky_factor_free(cholmod_factor **L, ohm_cholesky *s)
{
    if (L && *L) cholmod_l_free_factor(L, &s->cc);
}

/* One analysis with one ordering (perm: a given ordering, CHOLMOD_GIVEN);
 * the factor and its statistics in *out. */
static int analyze_one(cholmod_factor **out, double *lnz, double *fl, ohm_cholesky *s, cholmod_sparse *A, int ordering,
                       int64_t *perm, const char *name, ohm_error *err)
{
    cholmod_common *cc = &s->cc;
    cc->nmethods = 1;
    cc->postorder = 1;
    cc->method[0].ordering = ordering;
    *out = perm ? cholmod_l_analyze_p(A, perm, NULL, 0, cc) : cholmod_l_analyze(A, cc);
    if (!*out || cc->status < CHOLMOD_OK) {
        cholmod_l_free_factor(out, cc);
        if (cc->status == CHOLMOD_NOT_INSTALLED)
            return ohm_fail(err, OHM_ERR_INTERNAL, "ordering=%s is not available in this CHOLMOD build", name);
        if (cc->status == CHOLMOD_OUT_OF_MEMORY)
            return ohm_fail(err, OHM_ERR_NOMEM, "out of memory analysing a %lld x %lld matrix", (long long)A->nrow,
                            (long long)A->ncol);
        return ohm_fail(err, OHM_ERR_INTERNAL, "CHOLMOD analysis failed (status %d)", cc->status);
    }
    *lnz = cc->lnz;
    *fl = cc->fl;
    return OHM_OK;
}

/* The analysis with the geometric ordering of grid_order.h. */
static int analyze_grid(cholmod_factor **out, double *lnz, double *fl, ohm_cholesky *s, cholmod_sparse *A,
                        const ohm_grid_layout *layout, ohm_error *err)
{
    if (!layout || layout->n != (int64_t)A->nrow)
        return ohm_fail(err, OHM_ERR_USAGE, "ordering=grid needs the unknowns' grid positions, which this caller "
                                            "does not give: use metis, amd or nesdis");
    int64_t *perm = malloc((size_t)(layout->n ? layout->n : 1) * sizeof *perm);
    if (!perm) return ohm_fail(err, OHM_ERR_NOMEM, "ordering=grid: out of memory");
    int rc = ohm_grid_order(perm, layout, err);
    if (!rc) rc = analyze_one(out, lnz, fl, s, A, CHOLMOD_GIVEN, perm, "grid", err);
    free(perm);
    return rc;
}

/* The analysis kept as s's symbolic factor (the one before freed). */
static void keep_analysis(ohm_cholesky *s, cholmod_factor *F, double lnz, double fl, const char *name)
{
    cholmod_l_free_factor(&s->symbolic, &s->cc);
    s->symbolic = F;
    s->nnz_L = lnz;
    s->flops = fl;
    snprintf(s->ordering, sizeof s->ordering, "%s", name);
}

/* Bytes the factor will take, known from the symbolic analysis before
 * factorizing: its values (supernodal: xsize, with amalgamation zeros) and
 * row indices, the symbolic copy kept beside it, and a batch of B and X. */
static double factor_bytes(const ohm_cholesky *s, size_t batch)
{
    const cholmod_factor *F = s->symbolic;
    double values = F->is_super ? fmax((double)F->xsize, s->nnz_L) : s->nnz_L;
    double index = F->is_super ? (double)F->ssize : s->nnz_L;
    return 8.0 * values + 2.0 * 8.0 * index + 2.0 * sizeof(double) * (double)F->n * (double)batch;
}

/* ordering=auto's cost model, in units of the grid ordering's
 * own analysis time (this VM's speed varies 2x from day to day, the ratios
 * much less), from docs/ordering.md (every sample mesh and scan, 1.2e4-9.2e4
 * cells, on two days) and docs/bench.md:
 *   - a numeric factorization took 3.4-9x the grid ordering + analysis;
 *     a one-column solve ~1/50 of a factorization (spot, 2.8e4-2.2e5 cells);
 *   - METIS's ordering + analysis took 3.8-6.2x the grid's;
 *   - METIS left 0.89-1.09x the grid ordering's fill on objects from meshes,
 *     and 1/1.23-1/1.73 of it on scans; its factorization was then 0-23%
 *     faster on the scans, not the fill's 19-42% (their thin shells give
 *     small supernodes), so the fill saving is taken as an upper bound.
 * The model errs by tens of percent, so METIS is analysed only when its
 * predicted saving is twice its predicted analysis time: on the bundled
 * scans with one light it is not (measured: grid's one-light total was
 * then the lower one), with hundreds of lights it is.  Memory comes first:
 * a grid-ordered factor that does not fit makes METIS's worth a try. */
static const double FACTOR_OVER_GRID_ANALYSIS = 6.5;
static const double SOLVE_OVER_FACTOR = 0.02;
static const double METIS_ANALYSIS_OVER_GRID = 5.0;
static const double METIS_FILL_GAIN_SCAN = 1.45;
static const double METIS_MARGIN = 2.0;

/* ordering=auto: the grid ordering's analysis (a tenth to a fifth of a
 * factorization); then METIS's only when its factor is predicted to save
 * twice its analysis time over the factorizations and solves to come, or
 * when the grid's factor does not fit in memory; of the two, the smaller
 * factor. */
static int analyze_auto(ohm_cholesky *s, cholmod_sparse *A, const ohm_grid_layout *layout,
                        const ohm_ordering_costs *costs, const ohm_log *log, ohm_error *err)
{
    cholmod_factor *F = NULL;
    double lnz = 0, fl = 0, t0 = ohm_now();
    if (!layout || layout->n != (int64_t)A->nrow) {
        int rc = analyze_one(&F, &lnz, &fl, s, A, CHOLMOD_METIS, NULL, "metis", err);
        if (!rc) keep_analysis(s, F, lnz, fl, "metis");
        return rc;
    }
    int rc = analyze_grid(&F, &lnz, &fl, s, A, layout, err);
    if (rc) return rc;
    keep_analysis(s, F, lnz, fl, "grid");
    double t_grid = ohm_now() - t0;
    double factors = costs && costs->factors > 0 ? costs->factors : 1;
    double columns = costs && costs->columns > 0 ? costs->columns : 1;
    double gain = costs && costs->from_scan ? METIS_FILL_GAIN_SCAN : 1.0;
    int fits = factor_bytes(s, costs && costs->batch > 0 ? (size_t)costs->batch : 1) <=
                  ohm_memory_limit(costs ? costs->max_memory : 0);
    double work = FACTOR_OVER_GRID_ANALYSIS * t_grid * (factors + SOLVE_OVER_FACTOR * columns);
    double saving = work * (1.0 - 1.0 / gain), metis_analysis = METIS_ANALYSIS_OVER_GRID * t_grid;
    if (fits && !(saving > METIS_MARGIN * metis_analysis)) {
        ohm_log_info(log, "solve: ordering=auto: grid (METIS would save at most ~%.2g s of factorizations and "
                          "solves for ~%.2g s of analysis)", saving, metis_analysis);
        return OHM_OK;
    }
    double lnz_grid = lnz;
    rc = analyze_one(&F, &lnz, &fl, s, A, CHOLMOD_METIS, NULL, "metis", err);
    if (rc) return rc;
    ohm_log_info(log, "solve: ordering=auto: %s (nnz(L) grid %.3g, metis %.3g; %s)", lnz < lnz_grid ? "metis" : "grid",
                 lnz_grid, lnz, fits ? "METIS predicted to pay for its analysis" : "the grid's factor does not fit");
    if (lnz < lnz_grid) keep_analysis(s, F, lnz, fl, "metis");
    else cholmod_l_free_factor(&F, &s->cc);
    return OHM_OK;
}

int ohm_cholesky_analyze(ohm_cholesky *s, cholmod_sparse *A, const char *ordering, const ohm_grid_layout *layout,
                         const ohm_ordering_costs *costs, const ohm_log *log, ohm_error *err)
{
    cholmod_common *cc = &s->cc;
    cholmod_l_free_factor(&s->symbolic, cc);
    static const struct {
        const char *name;
        int id; /* CHOLMOD's; -1: grid_order.h */
    } orders[] = {{"metis", CHOLMOD_METIS}, {"amd", CHOLMOD_AMD}, {"nesdis", CHOLMOD_NESDIS}, {"grid", -1}};
    int best = strcmp(ordering, "best") == 0;
    double t0 = ohm_now();
    if (strcmp(ordering, "auto") == 0) {
        int rc = analyze_auto(s, A, layout, costs, log, err);
        if (rc) cholmod_l_free_factor(&s->symbolic, cc);
        s->t_analyze = ohm_now() - t0;
        s->nnz_A = (double)cholmod_l_nnz(A, cc);
        return rc;
    }
    int found = 0;
    for (int i = 0; i < 4; ++i) {
        /* best: METIS, AMD and (given the grid) grid; keep the smaller factor */
        if (best ? orders[i].id == CHOLMOD_NESDIS || (orders[i].id < 0 && !layout)
                 : strcmp(ordering, orders[i].name) != 0)
            continue;
        found = 1;
        cholmod_factor *F = NULL;
        double lnz = 0, fl = 0;
        int rc = orders[i].id < 0 ? analyze_grid(&F, &lnz, &fl, s, A, layout, err)
                                  : analyze_one(&F, &lnz, &fl, s, A, orders[i].id, NULL, orders[i].name, err);
        if (rc) {
            cholmod_l_free_factor(&s->symbolic, cc);
            return rc;
        }
        if (!s->symbolic || lnz < s->nnz_L) {
            keep_analysis(s, F, lnz, fl, orders[i].name);
        } else {
            cholmod_l_free_factor(&F, cc);
        }
    }
    if (!found)
        return ohm_fail(err, OHM_ERR_USAGE, "ordering=%s: expected auto, metis, amd, nesdis, grid or best", ordering);
    s->t_analyze = ohm_now() - t0;
    s->nnz_A = (double)cholmod_l_nnz(A, cc);
    return OHM_OK;
}

/* A factorization of more flops than this first looks whether the machine
 * is busy (ohm_idle_cores over 4 ms: a few percent of its own time). */
static const double BUSY_CHECK_FLOPS = 2e8;

/* OpenBLAS's thread count (its own calls, found by name: another BLAS has
 * none and keeps its threads); 0 where there is none to set.  OpenBLAS's
 * threads spin, then yield, while they wait for each other, so on cores
 * another process keeps busy (even at nice 19) each of its calls waits for
 * threads the scheduler has put behind that process: a factorization of
 * the cow took 12.8 times its quiet time that way (docs/performance.md). */
static int blas_threads(int set)
{
    typedef int (*get_fn)(void);
    typedef void (*set_fn)(int);
    get_fn get;
    set_fn put;
    *(void **)&get = dlsym(RTLD_DEFAULT, "openblas_get_num_threads");
    *(void **)&put = dlsym(RTLD_DEFAULT, "openblas_set_num_threads");
    if (!get || !put) return 0;
    int was = get();
    if (set > 0 && set != was) put(set);
    return was;
}

int ohm_cholesky_factorize(cholmod_factor **L, ohm_cholesky *s, cholmod_sparse *A, double *t, const ohm_log *log,
                           ohm_error *err)
{
    cholmod_common *cc = &s->cc;
    if (!s->symbolic) return ohm_fail(err, OHM_ERR_INTERNAL, "factorize before analyze");
    cholmod_factor *F = *L ? *L : cholmod_l_copy_factor(s->symbolic, cc);
    *L = NULL;
    if (!F) return ohm_fail(err, OHM_ERR_NOMEM, "out of memory copying the symbolic factor");
    s->norm_A = cholmod_l_norm_sparse(A, 0, cc); /* for every solve's backward error */
    double t0 = ohm_now();
    /* on a busy machine, the BLAS's threads only on the cores left idle */
    int threads_were = 0;
    if (s->flops > BUSY_CHECK_FLOPS) {
        int idle = ohm_idle_cores(0.004), have = blas_threads(0);
        if (have > idle) {
            threads_were = blas_threads(idle);
            ohm_log_info(log, "solve: factorize: %d of %d cores idle: the BLAS on %d thread(s)", idle,
                         ohm_usable_cores(), idle);
        }
    }
    ohm_factor_watch watch;
    ohm_factor_watch_begin(&watch, s->flops, log, "solve: factorize");
    int ok = cholmod_l_factorize(A, F, cc);
    ohm_factor_watch_end(&watch);
    if (threads_were > 0) blas_threads(threads_were);
    if (t) *t = ohm_now() - t0;
    /* a supernodal factorization whose BLAS and LAPACK calls never reached
     * the watch: the host program's LAPACK came first and libohm could not
     * point CHOLMOD back at its own (a platform rebind.h does not know) */
    if (ok && F->is_super && watch.done == 0 && s->flops > 0)
        ohm_log_info(log, "solve: factorize: CHOLMOD called the host program's LAPACK, not libohm's watch, "
                          "so the factorization reported no progress and could be cancelled only at its end");
    /* cholmod_factorize returns TRUE on an indefinite matrix: the status and
     * L->minor say so (and a cancelled run stops it the same way). */
    if (!ok || cc->status == CHOLMOD_NOT_POSDEF || F->minor < F->n) {
        long long minor = (long long)F->minor;
        int status = cc->status;
        cholmod_l_free_factor(&F, cc);
        if (watch.cancelled) return ohm_fail_cancelled(err, "factorize");
        if (status == CHOLMOD_OUT_OF_MEMORY)
            return ohm_fail(err, OHM_ERR_NOMEM, "out of memory factorizing (nnz(L) = %.3g)", s->nnz_L);
        return ohm_fail(err, OHM_ERR_NUMERIC,
                        "the matrix is not positive definite (pivot %lld of %lld failed): a conductance is negative "
                        "or a piece has neither absorption nor a leaking boundary",
                        minor, (long long)A->nrow);
    }
    *L = F;
    return OHM_OK;
}

/* X = A^-1 B for ncols columns of n rows, from the factor L. */
static int apply_inverse(double *X, ohm_cholesky *s, cholmod_factor *L, const double *B, size_t n, size_t ncols,
                         ohm_error *err)
{
    cholmod_common *cc = &s->cc;
    if (ncols <= SUBSTITUTE_MAX_COLUMNS && ohm_substitute_supports(L) &&
        8.0 * (double)L->xsize <= OHM_SUBSTITUTE_MAX_BYTES) {
        size_t need = ohm_substitute_work_size(L);
        if (need > s->work_size) {
            free(s->work);
            s->work = malloc(need * sizeof(double));
            s->work_size = s->work ? need : 0;
            if (!s->work) return ohm_fail(err, OHM_ERR_NOMEM, "out of memory for a solve of %zu unknowns", n);
        }
        for (size_t c = 0; c < ncols; ++c) ohm_substitute(X + c * n, L, B + c * n, s->work);
        return OHM_OK;
    }
    /* a header over the caller's B: cholmod_solve only reads it */
    cholmod_dense Bd = {.nrow = n, .ncol = ncols, .nzmax = n * ncols, .d = n, .x = (void *)B,
                        .xtype = CHOLMOD_REAL, .dtype = CHOLMOD_DOUBLE};
    cholmod_dense *Xd = cholmod_l_solve(CHOLMOD_A, L, &Bd, cc);
    if (!Xd) return ohm_fail(err, OHM_ERR_NOMEM, "CHOLMOD solve failed (status %d)", cc->status);
    memcpy(X, Xd->x, n * ncols * sizeof(double));
    cholmod_l_free_dense(&Xd, cc);
    return OHM_OK;
}

int ohm_cholesky_solve(double *X, ohm_cholesky *s, cholmod_factor *L, cholmod_sparse *A, const double *B,
                       size_t ncols, double *berr, int *refined, ohm_error *err)
{
    size_t n = A->nrow;
    if (refined) *refined = 0;
    int rc = apply_inverse(X, s, L, B, n, ncols, err);
    if (rc) return rc;
    double normA = s->norm_A > 0 ? s->norm_A : ohm_sym_upper_norm_inf(A);
    double e = ohm_backward_error(A, B, X, ncols, normA);
    if (!(e <= BERR_REFINE)) {
        /* one step of iterative refinement: x += A^-1 (b - A x) */
        double *r = malloc(2 * n * ncols * sizeof(double));
        if (!r) return ohm_fail(err, OHM_ERR_NOMEM, "out of memory refining %zu solves of %zu unknowns", ncols, n);
        double *dx = r + n * ncols;
        for (size_t c = 0; c < ncols; ++c) {
            ohm_sym_upper_mult(A, X + c * n, r + c * n);
            for (size_t i = 0; i < n; ++i) r[c * n + i] = B[c * n + i] - r[c * n + i];
        }
        rc = apply_inverse(dx, s, L, r, n, ncols, err);
        if (!rc)
            for (size_t i = 0; i < n * ncols; ++i) X[i] += dx[i];
        free(r);
        if (rc) return rc;
        e = ohm_backward_error(A, B, X, ncols, normA);
        if (refined) *refined = 1;
    }
    if (berr) *berr = e;
    if (!(e <= BERR_FAIL))
        return ohm_fail(err, OHM_ERR_NUMERIC,
                        "the solve is not accurate: scaled backward error %.3g after refinement (limit %.0e); the "
                        "matrix is singular or too ill-conditioned",
                        e, BERR_FAIL);
    return OHM_OK;
}

/* ---- the direct backend (backend.h) ---------------------------------------------- */

typedef struct direct_state {
    ohm_cholesky solver;       /* one analysis for the grid, shared by every setup */
    cholmod_factor *L;       /* the latest material's factor                      */
    ohm_backend_config cfg;
} direct_state;

static void direct_destroy(void *state)
{
    direct_state *d = state;
    if (!d) return;
    ohm_cholesky_factor_free(&d->L, &d->solver);
    ohm_cholesky_finish(&d->solver);
    free(d);
}

static int direct_create(void **state, const ohm_backend_config *cfg, ohm_error *err)
{
    direct_state *d = calloc(1, sizeof *d);
    if (!d) return ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory");
    d->cfg = *cfg;
    int rc = ohm_cholesky_start(&d->solver, err);
    if (rc) {
        free(d);
        return rc;
    }
    *state = d;
    return OHM_OK;
}


static int direct_setup(void *state, const ohm_operator *op, ohm_backend_report *rep, ohm_error *err)
{
    cholmod_sparse *A = op->A;
    direct_state *d = state;
    ohm_cholesky *s = &d->solver;
    const char *ordering = d->cfg.ordering ? d->cfg.ordering : "metis";
    if (!s->symbolic) {
        ohm_log_info(d->cfg.log, "solve: %lld unknowns, %lld matrix entries; analysing (%s)", (long long)A->nrow,
                     (long long)A->nzmax, ordering);
        ohm_ordering_costs costs = {d->cfg.materials, d->cfg.columns, (double)d->cfg.batch, d->cfg.max_memory,
                                    d->cfg.from_scan};
        int rc = ohm_cholesky_analyze(s, A, ordering, d->cfg.layout, &costs, d->cfg.log, err);
        if (rc) return rc;
        rep->t_analyze += s->t_analyze;
        rep->analyses++;
        rep->nnz_A = s->nnz_A;
        rep->nnz_L = s->nnz_L;
        rep->flops = s->flops;
        snprintf(rep->ordering, sizeof rep->ordering, "%s", s->ordering);
    }
    double need = factor_bytes(s, d->cfg.batch ? d->cfg.batch : 1);
    char what[64], detail[64];
    snprintf(what, sizeof what, "the Cholesky factor of %lld cells", (long long)A->nrow);
    snprintf(detail, sizeof detail, " (nnz(L) = %.3g)", s->nnz_L);
    int rc = ohm_backend_check_memory(need, d->cfg.max_memory, what, detail,
                                      ohm_backend_amg_available()
                                          ? "use solver=cg or solver=amg (memory O(cells)), a smaller dim= or a "
                                            "larger voxel="
                                          : "use solver=cg (memory O(cells)), a smaller dim= or a larger voxel=",
                                      err);
    if (rc) return rc;
    /* the next material refactorizes into the same L: same pattern, and its
     * memory is already mapped */
    double tf = 0;
    rc = ohm_cholesky_factorize(&d->L, s, A, &tf, d->cfg.log, err);
    if (rc) return rc;
    rep->t_factor += tf;
    rep->factors++;
    snprintf(rep->solver, sizeof rep->solver, "direct");
    if (need > rep->bytes) rep->bytes = need;
    ohm_log_info(d->cfg.log, "solve: factorized (nnz(L) %.3g, %.3g flops) in %.2f s", s->nnz_L, s->flops, tf);
    return OHM_OK;
}

static int direct_solve(void *state, const ohm_operator *op, const double *B, double *X, size_t ncols, double *berr,
                        ohm_backend_report *rep, ohm_error *err)
{
    cholmod_sparse *A = op->A;
    direct_state *d = state;
    int refined = 0;
    int rc = ohm_cholesky_solve(X, &d->solver, d->L, A, B, ncols, berr, &refined, err);
    rep->refined += refined;
    return rc;
}

/* solves over a small factor substitute on one core: media may be solved at once */
const ohm_backend_ops ohm_backend_direct = {.name = "direct",
                                            .create = direct_create,
                                            .setup = direct_setup,
                                            .solve = direct_solve,
                                            .destroy = direct_destroy,
                                            .caps = OHM_BACKEND_CONCURRENT_SOLVES,
                                            .concurrent_max_bytes = OHM_SUBSTITUTE_MAX_BYTES};
