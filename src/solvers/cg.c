/* solvers/cg.c — MIC(0)-preconditioned conjugate gradients (cg.h) and the
 * `cg` backend over them (backend.h). */
#include "solvers/cg.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "base/log.h"
#include "base/memory.h"
#include "solvers/backend.h"

/* Modification weight: 1 keeps M's row sums equal to A's (full MIC), which
 * is what lowers the condition number to O(h^-1); slightly below 1 guards
 * against tiny pivots when the row sums (the sinks: absorption and boundary
 * leaks) are themselves tiny.  0.97 was the best of 0, 0.9, 0.95, 0.97, 0.99
 * on spot and the slab scenes (docs/accuracy.md). */
static const double MIC_OMEGA = 0.97;

double ohm_cg_bytes(int64_t n) { return 5.0 * sizeof(double) * (double)n; }

void ohm_cg_free(ohm_cg *cg)
{
    if (!cg) return;
    free(cg->d);
    free(cg->r);
    free(cg->z);
    free(cg->p);
    free(cg->q);
    memset(cg, 0, sizeof *cg);
}

int ohm_cg_setup(ohm_cg *cg, const cholmod_sparse *A, ohm_error *err)
{
    double t0 = ohm_now();
    memset(cg, 0, sizeof *cg);
    int64_t n = (int64_t)A->ncol;
    cg->A = A;
    cg->n = n;
    cg->omega = MIC_OMEGA;
    size_t bytes = (size_t)(n ? n : 1) * sizeof(double);
    cg->d = malloc(bytes);
    cg->r = malloc(bytes);
    cg->z = malloc(bytes);
    cg->p = malloc(bytes);
    cg->q = malloc(bytes);
    double *upper_sum = calloc((size_t)(n ? n : 1), sizeof(double));
    if (!cg->d || !cg->r || !cg->z || !cg->p || !cg->q || !upper_sum) {
        free(upper_sum);
        ohm_cg_free(cg);
        return ohm_fail(err, OHM_ERR_NOMEM, "cg: out of memory for %lld unknowns", (long long)n);
    }
    const int64_t *Ap = A->p, *Ai = A->i;
    const double *Ax = A->x;
    /* upper_sum[i] = sum over k > i of a_ik (row i right of the diagonal):
     * column k of the upper triangle holds a_ik for i < k */
    for (int64_t k = 0; k < n; ++k)
        for (int64_t q = Ap[k]; q < Ap[k + 1]; ++q)
            if (Ai[q] != k) upper_sum[Ai[q]] += Ax[q];
    /* d_j = a_jj - sum_{i<j, i~j} (a_ij / d_i) (a_ij + omega (upper_sum_i - a_ij)):
     * the second term puts the fill that IC(0) drops (a_ji a_ik / d_i at
     * (j,k), k != j) back on the diagonal, so M and A have (nearly) equal row
     * sums (Gustafsson's modification). */
    for (int64_t j = 0; j < n; ++j) {
        double ajj = 0.0, s = 0.0;
        for (int64_t q = Ap[j]; q < Ap[j + 1]; ++q) {
            int64_t i = Ai[q];
            double a = Ax[q];
            if (i == j) ajj = a;
            else s += (a / cg->d[i]) * (a + cg->omega * (upper_sum[i] - a));
        }
        double dj = ajj - s;
        /* A is an M-matrix, so the pivots of IC(0) stay positive; the
         * modification can drive one to ~0 when a row's sinks vanish: keep
         * the unmodified share of the diagonal then. */
        if (!(dj > 1e-3 * ajj)) dj = 1e-3 * ajj;
        if (!(ajj > 0)) {
            free(upper_sum);
            ohm_cg_free(cg);
            return ohm_fail(err, OHM_ERR_NUMERIC, "cg: diagonal entry %lld is %g, expected > 0", (long long)j, ajj);
        }
        cg->d[j] = dj;
    }
    free(upper_sum);
    /* ||A||_inf: row sums of |a|, the upper triangle counted for both halves */
    double *rowsum = calloc((size_t)(n ? n : 1), sizeof *rowsum);
    if (!rowsum) {
        ohm_cg_free(cg);
        return ohm_fail(err, OHM_ERR_NOMEM, "cg: out of memory for %lld unknowns", (long long)n);
    }
    for (int64_t j = 0; j < n; ++j)
        for (int64_t q = Ap[j]; q < Ap[j + 1]; ++q) {
            rowsum[j] += fabs(Ax[q]);
            if (Ai[q] != j) rowsum[Ai[q]] += fabs(Ax[q]);
        }
    for (int64_t j = 0; j < n; ++j) cg->norm_A = fmax(cg->norm_A, rowsum[j]);
    free(rowsum);
    cg->t_setup = ohm_now() - t0;
    return OHM_OK;
}

