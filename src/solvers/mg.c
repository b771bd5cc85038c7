/* solvers/mg.c — geometric multigrid on the voxel grid (mg.h): the
 * hierarchy, and the host's implementation of the multigrid's operations
 * (mg_ops.h: its kernels on the host's cores), which the cycle and the
 * outer iteration (mg_cycle.c) run. */
#include "solvers/mg.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/parallel.h"
#include "physics/stencil.h"
#include "physics/stencil_rows.h"
#include "solvers/backend.h"
#include "solvers/mg_coarsen.h"
#include "solvers/mg_cycle.h"

/* Levels stop coarsening at this many cells, solved by a dense Cholesky
 * factor: (n^3 / 3 flops, n^2 doubles: 0.04 GFlop and 2 MB at 500). */
enum { COARSEST_MAX = 500, LEVELS_MAX = OHM_MG_LEVELS_MAX };

/* The K-cycle's two inner steps run at the levels 1 .. KCYCLE_LEVELS and
 * always both; below, one cycle.  Measured on the block medium at 1e7 cells
 * (docs/multigrid.md): every level with AGMG's early exit (one step when it
 * cut the residual to 0.25) took 20 iterations and 6.2-6.4 s, two steps at
 * levels 1-2 only 19 and 5.7-6.0 s; level 1 alone 32 iterations, none (a
 * V-cycle) 71.  Level 3 too since the coarsening follows the coefficients
 * (mg_coarsen.h): on the family's clear medium at 108^3 its level 3 keeps
 * 0.28 of level 2's cells, and 22 iterations became 16, the others
 * unchanged. */
enum { KCYCLE_LEVELS = 3 };

/* A coarse level is solved by the K-cycle's two inner steps only when it
 * has at most this fraction of its finer level's cells: two recursive
 * cycles cost twice one, which only a strong coarsening keeps a bounded
 * share of the whole (a thin sheet or line coarsens by 4 or 2, and a block
 * cut by the medium's jumps into parts by less than 8). */
static const double KCYCLE_MAX_RATIO = 0.35;

/* A level: its operator, an ohm_stencil (physics/stencil_form.h; level 0: the network's
 * own, shared with the outer iteration, whose links are single precision
 * already, so the cycle needs no copy of them; a coarse level's: the
 * Galerkin sums, owned), the smoother's inverse diagonal, and the cycle's
 * vectors, floats: the preconditioner only needs to be near A^-1, and
 * floats halve the bytes each pass streams, while the outer iteration's
 * residual and steps stay in double (so the solution and the books are as
 * exact as with a double cycle). */
typedef struct mg_level {
    ohm_stencil st;   /* level 0's (the network's), or a whole-block level's */
    int owns_st;      /* a coarse level's stencil: freed with the level      */
    ohm_mg_sparse sp; /* a coarse level's rows (mg_coarsen.h), owned          */
    int sparse;       /* this level is sp's                                  */
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
    double *r; /* the outer flexible CG's residual, in double */
    float *p;  /* its direction, in floats, times pscale (host_direction) */
    /* A p's value (A times p's floats, before pscale) in two floats, hi +
     * lo, exact to 2^-48 of it: hi kept from one iteration to the next (the
     * flexible step's z.q), lo only from the product to the step, in level
     * 0's t (the cycle's, unused between them): 4 B a cell held, not a
     * double q's 8 (docs/multigrid.md, "The outer iteration") */
    float *ap_hi;
    double pscale;
    double *x;       /* the solve's iterate and right-hand side (the caller's) */
    const double *b;
    double norm_A;
    double bytes;
    ohm_mg_machine machine; /* the hierarchy on the host, for mg_cycle.c */
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
    double partial[OHM_ROWS_CHUNKS], partial2[OHM_ROWS_CHUNKS]; /* a reduction's (two at most) */
    double sum2;                              /* the second reduction's total */
};

static void kernel_piece(void *user, int64_t lo, int64_t hi, int chunk)
{
    kernel *k = user;
    k->fn(k, lo, hi, chunk);
}

/* k->fn over 0 .. n-1 in pieces (stencil_rows.h); a reduction's sum of the
 * pieces' partial sums, in order. */
