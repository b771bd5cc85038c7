/* physics/stencil_rows.h — the loop over a stencil's rows (ohm_stencil,
 * stencil_form.h), stretch by stretch, and the rows' arithmetic in double:
 * what the stencil's own operations (stencil.c) and the multigrid's host
 * kernels (solvers/mg.c) are written with.  Static inline, so that each
 * loop is compiled, and vectorised, where it is used (with -fopenmp-simd:
 * CMakeLists.txt). */
#ifndef OHM_PHYSICS_STENCIL_ROWS_H
#define OHM_PHYSICS_STENCIL_ROWS_H

#include <stdint.h>

#include "base/parallel.h"
#include "physics/stencil_form.h"

/* Below this many rows a loop runs on one core: a thread's start (~20-50
 * us) would cost more than it shares.  Above, it is cut into
 * OHM_ROWS_CHUNKS pieces whatever the number of cores, and reductions add
 * the pieces' sums in order, so that a solve gives the same bits on any
 * number of cores. */
enum { OHM_ROWS_PARALLEL_MIN = 1 << 16, OHM_ROWS_CHUNKS = 64 };

typedef struct ohm_rows_loop {
    void (*fn)(void *user, int64_t lo, int64_t hi, int chunk);
    void *user;
    int64_t n;
    int chunks;
} ohm_rows_loop;

static inline void ohm_rows_piece(void *user, int64_t i)
{
    const ohm_rows_loop *loop = user;
    int64_t lo = loop->n * i / loop->chunks, hi = loop->n * (i + 1) / loop->chunks;
    loop->fn(loop->user, lo, hi, (int)i);
}

/* fn(user, lo, hi, chunk) over 0 .. n-1 in pieces, on up to `threads`
 * cores; returns the number of pieces (chunk runs 0 .. that - 1). */
static inline int ohm_rows_run(void (*fn)(void *user, int64_t lo, int64_t hi, int chunk), void *user, int64_t n,
                               int threads)
{
    ohm_rows_loop loop = {fn, user, n, n >= OHM_ROWS_PARALLEL_MIN ? OHM_ROWS_CHUNKS : 1};
    if (loop.chunks == 1 || threads <= 1)
        for (int i = 0; i < loop.chunks; ++i) ohm_rows_piece(&loop, i);
    else ohm_parallel_for(loop.chunks, threads, ohm_rows_piece, &loop);
    return loop.chunks;
}

/* Rows lo .. hi-1 of a stencil cut where its runs end (network.h): in
 * each stretch a .. e-1 the neighbours lie at the fixed distances ym, yp,
 * zm, zp (0: none), so a row loop over it reads every array at a fixed
 * offset and vectorises.  The first and last unknowns come alone, as
 * edge stretches: their -x (+x) neighbour's index would fall outside the
 * vectors. */
typedef struct stretch {
    const ohm_stencil *st;
    int64_t v, hi, run; /* the next row, the end, its run */
    int64_t a, e, ym, yp, zm, zp;
    int edge;
} stretch;

static inline stretch stretches(const ohm_stencil *st, int64_t lo, int64_t hi)
{
    return (stretch){.st = st, .v = lo, .hi = hi, .run = lo < hi ? ohm_stencil_run_of(st, lo) : 0};
}

static inline int next_stretch(stretch *it)
{
    const ohm_stencil *st = it->st;
    int64_t v = it->v;
    if (v >= it->hi) return 0;
    int64_t r = ohm_stencil_run(st, v, &it->run), end = st->run_start[r + 1];
    const int32_t *o = st->run_off[r];
    it->ym = o[0], it->yp = o[1], it->zm = o[2], it->zp = o[3];
    it->a = v;
    it->edge = v == 0 || v == st->n - 1;
    if (it->edge) it->e = v + 1;
    else { /* to the run's end, the range's or the last unknown, whichever is first */
        int64_t e = end < it->hi ? end : it->hi;
        it->e = e < st->n - 1 ? e : st->n - 1;
    }
    it->v = it->e;
    return 1;
}

/* The statements ... for every row v in lo .. hi-1 of ST, stretch by
 * stretch, with v's neighbours' distances ym, yp, zm, zp, my = (ym != 0),
 * mz = (zm != 0) and edge (1 for the first and last unknowns) in scope,
 * constant in each stretch's loop, and S, a local copy of ST (the loop's
 * stores cannot move its arrays).  FOR_ROWS_EACH is for statements that
 * write row v's own output only, in an array no other row reads, and
 * FOR_ROWS_SUM("omp simd reduction(+ : s, t)", ...) for those that also
 * add into the variables named there:
 * the compiler is told so (OpenMP's simd, with -fopenmp-simd), since it
 * cannot prove it (every array is float, and a dozen run-time overlap
 * tests are more than it will make; a sum's order is fixed by the stretch,
 * not by the cores), and vectorises the loop. */