/* z = M^-1 r with M = (D + L) D^-1 (D + L^T). */
static void precondition(const ohm_cg *cg, const double *r, double *z)
{
    const cholmod_sparse *A = cg->A;
    const int64_t *Ap = A->p, *Ai = A->i;
    const double *Ax = A->x, *d = cg->d;
    int64_t n = cg->n;
    /* (D + L) y = r, forward: row j of L = column j of the upper triangle */
    for (int64_t j = 0; j < n; ++j) {
        double s = r[j];
        for (int64_t q = Ap[j]; q < Ap[j + 1]; ++q)
            if (Ai[q] != j) s -= Ax[q] * z[Ai[q]];
        z[j] = s / d[j];
    }
    /* (I + D^-1 L^T) z = y, backward, column-oriented: once z_j is final,
     * subtract its share from the rows i < j above it */
    for (int64_t j = n - 1; j >= 0; --j) {
        double zj = z[j];
        for (int64_t q = Ap[j]; q < Ap[j + 1]; ++q) {
            int64_t i = Ai[q];
            if (i != j) z[i] -= Ax[q] * zj / d[i];
        }
    }
}

static double dot(const double *a, const double *b, int64_t n)
{
    double s = 0.0;
    for (int64_t i = 0; i < n; ++i) s += a[i] * b[i];
    return s;
}

int ohm_cg_solve(ohm_cg *cg, double *x, const double *b, double tol, int64_t max_iter, int64_t *iters,
                 double *relres, ohm_error *err)
{
    int64_t n = cg->n;
    double *r = cg->r, *z = cg->z, *p = cg->p, *q = cg->q;
    double nb = sqrt(dot(b, b, n));
    *iters = 0;
    *relres = 0.0;
    if (!(nb > 0)) {
        memset(x, 0, (size_t)n * sizeof *x);
        return OHM_OK;
    }
    int64_t it = 0;
    int restarts = 0;
    /* progress: the residual's fall so far against the fall asked for */
    ohm_progress prog;
    ohm_progress_begin(&prog, cg->log, "solve: cg");
    double t_reported = prog.t_begin;
    for (;;) {
        /* the true residual; CG's recursive one drifts from it, so every
         * (re)start and the final test use b - A x */
        ohm_sym_upper_mult(cg->A, x, q);
        for (int64_t i = 0; i < n; ++i) r[i] = b[i] - q[i];
        double nr = sqrt(dot(r, r, n));
        if (it == 0 && !(nr <= nb)) { /* a warm start worse than zero (or not finite): start cold */
            memset(x, 0, (size_t)n * sizeof *x);
            memcpy(r, b, (size_t)n * sizeof *r);
            nr = nb;
        }
        *relres = nr / nb;
        if (nr <= tol * nb) break;
        /* stagnated at the floor */
        if (restarts > 0 && ohm_scaled_backward_error(b, x, r, (size_t)cg->n, cg->norm_A) <= 0.01 * tol) break;
        if (it >= max_iter || restarts > 5) {
            *iters = it;
            return ohm_fail(err, OHM_ERR_NUMERIC,
                            "cg: did not converge: relative residual %.3g after %lld iterations (cg_tol=%.1g); use "
                            "solver=direct, or a looser cg_tol=",
                            nr / nb, (long long)it, tol);
        }
        ++restarts;
        precondition(cg, r, z);
        memcpy(p, z, (size_t)n * sizeof *p);
        double rz = dot(r, z, n);
        while (nr > tol * nb && it < max_iter) {
            ohm_sym_upper_mult(cg->A, p, q);
            double pq = dot(p, q, n);
            if (!(pq > 0)) break; /* converged to round-off (or A not positive definite) */
            double alpha = rz / pq;
            for (int64_t i = 0; i < n; ++i) {
                x[i] += alpha * p[i];
                r[i] -= alpha * q[i];
            }
            ++it;
            nr = sqrt(dot(r, r, n));
            if (ohm_log_cancelled(cg->log)) {
                *iters = it;
                return ohm_fail_cancelled(err, "cg");
            }
            if (cg->log && ohm_now() - t_reported >= 0.05) {
                t_reported = ohm_now();
                ohm_progress_update(&prog, fmin(1.0, fmax(0.0, log(nr / nb) / log(tol))));
            }
            precondition(cg, r, z);
            double rz_new = dot(r, z, n);
            double beta = rz_new / rz;
            rz = rz_new;
            for (int64_t i = 0; i < n; ++i) p[i] = z[i] + beta * p[i];
        }
    }
    *iters = it;
    ohm_progress_end(&prog);
    return OHM_OK;
}

