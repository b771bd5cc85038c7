#include "factor.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "log.h"

/* Thresholds on the scaled backward error (issue 3 / DESIGN.md §3). */
static const double BERR_REFINE = 1e-12;
static const double BERR_FAIL = 1e-10;

int ohm_solver_start(ohm_solver *s, ohm_error *err)
{
    memset(s, 0, sizeof *s);
    if (!cholmod_l_start(&s->cc)) return ohm_fail(err, OHM_ERR_INTERNAL, "CHOLMOD failed to start");
    s->started = 1;
    s->cc.print = 0;
    s->cc.error_handler = NULL; /* statuses are checked; nothing printed */
    return OHM_OK;
}

void ohm_solver_finish(ohm_solver *s)
{
    if (!s || !s->started) return;
    cholmod_l_free_factor(&s->symbolic, &s->cc);
    cholmod_l_finish(&s->cc);
    s->started = 0;
}

void ohm_factor_free(cholmod_factor **L, ohm_solver *s)
{
    if (L && *L) cholmod_l_free_factor(L, &s->cc);
}

/* One analysis with one ordering; the factor and its statistics in *out. */
static int analyze_one(cholmod_factor **out, double *lnz, double *fl, ohm_solver *s, cholmod_sparse *A, int ordering,
                       const char *name, ohm_error *err)
{
    cholmod_common *cc = &s->cc;
    cc->nmethods = 1;
    cc->postorder = 1;
    cc->method[0].ordering = ordering;
    *out = cholmod_l_analyze(A, cc);
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

int ohm_solver_analyze(ohm_solver *s, cholmod_sparse *A, const char *ordering, ohm_error *err)
{
    cholmod_common *cc = &s->cc;
    cholmod_l_free_factor(&s->symbolic, cc);
    static const struct {
        const char *name;
        int id;
    } orders[] = {{"metis", CHOLMOD_METIS}, {"amd", CHOLMOD_AMD}, {"nesdis", CHOLMOD_NESDIS}};
    int best = strcmp(ordering, "best") == 0;
    double t0 = ohm_now();
    int found = 0;
    for (int i = 0; i < 3; ++i) {
        /* best: METIS and AMD, keep the smaller factor */
        if (best ? orders[i].id == CHOLMOD_NESDIS : strcmp(ordering, orders[i].name) != 0) continue;
        found = 1;
        cholmod_factor *F = NULL;
        double lnz = 0, fl = 0;
        int rc = analyze_one(&F, &lnz, &fl, s, A, orders[i].id, orders[i].name, err);
        if (rc) {
            cholmod_l_free_factor(&s->symbolic, cc);
            return rc;
        }
        if (!s->symbolic || lnz < s->nnz_L) {
            cholmod_l_free_factor(&s->symbolic, cc);
            s->symbolic = F;
            s->nnz_L = lnz;
            s->flops = fl;
            snprintf(s->ordering, sizeof s->ordering, "%s", orders[i].name);
        } else {
            cholmod_l_free_factor(&F, cc);
        }
    }
    if (!found) return ohm_fail(err, OHM_ERR_USAGE, "ordering=%s: expected metis, amd, nesdis or best", ordering);
    s->t_analyze = ohm_now() - t0;
    s->nnz_A = (double)cholmod_l_nnz(A, cc);
    return OHM_OK;
}

int ohm_solver_factorize(cholmod_factor **L, ohm_solver *s, cholmod_sparse *A, double *t, ohm_error *err)
{
    cholmod_common *cc = &s->cc;
    if (!s->symbolic) return ohm_fail(err, OHM_ERR_INTERNAL, "factorize before analyze");
    cholmod_factor *F = *L ? *L : cholmod_l_copy_factor(s->symbolic, cc);
    *L = NULL;
    if (!F) return ohm_fail(err, OHM_ERR_NOMEM, "out of memory copying the symbolic factor");
    s->norm_A = cholmod_l_norm_sparse(A, 0, cc); /* for every solve's backward error */
    double t0 = ohm_now();
    int ok = cholmod_l_factorize(A, F, cc);
    if (t) *t = ohm_now() - t0;
    /* cholmod_factorize returns TRUE on an indefinite matrix: the status and
     * L->minor say so. */
    if (!ok || cc->status == CHOLMOD_NOT_POSDEF || F->minor < F->n) {
        long long minor = (long long)F->minor;
        int status = cc->status;
        cholmod_l_free_factor(&F, cc);
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

/* Largest scaled backward error over the columns of X for residual R. */
static double backward_error(const cholmod_dense *B, const cholmod_dense *X, const cholmod_dense *R, double normA)
{
    size_t n = B->nrow;
    double worst = 0.0;
    for (size_t c = 0; c < B->ncol; ++c) {
        const double *b = (const double *)B->x + c * B->d, *x = (const double *)X->x + c * X->d,
                     *r = (const double *)R->x + c * R->d;
        double nb = 0, nx = 0, nr = 0;
        for (size_t i = 0; i < n; ++i) {
            nb = fmax(nb, fabs(b[i]));
            nx = fmax(nx, fabs(x[i]));
            nr = fmax(nr, fabs(r[i]));
        }
        double denom = normA * nx + nb;
        double e = denom > 0 ? nr / denom : (nr > 0 ? INFINITY : 0.0);
        if (!(e <= worst)) worst = e; /* NaN propagates as worst */
    }
    return worst;
}

/* R = B - A X */
static int residual(cholmod_dense *R, cholmod_sparse *A, const cholmod_dense *B, cholmod_dense *X, cholmod_common *cc)
{
    memcpy(R->x, B->x, B->nrow * B->ncol * sizeof(double));
    double minus_one[2] = {-1, 0}, one[2] = {1, 0};
    return cholmod_l_sdmult(A, 0, minus_one, one, X, R, cc);
}

int ohm_solver_backward_error(double *berr, ohm_solver *s, cholmod_sparse *A, const double *Bin, const double *Xin,
                              size_t ncols, ohm_error *err)
{
    cholmod_common *cc = &s->cc;
    size_t n = A->nrow;
    cholmod_dense *B = cholmod_l_allocate_dense(n, ncols, n, CHOLMOD_REAL, cc);
    cholmod_dense *X = cholmod_l_allocate_dense(n, ncols, n, CHOLMOD_REAL, cc);
    cholmod_dense *R = cholmod_l_allocate_dense(n, ncols, n, CHOLMOD_REAL, cc);
    int rc = OHM_OK;
    if (!B || !X || !R) rc = ohm_fail(err, OHM_ERR_NOMEM, "out of memory computing a residual");
    if (!rc) {
        memcpy(B->x, Bin, n * ncols * sizeof(double));
        memcpy(X->x, Xin, n * ncols * sizeof(double));
        if (!residual(R, A, B, X, cc)) rc = ohm_fail(err, OHM_ERR_NOMEM, "CHOLMOD multiply failed");
        else *berr = backward_error(B, X, R, cholmod_l_norm_sparse(A, 0, cc));
    }
    cholmod_l_free_dense(&B, cc);
    cholmod_l_free_dense(&X, cc);
    cholmod_l_free_dense(&R, cc);
    return rc;
}

int ohm_solver_solve(double *Xout, ohm_solver *s, cholmod_factor *L, cholmod_sparse *A, const double *Bin,
                     size_t ncols, double *berr, int *refined, ohm_error *err)
{
    cholmod_common *cc = &s->cc;
    size_t n = A->nrow;
    int rc = OHM_OK;
    cholmod_dense *B = cholmod_l_allocate_dense(n, ncols, n, CHOLMOD_REAL, cc);
    cholmod_dense *R = cholmod_l_allocate_dense(n, ncols, n, CHOLMOD_REAL, cc);
    cholmod_dense *X = NULL, *dX = NULL;
    if (refined) *refined = 0;
    if (!B || !R) {
        rc = ohm_fail(err, OHM_ERR_NOMEM, "out of memory for %zu right-hand sides of %zu unknowns", ncols, n);
        goto done;
    }
    memcpy(B->x, Bin, n * ncols * sizeof(double));
    X = cholmod_l_solve(CHOLMOD_A, L, B, cc);
    if (!X || !residual(R, A, B, X, cc)) {
        rc = ohm_fail(err, OHM_ERR_NOMEM, "CHOLMOD solve failed (status %d)", cc->status);
        goto done;
    }
    double normA = s->norm_A > 0 ? s->norm_A : cholmod_l_norm_sparse(A, 0, cc);
    double e = backward_error(B, X, R, normA);
    if (!(e <= BERR_REFINE)) {
        /* one step of iterative refinement: x += A^-1 (b - A x) */
        dX = cholmod_l_solve(CHOLMOD_A, L, R, cc);
        if (!dX) {
            rc = ohm_fail(err, OHM_ERR_NOMEM, "CHOLMOD solve failed (status %d)", cc->status);
            goto done;
        }
        double *x = X->x, *dx = dX->x;
        for (size_t i = 0; i < n * ncols; ++i) x[i] += dx[i];
        if (!residual(R, A, B, X, cc)) {
            rc = ohm_fail(err, OHM_ERR_NOMEM, "CHOLMOD multiply failed (status %d)", cc->status);
            goto done;
        }
        e = backward_error(B, X, R, normA);
        if (refined) *refined = 1;
    }
    if (berr) *berr = e;
    if (!(e <= BERR_FAIL)) {
        rc = ohm_fail(err, OHM_ERR_NUMERIC,
                      "the solve is not accurate: scaled backward error %.3g after refinement (limit %.0e); the "
                      "matrix is singular or too ill-conditioned",
                      e, BERR_FAIL);
        goto done;
    }
    memcpy(Xout, X->x, n * ncols * sizeof(double));
done:
    cholmod_l_free_dense(&B, cc);
    cholmod_l_free_dense(&R, cc);
    cholmod_l_free_dense(&X, cc);
    cholmod_l_free_dense(&dX, cc);
    return rc;
}
