/* solvers/mg.c — geometric multigrid on the voxel grid (mg.h): the
 * hierarchy, the K-cycle, the outer flexible CG, and the stencil's own
 * operations (apply, diagonal, norm). */
#include "solvers/mg.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/parallel.h"
#include "solvers/backend.h"
#include "solvers/mg_device.h"

/* Levels stop coarsening at this many cells, solved by a dense Cholesky
 * factor: (n^3 / 3 flops, n^2 doubles: 0.04 GFlop and 2 MB at 500). */
enum { COARSEST_MAX = 500, LEVELS_MAX = 40 }; /* LEVELS_MAX: mg.h's ohm_mg_view too */

/* Below this many cells a kernel runs on one core: a thread's start
 * (~20-50 us) would cost more than it shares.  Above, its loop is cut into
 * CHUNKS pieces whatever the number of cores, and reductions add the pieces'
 * sums in order, so that a solve gives the same bits on any number of
 * cores. */
enum { PARALLEL_MIN = 1 << 16, CHUNKS = 64 };

/* The K-cycle's two inner steps run at the levels 1 .. KCYCLE_LEVELS and
 * always both; below, one cycle.  Measured on the block medium at 1e7 cells
 * (docs/multigrid.md): every level with AGMG's early exit (one step when it
 * cut the residual to 0.25) took 20 iterations and 6.2-6.4 s, two steps at
 * levels 1-2 only 19 and 5.7-6.0 s; level 1 alone 32 iterations, none (a
 * V-cycle) 71. */
enum { KCYCLE_LEVELS = 2 };

/* A coarse level is solved by the K-cycle's two inner steps only when it
 * has at most this fraction of its finer level's cells: two recursive
 * cycles cost twice one, which only a coarsening by 4 or more keeps a
 * bounded share of the whole (a thin sheet or line coarsens by 4 or 2). */
static const double KCYCLE_MAX_RATIO = 0.25;

/* The smoother: two Chebyshev steps on D^-1 A before and after each coarse
 * correction (Adams, Brezina, Hu and Tuminaro, "Parallel multigrid
 * smoothing: polynomial versus Gauss-Seidel", J. Comput. Phys. 188, 2003),
 * aimed at the eigenvalues in [LMAX / CHEB_RATIO, LMAX]; those below are the
 * coarse levels' to remove.  LMAX = 2 bounds D^-1 A's spectrum for any
 * diagonally dominant stencil (Gershgorin), so nothing is estimated.  By
 * measurement (docs/multigrid.md): on the block medium at 1e7 cells 17
 * iterations and 4.8-5.0 s against damped Jacobi's 19 and 5.4 s (omega
 * 0.9, two sweeps, the best of 0.67-1.0 and one to three sweeps) and
 * red-black Gauss-Seidel's 23 and 6.0 s (one symmetric sweep) or 15 and
 * 6.2 s (two); fewer iterations or as many on every test scene; ratio 5-8
 * as good as 6. */
static const double CHEB_LMAX = 2.0, CHEB_RATIO = 6.0;

/* A level: its operator, network.h's ohm_stencil (level 0: the network's
 * own, shared with the outer iteration, whose links are single precision
 * already, so the cycle needs no copy of them; a coarse level's: the
 * Galerkin sums, owned), the smoother's inverse diagonal, and the cycle's
 * vectors, floats: the preconditioner only needs to be near A^-1, and
 * floats halve the bytes each pass streams, while the outer iteration's
 * residual and steps stay in double (so the solution and the books are as
 * exact as with a double cycle). */
typedef struct mg_level {
    ohm_stencil st;
    int owns_st; /* a coarse level's: freed with the level */
    float *invd; /* 1 / the diagonal (the smoother's, so that it divides nothing) */
    int64_t n;
    /* n: the next level's cell holding this one; NULL at the coarsest.  32
     * bits: a coarse level has fewer cells than the grid, which the
     * voxelizer keeps below 2^31 (checked in aggregate) */
    int32_t *agg;
    /* the next level's slabs (its z index K): this level's cells in slab K
     * are fine_at[K] .. fine_at[K + 1] - 1, the next level's coarse_at[K]
     * .. coarse_at[K + 1] - 1 */
    int64_t *fine_at, *coarse_at, nslabs;
    float *b, *x;                   /* the level's right-hand side and correction */
    float *t;                       /* the cycle's temporary (cycle)              */
    float *c1, *v1, *c2, *rt;       /* the K-cycle's, solving this level          */
    int kcycle;                     /* this level is solved by the K-cycle        */
} mg_level;

struct ohm_mg {
    const ohm_stencil *fine; /* the network's: the outer iteration's operator */
    mg_level lev[LEVELS_MAX];
    int nlevels;
    int threads;
    double *dense;                 /* the coarsest level's Cholesky factor, n x n, lower */
    double *dense_x;               /* its solution, in double (the sweeps' work)         */
    int64_t ndense;
    double *r, *q; /* the outer flexible CG's residual and A p, in double */
    float *p;      /* its direction, in floats, times a scale (ohm_mg_solve) */
    double norm_A;
    double bytes;
};

/* ---- parallel loops ------------------------------------------------------------------ */

typedef struct kernel kernel;
struct kernel {
    void (*fn)(kernel *k, int64_t lo, int64_t hi, int chunk);
    const mg_level *L;       /* a cycle kernel's level            */
    const ohm_stencil *st;   /* an outer kernel's operator        */
    const double *x, *y, *z; /* double operands (the outer iteration's) */
    double *out, *out2;
    const float *xf, *yf, *bf; /* single operands (the cycle's) */
    float *outf, *out_tmp;
    double a, a2, a3;
    int64_t n;
    int chunks;
    double partial[CHUNKS], partial2[CHUNKS], partial3[CHUNKS]; /* a reduction's (three at most) */
    double sum2;                              /* the second reduction's total */
};

static void kernel_job(void *user, int64_t i)
{
    kernel *k = user;
    int64_t lo = k->n * i / k->chunks, hi = k->n * (i + 1) / k->chunks;
    k->fn(k, lo, hi, (int)i);
}

/* k->fn over 0 .. n-1 in k->chunks pieces; a reduction's sum of the
 * pieces' partial sums, in order. */
static double run(kernel *k, int64_t n, int threads)
{
    k->n = n;
    k->chunks = n >= PARALLEL_MIN ? CHUNKS : 1;
    if (k->chunks == 1 || threads <= 1)
        for (int i = 0; i < k->chunks; ++i) kernel_job(k, i);
    else ohm_parallel_for(k->chunks, threads, kernel_job, k);
    double sum = 0;
    k->sum2 = 0;
    for (int i = 0; i < k->chunks; ++i) {
        sum += k->partial[i];
        k->sum2 += k->partial2[i];
    }
    return sum;
}

/* ---- the stencils' rows ---------------------------------------------------------------- */

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