static double run(kernel *k, int64_t n, int threads)
{
    k->n = n;
    k->chunks = ohm_rows_run(kernel_piece, k, n, threads);
    double sum = 0;
    k->sum2 = 0;
    for (int i = 0; i < k->chunks; ++i) {
        sum += k->partial[i];
        k->sum2 += k->partial2[i];
    }
    return sum;
}

/* ---- the cycle's rows (single; the loop and the double rows: stencil_rows.h) ----------- */

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

/* row v's diagonal in the cycle's precision, from the sink and links */
static inline float cyc_diag(const ohm_stencil *st, ROW_PARAMS)
{
    (void)yp, (void)zp;
    const float *gx = st->gx, *gy = st->gy, *gz = st->gz;
    float d = (float)st->sink[v] + gx[v] + gy[v] + gz[v] + my * gy[v + ym] + mz * gz[v + zm];
    if (!edge || v > 0) d += gx[v - 1];
    return d;
}

/* row v's links beyond the grid (stencil_form.h): their sum g x_w, and
 * their share of the diagonal */
static inline float cyc_extra_sum(const ohm_stencil *st, const float *x, int64_t v)
{
    float s = 0;
    for (int64_t k = st->xstart[v]; k < st->xstart[v + 1]; ++k) s += st->xg[k] * x[st->xcol[k]];
    return s;
}

static inline float cyc_extra_diag(const ohm_stencil *st, int64_t v)
{
    float d = 0;
    for (int64_t k = st->xstart[v]; k < st->xstart[v + 1]; ++k) d += st->xg[k];
    return d;
}

/* A coarse level's rows in the cycle's form (mg_coarsen.h: float sinks,
 * starts of RP's width), each row's sum_ and diag_ for the body. */
#define SPARSE_ROWS(RP, L, X, LO, HI, ...)                                                                      \
    do {                                                                                                        \
        const int32_t *col_ = (L)->sp.col;                                                                      \
        const float *g_ = (L)->sp.g, *sink_ = (L)->sp.sink_f;                                                   \
        for (int64_t v = (LO); v < (HI); ++v) {                                                                 \
            float sum_ = 0, diag_ = sink_[v];                                                                   \
            for (int64_t k_ = (RP)[v]; k_ < (RP)[v + 1]; ++k_) {                                                \
                sum_ += g_[k_] * (X)[col_[k_]];                                                                 \
                diag_ += g_[k_];                                                                                \
            }                                                                                                   \
            (void)diag_;                                                                                        \
            __VA_ARGS__                                                                                         \
        }                                                                                                       \
    } while (0)

/* The statements ... for every row v in lo .. hi-1 of level L, with sum_
 * = sum_w g_vw x_w over the row's links and diag_ its diagonal in scope
 * (so (A x)_v is diag_ x_v - sum_, the Jacobi step (b_v + sum_) / diag_):
 * a coarse level's sparse rows (mg_coarsen.h), level 0's stencil with its
 * links beyond the grid (a loop that does not vectorise), or without them
 * (one that does: SIMD is FOR_ROWS_SUM's pragma).  diag_ is computed only
 * where the statements read it. */
#define LEVEL_ROWS(SIMD, L, X, LO, HI, ...)                                                                     \
    do {                                                                                                        \
        if ((L)->sparse && (L)->sp.rp32) {                                                                      \
            SPARSE_ROWS((L)->sp.rp32, L, X, LO, HI, __VA_ARGS__);                                               \
        } else if ((L)->sparse) {                                                                               \
            SPARSE_ROWS((L)->sp.rp, L, X, LO, HI, __VA_ARGS__);                                                 \
        } else if ((L)->st.xstart) {                                                                            \
            FOR_ROWS(&(L)->st, LO, HI, {                                                                        \
                float sum_ = cyc_sum(S, X, ROW_ARGS) + cyc_extra_sum(S, X, v);                                  \
                float diag_ = cyc_diag(S, ROW_ARGS) + cyc_extra_diag(S, v);                                     \
                (void)diag_;                                                                                    \
                __VA_ARGS__                                                                                     \
            })                                                                                                  \
        } else {                                                                                                \
            FOR_ROWS_SUM(SIMD, &(L)->st, LO, HI, {                                                              \
                float sum_ = cyc_sum(S, X, ROW_ARGS);                                                           \
                float diag_ = cyc_diag(S, ROW_ARGS);                                                            \
                (void)diag_;                                                                                    \
                __VA_ARGS__                                                                                     \
            })                                                                                                  \
        }                                                                                                       \
    } while (0)

