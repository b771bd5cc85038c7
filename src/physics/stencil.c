/* physics/stencil.c — the stencil's form, its runs and its operations
 * (stencil.h), on its rows' loop (stencil_rows.h). */
#include "physics/stencil.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "physics/stencil_rows.h"

void ohm_stencil_free(ohm_stencil *st)
{
    if (!st) return;
    free(st->run_start);
    free(st->run_off);
    free(st->gx);
    free(st->gy);
    free(st->gz);
    free(st->sink);
    ohm_stencil_drop_extra(st);
    memset(st, 0, sizeof *st);
}

void ohm_stencil_drop_extra(ohm_stencil *st)
{
    free(st->xstart);
    free(st->xcol);
    free(st->xg);
    st->xstart = NULL;
    st->xcol = NULL;
    st->xg = NULL;
}

void ohm_stencil_runs_push(ohm_stencil_runs *rl, int64_t v, const int32_t off[4])
{
    if (rl->n && memcmp(rl->off[rl->n - 1], off, sizeof rl->off[0]) == 0) return;
    if (rl->n == rl->cap) {
        int64_t cap = rl->cap ? 2 * rl->cap : 256;
        int64_t *start = realloc(rl->start, (size_t)cap * sizeof *start);
        if (start) rl->start = start;
        int32_t(*o)[4] = start ? realloc(rl->off, (size_t)cap * sizeof *o) : NULL;
        if (!o) {
            rl->failed = 1;
            return;
        }
        rl->off = o;
        rl->cap = cap;
    }
    rl->start[rl->n] = v;
    memcpy(rl->off[rl->n], off, sizeof rl->off[0]);
    rl->n++;
}

void ohm_stencil_runs_free(ohm_stencil_runs *rl)
{
    free(rl->start);
    free(rl->off);
    memset(rl, 0, sizeof *rl);
}

int ohm_stencil_adopt_runs(ohm_stencil *st, const ohm_stencil_runs *lists, int count, ohm_error *err)
{
    free(st->run_start);
    free(st->run_off);
    st->run_start = NULL;
    st->run_off = NULL;
    st->nruns = 0;
    int64_t total = 0;
    for (int i = 0; i < count; ++i) {
        if (lists[i].failed)
            return ohm_fail(err, OHM_ERR_NOMEM, "stencil: out of memory for its runs");
        total += lists[i].n;
    }
    st->run_start = malloc((size_t)(total + 1) * sizeof *st->run_start);
    st->run_off = malloc((size_t)(total ? total : 1) * sizeof *st->run_off);
    if (!st->run_start || !st->run_off)
        return ohm_fail(err, OHM_ERR_NOMEM, "stencil: out of memory for its %lld runs", (long long)total);
    int64_t r = 0;
    for (int i = 0; i < count; ++i)
        for (int64_t k = 0; k < lists[i].n; ++k) {
            if (r && memcmp(st->run_off[r - 1], lists[i].off[k], sizeof st->run_off[0]) == 0) continue;
            st->run_start[r] = lists[i].start[k];
            memcpy(st->run_off[r], lists[i].off[k], sizeof st->run_off[0]);
            ++r;
        }
    st->run_start[r] = st->n;
    st->nruns = r;
    return OHM_OK;
}

double ohm_stencil_bytes(const ohm_stencil *st)
{
    double extra = st->xstart ? (double)(st->n + 1) * sizeof *st->xstart +
                                    (double)st->xstart[st->n] * (sizeof *st->xcol + sizeof *st->xg)
                              : 0.0;
    return (double)st->n * (3 * sizeof(float) + sizeof(double)) +
           (double)st->nruns * (sizeof *st->run_start + sizeof *st->run_off) + sizeof *st->run_start + extra;
}

int ohm_stencil_set_runs(ohm_stencil *st, const int32_t (*off)[4], ohm_error *err)
{
    ohm_stencil_runs rl = {0};
    for (int64_t v = 0; v < st->n; ++v) ohm_stencil_runs_push(&rl, v, off[v]);
    int rc = ohm_stencil_adopt_runs(st, &rl, 1, err);
    ohm_stencil_runs_free(&rl);
    return rc;
}