/* Row v's diagonal, sink + its links, in double. */
static inline double row_diag(const ohm_stencil *st, ROW_PARAMS)
{
    (void)yp, (void)zp;
    const float *gx = st->gx, *gy = st->gy, *gz = st->gz;
    double d = st->sink[v] + gx[v] + gy[v] + gz[v] + my * gy[v + ym] + mz * gz[v + zm];
    if (!edge || v > 0) d += gx[v - 1]; /* 0 unless v - 1's +x link is v */
    return d;
}

/* The cycle's row v, in single precision: its links' sum, sum_w g_vw x_w
 * (so (A x)_v is diag x_v - that sum, and the Jacobi step (b_v + that sum)
 * / diag_v). */
static inline float cyc_sum(const ohm_stencil *st, const float *x, ROW_PARAMS)
{
    const float *gx = st->gx, *gy = st->gy, *gz = st->gz;
    float s = gy[v] * x[v + yp] + my * gy[v + ym] * x[v + ym] + gz[v] * x[v + zp] + mz * gz[v + zm] * x[v + zm];
    if (!edge || v < st->n - 1) s += gx[v] * x[v + 1];
    if (!edge || v > 0) s += gx[v - 1] * x[v - 1];
    return s;
}

/* (A x)_v in the cycle's precision, its diagonal from the sink and links */
static inline float cyc_apply(const ohm_stencil *st, const float *x, ROW_PARAMS)
{
    const float *gx = st->gx, *gy = st->gy, *gz = st->gz;
    float d = (float)st->sink[v] + gx[v] + gy[v] + gz[v] + my * gy[v + ym] + mz * gz[v + zm];
    if (!edge || v > 0) d += gx[v - 1];
    return d * x[v] - cyc_sum(st, x, ROW_ARGS);
}

/* D^-1 (b - A x) in row v, from the stored inverse diagonal (no division) */
static inline float cyc_jacobi(const ohm_stencil *st, const float *invd, const float *x, const float *b, ROW_PARAMS)
{
    return (b[v] + cyc_sum(st, x, ROW_ARGS)) * invd[v] - x[v];
}

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

/* ---- the outer iteration's kernels (double) ------------------------------------------- */

static void apply_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    (void)chunk;
    const double *x = k->x;
    double *out = k->out;
    FOR_ROWS_EACH(k->st, lo, hi, out[v] = net_apply(S, x, ROW_ARGS);)
}

void ohm_stencil_apply(const ohm_stencil *st, const double *x, double *y, int threads)
{
    kernel k = {.fn = apply_k, .st = st, .x = x, .out = y};
    run(&k, st->n, threads);
}

/* the largest |b - A x| (b in y), |x| and |b| of the rows, into
 * partial[chunk], partial2[chunk] and partial3[chunk] */
static void residual_inf_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    double worst = 0, nx = 0, nb = 0;
    const double *x = k->x, *b = k->y;
    FOR_ROWS(k->st, lo, hi, {
        double r = fabs(b[v] - net_apply(S, x, ROW_ARGS));
        if (!(r <= worst)) worst = r; /* NaN propagates */
        if (fabs(x[v]) > nx) nx = fabs(x[v]);
        if (fabs(b[v]) > nb) nb = fabs(b[v]);
    })
    k->partial[chunk] = worst;
    k->partial2[chunk] = nx;
    k->partial3[chunk] = nb;
}

void ohm_stencil_residual_norms(const ohm_stencil *st, const double *b, const double *x, int threads, double *nr,
                                double *nx, double *nb)
{
    kernel k = {.fn = residual_inf_k, .st = st, .x = x, .y = b};
    run(&k, st->n, threads > 0 ? threads : ohm_usable_cores());
    *nr = *nx = *nb = 0;
    for (int i = 0; i < k.chunks; ++i) {
        if (!(k.partial[i] <= *nr)) *nr = k.partial[i];
        if (k.partial2[i] > *nx) *nx = k.partial2[i];
        if (k.partial3[i] > *nb) *nb = k.partial3[i];
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

/* out = b - A x (b in y); returns ||out||^2, and its sum in k.sum2 */
static void residual_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    double s = 0, sr = 0;
    const double *x = k->x, *b = k->y;
    double *out = k->out;
    FOR_ROWS_SUM("omp simd reduction(+ : s, sr)", k->st, lo, hi, {
        double r = b[v] - net_apply(S, x, ROW_ARGS);
        out[v] = r;
        s += r * r;
        sr += r;
    })
    k->partial[chunk] = s;
    k->partial2[chunk] = sr;
}

/* q = A p for the direction p = a pt (pt in xf, q in out); returns pt.q,
 * and pt.r (r in z) in k.sum2 */
static void apply_dots_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    double pq = 0, pr = 0, a = k->a;
    const float *p = k->xf;
    const double *r = k->z;
    double *out = k->out;
    FOR_ROWS_SUM("omp simd reduction(+ : pq, pr)", k->st, lo, hi, {
        double q = a * net_apply_single(S, p, ROW_ARGS);
        out[v] = q;
        pq += p[v] * q;
        pr += p[v] * r[v];
    })
    k->partial[chunk] = pq;
    k->partial2[chunk] = pr;
}

/* The outer step: x += alpha p with p = a pt (alpha a in a2, pt in xf), r
 * -= alpha q, and the next cycle's right-hand side outf = a3 r in the same
 * pass (to_single_k's, not a pass of its own); returns ||r||^2, and the
 * sum of r (the power the books miss) in k.sum2. */
static void step_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    double s = 0, sr = 0, alpha = k->a, alpha_p = k->a2, scale = k->a3;
    double *x = k->out, *r = k->out2;
    const float *p = k->xf;
    const double *q = k->y;
    float *rhs = k->outf;
#pragma omp simd reduction(+ : s, sr)
    for (int64_t i = lo; i < hi; ++i) {
        x[i] += alpha_p * p[i];
        double ri = r[i] - alpha * q[i];
        r[i] = ri;
        rhs[i] = (float)(scale * ri);
        s += ri * ri;
        sr += ri;
    }
    k->partial[chunk] = s;
    k->partial2[chunk] = sr;
}

/* The cycle's right-hand side: outf = a x, in single precision */
static void to_single_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    (void)chunk;
    for (int64_t i = lo; i < hi; ++i) k->outf[i] = (float)(k->a * k->x[i]);
}

/* returns xf.y, the preconditioned residual's product with q */
static void mixed_dot_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    double s = 0;
    const float *z = k->xf;
    const double *q = k->y;
#pragma omp simd reduction(+ : s)
    for (int64_t i = lo; i < hi; ++i) s += (double)z[i] * q[i];
    k->partial[chunk] = s;
}

/* The outer direction, in floats: pt = z - c pt (z in xf, pt in outf, c in
 * a; 0: pt = z) */
static void direction_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    (void)chunk;
    const float *z = k->xf, c = (float)k->a;
    float *p = k->outf;
    if (c == 0) memcpy(p + lo, z + lo, (size_t)(hi - lo) * sizeof *p);
    else
        for (int64_t i = lo; i < hi; ++i) p[i] = z[i] - c * p[i];
}

/* ---- the cycle's kernels (single) ------------------------------------------------------ */

/* y = A x, returning x.q (q NULL: x.y) in the same pass; y NULL: only
 * x.A x, nothing stored */