/* out = b - A x (b in y); returns ||out||^2, and its sum in k.sum2 */
static void residual_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    double s = 0, sr = 0;
    const double *x = k->x, *b = k->y;
    double *out = k->out;
    if (k->st->xstart)
        FOR_ROWS(k->st, lo, hi, {
            double r = b[v] - net_apply(S, x, ROW_ARGS) - extra_apply(S, x, v);
            out[v] = r;
            s += r * r;
            sr += r;
        })
    else FOR_ROWS_SUM("omp simd reduction(+ : s, sr)", k->st, lo, hi, {
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
    float *q_hi = k->outf, *q_lo = k->out_tmp;
    if (k->st->xstart)
        FOR_ROWS(k->st, lo, hi, {
            double q = net_apply_single(S, p, ROW_ARGS) + extra_apply_single(S, p, v);
            float h = (float)q;
            q_hi[v] = h;
            q_lo[v] = (float)(q - h);
            pq += p[v] * q;
            pr += p[v] * r[v];
        })
    else FOR_ROWS_SUM("omp simd reduction(+ : pq, pr)", k->st, lo, hi, {
            double q = net_apply_single(S, p, ROW_ARGS);
            float h = (float)q;
            q_hi[v] = h;
            q_lo[v] = (float)(q - h);
            pq += p[v] * q;
            pr += p[v] * r[v];
        })
    k->partial[chunk] = a * pq;
    k->partial2[chunk] = pr;
}

/* The outer step: x += alpha p with p = a pt (alpha a in a2, pt in xf), r
 * -= alpha q with q = a (A pt) (its halves in yf and bf), and the next
 * cycle's right-hand side outf = a3 r in the same pass (to_single_k's, not
 * a pass of its own); returns ||r||^2, and the sum of r (the power the
 * books miss) in k.sum2. */
static void step_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    double s = 0, sr = 0, alpha_p = k->a2, scale = k->a3;
    double *x = k->out, *r = k->out2;
    const float *p = k->xf, *q_hi = k->yf, *q_lo = k->bf;
    float *rhs = k->outf;
#pragma omp simd reduction(+ : s, sr)
    for (int64_t i = lo; i < hi; ++i) {
        x[i] += alpha_p * p[i];
        double ri = r[i] - alpha_p * ((double)q_hi[i] + (double)q_lo[i]);
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

/* returns xf.yf, the preconditioned residual's product with A pt's high
 * half (to 6e-8 of q's: what the flexible step's beta needs) */
static void mixed_dot_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    double s = 0;
    const float *z = k->xf, *q = k->yf;
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
    if (!out) LEVEL_ROWS("omp simd reduction(+ : s)", k->L, x, lo, hi, s += x[v] * (double)(diag_ * x[v] - sum_););
    else LEVEL_ROWS("omp simd reduction(+ : s)", k->L, x, lo, hi, {
            float y = diag_ * x[v] - sum_;
            out[v] = y;
            s += x[v] * (q ? (double)q[v] : (double)y);
        });
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
    else LEVEL_ROWS("omp simd", L, x, lo, hi, out[v] = x[v] + w * ((b[v] + sum_) * invd[v] - x[v]););
}

/* out = x + a (x - y) + c D^-1 (b - A x), y NULL: 0 (Chebyshev's second step) */
static void cheb_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    (void)chunk;
    const mg_level *L = k->L;
    const float a = (float)k->a, a2 = (float)k->a2, *x = k->xf, *y = k->yf, *b = k->bf, *invd = L->invd;
    float *out = k->outf;
    if (!y) LEVEL_ROWS("omp simd", L, x, lo, hi, out[v] = x[v] + a * x[v] + a2 * ((b[v] + sum_) * invd[v] - x[v]););
    else LEVEL_ROWS("omp simd", L, x, lo, hi,
                    out[v] = x[v] + a * (x[v] - y[v]) + a2 * ((b[v] + sum_) * invd[v] - x[v]););
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
    LEVEL_ROWS("omp simd", L, x, f0, f1, r[v] = b[v] - (diag_ * x[v] - sum_););
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
    if (L->n < OHM_ROWS_PARALLEL_MIN || threads <= 1)
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

static void host_machine(ohm_mg *m);

/* ---- set-up ---------------------------------------------------------------------------- */

static void level_free(mg_level *L)
{
    if (L->owns_st) ohm_stencil_free(&L->st);
    ohm_mg_sparse_free(&L->sp);
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
    free(mg->ap_hi);
    free(mg);
}

/* n elements of size bytes each, counted in m->bytes */
static void *array(ohm_mg *m, int64_t n, size_t size)
{
    m->bytes += (double)(n ? n : 1) * (double)size;
    return malloc((size_t)(n ? n : 1) * size);
}

/* Row v's diagonal in double: sink + links (+ links beyond the grid) */
static void inverse_diagonal_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    (void)chunk;
    const mg_level *L = k->L;
    if (L->sparse) {
        const ohm_mg_sparse *sp = &L->sp;
        for (int64_t v = lo; v < hi; ++v) {
            double d = sp->sink[v];
            for (int64_t j = sp->rp[v]; j < sp->rp[v + 1]; ++j) d += sp->g[j];
            L->invd[v] = d > 0 ? (float)(1.0 / d) : 0.0f;
        }
        return;
    }
    FOR_ROWS(&L->st, lo, hi, {
        double d = row_diag(&L->st, ROW_ARGS) + extra_diag(&L->st, v);
        L->invd[v] = d > 0 ? (float)(1.0 / d) : 0.0f;
    })
}