double ohm_stencil_diag(const ohm_stencil *st, int64_t v)
{
    const int32_t *o = st->run_off[ohm_stencil_run_of(st, v)];
    return row_diag(st, v, o[0], o[1], o[2], o[3], o[0] != 0, o[2] != 0, 1) + extra_diag(st, v);
}

double ohm_stencil_norm_inf(const ohm_stencil *st)
{
    /* an M-matrix's row: |diag| + sum of |links| = sink + 2 sum of links */
    double norm = 0;
    FOR_ROWS(st, 0, st->n, {
        double row = 2.0 * (row_diag(S, ROW_ARGS) + extra_diag(S, v)) - S->sink[v];
        if (row > norm) norm = row; /* not fmax: a library call per row */
    })
    return norm;
}

/* A pass over the rows: its operands, and its pieces' largest values. */
typedef struct rows_pass {
    const ohm_stencil *st;
    const double *x, *b;
    double *y;
    double nr[OHM_ROWS_CHUNKS], nx[OHM_ROWS_CHUNKS], nb[OHM_ROWS_CHUNKS];
} rows_pass;

static void apply_rows(void *user, int64_t lo, int64_t hi, int chunk)
{
    (void)chunk;
    rows_pass *p = user;
    const double *x = p->x;
    double *out = p->y;
    FOR_ROWS_EACH(p->st, lo, hi, out[v] = net_apply(S, x, ROW_ARGS);)
    if (p->st->xstart)
        for (int64_t v = lo; v < hi; ++v) out[v] += extra_apply(p->st, x, v);
}

void ohm_stencil_apply(const ohm_stencil *st, const double *x, double *y, int threads)
{
    rows_pass p = {.st = st, .x = x, .y = y};
    ohm_rows_run(apply_rows, &p, st->n, threads);
}

/* the largest |b - A x|, |x| and |b| of the rows, into the piece's nr, nx, nb */
static void residual_inf_rows(void *user, int64_t lo, int64_t hi, int chunk)
{
    rows_pass *p = user;
    double worst = 0, nx = 0, nb = 0;
    const double *x = p->x, *b = p->b;
    FOR_ROWS(p->st, lo, hi, {
        double r = fabs(b[v] - net_apply(S, x, ROW_ARGS) - (S->xstart ? extra_apply(S, x, v) : 0.0));
        if (!(r <= worst)) worst = r; /* NaN propagates */
        if (fabs(x[v]) > nx) nx = fabs(x[v]);
        if (fabs(b[v]) > nb) nb = fabs(b[v]);
    })
    p->nr[chunk] = worst;
    p->nx[chunk] = nx;
    p->nb[chunk] = nb;
}

void ohm_stencil_residual_norms(const ohm_stencil *st, const double *b, const double *x, int threads, double *nr,
                                double *nx, double *nb)
{
    rows_pass p = {.st = st, .x = x, .b = b};
    int chunks = ohm_rows_run(residual_inf_rows, &p, st->n, threads > 0 ? threads : ohm_usable_cores());
    *nr = *nx = *nb = 0;
    for (int i = 0; i < chunks; ++i) {
        if (!(p.nr[i] <= *nr)) *nr = p.nr[i];
        if (p.nx[i] > *nx) *nx = p.nx[i];
        if (p.nb[i] > *nb) *nb = p.nb[i];
    }
}

/* unknowns lo .. hi-1's sums of the sinks and of the diagonal, added into
 * *sink and *diag */
static void rows_sums(const ohm_stencil *st, int64_t lo, int64_t hi, double *sink, double *diag)
{
    double s = 0, d = 0;
    FOR_ROWS_SUM("omp simd reduction(+ : s, d)", st, lo, hi, {
        s += S->sink[v];
        d += row_diag(S, ROW_ARGS);
    })
    if (st->xstart)
        for (int64_t v = lo; v < hi; ++v) d += extra_diag(st, v);
    *sink += s;
    *diag += d;
}

/* each piece's sums of the sinks and of the diagonal, run by run */
void ohm_stencil_piece_sums(const ohm_stencil *st, const int64_t *start, const int32_t *piece, int64_t count,
                            double *sink, double *diag)
{
    if (!count) rows_sums(st, 0, st->n, &sink[0], &diag[0]);
    for (int64_t r = 0; r < count; ++r) rows_sums(st, start[r], start[r + 1], &sink[piece[r]], &diag[piece[r]]);
}