static void cycle_apply_dot_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    double s = 0;
    const float *x = k->xf, *q = k->yf;
    float *out = k->outf;
    if (!out)
        FOR_ROWS_SUM("omp simd reduction(+ : s)", &k->L->st, lo, hi,
                     s += x[v] * (double)cyc_apply(S, x, ROW_ARGS);)
    else FOR_ROWS_SUM("omp simd reduction(+ : s)", &k->L->st, lo, hi, {
            float y = cyc_apply(S, x, ROW_ARGS);
            out[v] = y;
            s += x[v] * (q ? (double)q[v] : (double)y);
        })
    k->partial[chunk] = s;
}

static double level_apply_dot(const mg_level *L, const float *x, float *y, const float *q, int threads)
{
    kernel k = {.fn = cycle_apply_dot_k, .L = L, .xf = x, .yf = q, .outf = y};
    return run(&k, L->n, threads);
}

static void dot_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    double s = 0;
    const float *x = k->xf, *y = k->yf;
#pragma omp simd reduction(+ : s)
    for (int64_t i = lo; i < hi; ++i) s += (double)x[i] * y[i];
    k->partial[chunk] = s;
}

static double dot(const float *x, const float *y, int64_t n, int threads)
{
    kernel k = {.fn = dot_k, .xf = x, .yf = y};
    return run(&k, n, threads);
}

/* out = a x + a2 y (y NULL: a x) */
static void combine_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    (void)chunk;
    for (int64_t i = lo; i < hi; ++i) k->outf[i] = (float)(k->a * k->xf[i] + (k->yf ? k->a2 * k->yf[i] : 0.0));
}

static void combine(float *out, double a, const float *x, double a2, const float *y, int64_t n, int threads)
{
    kernel k = {.fn = combine_k, .xf = x, .yf = y, .outf = out, .a = a, .a2 = a2};
    run(&k, n, threads);
}

/* out = x + w D^-1 (b - A x); x NULL: from zero (out = w D^-1 b). */
static void jacobi_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    (void)chunk;
    const mg_level *L = k->L;
    const float w = (float)k->a, *x = k->xf, *b = k->bf, *invd = L->invd;
    float *out = k->outf;
    if (!x)
        for (int64_t v = lo; v < hi; ++v) out[v] = w * b[v] * invd[v];
    else FOR_ROWS_EACH(&L->st, lo, hi, out[v] = x[v] + w * cyc_jacobi(S, invd, x, b, ROW_ARGS);)
}

/* out = x + a (x - y) + c D^-1 (b - A x), y NULL: 0 (Chebyshev's second step) */
static void cheb_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    (void)chunk;
    const mg_level *L = k->L;
    const float a = (float)k->a, a2 = (float)k->a2, *x = k->xf, *y = k->yf, *b = k->bf, *invd = L->invd;
    float *out = k->outf;
    if (!y) FOR_ROWS_EACH(&L->st, lo, hi, out[v] = x[v] + a * x[v] + a2 * cyc_jacobi(S, invd, x, b, ROW_ARGS);)
    else FOR_ROWS_EACH(&L->st, lo, hi, out[v] = x[v] + a * (x[v] - y[v]) + a2 * cyc_jacobi(S, invd, x, b, ROW_ARGS);)
}

/* Two Chebyshev steps for A out = b from y (NULL: zero), the first into
 * tmp: x1 = y + D^-1 (b - A y) / theta, then out = x1 + rho1 rho0 (x1 - y) +
 * (2 rho1 / delta) D^-1 (b - A x1) (the three-term recurrence of Saad,
 * "Iterative Methods for Sparse Linear Systems", 2nd ed., Algorithm 12.1,
 * with d0 = x1 - y). */
void ohm_mg_smoother(double *w0, double *a, double *a2)
{
    const double lmin = CHEB_LMAX / CHEB_RATIO;
    const double theta = 0.5 * (CHEB_LMAX + lmin), delta = 0.5 * (CHEB_LMAX - lmin), sigma = theta / delta;
    const double rho0 = 1.0 / sigma, rho1 = 1.0 / (2.0 * sigma - rho0);
    *w0 = 1.0 / theta;
    *a = rho1 * rho0;
    *a2 = 2.0 * rho1 / delta;
}

/* out may be y: the second step reads y in its own row only (an update in
 * place, which saves the cycle a vector per level); tmp is neither. */
static void smooth(const mg_level *L, const float *y, const float *b, float *tmp, float *out, int threads)
{
    double w0, a, a2;
    ohm_mg_smoother(&w0, &a, &a2);
    kernel k1 = {.fn = jacobi_k, .L = L, .xf = y, .bf = b, .outf = tmp, .a = w0};
    run(&k1, L->n, threads);
    kernel k2 = {.fn = cheb_k, .L = L, .xf = tmp, .yf = y, .bf = b, .outf = out, .a = a, .a2 = a2};
    run(&k2, L->n, threads);
}

/* rc = P^T (b - A x): each coarse cell's the sum of its cells' residuals,
 * slab by slab (a coarse slab's cells are its two fine layers' and no
 * other's).  The slab's residuals are computed first, into r, in a loop
 * that vectorises, then added into their coarse cells while still in the
 * cache (the additions, a scatter, do not vectorise: at 1e7 cells one loop
 * doing both took as long as two Chebyshev steps). */
static void restrict_job(void *user, int64_t K)
{
    kernel *k = user;
    const mg_level *L = k->L;
    int64_t f0 = L->fine_at[K], f1 = L->fine_at[K + 1];
    const float *x = k->xf, *b = k->bf;
    const int32_t *agg = L->agg;
    float *rc = k->outf, *r = k->out_tmp;
    FOR_ROWS_EACH(&L->st, f0, f1, r[v] = b[v] - cyc_apply(S, x, ROW_ARGS);)
    memset(rc + L->coarse_at[K], 0, (size_t)(L->coarse_at[K + 1] - L->coarse_at[K]) * sizeof *rc);
    /* consecutive cells in x share their coarse cell: summed in a register
     * before it is added, not through memory (a chain of stores and loads) */
    int32_t cur = f0 < f1 ? agg[f0] : 0;
    float acc = 0;
    for (int64_t v = f0; v < f1; ++v) {
        if (agg[v] != cur) {
            rc[cur] += acc;
            cur = agg[v];
            acc = 0;
        }
        acc += r[v];
    }
    if (f0 < f1) rc[cur] += acc;
}

/* r: n floats of room for the residual (the cycle lends its temporary) */
static void restrict_residual(const mg_level *L, const float *x, const float *b, float *r, float *rc, int threads)
{
    kernel k = {.L = L, .xf = x, .bf = b, .outf = rc, .out_tmp = r};
    if (L->n < PARALLEL_MIN || threads <= 1)
        for (int64_t K = 0; K < L->nslabs; ++K) restrict_job(&k, K);
    else ohm_parallel_for(L->nslabs, threads, restrict_job, &k);
}