/* The smoother's inverse diagonal of level l's operator. */
static int inverse_diagonal(ohm_mg *m, int l, ohm_error *err)
{
    mg_level *L = &m->lev[l];
    if (!(L->invd = array(m, L->n, sizeof *L->invd)))
        return ohm_fail(err, OHM_ERR_NOMEM, "mg: out of memory for %lld cells' diagonal", (long long)L->n);
    kernel k = {.fn = inverse_diagonal_k, .L = L};
    run(&k, L->n, m->threads);
    return OHM_OK;
}

/* Level l + 1 from level l (mg_coarsen.h), whose unknowns sit at places:
 * level l's map and slabs, level l + 1's rows and inverse diagonal; the
 * coarse cells into *cells (the caller's, for the next step). */
static int coarsen(ohm_mg *m, int l, const ohm_mg_places *places, int64_t **cells, int64_t cdims[3], ohm_error *err)
{
    mg_level *L = &m->lev[l], *C = &m->lev[l + 1];
    ohm_mg_operator op = {.st = L->sparse ? NULL : &L->st, .sp = L->sparse ? &L->sp : NULL};
    ohm_mg_coarse c;
    int rc = ohm_mg_coarsen(&op, L->n, places, OHM_MG_THETA, m->threads, &c, err);
    if (rc) return rc;
    L->agg = c.agg, L->fine_at = c.fine_at, L->coarse_at = c.coarse_at, L->nslabs = c.nslabs;
    *cells = c.cell;
    memcpy(cdims, c.cdims, sizeof c.cdims);
    C->n = c.nc;
    m->nlevels++;
    m->bytes += (double)L->n * sizeof *L->agg + (double)(c.nslabs + 1) * 16;
    int is_stencil = 0;
    rc = ohm_mg_sparse_as_stencil(&c.sp, c.cell, c.cdims, &C->st, &is_stencil, err);
    if (rc) {
        ohm_mg_sparse_free(&c.sp);
        return rc;
    }
    if (is_stencil) { /* whole blocks: the stencil's loops */
        C->owns_st = 1;
        ohm_mg_sparse_free(&c.sp);
        m->bytes += (double)c.nc * (3 * sizeof(float) + sizeof(double)) +
                    (double)C->st.nruns * (sizeof *C->st.run_start + sizeof *C->st.run_off);
    } else {
        C->sp = c.sp;
        C->sparse = 1;
        m->bytes += (double)(c.nc + 1) * 8 + (double)c.nc * 8 + (double)c.sp.nnz * (4 + 4);
    }
    return inverse_diagonal(m, l + 1, err);
}

