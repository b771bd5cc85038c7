/* solvers/batch.c — frames in batches (solve.h): how many fit the memory
 * cap, the work arrays of a batch (owned by whoever allocates them),
 * frames whose light did not change skipped and restored, each batch's warm
 * start, and the scaled unknowns of a per-cell index (network.h). */
#include "solvers/solver_impl.h"
#include "solvers/transport.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* Frames whose light did not change (the same right-hand side as the frame
 * before) are not solved again: B's nb columns are compacted to the distinct
 * ones, in order; col_of[j] is the distinct column frame j takes, or SIZE_MAX
 * for "the previous batch's last frame" (prev_b, NULL in the first batch).
 * Returns how many are distinct. */
size_t ohm_distinct_columns(channel_tally *t, double *B, size_t *col_of, size_t nb, const double *prev_b,
                            size_t n)
{
    size_t nu = 0;
    for (size_t j = 0; j < nb; ++j) {
        const double *bj = B + j * n;
        const double *bp = j > 0 && col_of[j - 1] != SIZE_MAX ? B + col_of[j - 1] * n : prev_b;
        if (bp && !memcmp(bj, bp, n * sizeof *B)) {
            col_of[j] = bp == prev_b ? SIZE_MAX : col_of[j - 1];
            t->solves_skipped++;
            continue;
        }
        if (nu != j) memcpy(B + nu * n, bj, n * sizeof *B);
        col_of[j] = nu++;
    }
    return nu;
}

/* The starting guess of the batch's first column (the backends start every
 * later one from the column before it: consecutive frames): the frame before
 * (the last batch's last), else this frame of channel warm_from (same light,
 * another colour or medium), else zero. */
void ohm_warm_start(double *X, const ohm_solution *sol, size_t f0, int c, int warm_from, size_t n)
{
    if (f0 > 0) memcpy(X, sol->fluence[c] + (f0 - 1) * n, n * sizeof *X);
    else if (warm_from >= 0) memcpy(X, sol->fluence[warm_from], n * sizeof *X);
    else memset(X, 0, n * sizeof *X);
}

/* Undo ohm_distinct_columns: column j of X and B becomes distinct column
 * col_of[j] (<= j), or the previous batch's last frame; prev_b then keeps
 * this batch's last right-hand side (NULL: there is no later batch). */
void ohm_expand_columns(double *X, double *B, const ohm_solution *sol, const size_t *col_of, size_t nb, size_t f0,
                        int c, double *prev_b, size_t n)
{
    for (size_t j = nb; j-- > 0;) {
        double *xj = X + j * n, *bj = B + j * n;
        if (col_of[j] == SIZE_MAX) {
            memcpy(xj, sol->fluence[c] + (f0 - 1) * n, n * sizeof *X);
            memcpy(bj, prev_b, n * sizeof *B);
        } else if (col_of[j] != j) {
            memcpy(xj, X + col_of[j] * n, n * sizeof *X);
            memcpy(bj, B + col_of[j] * n, n * sizeof *B);
        }
    }
    if (prev_b) memcpy(prev_b, B + (nb - 1) * n, n * sizeof *B);
}

/* With a per-cell index the matrix's unknowns are psi = phi / s (network.h):
 * ncols columns of X from phi to psi (to_phi = 0: a starting guess) or back. */
void ohm_scale_unknowns(double *X, size_t ncols, size_t n, const ohm_channel_medium *med, int to_phi)
{
    if (!med->eta_v) return;
    for (size_t v = 0; v < n; ++v) {
        double s = ohm_network_unknown_scale(med, (int64_t)v);
        for (size_t j = 0; j < ncols; ++j) X[j * n + v] = to_phi ? X[j * n + v] * s : X[j * n + v] / s;
    }
}

/* Frames per batch: B and X together within the memory cap (X, the
 * solution, is no array of its own: each batch is solved in place in its
 * frames' columns of sol->fluence, -8 B per cell and column); the hybrid
 * keeps its transport part's fluence and faces per column too. */
size_t ohm_batch_frames(const ohm_solver *s, size_t frames, int hybrid)
{
    const ohm_solution *sol = &s->sol;
    double n = (double)sol->n, nf = (double)(sol->net.nfaces ? sol->net.nfaces : 1);
    double cap = s->params.num.max_rhs_bytes > 0 ? s->params.num.max_rhs_bytes : (double)(1u << 30);
    double per_column = hybrid ? 3.0 * n + nf : 2.0 * n;
    size_t batch = (size_t)(cap / (sizeof(double) * per_column));
    if (batch < 1) batch = 1;
    return batch > frames ? frames : batch;
}

void ohm_batch_work_free(batch_work *w)
{
    free(w->B);
    free(w->col_of);
    free(w->prev_b);
    ohm_hybrid_free(&w->hy);
}

int ohm_batch_work_alloc(batch_work *w, const ohm_solution *sol, size_t batch, int hybrid, ohm_error *err)
{
    size_t n = (size_t)sol->n, nf = (size_t)(sol->net.nfaces ? sol->net.nfaces : 1), frames = (size_t)sol->frames;
    memset(w, 0, sizeof *w);
    w->B = malloc((n ? n : 1) * batch * sizeof *w->B);
    w->col_of = malloc(batch * sizeof *w->col_of);
    w->prev_b = batch < frames ? malloc((n ? n : 1) * sizeof *w->prev_b) : NULL;
    if (!w->B || !w->col_of || (batch < frames && !w->prev_b))
        return ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory for %zu right-hand sides of %zu unknowns", batch, n);
    return hybrid ? ohm_hybrid_alloc(&w->hy, n, nf, batch, err) : OHM_OK;
}