/* out = x + P e (out may be x) */
static void prolong_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    (void)chunk;
    const int32_t *agg = k->L->agg;
    for (int64_t v = lo; v < hi; ++v) k->outf[v] = k->xf[v] + k->yf[agg[v]];
}

static void prolong_add(const mg_level *L, const float *x, const float *e, float *out, int threads)
{
    kernel k = {.fn = prolong_k, .L = L, .xf = x, .yf = e, .outf = out};
    run(&k, L->n, threads);
}

/* ---- the cycle ------------------------------------------------------------------------ */

/* The coarsest level's solve, by its dense factor, in double. */
static void dense_solve(const ohm_mg *m, const float *b, float *x)
{
    int64_t n = m->ndense;
    const double *Lf = m->dense;
    double *y = m->dense_x;
    for (int64_t i = 0; i < n; ++i) { /* L y = b */
        double s = b[i];
        for (int64_t j = 0; j < i; ++j) s -= Lf[i * n + j] * y[j];
        y[i] = s / Lf[i * n + i];
    }
    for (int64_t i = n; i-- > 0;) { /* L^T x = y */
        double s = y[i];
        for (int64_t j = i + 1; j < n; ++j) s -= Lf[j * n + i] * y[j];
        y[i] = s / Lf[i * n + i];
    }
    for (int64_t i = 0; i < n; ++i) x[i] = (float)y[i];
}

static void cycle(const ohm_mg *m, int l, const float *b, float *x);

/* ec ~ A_l^-1 rc for coarse level l: exactly at the coarsest; else one
 * cycle, or the K-cycle's two steps of flexible CG preconditioned by it
 * (Notay and Vassilevski 2008, Algorithm 2.1). */
static void coarse_solve(const ohm_mg *m, int l, const float *rc, float *ec)
{
    const mg_level *L = &m->lev[l];
    int th = m->threads;
    int64_t n = L->n;
    if (l == m->nlevels - 1) {
        dense_solve(m, rc, ec);
        return;
    }
    if (!L->kcycle) {
        cycle(m, l, rc, ec);
        return;
    }
    cycle(m, l, rc, L->c1);
    double rho1 = level_apply_dot(L, L->c1, L->v1, NULL, th), alpha1 = dot(L->c1, rc, n, th);
    if (!(rho1 > 0)) {
        memset(ec, 0, (size_t)n * sizeof *ec);
        return;
    }
    double a1 = alpha1 / rho1;
    combine(L->rt, 1.0, rc, -a1, L->v1, n, th);
    cycle(m, l, L->rt, L->c2);
    double beta = level_apply_dot(L, L->c2, NULL, NULL, th); /* c2.A c2: A c2 itself is not needed */
    double gamma = dot(L->c2, L->v1, n, th), alpha2 = dot(L->c2, L->rt, n, th);
    double rho2 = beta - gamma * gamma / rho1;
    if (!(rho2 > 0)) {
        combine(ec, a1, L->c1, 0, NULL, n, th);
        return;
    }
    double w1 = a1 - gamma * alpha2 / (rho1 * rho2), w2 = alpha2 / rho2;
    combine(ec, w1, L->c1, w2, L->c2, n, th);
}

/* x = M_l b: smooth from zero, correct on the next level, smooth again.
 * b and x are not level l's temporaries. */
static void cycle(const ohm_mg *m, int l, const float *b, float *x)
{
    const mg_level *L = &m->lev[l];
    const mg_level *C = &m->lev[l + 1];
    int th = m->threads;
    smooth(L, NULL, b, L->t, x, th);            /* pre-smoothed: x (t: its first step) */
    restrict_residual(L, x, b, L->t, C->b, th); /* t: the slabs' residuals */
    coarse_solve(m, l + 1, C->b, C->x);
    prolong_add(L, x, C->x, x, th); /* corrected, in place */
    smooth(L, x, b, L->t, x, th);   /* post-smoothed, in place (smooth) */
}

/* ---- set-up ---------------------------------------------------------------------------- */

static void level_free(mg_level *L)
{
    if (L->owns_st) ohm_stencil_free(&L->st);
    free(L->invd);
    free(L->agg);
    free(L->fine_at);
    free(L->coarse_at);
    float *v[] = {L->b, L->x, L->t, L->c1, L->v1, L->c2, L->rt};
    for (size_t i = 0; i < sizeof v / sizeof v[0]; ++i) free(v[i]);
    memset(L, 0, sizeof *L);
}

void ohm_mg_free(ohm_mg *mg)
{
    if (!mg) return;
    for (int l = 0; l < mg->nlevels; ++l) level_free(&mg->lev[l]);
    free(mg->dense);
    free(mg->dense_x);
    free(mg->r);
    free(mg->p);
    free(mg->q);
    free(mg);
}

/* n elements of size bytes each, counted in m->bytes */
static void *array(ohm_mg *m, int64_t n, size_t size)
{
    m->bytes += (double)(n ? n : 1) * (double)size;
    return malloc((size_t)(n ? n : 1) * size);
}

/* Level l's cells aggregated into level l + 1's (mg.h): its cells (the
 * members of cells, in a grid of dims) in cell order; the coarse cells into
 * ccells, their grid's dims into cdims.  Slab by slab: a coarse slab's fine
 * cells are consecutive, and its cells are numbered in its (J, I) order,
 * which is the coarse grid's cell order. */
static int aggregate(ohm_mg *m, int l, const ohm_cell_index *cells, const int64_t dims[3], ohm_cell_index *ccells,
                     int64_t cdims[3], ohm_error *err)
{
    mg_level *L = &m->lev[l];
    for (int a = 0; a < 3; ++a) cdims[a] = (dims[a] + 1) / 2;
    int64_t n = L->n, plane = dims[0] * dims[1], cplane = cdims[0] * cdims[1];
    L->nslabs = cdims[2];
    L->agg = malloc((size_t)(n ? n : 1) * sizeof *L->agg);
    L->fine_at = malloc((size_t)(cdims[2] + 1) * sizeof *L->fine_at);
    L->coarse_at = malloc((size_t)(cdims[2] + 1) * sizeof *L->coarse_at);
    int64_t *mark = malloc((size_t)cplane * sizeof *mark);
    size_t cbox = (size_t)(cplane * cdims[2]);
    int ccells_failed = ohm_cell_index_alloc(ccells, cbox);
    m->bytes += (double)n * sizeof *L->agg;
    if (!L->agg || !L->fine_at || !L->coarse_at || !mark || ccells_failed) {
        free(mark);
        return ohm_fail(err, OHM_ERR_NOMEM, "mg: out of memory coarsening %lld cells", (long long)n);
    }
    for (int64_t q = 0; q < cplane; ++q) mark[q] = -1;
    ohm_cell_cursor next = ohm_cell_index_cursor(cells, 0);
    int64_t v = 0, nc = 0, c = n ? ohm_cell_cursor_next(&next) : 0; /* c: v's cell */
    for (int64_t K = 0; K < cdims[2]; ++K) {
        L->fine_at[K] = v;
        L->coarse_at[K] = nc;
        int64_t v0 = v;
        for (; v < n && c / plane / 2 == K; ++v) { /* the slab's cells: their places in the coarse plane */
            int64_t i = c % dims[0], j = c / dims[0] % dims[1], q = i / 2 + cdims[0] * (j / 2);
            mark[q] = 0;
            L->agg[v] = (int32_t)q; /* < cplane, inside a grid below 2^31 cells */
            if (v + 1 < n) c = ohm_cell_cursor_next(&next);
        }
        for (int64_t q = 0; q < cplane; ++q) /* the slab's coarse cells, numbered in order */
            if (mark[q] == 0) {
                ohm_cell_index_add(ccells, (size_t)(q + cplane * K));
                mark[q] = nc++;
            }
        for (int64_t u = v0; u < v; ++u) L->agg[u] = (int32_t)mark[L->agg[u]];
        for (int64_t q = 0; q < cplane; ++q) mark[q] = -1;
    }
    L->fine_at[cdims[2]] = v;
    L->coarse_at[cdims[2]] = nc;
    free(mark);
    ohm_cell_index_finish(ccells, cbox);
    if (nc > INT32_MAX) return ohm_fail(err, OHM_ERR_USAGE, "mg: %lld coarse cells are more than 2^31", (long long)nc);
    m->lev[l + 1].n = nc;
    return OHM_OK;
}

