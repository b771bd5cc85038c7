/* solvers/backend.c — the backend registry and the one backward-error check
 * every backend's solve ends with (backend.h). */
#include "solvers/backend.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "base/memory.h"
#include "physics/stencil.h"

double ohm_sym_upper_norm_inf(const cholmod_sparse *A)
{
    /* row sums of |A| = column sums (A is symmetric): each stored
     * off-diagonal entry counts in its row and in its column */
    int64_t n = (int64_t)A->ncol;
    const int64_t *Ap = A->p, *Ai = A->i;
    const double *Ax = A->x;
    double *sum = calloc((size_t)(n ? n : 1), sizeof *sum), norm = 0;
    if (!sum) return NAN; /* unknown: every check against it fails */
    for (int64_t j = 0; j < n; ++j)
        for (int64_t q = Ap[j]; q < Ap[j + 1]; ++q) {
            sum[j] += fabs(Ax[q]);
            if (Ai[q] != j) sum[Ai[q]] += fabs(Ax[q]);
        }
    for (int64_t j = 0; j < n; ++j) norm = fmax(norm, sum[j]);
    free(sum);
    return norm;
}

void ohm_sym_upper_mult(const cholmod_sparse *A, const double *x, double *y)
{
    const int64_t *Ap = A->p, *Ai = A->i;
    const double *Ax = A->x;
    int64_t n = (int64_t)A->ncol;
    memset(y, 0, (size_t)n * sizeof *y);
    for (int64_t j = 0; j < n; ++j) {
        double xj = x[j], yj = 0.0;
        for (int64_t q = Ap[j]; q < Ap[j + 1]; ++q) {
            int64_t i = Ai[q];
            double a = Ax[q];
            if (i == j) {
                yj += a * xj;
            } else {
                yj += a * x[i];
                y[i] += a * xj;
            }
        }
        y[j] += yj;
    }
}

void ohm_operator_apply(const ohm_operator *op, const double *x, double *y)
{
    if (op->stencil) ohm_stencil_apply(op->stencil, x, y, 0);
    else ohm_sym_upper_mult(op->A, x, y);
}

double ohm_operator_diag(const ohm_operator *op, int64_t v)
{
    if (op->stencil) return ohm_stencil_diag(op->stencil, v);
    const int64_t *Ap = op->A->p;
    return ((const double *)op->A->x)[Ap[v + 1] - 1]; /* the diagonal closes each column (network.h) */
}

double ohm_operator_norm_inf(const ohm_operator *op)
{
    return op->stencil ? ohm_stencil_norm_inf(op->stencil) : ohm_sym_upper_norm_inf(op->A);
}

/* ||r|| / (normA ||x|| + ||b||) from the three infinity norms (nr: NaN
 * propagates) */
static double scaled_error(double nr, double nx, double nb, double normA)
{
    double denom = normA * nx + nb;
    return denom > 0 ? nr / denom : (nr > 0 ? INFINITY : 0.0);
}

double ohm_scaled_backward_error(const double *b, const double *x, const double *r, size_t n, double normA)
{
    double nr = 0, nx = 0, nb = 0;
    for (size_t i = 0; i < n; ++i) {
        nr = fmax(nr, fabs(r[i]));
        nx = fmax(nx, fabs(x[i]));
        nb = fmax(nb, fabs(b[i]));
    }
    return scaled_error(nr, nx, nb, normA);
}

double ohm_operator_backward_error(const ohm_operator *op, const double *B, const double *X, size_t ncols,
                                   double normA)
{
    size_t n = (size_t)op->n;
    if (!(normA > 0)) normA = ohm_operator_norm_inf(op);
    double worst = 0;
    if (op->stencil) { /* row by row: no n-long residual beside a large solve's vectors */
        for (size_t c = 0; c < ncols; ++c) {
            const double *b = B + c * n, *x = X + c * n;
            double nr, nx, nb;
            ohm_stencil_residual_norms(op->stencil, b, x, 0, &nr, &nx, &nb);
            double e = scaled_error(nr, nx, nb, normA);
            if (!(e <= worst)) worst = e;
        }
        return worst;
    }
    double *r = malloc((n ? n : 1) * sizeof *r);
    if (!r) return INFINITY; /* cannot check: report it as failed, never as passed */
    for (size_t c = 0; c < ncols; ++c) {
        const double *b = B + c * n, *x = X + c * n;
        ohm_operator_apply(op, x, r);
        for (size_t i = 0; i < n; ++i) r[i] = b[i] - r[i];
        double e = ohm_scaled_backward_error(b, x, r, n, normA);
        if (!(e <= worst)) worst = e; /* NaN propagates as worst */
    }
    free(r);
    return worst;
}

double ohm_backward_error(cholmod_sparse *A, const double *B, const double *X, size_t ncols, double normA)
{
    ohm_operator op = {.n = (int64_t)A->ncol, .A = A};
    return ohm_operator_backward_error(&op, B, X, ncols, normA);
}

void ohm_backend_iterative_defaults(ohm_backend_config *cfg, int64_t max_iter)
{
    if (!(cfg->tol > 0)) cfg->tol = 1e-10;
    if (cfg->max_iter <= 0) cfg->max_iter = max_iter;
}

void ohm_backend_book_columns(ohm_backend_report *rep, int64_t iters, double relres, double tol, int64_t stopped_short)
{
    rep->iterations += iters;
    if (relres > rep->relres) rep->relres = relres;
    rep->tol = tol;
    rep->stalled += stopped_short;
}

int ohm_backend_solve_columns(ohm_column_solver fn, void *solver, size_t n, const double *B, double *X, size_t ncols,
                              double tol, ohm_backend_report *rep, ohm_error *err)
{
    for (size_t j = 0; j < ncols; ++j) {
        int64_t its = 0;
        double relres = 0;
        if (j > 0) memcpy(X + j * n, X + (j - 1) * n, n * sizeof *X);
        int rc = fn(solver, X + j * n, B + j * n, &its, &relres, err);
        /* a column the solver accepted above tol passed its backward-error
         * test at the cap or a residual floor (cg.c, mg_cycle.c): kept, but
         * said; a failed column is no accepted one */
        ohm_backend_book_columns(rep, its, relres, tol, !rc && relres > tol);
        if (rc) return rc;
    }
    return OHM_OK;
}

int ohm_backend_check_memory(double need, double max_memory, const char *what, const char *detail,
                             const char *advice, ohm_error *err)
{
    double limit = ohm_memory_limit(max_memory);
    if (!(need > limit)) return OHM_OK;
    char nb[32], lb[32];
    return ohm_fail(err, OHM_ERR_NOMEM, "solve: %s needs about %s%s, more than the %s %s; %s", what,
                    ohm_format_bytes(need, nb, 32), detail ? detail : "", ohm_format_bytes(limit, lb, 32),
                    max_memory > 0 ? "max_memory= allows" : "available", advice);
}