/* Level l's rows (a coarse level's) in the cycle's form (mg_coarsen.h),
 * once every sum, diagonal and factor that needs the set-up's is taken:
 * the cycle reads the same floats, 8 B a row fewer. */
static int compact_rows(ohm_mg *m, int l, ohm_error *err)
{
    mg_level *L = &m->lev[l];
    if (!L->sparse) return OHM_OK;
    int narrow = L->sp.nnz <= INT32_MAX;
    if (ohm_mg_sparse_compact(&L->sp))
        return ohm_fail(err, OHM_ERR_NOMEM, "mg: out of memory for level %d's rows (%lld cells)", l, (long long)L->n);
    m->bytes -= (double)L->n * 4 + (narrow ? (double)(L->n + 1) * 4 : 0);
    return OHM_OK;
}

/* The coarsest level's dense matrix, row-major (its rows are sparse). */
static void dense_matrix(const mg_level *L, double *A)
{
    int64_t n = L->n;
    if (L->sparse) {
        const ohm_mg_sparse *sp = &L->sp;
        for (int64_t v = 0; v < n; ++v) {
            double d = sp->sink[v];
            for (int64_t j = sp->rp[v]; j < sp->rp[v + 1]; ++j) {
                d += sp->g[j];
                A[v * n + sp->col[j]] -= sp->g[j];
            }
            A[v * n + v] += d;
        }
        return;
    }
    const ohm_stencil *st = &L->st;
    FOR_ROWS(st, 0, n, {
        A[v * n + v] = row_diag(st, ROW_ARGS) + extra_diag(st, v);
        int64_t up[3] = {st->gx[v] > 0 ? v + 1 : -1, yp ? v + yp : -1, zp ? v + zp : -1};
        const float g[3] = {st->gx[v], st->gy[v], st->gz[v]};
        for (int a = 0; a < 3; ++a)
            if (up[a] >= 0) A[v * n + up[a]] = A[up[a] * n + v] = -(double)g[a];
    })
    if (st->xstart)
        for (int64_t v = 0; v < n; ++v)
            for (int64_t k = st->xstart[v]; k < st->xstart[v + 1]; ++k) A[v * n + st->xcol[k]] -= st->xg[k];
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
    dense_matrix(L, A);
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
    if ((l == 0 || !last) && !(L->t = array(m, n, f))) goto nomem; /* level 0's: also A p's low half */
    L->kcycle = l > 0 && l <= KCYCLE_LEVELS && !last && (double)n <= KCYCLE_MAX_RATIO * (double)m->lev[l - 1].n;
    if (L->kcycle && (!(L->c1 = array(m, n, f)) || !(L->v1 = array(m, n, f)) || !(L->c2 = array(m, n, f)) ||
                      !(L->rt = array(m, n, f))))
        goto nomem;
    return OHM_OK;
nomem:
    return ohm_fail(err, OHM_ERR_NOMEM, "mg: out of memory for level %d's vectors (%lld cells)", l, (long long)n);
}