static void inverse_diagonal_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    (void)chunk;
    const mg_level *L = k->L;
    FOR_ROWS(&L->st, lo, hi, {
        double d = row_diag(&L->st, ROW_ARGS);
        L->invd[v] = d > 0 ? (float)(1.0 / d) : 0.0f;
    })
}

/* The smoother's inverse diagonal of level l's stencil, once its links are
 * summed. */
static int inverse_diagonal(ohm_mg *m, int l, ohm_error *err)
{
    mg_level *L = &m->lev[l];
    if (!(L->invd = array(m, L->n, sizeof *L->invd)))
        return ohm_fail(err, OHM_ERR_NOMEM, "mg: out of memory for %lld cells' diagonal", (long long)L->n);
    kernel k = {.fn = inverse_diagonal_k, .L = L};
    run(&k, L->n, m->threads);
    return OHM_OK;
}

/* Level 0's operator: the network's stencil itself, and its inverse
 * diagonal. */
static int fine_stencil(ohm_mg *m, ohm_error *err)
{
    m->lev[0].st = *m->fine;
    return inverse_diagonal(m, 0, err);
}

/* Level l + 1's stencil, the Galerkin product P^T A P of level l's with
 * piecewise-constant P: exactly sums of conductances (mg.h).  Its offsets
 * are found cell by cell, then kept as runs (network.h). */
static int galerkin(ohm_mg *m, int l, ohm_error *err)
{
    const mg_level *L = &m->lev[l];
    mg_level *C = &m->lev[l + 1];
    int64_t nc = C->n;
    size_t mc = (size_t)(nc ? nc : 1);
    ohm_stencil *cs = &C->st;
    cs->n = nc;
    C->owns_st = 1;
    cs->gx = calloc(mc, sizeof *cs->gx);
    cs->gy = calloc(mc, sizeof *cs->gy);
    cs->gz = calloc(mc, sizeof *cs->gz);
    cs->sink = calloc(mc, sizeof *cs->sink);
    int32_t(*off)[4] = calloc(mc, sizeof *off);
    if (!cs->gx || !cs->gy || !cs->gz || !cs->sink || !off) {
        free(off);
        return ohm_fail(err, OHM_ERR_NOMEM, "mg: out of memory for a coarse level of %lld cells", (long long)nc);
    }
    const ohm_stencil *st = &L->st;
    const float *g[3] = {st->gx, st->gy, st->gz};
    float *cg[3] = {cs->gx, cs->gy, cs->gz};
    int overflow = 0;
    FOR_ROWS(st, 0, L->n, {
        int64_t I = L->agg[v];
        cs->sink[I] += st->sink[v];
        int64_t up[3] = {g[0][v] > 0 ? v + 1 : -1, yp ? v + yp : -1, zp ? v + zp : -1};
        for (int a = 0; a < 3; ++a) {
            if (up[a] < 0) continue;
            int64_t J = L->agg[up[a]];
            if (J == I) continue; /* inside the block: neither a link nor a sink */
            /* the blocks are neighbours across their +a face: J is I's +a
             * neighbour (I + 1 for +x, coarse cells being in cell order too) */
            cg[a][I] += g[a][v];
            if (a == 0) continue;
            int64_t delta = J - I;
            if (delta > INT32_MAX) overflow = 1;
            off[I][2 * a - 1] = (int32_t)delta;
            off[J][2 * a - 2] = (int32_t)-delta;
        }
    })
    int rc = overflow ? ohm_fail(err, OHM_ERR_INTERNAL, "mg: a coarse offset overflows")
                      : ohm_stencil_set_runs(cs, (const int32_t(*)[4])off, err);
    free(off);
    m->bytes += (double)nc * (3 * sizeof(float) + sizeof(double)) +
                (double)cs->nruns * (sizeof *cs->run_start + sizeof *cs->run_off);
    return rc ? rc : inverse_diagonal(m, l + 1, err);
}

/* The coarsest level's dense Cholesky factor. */
static int dense_factor(ohm_mg *m, ohm_error *err)
{
    const mg_level *L = &m->lev[m->nlevels - 1];
    int64_t n = L->n;
    m->ndense = n;
    m->dense = calloc((size_t)(n ? n * n : 1), sizeof *m->dense);
    m->bytes += (double)n * (double)n * 8;
    if (!m->dense || !(m->dense_x = array(m, n, sizeof(double))))
        return ohm_fail(err, OHM_ERR_NOMEM, "mg: out of memory for the coarsest level");
    double *A = m->dense;
    const ohm_stencil *st = &L->st;
    FOR_ROWS(st, 0, n, {
        A[v * n + v] = row_diag(st, ROW_ARGS);
        int64_t up[3] = {st->gx[v] > 0 ? v + 1 : -1, yp ? v + yp : -1, zp ? v + zp : -1};
        const float g[3] = {st->gx[v], st->gy[v], st->gz[v]};
        for (int a = 0; a < 3; ++a)
            if (up[a] >= 0) A[v * n + up[a]] = A[up[a] * n + v] = -(double)g[a];
    })
    for (int64_t j = 0; j < n; ++j) { /* lower factor in place, row-major */
        double s = A[j * n + j];
        for (int64_t k = 0; k < j; ++k) s -= A[j * n + k] * A[j * n + k];
        if (!(s > 0))
            return ohm_fail(err, OHM_ERR_NUMERIC, "mg: the coarsest level (%lld cells) is not positive definite",
                            (long long)n);
        A[j * n + j] = sqrt(s);
        for (int64_t i = j + 1; i < n; ++i) {
            double t = A[i * n + j];
            for (int64_t k = 0; k < j; ++k) t -= A[i * n + k] * A[j * n + k];
            A[i * n + j] = t / A[j * n + j];
        }
    }
    return OHM_OK;
}