#define FOR_ROWS_(PRAGMA, ST, LO, HI, ...)                                                                      \
    for (stretch it_ = stretches(ST, LO, HI); next_stretch(&it_);) {                                            \
        const ohm_stencil S_ = *it_.st, *S = &S_;                                                               \
        (void)S;                                                                                                \
        const int64_t ym = it_.ym, yp = it_.yp, zm = it_.zm, zp = it_.zp, a_ = it_.a, e_ = it_.e;               \
        const float my = ym != 0, mz = zm != 0;                                                                 \
        (void)ym, (void)yp, (void)zm, (void)zp, (void)my, (void)mz;                                             \
        if (it_.edge)                                                                                           \
            for (int64_t v = a_; v < e_; ++v) {                                                                 \
                const int edge = 1;                                                                             \
                (void)edge;                                                                                     \
                __VA_ARGS__                                                                                     \
            }                                                                                                   \
        else {                                                                                                  \
            PRAGMA                                                                                              \
            for (int64_t v = a_; v < e_; ++v) {                                                                 \
                const int edge = 0;                                                                             \
                (void)edge;                                                                                     \
                __VA_ARGS__                                                                                     \
            }                                                                                                   \
        }                                                                                                       \
    }
#define FOR_ROWS(ST, LO, HI, ...) FOR_ROWS_(, ST, LO, HI, __VA_ARGS__)
#define FOR_ROWS_EACH(ST, LO, HI, ...) FOR_ROWS_(_Pragma("omp simd"), ST, LO, HI, __VA_ARGS__)
#define FOR_ROWS_SUM(SIMD, ST, LO, HI, ...) FOR_ROWS_(_Pragma(SIMD), ST, LO, HI, __VA_ARGS__)

/* The arguments of a row function: a row, its neighbours' distances. */
#define ROW_ARGS v, ym, yp, zm, zp, my, mz, edge
#define ROW_PARAMS int64_t v, int64_t ym, int64_t yp, int64_t zm, int64_t zp, float my, float mz, int edge

/* (A x)_v for the network's stencil, in double, in flux form:
 *   sink_v x_v + sum_w g_vw (x_v - x_w)
 * (network.h's KCL), not diag_v x_v - sum_w g_vw x_w.  Each link's term is
 * the exact negative of its term in w's row, so the rows' sum is
 * sum_v sink_v x_v up to the rounding of those terms, not of diag_v x_v,
 * where the links may dwarf the sinks (sigma_s' 1e6 beside sigma_a 1e-3).  A missing link's conductance is 0 (and a missing lower
 * neighbour's is masked by my, mz), its distance 0, so its term is 0
 * without a branch. */
#define DEFINE_NET_APPLY(NAME, XTYPE)                                                                           \
    static inline double NAME(const ohm_stencil *st, const XTYPE *x, ROW_PARAMS)                                \
    {                                                                                                           \
        const float *gx = st->gx, *gy = st->gy, *gz = st->gz;                                                   \
        double xv = x[v];                                                                                       \
        double s = st->sink[v] * xv + gy[v] * (xv - x[v + yp]) + (double)(my * gy[v + ym]) * (xv - x[v + ym]) + \
                   gz[v] * (xv - x[v + zp]) + (double)(mz * gz[v + zm]) * (xv - x[v + zm]);                     \
        if (!edge || v < st->n - 1) s += gx[v] * (xv - x[v + 1]);                                               \
        if (!edge || v > 0) s += gx[v - 1] * (xv - x[v - 1]);                                                   \
        return s;                                                                                               \
    }
DEFINE_NET_APPLY(net_apply, double)       /* the residual's, of the double iterate */
DEFINE_NET_APPLY(net_apply_single, float) /* the outer direction's, kept in floats */

/* Row v's terms of the links beyond the grid (stencil_form.h), in flux
 * form, and their sum (the diagonal's share); 0 for a stencil with none. */
#define DEFINE_EXTRA_APPLY(NAME, XTYPE)                                                                         \
    static inline double NAME(const ohm_stencil *st, const XTYPE *x, int64_t v)                                 \
    {                                                                                                           \
        double s = 0;                                                                                           \
        for (int64_t k = st->xstart[v]; k < st->xstart[v + 1]; ++k)                                             \
            s += st->xg[k] * ((double)x[v] - (double)x[st->xcol[k]]);                                           \
        return s;                                                                                               \
    }
DEFINE_EXTRA_APPLY(extra_apply, double)
DEFINE_EXTRA_APPLY(extra_apply_single, float)

static inline double extra_diag(const ohm_stencil *st, int64_t v)
{
    double d = 0;
    if (st->xstart)
        for (int64_t k = st->xstart[v]; k < st->xstart[v + 1]; ++k) d += st->xg[k];
    return d;
}

/* Row v's diagonal, sink + its links, in double. */
static inline double row_diag(const ohm_stencil *st, ROW_PARAMS)
{
    (void)yp, (void)zp;
    const float *gx = st->gx, *gy = st->gy, *gz = st->gz;
    double d = st->sink[v] + gx[v] + gy[v] + gz[v] + my * gy[v + ym] + mz * gz[v + zm];
    if (!edge || v > 0) d += gx[v - 1]; /* 0 unless v - 1's +x link is v */
    return d;
}

#endif