/* The levels below the finest, until one is small enough to factor. */
static int coarse_levels(ohm_mg *m, const ohm_grid_layout *layout, ohm_error *err)
{
    ohm_mg_places places = {.cells = layout->cells};
    memcpy(places.dims, layout->dims, sizeof places.dims);
    int64_t *cells = NULL; /* the last coarse level's */
    int rc = OHM_OK;
    while (!rc && m->lev[m->nlevels - 1].n > COARSEST_MAX && m->nlevels < LEVELS_MAX) {
        int64_t *ccells = NULL, cdims[3];
        rc = coarsen(m, m->nlevels - 1, &places, &ccells, cdims, err);
        free(cells);
        cells = ccells;
        places = (ohm_mg_places){.cell = cells};
        memcpy(places.dims, cdims, sizeof places.dims);
    }
    free(cells);
    if (!rc && m->lev[m->nlevels - 1].n > COARSEST_MAX)
        rc = ohm_fail(err, OHM_ERR_INTERNAL, "mg: %d levels leave %lld cells", m->nlevels,
                      (long long)m->lev[m->nlevels - 1].n);
    return rc;
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
    m->lev[0].st = *st; /* level 0's operator: the network's stencil itself */
    m->nlevels = 1;
    int rc = inverse_diagonal(m, 0, err);
    if (!rc) rc = coarse_levels(m, layout, err);
    if (!rc) rc = dense_factor(m, err);
    for (int l = 0; l < m->nlevels && !rc; ++l) rc = compact_rows(m, l, err);
    for (int l = 0; l < m->nlevels && !rc; ++l) rc = level_vectors(m, l, err);
    int64_t n = st->n;
    size_t d = sizeof(double);
    if (!rc &&
        (!(m->r = array(m, n, d)) || !(m->p = array(m, n, sizeof(float))) || !(m->ap_hi = array(m, n, sizeof(float)))))
        rc = ohm_fail(err, OHM_ERR_NOMEM, "mg: out of memory for %lld unknowns", (long long)n);
    if (rc) {
        ohm_mg_free(m);
        return rc;
    }
    host_machine(m);
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
                                           .st = L->sparse ? NULL : &L->st,
                                           .sp = L->sparse ? &L->sp : NULL,
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
     * the aggregate map 4, the outer r in double, p and A p's high half
     * in floats 16, the cycle's b x t 12 (t also A p's low half); the
     * coarse levels together about n/4 unknowns
     * (where the medium's jumps cut blocks into parts: mg_coarsen.h) of
     * rows of about eight links (8 B each: column and conductance), a row
     * start and sink 16 while the level is built (8 in the cycle's form),
     * inverse diagonal 4, map 4 and up to seven vectors of 4 */
    double fine = 20 + 4 + 4 + 4 + 16 + 12, coarse = (64 + 16 + 4 + 4 + 28) / 4.0;
    double dense = (double)(n < COARSEST_MAX ? n : COARSEST_MAX);
    return (fine + coarse) * (double)n + 8.0 * dense * dense;
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


/* ---- the host's operations (mg_ops.h) ---------------------------------------------------- */

static void host_smooth(void *self, int l, ohm_mg_vec y, ohm_mg_vec b, ohm_mg_vec tmp, ohm_mg_vec out)
{
    const ohm_mg *m = self;
    smooth(&m->lev[l], y, b, tmp, out, m->threads);
}

static void host_restrict(void *self, int l, ohm_mg_vec x, ohm_mg_vec b, ohm_mg_vec scratch, ohm_mg_vec rc)
{
    const ohm_mg *m = self;
    restrict_residual(&m->lev[l], x, b, scratch, rc, m->threads);
}

static void host_prolong(void *self, int l, ohm_mg_vec x, ohm_mg_vec e, ohm_mg_vec out)
{
    const ohm_mg *m = self;
    prolong_add(&m->lev[l], x, e, out, m->threads);
}

static double host_apply_dot(void *self, int l, ohm_mg_vec x, ohm_mg_vec y, ohm_mg_vec q)
{
    const ohm_mg *m = self;
    return level_apply_dot(&m->lev[l], x, y, q, m->threads);
}

static double host_dot(void *self, int l, ohm_mg_vec x, ohm_mg_vec y)
{
    const ohm_mg *m = self;
    return dot(x, y, m->lev[l].n, m->threads);
}

static void host_combine(void *self, int l, ohm_mg_vec out, double a, ohm_mg_vec x, double a2, ohm_mg_vec y)
{
    const ohm_mg *m = self;
    combine(out, a, x, a2, y, m->lev[l].n, m->threads);
}

static void host_zero(void *self, int l, ohm_mg_vec x)
{
    const ohm_mg *m = self;
    memset(x, 0, (size_t)m->lev[l].n * sizeof(float));
}

static void host_coarsest(void *self, ohm_mg_vec b, ohm_mg_vec x) { dense_solve(self, b, x); }

static int host_begin(void *self, double *x, const double *b, ohm_error *err)
{
    (void)err;
    ohm_mg *m = self;
    m->x = x;
    m->b = b;
    return OHM_OK;
}

static void host_residual(void *self, double *nr, double *sr)
{
    ohm_mg *m = self;
    kernel kr = {.fn = residual_k, .st = m->fine, .x = m->x, .y = m->b, .out = m->r};
    *nr = sqrt(run(&kr, m->fine->n, m->threads));
    *sr = kr.sum2;
}

static int host_start_cold(void *self, double *x, const double *b, ohm_error *err)
{
    (void)x, (void)err; /* x is the iterate, zeroed already */
    ohm_mg *m = self;
    memcpy(m->r, b, (size_t)m->fine->n * sizeof *m->r);
    return OHM_OK;
}

static int64_t host_clamp(void *self)
{
    ohm_mg *m = self;
    return clamp_negative(m->x, m->fine->n);
}

static int host_backward_error(void *self, double *x, const double *b, double *berr, ohm_error *err)
{
    (void)err;
    const ohm_mg *m = self;
    *berr = ohm_scaled_backward_error(b, x, m->r, (size_t)m->fine->n, m->norm_A);
    return OHM_OK;
}

/* level 0's b = s r */
static void host_rhs(void *self, double s)
{
    ohm_mg *m = self;
    kernel k = {.fn = to_single_k, .x = m->r, .outf = m->lev[0].b, .a = s};
    run(&k, m->lev[0].n, m->threads);
}

static double host_mixed_dot(void *self)
{
    ohm_mg *m = self;
    kernel kb = {.fn = mixed_dot_k, .xf = m->lev[0].x, .yf = m->ap_hi};
    return m->pscale * run(&kb, m->fine->n, m->threads); /* the direction's scale, not yet the next's */
}

/* p = kz z - beta p kept as pscale pt, pt in floats: any direction will do,
 * so long as q is A times the one taken (computed in double from pt's own
 * values), and x and r move along it together.  pt is of z's size whatever
 * the residual's, far inside a float's range; 4 B a cell fewer than a
 * double p, and 4 fewer streamed by three of the iteration's passes.  p =
 * kz (z - (beta pscale / kz) pt). */
static void host_direction(void *self, double kz, double beta)
{
    ohm_mg *m = self;
    kernel kd = {.fn = direction_k, .xf = m->lev[0].x, .outf = m->p, .a = beta == 0 ? 0.0 : beta * m->pscale / kz};
    run(&kd, m->fine->n, m->threads);
    m->pscale = kz;
}

static void host_apply_dots(void *self, double *pq, double *pr)
{
    ohm_mg *m = self;
    kernel kq = {
        .fn = apply_dots_k, .st = m->fine, .xf = m->p, .z = m->r, .outf = m->ap_hi, .out_tmp = m->lev[0].t, .a = m->pscale};
    *pq = m->pscale * run(&kq, m->fine->n, m->threads);
    *pr = m->pscale * kq.sum2;
}

/* the next cycle's right-hand side written by the step's own pass, scaled
 * by the norm before the step: the new residual is smaller, so s r stays
 * below ||A||_inf (ohm_mg_rhs_scale) */
static double host_step(void *self, double alpha, double nr, double *nr_after, double *sr_after)
{
    ohm_mg *m = self;
    double s = ohm_mg_rhs_scale(m->norm_A, nr);
    kernel ks = {.fn = step_k,
                 .xf = m->p,
                 .yf = m->ap_hi,
                 .bf = m->lev[0].t,
                 .out = m->x,
                 .out2 = m->r,
                 .outf = m->lev[0].b,
                 .a2 = alpha * m->pscale,
                 .a3 = s};
    *nr_after = sqrt(run(&ks, m->fine->n, m->threads));
    *sr_after = ks.sum2;
    return s;
}

static const ohm_mg_ops host_ops = {
    .smooth = host_smooth, .restrict_residual = host_restrict, .prolong_add = host_prolong,
    .apply_dot = host_apply_dot, .dot = host_dot, .combine = host_combine, .zero = host_zero,
    .coarsest_solve = host_coarsest, .begin = host_begin, .residual = host_residual, .start_cold = host_start_cold,
    .clamp = host_clamp, .backward_error = host_backward_error, .rhs = host_rhs, .mixed_dot = host_mixed_dot,
    .direction = host_direction, .apply_dots = host_apply_dots, .step = host_step};

/* the hierarchy's levels for mg_cycle.c */
static void host_machine(ohm_mg *m)
{
    ohm_mg_machine_init(&m->machine, &host_ops, m, m->fine->n, m->norm_A, m->nlevels);
    for (int l = 0; l < m->nlevels; ++l) {
        const mg_level *L = &m->lev[l];
        ohm_mg_machine_level(&m->machine, l, L->n, L->kcycle, (ohm_mg_vec[]){L->b, L->x, L->t, L->c1, L->v1, L->c2, L->rt});
    }
}

int ohm_mg_solve(ohm_mg *m, double *x, const double *b, double tol, int64_t max_iter, const ohm_log *log,
                 int64_t *iters, double *relres, ohm_error *err)
{
    return ohm_mg_fcg(&m->machine, x, b, tol, max_iter, log, iters, relres, err);
}

double ohm_mg_norm_inf(const ohm_mg *mg) { return mg->norm_A; }

void ohm_mg_set_threads(ohm_mg *mg, int threads) { mg->threads = threads > 0 ? threads : ohm_usable_cores(); }

/* ---- the outer iteration --------------------------------------------------------------- */

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
    double s = ohm_mg_rhs_scale(m->norm_A, nr);
    host_rhs(m, s);
    ohm_mg_cycle_level0(&m->machine);
    double kz = 1.0 / s;
    kernel kd = {.fn = to_double_k, .xf = L0->x, .out = z, .a = kz};
    run(&kd, L0->n, m->threads);
}

/* Bytes one cycle at level l streams, each array counted once per pass as
 * STREAM counts them (gathered neighbours hit the cache; a write's
 * allocating read is not counted), per level visit: a row's operator
 * (level_op_bytes), the inverse diagonal 4, the aggregate map 4, a vector
 * 4 per cell. */
static double cycle_bytes(const ohm_mg *m, int l);
static double level_op_bytes(const ohm_mg *m, int l);

static double coarse_solve_bytes(const ohm_mg *m, int l)
{
    const mg_level *L = &m->lev[l];
    double n = (double)L->n;
    if (l == m->nlevels - 1) return 8.0 * n * n + 8.0 * n; /* the dense factor's two sweeps */
    if (!L->kcycle) return cycle_bytes(m, l);
    /* two cycles, two applications with a dot (the operator, x, out: op +
     * 8), three dots (8) and two combinations (12) */
    return 2.0 * cycle_bytes(m, l) + (2.0 * (level_op_bytes(m, l) + 8) + 3.0 * 8 + 2.0 * 12) * n;
}

/* A pass over level l's operator, per row: the stencil's links 12 and
 * sink 8 (its runs are a few bytes per row of cells), or a coarse level's
 * row start 4 (8 past 2^31 links), float sink 4 and links 8 each (column
 * and conductance). */
static double level_op_bytes(const ohm_mg *m, int l)
{
    const mg_level *L = &m->lev[l];
    if (!L->sparse) return 20.0;
    return (L->sp.rp32 ? 8.0 : 12.0) + 8.0 * (double)L->sp.nnz / (double)(L->n ? L->n : 1);
}

static double cycle_bytes(const ohm_mg *m, int l)
{
    double n = (double)m->lev[l].n, nc = (double)m->lev[l + 1].n, op = level_op_bytes(m, l);
    /* pre-smoothing: from zero (b, invd, out: 12), a Chebyshev step (the
     * operator without the sink, x, b, invd, out: op - 8 + 16); the
     * residual restricted (the operator, x, b, agg, and the slab's
     * residuals written: op + 16, the coarse sums 4 nc); the correction
     * prolonged (x, agg, out: 12, the coarse values 4 nc); post-smoothing:
     * two steps (op + 8, and op + 12 with the previous iterate) */
    return (12 + (op + 8) + (op + 16) + 12 + (op + 8) + (op + 12)) * n + 8.0 * nc + coarse_solve_bytes(m, l + 1);
}

double ohm_mg_cycle_bytes(const ohm_mg *m)
{
    double n = (double)m->lev[0].n;
    /* r to single precision (8 + 4), the result to double (4 + 8) */
    return 24.0 * n + (m->nlevels == 1 ? coarse_solve_bytes(m, 0) : cycle_bytes(m, 0));
}