/* The work vectors: every level's right-hand side and correction (level
 * 0's: the preconditioner's input and output), the cycle's at every level
 * but the coarsest, the K-cycle's where it runs. */
static int level_vectors(ohm_mg *m, int l, ohm_error *err)
{
    mg_level *L = &m->lev[l];
    int64_t n = L->n;
    size_t f = sizeof(float);
    int last = l == m->nlevels - 1;
    if (!(L->b = array(m, n, f)) || !(L->x = array(m, n, f))) goto nomem;
    if (!last && !(L->t = array(m, n, f))) goto nomem;
    L->kcycle = l > 0 && l <= KCYCLE_LEVELS && !last && (double)n <= KCYCLE_MAX_RATIO * (double)m->lev[l - 1].n;
    if (L->kcycle && (!(L->c1 = array(m, n, f)) || !(L->v1 = array(m, n, f)) || !(L->c2 = array(m, n, f)) ||
                      !(L->rt = array(m, n, f))))
        goto nomem;
    return OHM_OK;
nomem:
    return ohm_fail(err, OHM_ERR_NOMEM, "mg: out of memory for level %d's vectors (%lld cells)", l, (long long)n);
}

int ohm_mg_setup(ohm_mg **out, const ohm_stencil *st, const ohm_grid_layout *layout, int threads, ohm_error *err)
{
    *out = NULL;
    ohm_mg *m = calloc(1, sizeof *m);
    if (!m) return ohm_fail(err, OHM_ERR_NOMEM, "mg: out of memory");
    m->threads = threads > 0 ? threads : ohm_usable_cores();
    m->fine = st;
    m->norm_A = ohm_stencil_norm_inf(st);
    m->lev[0].n = st->n;
    m->nlevels = 1;
    int rc = fine_stencil(m, err);
    const ohm_cell_index *cells = layout->cells;
    int64_t dims[3] = {layout->dims[0], layout->dims[1], layout->dims[2]};
    ohm_cell_index owned[2] = {{0}}; /* two coarse levels' cells: the last, and the next being made */
    while (!rc && m->lev[m->nlevels - 1].n > COARSEST_MAX && m->nlevels < LEVELS_MAX) {
        int l = m->nlevels - 1;
        int64_t cdims[3];
        ohm_cell_index *ccells = &owned[l % 2];
        ohm_cell_index_free(ccells);
        rc = aggregate(m, l, cells, dims, ccells, cdims, err);
        if (!rc) {
            m->nlevels++;
            rc = galerkin(m, l, err);
        }
        cells = ccells;
        memcpy(dims, cdims, sizeof dims);
    }
    ohm_cell_index_free(&owned[0]);
    ohm_cell_index_free(&owned[1]);
    if (!rc && m->lev[m->nlevels - 1].n > COARSEST_MAX)
        rc = ohm_fail(err, OHM_ERR_INTERNAL, "mg: %d levels leave %lld cells", m->nlevels,
                      (long long)m->lev[m->nlevels - 1].n);
    if (!rc) rc = dense_factor(m, err);
    for (int l = 0; l < m->nlevels && !rc; ++l) rc = level_vectors(m, l, err);
    int64_t n = st->n;
    size_t d = sizeof(double);
    if (!rc && (!(m->r = array(m, n, d)) || !(m->p = array(m, n, sizeof(float))) || !(m->q = array(m, n, d))))
        rc = ohm_fail(err, OHM_ERR_NOMEM, "mg: out of memory for %lld unknowns", (long long)n);
    if (rc) {
        ohm_mg_free(m);
        return rc;
    }
    *out = m;
    return OHM_OK;
}

int ohm_mg_levels(const ohm_mg *mg, int64_t *cells)
{
    int64_t sum = 0;
    for (int l = 0; l < mg->nlevels; ++l) sum += mg->lev[l].n;
    if (cells) *cells = sum;
    return mg->nlevels;
}

double ohm_mg_bytes(const ohm_mg *mg) { return mg->bytes; }

void ohm_mg_view_of(const ohm_mg *mg, ohm_mg_view *view)
{
    memset(view, 0, sizeof *view);
    view->fine = mg->fine;
    view->norm_A = mg->norm_A;
    view->nlevels = mg->nlevels;
    for (int l = 0; l < mg->nlevels; ++l) {
        const mg_level *L = &mg->lev[l];
        view->lev[l] = (ohm_mg_level_view){.n = L->n,
                                           .st = &L->st,
                                           .invd = L->invd,
                                           .agg = L->agg,
                                           .kcycle = L->kcycle};
    }
    view->dense = mg->dense;
    view->ndense = mg->ndense;
}

double ohm_mg_bytes_estimate(int64_t n)
{
    /* fine: the network's stencil 20 and its runs (24 B each, allowed 4
     * per cell: runs of 6 cells on average, where a solid's rows are one
     * run each and a voxelized surface's a few), the inverse diagonal 4,
     * the aggregate map 4, the outer r and q in double and p in float 20,
     * the cycle's b x t 12; the coarse levels together about n/7 cells of
     * stencil 24 and inverse diagonal 4, map 4 and up to seven vectors of 4 */
    double fine = 20 + 4 + 4 + 4 + 20 + 12, coarse = (28 + 4 + 28) / 7.0;
    double dense = (double)(n < COARSEST_MAX ? n : COARSEST_MAX);
    return (fine + coarse) * (double)n + 8.0 * dense * dense;
}

/* ---- the outer iteration --------------------------------------------------------------- */

void ohm_mg_rhs_sizes(const double *b, int64_t n, double *norm2, double *sum_abs, int *nonnegative)
{
    double s2 = 0, s1 = 0;
    int nonneg = 1;
    for (int64_t i = 0; i < n; ++i) {
        s2 += b[i] * b[i];
        s1 += fabs(b[i]);
        nonneg &= b[i] >= 0;
    }
    *norm2 = sqrt(s2);
    *sum_abs = s1;
    *nonnegative = nonneg;
}

/* The cycle on r, in single precision: level 0's x = M (s r), M near
 * A^-1, with s = ||A||_inf / ||r||_inf.  Scaled so, the cycle's
 * right-hand sides are at most ||A||_inf and its corrections at most
 * about cond(A) = ||A|| ||A^-1||, free of h and of the coefficients' units
 * (as with a stencil scaled to ||A|| = 1), inside a float's range at any
 * contrast the stencil holds.  A^-1 r is then about x / s: returns 1 / s. */
double ohm_mg_rhs_scale(double norm_A, double nr) { return nr > 0 ? (norm_A > 0 ? norm_A : 1.0) / nr : 1.0; }

/* level 0's x = M b, b = s r already in level 0's b */
static void precondition_rhs(const ohm_mg *m)
{
    const mg_level *L0 = &m->lev[0];
    if (m->nlevels == 1) dense_solve(m, L0->b, L0->x);
    else cycle(m, 0, L0->b, L0->x);
}

/* level 0's b = s r, s = ohm_mg_rhs_scale(norm_A, nr); returns s */
static double rhs_of(const ohm_mg *m, const double *r, double nr)
{
    double s = ohm_mg_rhs_scale(m->norm_A, nr);
    kernel k = {.fn = to_single_k, .x = r, .outf = m->lev[0].b, .a = s};
    run(&k, m->lev[0].n, m->threads);
    return s;
}