/* ---- the cg backend (backend.h) -------------------------------------------------- */

typedef struct cg_state {
    ohm_cg cg;
    ohm_backend_config cfg;
} cg_state;

static void cg_destroy(void *state)
{
    cg_state *s = state;
    if (!s) return;
    ohm_cg_free(&s->cg);
    free(s);
}

static int cg_create(void **state, const ohm_backend_config *cfg, ohm_error *err)
{
    cg_state *s = calloc(1, sizeof *s);
    if (!s) return ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory");
    s->cfg = *cfg;
    ohm_backend_iterative_defaults(&s->cfg, 20000);
    *state = s;
    return OHM_OK;
}

static int cg_backend_setup(void *state, const ohm_operator *op, ohm_backend_report *rep, ohm_error *err)
{
    cholmod_sparse *A = op->A;
    cg_state *s = state;
    int64_t n = (int64_t)A->nrow;
    double need = ohm_cg_bytes(n) + 2.0 * sizeof(double) * (double)n * (double)(s->cfg.batch ? s->cfg.batch : 1);
    char what[64];
    snprintf(what, sizeof what, "CG on %lld cells", (long long)n);
    int rc = ohm_backend_check_memory(need, s->cfg.max_memory, what, NULL, "use a smaller dim= or a larger voxel=", err);
    if (rc) return rc;
    ohm_cg_free(&s->cg);
    rc = ohm_cg_setup(&s->cg, A, err);
    if (rc) return rc;
    s->cg.log = s->cfg.log;
    rep->t_precond += s->cg.t_setup;
    rep->precond_setups++;
    snprintf(rep->solver, sizeof rep->solver, "cg");
    rep->nnz_A = (double)A->nzmax;
    if (need > rep->bytes) rep->bytes = need;
    return OHM_OK;
}

static int cg_column(void *solver, double *x, const double *b, int64_t *iters, double *relres, ohm_error *err)
{
    cg_state *s = solver;
    return ohm_cg_solve(&s->cg, x, b, s->cfg.tol, s->cfg.max_iter, iters, relres, err);
}

static int cg_backend_solve(void *state, const ohm_operator *op, const double *B, double *X, size_t ncols, double *berr,
                            ohm_backend_report *rep, ohm_error *err)
{
    cholmod_sparse *A = op->A;
    cg_state *s = state;
    int rc = ohm_backend_solve_columns(cg_column, s, A->nrow, B, X, ncols, s->cfg.tol, rep, err);
    if (!rc) *berr = ohm_backward_error(A, B, X, ncols, s->cg.norm_A);
    return rc;
}

const ohm_backend_ops ohm_backend_cg = {.name = "cg",
                                        .create = cg_create,
                                        .setup = cg_backend_setup,
                                        .solve = cg_backend_solve,
                                        .destroy = cg_destroy,
                                        .caps = OHM_BACKEND_WARM_START};
