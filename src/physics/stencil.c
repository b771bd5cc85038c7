/* physics/stencil.c — the stencil's own operations (stencil.h), on its
 * rows' loop (stencil_rows.h). */
#include "physics/stencil.h"

#include <math.h>

#include "physics/stencil_rows.h"

double ohm_stencil_diag(const ohm_stencil *st, int64_t v)
{
    const int32_t *o = st->run_off[ohm_stencil_run_of(st, v)];
    return row_diag(st, v, o[0], o[1], o[2], o[3], o[0] != 0, o[2] != 0, 1);
}

double ohm_stencil_norm_inf(const ohm_stencil *st)
{
    /* an M-matrix's row: |diag| + sum of |links| = sink + 2 sum of links */
    double norm = 0;
    FOR_ROWS(st, 0, st->n, {
        double row = 2.0 * row_diag(S, ROW_ARGS) - S->sink[v];
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
        double r = fabs(b[v] - net_apply(S, x, ROW_ARGS));
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
    *sink += s;
    *diag += d;
}

/* each piece's sums of the sinks and of the diagonal, run by run */
void ohm_stencil_piece_sums(const ohm_stencil *st, const ohm_piece_runs *pieces, double *sink, double *diag)
{
    if (!pieces->count) rows_sums(st, 0, st->n, &sink[0], &diag[0]);
    for (int64_t r = 0; r < pieces->count; ++r) {
        int32_t p = pieces->piece[r];
        rows_sums(st, pieces->start[r], pieces->start[r + 1], &sink[p], &diag[p]);
    }
}