static double precondition(const ohm_mg *m, const double *r, double nr)
{
    double s = rhs_of(m, r, nr);
    precondition_rhs(m);
    return 1.0 / s;
}

/* the largest |x| of the rows, into partial[chunk] */
static void max_abs_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    double worst = 0;
    for (int64_t i = lo; i < hi; ++i)
        if (fabs(k->x[i]) > worst) worst = fabs(k->x[i]);
    k->partial[chunk] = worst;
}

/* out = a xf, in double */
static void to_double_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    (void)chunk;
    for (int64_t i = lo; i < hi; ++i) k->out[i] = k->a * k->xf[i];
}

/* On every core, as the solve's own passes are (its step writes the next
 * right-hand side; z is not converted at all): a measurement of the cycle
 * should not be one of a serial loop around it. */
void ohm_mg_precondition(ohm_mg *m, const double *r, double *z)
{
    const mg_level *L0 = &m->lev[0];
    kernel km = {.fn = max_abs_k, .x = r};
    run(&km, L0->n, m->threads);
    double nr = 0;
    for (int i = 0; i < km.chunks; ++i)
        if (km.partial[i] > nr) nr = km.partial[i];
    double kz = precondition(m, r, nr);
    kernel kd = {.fn = to_double_k, .xf = L0->x, .out = z, .a = kz};
    run(&kd, L0->n, m->threads);
}

/* Bytes one cycle at level l streams, each array counted once per pass as
 * STREAM counts them (gathered neighbours hit the cache; a write's
 * allocating read is not counted), per level visit: the stencil's links
 * 12 and sinks 8 (read only where the diagonal is: residuals and
 * products; its runs are a few bytes per row of cells), the inverse
 * diagonal 4, the aggregate map 4, a vector 4 per cell. */
static double cycle_bytes(const ohm_mg *m, int l);

static double coarse_solve_bytes(const ohm_mg *m, int l)
{
    const mg_level *L = &m->lev[l];
    double n = (double)L->n;
    if (l == m->nlevels - 1) return 8.0 * n * n + 8.0 * n; /* the dense factor's two sweeps */
    if (!L->kcycle) return cycle_bytes(m, l);
    /* two cycles, two applications with a dot (g, sink, x, out: 28),
     * three dots (8) and two combinations (12) */
    return 2.0 * cycle_bytes(m, l) + (2.0 * 28 + 3.0 * 8 + 2.0 * 12) * n;
}

static double cycle_bytes(const ohm_mg *m, int l)
{
    double n = (double)m->lev[l].n, nc = (double)m->lev[l + 1].n;
    /* pre-smoothing: from zero (b, invd, out: 12), a Chebyshev step (g, x,
     * b, invd, out: 28); the residual restricted (g, sink, x, b, agg, and the
     * slab's residuals written: 36, the coarse sums 4 nc); the correction
     * prolonged (x, agg, out: 12, the coarse values 4 nc); post-smoothing:
     * two steps (28, and 32 with the previous iterate) */
    return (12 + 28 + 36 + 12 + 28 + 32) * n + 8.0 * nc + coarse_solve_bytes(m, l + 1);
}

double ohm_mg_cycle_bytes(const ohm_mg *m)
{
    double n = (double)m->lev[0].n;
    /* r to single precision (8 + 4), the result to double (4 + 8) */
    return 24.0 * n + (m->nlevels == 1 ? coarse_solve_bytes(m, 0) : cycle_bytes(m, 0));
}

/* x's negative values set to 0; returns how many there were */
static int64_t clamp_negative(double *x, int64_t n)
{
    int64_t count = 0;
    for (int64_t i = 0; i < n; ++i)
        if (x[i] < 0) {
            x[i] = 0;
            ++count;
        }
    return count;
}

int ohm_mg_solve(ohm_mg *m, double *x, const double *b, double tol, int64_t max_iter, const ohm_log *log,
                 int64_t *iters, double *relres, ohm_error *err)
{
    const ohm_stencil *A = m->fine;
    const float *z = m->lev[0].x; /* the preconditioned residual, z = kz * this */
    int64_t n = A->n;
    int th = m->threads;
    double *r = m->r, *q = m->q;
    float *p = m->p;
    double nb, sb;
    int b_nonnegative;
    ohm_mg_rhs_sizes(b, n, &nb, &sb, &b_nonnegative);
    /* Converged when the residual is tol of b's and so is its sum: the sum
     * of b - A x is the power in less what the solution absorbs and lets
     * out (A's column sums are the sinks), and ||r||_2 <= tol ||b||_2 alone
     * bounds it only by sqrt(n) tol. */
#define CONVERGED(nr, sr) ((nr) <= tol * nb && fabs(sr) <= tol * sb)
    *iters = 0;
    *relres = 0.0;
    if (!(nb > 0)) {
        memset(x, 0, (size_t)n * sizeof *x);
        return OHM_OK;
    }
    int64_t it = 0;
    int restarts = 0, clamps = 0;
    ohm_progress prog;
    ohm_progress_begin(&prog, log, "solve: mg");
    double t_reported = prog.t_begin;
    for (;;) {
        /* the true residual at every (re)start and at the end */
        kernel kr = {.fn = residual_k, .st = A, .x = x, .y = b, .out = r};
        double nr = sqrt(run(&kr, n, th)), sr = kr.sum2;
        if (it == 0 && !(nr <= nb)) { /* a warm start worse than zero (or not finite): start cold */
            memset(x, 0, (size_t)n * sizeof *x);
            memcpy(r, b, (size_t)n * sizeof *r);
            nr = nb;
            sr = 0;
            for (int64_t i = 0; i < n; ++i) sr += b[i];
        }
        *relres = nr / nb;
        /* A is an M-matrix, so A^-1 >= 0 and a source b >= 0 has x >= 0.
         * Where the fluence has decayed to ~1e-40 of its peak (a 100 mm
         * voxel, a 1e12 contrast) the iteration's error, tol of the peak,
         * leaves values of either sign: taken to the 0 they are within that
         * error of, and the true residual judged again, since the power
         * they held can be tol of the whole (a point source in the block
         * medium: 1.4e-10); a round from the clamped x removes it.  Twice
         * at most: then the clamped x stands (below). */
        if (CONVERGED(nr, sr) && b_nonnegative && clamps < 2 && clamp_negative(x, n) > 0) {
            ++clamps;
            nr = sqrt(run(&kr, n, th));
            sr = kr.sum2;
            *relres = nr / nb;
        }
        if (CONVERGED(nr, sr)) break;
        /* stagnated at the floor */
        if (restarts > 0 && ohm_scaled_backward_error(b, x, r, (size_t)n, m->norm_A) <= 0.01 * tol) break;
        if (it >= max_iter || restarts > 5) {
            *iters = it;
            ohm_progress_end(&prog);
            return ohm_fail(err, OHM_ERR_NUMERIC,
                            "mg: did not converge: relative residual %.3g after %lld iterations (cg_tol=%.1g); use "
                            "solver=direct, or a looser cg_tol=",
                            nr / nb, (long long)it, tol);
        }
        ++restarts;
        /* flexible CG (Notay, "Flexible conjugate gradients", SIAM J. Sci.
         * Comput. 22, 2000), one direction kept: p = kz z - beta p with
         * beta = kz z.q / p.q making p A-orthogonal to the last (q = A p).
         * p is kept as pscale pt, pt in floats: any direction will do, so
         * long as q is A times the one taken (computed in double from pt's
         * own values), and x and r move along it together.  pt is of z's
         * size whatever the residual's, far inside a float's range; 4 B a
         * cell fewer than a double p, and 4 fewer streamed by three of the
         * iteration's passes. */
        double beta = 0, pq = 0, pr = 0, pscale = 0;
        double s = rhs_of(m, r, nr); /* the cycle's right-hand side s r; then each step's */
        for (int first = 1; !CONVERGED(nr, sr) && it < max_iter; first = 0) {
            precondition_rhs(m);
            double kz = 1.0 / s;
            if (!first) {
                kernel kb = {.fn = mixed_dot_k, .xf = z, .y = q};
                beta = kz * run(&kb, n, th) / pq;
            }
            /* p = kz z - beta pscale pt = kz (z - (beta pscale / kz) pt) */
            kernel kd = {.fn = direction_k, .xf = z, .outf = p, .a = first ? 0.0 : beta * pscale / kz};
            run(&kd, n, th);
            pscale = kz;
            kernel kq = {.fn = apply_dots_k, .st = A, .xf = p, .z = r, .out = q, .a = pscale};
            pq = pscale * run(&kq, n, th);
            pr = pscale * kq.sum2;
            if (!(pq > 0)) break; /* converged to round-off (or A not positive definite) */
            /* scaled by the norm before the step: the new residual is
             * smaller, so s r stays below ||A||_inf (ohm_mg_rhs_scale) */
            s = ohm_mg_rhs_scale(m->norm_A, nr);
            kernel ks = {.fn = step_k,
                         .xf = p,
                         .y = q,
                         .out = x,
                         .out2 = r,
                         .outf = m->lev[0].b,
                         .a = pr / pq,
                         .a2 = pr / pq * pscale,
                         .a3 = s};
            nr = sqrt(run(&ks, n, th));
            sr = ks.sum2;
            ++it;
            if (ohm_log_cancelled(log)) {
                *iters = it;
                ohm_progress_end(&prog);
                return ohm_fail_cancelled(err, "mg");
            }
            if (log && ohm_now() - t_reported >= 0.05) {
                t_reported = ohm_now();
                ohm_progress_update(&prog, fmin(1.0, fmax(0.0, log10(nr / nb) / log10(tol))));
            }
        }
    }
#undef CONVERGED
    if (b_nonnegative) clamp_negative(x, n);
    *iters = it;
    ohm_progress_end(&prog);
    return OHM_OK;
}

/* ---- the mg backend (backend.h) ------------------------------------------------------- */

typedef struct mg_state {
    ohm_mg *mg;
    ohm_mg_device *device; /* the hierarchy on an OpenCL device (device=), or NULL: the host */
    ohm_backend_config cfg;
} mg_state;

static void mg_release(void *state)
{
    mg_state *s = state;
    ohm_mg_device_free(s->device);
    s->device = NULL;
    ohm_mg_free(s->mg);
    s->mg = NULL;
}

static void mg_destroy(void *state)
{
    if (!state) return;
    mg_release(state);
    free(state);
}

static int mg_create(void **state, const ohm_backend_config *cfg, ohm_error *err)
{
    mg_state *s = calloc(1, sizeof *s);
    if (!s) return ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory");
    s->cfg = *cfg;
    ohm_backend_iterative_defaults(&s->cfg, 1000);
    *state = s;
    return OHM_OK;
}

static int mg_setup(void *state, const ohm_operator *op, ohm_backend_report *rep, ohm_error *err)
{
    mg_state *s = state;
    if ((!op->stencil && !op->make_stencil) || !s->cfg.layout || s->cfg.layout->n != op->n)
        return ohm_fail(err, OHM_ERR_INTERNAL, "solve: solver=mg needs the network's stencil and its cells");
    int64_t n = op->n;
    double columns = (double)(s->cfg.batch ? s->cfg.batch : 1);
    double need = ohm_mg_bytes_estimate(n) + 2.0 * sizeof(double) * (double)n * columns;
    if (op->A) need += 24.0 * (double)op->A->nzmax; /* A is held beside the stencil made for mg */
    char what[64];
    snprintf(what, sizeof what, "multigrid on %lld cells", (long long)n);
    int rc =
        ohm_backend_check_memory(need, s->cfg.max_memory, what, NULL, "use a smaller dim= or a larger voxel=", err);
    if (rc) return rc;
    mg_release(s);
    double t0 = ohm_now();
    const ohm_stencil *st = op->stencil;
    if (!st) rc = op->make_stencil(op->maker, &st, err);
    if (!rc) rc = ohm_mg_setup(&s->mg, st, s->cfg.layout, 0, err);
    if (!rc) rc = ohm_mg_device_open(&s->device, s->mg, &s->cfg.device, s->cfg.log, err);
    if (rc) return rc;
    if (s->device) snprintf(rep->device, sizeof rep->device, "%s", ohm_mg_device_name(s->device));
    rep->t_precond += ohm_now() - t0;
    rep->precond_setups++;
    rep->levels = ohm_mg_levels(s->mg, NULL);
    snprintf(rep->solver, sizeof rep->solver, "mg");
    double held = ohm_mg_bytes(s->mg) + ohm_stencil_bytes(st); /* and the stencil it reads */
    if (held > rep->bytes) rep->bytes = held;
    return OHM_OK;
}

static int mg_column(void *solver, double *x, const double *b, int64_t *iters, double *relres, ohm_error *err)
{
    mg_state *s = solver;
    if (s->device) return ohm_mg_device_solve(s->device, x, b, s->cfg.tol, s->cfg.max_iter, s->cfg.log, iters, relres, err);
    return ohm_mg_solve(s->mg, x, b, s->cfg.tol, s->cfg.max_iter, s->cfg.log, iters, relres, err);
}

static int mg_solve(void *state, const ohm_operator *op, const double *B, double *X, size_t ncols, double *berr,
                    ohm_backend_report *rep, ohm_error *err)
{
    mg_state *s = state;
    int rc = ohm_backend_solve_columns(mg_column, s, (size_t)op->n, B, X, ncols, rep, err);
    if (!rc) *berr = ohm_operator_backward_error(op, B, X, ncols, s->mg->norm_A);
    return rc;
}

const ohm_backend_ops ohm_backend_mg = {.name = "mg",
                                        .create = mg_create,
                                        .setup = mg_setup,
                                        .solve = mg_solve,
                                        .destroy = mg_destroy,
                                        .release = mg_release,
                                        .caps = OHM_BACKEND_STENCIL | OHM_BACKEND_WARM_START};
