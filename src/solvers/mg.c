/* solvers/mg.c — geometric multigrid on the voxel grid (mg.h): the
 * hierarchy, the K-cycle, the outer flexible CG, and the stencil's own
 * operations (apply, diagonal, norm). */
#include "solvers/mg.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/parallel.h"
#include "solvers/backend.h"

/* Levels stop coarsening at this many cells, solved by a dense Cholesky
 * factor: (n^3 / 3 flops, n^2 doubles: 0.04 GFlop and 2 MB at 500). */
enum { COARSEST_MAX = 500, LEVELS_MAX = 40 };

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

typedef struct mg_level {
    const ohm_stencil *st; /* this level's operator: the driver's at level 0 */
    ohm_stencil own;       /* a coarse level's, the Galerkin sums          */
    int64_t n;
    /* n: the next level's cell holding this one; NULL at the coarsest.  32
     * bits: a coarse level has fewer cells than the grid, which the
     * voxelizer keeps below 2^31 (checked in aggregate) */
    int32_t *agg;
    /* the next level's slabs (its z index K): this level's cells in slab K
     * are fine_at[K] .. fine_at[K + 1] - 1, the next level's coarse_at[K]
     * .. coarse_at[K + 1] - 1 */
    int64_t *fine_at, *coarse_at, nslabs;
    double *r, *t;                     /* the cycle's temporaries           */
    double *b, *x;                     /* a coarse level's right-hand side and correction */
    double *c1, *v1, *c2, *v2, *rt;    /* the K-cycle's, solving this level */
    int kcycle;                        /* this level is solved by the K-cycle */
} mg_level;

struct ohm_mg {
    mg_level lev[LEVELS_MAX];
    int nlevels;
    int threads;
    double *dense;     /* the coarsest level's Cholesky factor, n x n, lower */
    int64_t ndense;
    double *r, *z, *p, *q; /* the outer flexible CG's vectors              */
    double norm_A;
    double bytes;
};

/* ---- parallel loops ------------------------------------------------------------------ */

typedef struct kernel kernel;
struct kernel {
    void (*fn)(kernel *k, int64_t lo, int64_t hi, int chunk);
    const mg_level *L;
    const double *x, *b, *y, *z;
    double *out, *out2;
    double a, a2;
    int64_t n;
    int chunks;
    double partial[CHUNKS], partial2[CHUNKS]; /* a reduction's (two at most) */
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

/* ---- the stencil's operations -------------------------------------------------------- */

/* Row v's diagonal and (A x)_v (network.h's ohm_stencil): the links stored
 * by v (+x, +y, +z; 0 where there is none) and by its lower neighbours (-x:
 * v - 1's +x link when it has one; -y, -z: at their offsets). */
static inline double row_apply(const ohm_stencil *st, const double *x, int64_t v, double *diag)
{
    const int32_t *off = st->off[v];
    const double *g = st->g[v];
    double d = st->sink[v] + g[0] + g[1] + g[2], sum = 0;
    if (g[0] > 0) sum += g[0] * x[v + 1];
    if (off[1]) sum += g[1] * x[v + off[1]];
    if (off[3]) sum += g[2] * x[v + off[3]];
    if (v > 0 && st->g[v - 1][0] > 0) {
        double gw = st->g[v - 1][0];
        d += gw;
        sum += gw * x[v - 1];
    }
    for (int a = 1; a < 3; ++a)
        if (off[2 * a - 2]) {
            int64_t w = v + off[2 * a - 2];
            double gw = st->g[w][a];
            d += gw;
            sum += gw * x[w];
        }
    *diag = d;
    return d * x[v] - sum;
}

double ohm_stencil_diag(const ohm_stencil *st, int64_t v)
{
    double d = st->sink[v];
    for (int dir = 0; dir < 6; ++dir) {
        int64_t w = ohm_stencil_neighbour(st, v, dir);
        if (w >= 0) d += ohm_stencil_link(st, v, dir, w);
    }
    return d;
}

double ohm_stencil_norm_inf(const ohm_stencil *st)
{
    /* an M-matrix's row: |diag| + sum of |links| = sink + 2 sum of links */
    double norm = 0;
    for (int64_t v = 0; v < st->n; ++v) {
        double d = ohm_stencil_diag(st, v);
        norm = fmax(norm, 2.0 * d - st->sink[v]);
    }
    return norm;
}

static void apply_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    (void)chunk;
    const ohm_stencil *st = k->L->st;
    double d;
    for (int64_t v = lo; v < hi; ++v) k->out[v] = row_apply(st, k->x, v, &d);
}

static void level_apply(const mg_level *L, const double *x, double *y, int threads)
{
    kernel k = {.fn = apply_k, .L = L, .x = x, .out = y};
    run(&k, L->n, threads);
}

/* y = A x, returning x.q (q NULL: x.y) in the same pass */
static void apply_dot_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    const ohm_stencil *st = k->L->st;
    const double *q = k->y ? k->y : k->out;
    double d, s = 0;
    for (int64_t v = lo; v < hi; ++v) {
        double y = row_apply(st, k->x, v, &d);
        k->out[v] = y;
        s += k->x[v] * (k->y ? q[v] : y);
    }
    k->partial[chunk] = s;
}

static double level_apply_dot(const mg_level *L, const double *x, double *y, const double *q, int threads)
{
    kernel k = {.fn = apply_dot_k, .L = L, .x = x, .y = q, .out = y};
    return run(&k, L->n, threads);
}

void ohm_stencil_apply(const ohm_stencil *st, const double *x, double *y, int threads)
{
    mg_level L = {.st = st, .n = st->n};
    level_apply(&L, x, y, threads);
}

/* ---- vector kernels ------------------------------------------------------------------- */

static void dot_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    double s = 0;
    for (int64_t i = lo; i < hi; ++i) s += k->x[i] * k->y[i];
    k->partial[chunk] = s;
}

static double dot(const double *x, const double *y, int64_t n, int threads)
{
    kernel k = {.fn = dot_k, .x = x, .y = y};
    return run(&k, n, threads);
}

/* out = a x + a2 y (y NULL: a x); returns ||out||^2 */
static void combine_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    double s = 0;
    for (int64_t i = lo; i < hi; ++i) {
        double v = k->a * k->x[i] + (k->y ? k->a2 * k->y[i] : 0.0);
        k->out[i] = v;
        s += v * v;
    }
    k->partial[chunk] = s;
}

static double combine(double *out, double a, const double *x, double a2, const double *y, int64_t n, int threads)
{
    kernel k = {.fn = combine_k, .x = x, .y = y, .out = out, .a = a, .a2 = a2};
    return run(&k, n, threads);
}

/* The outer step: x += alpha p, r -= alpha q; returns ||r||^2, and the
 * sum of r (the power the books miss) in k.sum2. */
static void step_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    double s = 0, sr = 0, alpha = k->a;
    double *x = k->out, *r = k->out2;
    for (int64_t i = lo; i < hi; ++i) {
        x[i] += alpha * k->x[i];
        double ri = r[i] - alpha * k->y[i];
        r[i] = ri;
        s += ri * ri;
        sr += ri;
    }
    k->partial[chunk] = s;
    k->partial2[chunk] = sr;
}

/* The outer direction: p = z - beta p, q = w - beta q; returns p.q, and
 * p.r in k.sum2 (the next step's dots, in the same pass). */
static void direction_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    double pq = 0, pr = 0, beta = k->a;
    double *p = k->out, *q = k->out2;
    const double *z = k->x, *w = k->y, *r = k->z;
    for (int64_t i = lo; i < hi; ++i) {
        double pi = z[i] - beta * p[i], qi = w[i] - beta * q[i];
        p[i] = pi;
        q[i] = qi;
        pq += pi * qi;
        pr += pi * r[i];
    }
    k->partial[chunk] = pq;
    k->partial2[chunk] = pr;
}

/* ---- the smoother and the transfers --------------------------------------------------- */

/* out = x + w D^-1 (b - A x); x NULL: from zero (out = w D^-1 b). */
static void jacobi_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    (void)chunk;
    const ohm_stencil *st = k->L->st;
    const double w = k->a;
    for (int64_t v = lo; v < hi; ++v) {
        double d;
        if (!k->x) {
            k->out[v] = w * k->b[v] / ohm_stencil_diag(st, v);
        } else {
            double ax = row_apply(st, k->x, v, &d);
            k->out[v] = k->x[v] + w * (k->b[v] - ax) / d;
        }
    }
}

/* out = x + a (x - y) + c D^-1 (b - A x), y NULL: 0 (Chebyshev's second step) */
static void cheb_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    (void)chunk;
    const ohm_stencil *st = k->L->st;
    for (int64_t v = lo; v < hi; ++v) {
        double d, ax = row_apply(st, k->x, v, &d);
        k->out[v] = k->x[v] + k->a * (k->x[v] - (k->y ? k->y[v] : 0.0)) + k->a2 * (k->b[v] - ax) / d;
    }
}

/* Two Chebyshev steps for A out = b from y (NULL: zero), the first into
 * tmp: x1 = y + D^-1 (b - A y) / theta, then out = x1 + rho1 rho0 (x1 - y) +
 * (2 rho1 / delta) D^-1 (b - A x1) (the three-term recurrence of Saad,
 * "Iterative Methods for Sparse Linear Systems", 2nd ed., Algorithm 12.1,
 * with d0 = x1 - y). */
static void smooth(const mg_level *L, const double *y, const double *b, double *tmp, double *out, int threads)
{
    const double lmin = CHEB_LMAX / CHEB_RATIO;
    const double theta = 0.5 * (CHEB_LMAX + lmin), delta = 0.5 * (CHEB_LMAX - lmin), sigma = theta / delta;
    const double rho0 = 1.0 / sigma, rho1 = 1.0 / (2.0 * sigma - rho0);
    kernel k1 = {.fn = jacobi_k, .L = L, .x = y, .b = b, .out = tmp, .a = 1.0 / theta};
    run(&k1, L->n, threads);
    kernel k2 = {
        .fn = cheb_k, .L = L, .x = tmp, .y = y, .b = b, .out = out, .a = rho1 * rho0, .a2 = 2.0 * rho1 / delta};
    run(&k2, L->n, threads);
}

/* out = b - A x */
static void residual_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    (void)chunk;
    const ohm_stencil *st = k->L->st;
    double d;
    for (int64_t v = lo; v < hi; ++v) k->out[v] = k->b[v] - row_apply(st, k->x, v, &d);
}

static void residual(const mg_level *L, const double *x, const double *b, double *out, int threads)
{
    kernel k = {.fn = residual_k, .L = L, .x = x, .b = b, .out = out};
    run(&k, L->n, threads);
}

/* rc = P^T r: each coarse cell's the sum of its cells', slab by slab (a
 * coarse slab's cells are its two fine layers' and no other's). */
static void restrict_job(void *user, int64_t K)
{
    kernel *k = user;
    const mg_level *L = k->L;
    memset(k->out + L->coarse_at[K], 0, (size_t)(L->coarse_at[K + 1] - L->coarse_at[K]) * sizeof *k->out);
    for (int64_t v = L->fine_at[K]; v < L->fine_at[K + 1]; ++v) k->out[L->agg[v]] += k->x[v];
}

static void restrict_residual(const mg_level *L, const double *r, double *rc, int threads)
{
    kernel k = {.L = L, .x = r, .out = rc};
    if (L->n < PARALLEL_MIN || threads <= 1)
        for (int64_t K = 0; K < L->nslabs; ++K) restrict_job(&k, K);
    else ohm_parallel_for(L->nslabs, threads, restrict_job, &k);
}

/* out = x + P e */
static void prolong_k(kernel *k, int64_t lo, int64_t hi, int chunk)
{
    (void)chunk;
    const int32_t *agg = k->L->agg;
    for (int64_t v = lo; v < hi; ++v) k->out[v] = k->x[v] + k->y[agg[v]];
}

static void prolong_add(const mg_level *L, const double *x, const double *e, double *out, int threads)
{
    kernel k = {.fn = prolong_k, .L = L, .x = x, .y = e, .out = out};
    run(&k, L->n, threads);
}

/* ---- the cycle ------------------------------------------------------------------------ */

static void dense_solve(const ohm_mg *m, const double *b, double *x)
{
    int64_t n = m->ndense;
    const double *Lf = m->dense;
    for (int64_t i = 0; i < n; ++i) { /* L y = b */
        double s = b[i];
        for (int64_t j = 0; j < i; ++j) s -= Lf[i * n + j] * x[j];
        x[i] = s / Lf[i * n + i];
    }
    for (int64_t i = n; i-- > 0;) { /* L^T x = y */
        double s = x[i];
        for (int64_t j = i + 1; j < n; ++j) s -= Lf[j * n + i] * x[j];
        x[i] = s / Lf[i * n + i];
    }
}

static void cycle(const ohm_mg *m, int l, const double *b, double *x);

/* ec ~ A_l^-1 rc for coarse level l: exactly at the coarsest; else one
 * cycle, or the K-cycle's two steps of flexible CG preconditioned by it
 * (Notay and Vassilevski 2008, Algorithm 2.1). */
static void coarse_solve(const ohm_mg *m, int l, const double *rc, double *ec)
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
    double beta = level_apply_dot(L, L->c2, L->v2, NULL, th);
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
static void cycle(const ohm_mg *m, int l, const double *b, double *x)
{
    const mg_level *L = &m->lev[l];
    const mg_level *C = &m->lev[l + 1];
    int th = m->threads;
    smooth(L, NULL, b, x, L->t, th); /* pre-smoothed: t */
    residual(L, L->t, b, L->r, th);
    restrict_residual(L, L->r, C->b, th);
    coarse_solve(m, l + 1, C->b, C->x);
    prolong_add(L, L->t, C->x, L->r, th); /* corrected: r */
    smooth(L, L->r, b, L->t, x, th);      /* post-smoothed: x */
}

/* ---- set-up ---------------------------------------------------------------------------- */

static void level_free(mg_level *L)
{
    ohm_stencil_free(&L->own);
    free(L->agg);
    free(L->fine_at);
    free(L->coarse_at);
    double *v[] = {L->r, L->t, L->b, L->x, L->c1, L->v1, L->c2, L->v2, L->rt};
    for (size_t i = 0; i < sizeof v / sizeof v[0]; ++i) free(v[i]);
    memset(L, 0, sizeof *L);
}

void ohm_mg_free(ohm_mg *mg)
{
    if (!mg) return;
    for (int l = 0; l < mg->nlevels; ++l) level_free(&mg->lev[l]);
    free(mg->dense);
    free(mg->r);
    free(mg->z);
    free(mg->p);
    free(mg->q);
    free(mg);
}

static double *vec(ohm_mg *m, int64_t n)
{
    m->bytes += (double)(n ? n : 1) * sizeof(double);
    return malloc((size_t)(n ? n : 1) * sizeof(double));
}

/* Level l's cells aggregated into level l + 1's (mg.h): cells (dense index
 * cell[v] in a grid of dims) in cell order; the coarse cells' dense indices
 * into *ccell, their dims into cdims.  Slab by slab: a coarse slab's fine
 * cells are consecutive, and its cells are numbered in its (J, I) order,
 * which is the coarse grid's cell order. */
static int aggregate(ohm_mg *m, int l, const int64_t *cell, const int64_t dims[3], int64_t **ccell, int64_t cdims[3],
                     ohm_error *err)
{
    mg_level *L = &m->lev[l];
    for (int a = 0; a < 3; ++a) cdims[a] = (dims[a] + 1) / 2;
    int64_t n = L->n, plane = dims[0] * dims[1], cplane = cdims[0] * cdims[1];
    L->nslabs = cdims[2];
    L->agg = malloc((size_t)(n ? n : 1) * sizeof *L->agg);
    L->fine_at = malloc((size_t)(cdims[2] + 1) * sizeof *L->fine_at);
    L->coarse_at = malloc((size_t)(cdims[2] + 1) * sizeof *L->coarse_at);
    int64_t *mark = malloc((size_t)cplane * sizeof *mark);
    *ccell = malloc((size_t)(n ? n : 1) * sizeof **ccell); /* at most n coarse cells; shrunk below */
    m->bytes += (double)n * sizeof *L->agg;
    if (!L->agg || !L->fine_at || !L->coarse_at || !mark || !*ccell) {
        free(mark);
        return ohm_fail(err, OHM_ERR_NOMEM, "mg: out of memory coarsening %lld cells", (long long)n);
    }
    for (int64_t q = 0; q < cplane; ++q) mark[q] = -1;
    int64_t v = 0, nc = 0;
    for (int64_t K = 0; K < cdims[2]; ++K) {
        L->fine_at[K] = v;
        L->coarse_at[K] = nc;
        int64_t v0 = v;
        for (; v < n && cell[v] / plane / 2 == K; ++v) {
            int64_t c = cell[v], i = c % dims[0], j = c / dims[0] % dims[1];
            mark[i / 2 + cdims[0] * (j / 2)] = 0;
        }
        for (int64_t q = 0; q < cplane; ++q) /* the slab's coarse cells, numbered in order */
            if (mark[q] == 0) {
                (*ccell)[nc] = q + cplane * K;
                mark[q] = nc++;
            }
        for (int64_t u = v0; u < v; ++u) {
            int64_t c = cell[u], i = c % dims[0], j = c / dims[0] % dims[1];
            L->agg[u] = (int32_t)mark[i / 2 + cdims[0] * (j / 2)];
        }
        for (int64_t u = v0; u < v; ++u) { /* reset the marks this slab set */
            int64_t c = cell[u], i = c % dims[0], j = c / dims[0] % dims[1];
            mark[i / 2 + cdims[0] * (j / 2)] = -1;
        }
    }
    L->fine_at[cdims[2]] = v;
    L->coarse_at[cdims[2]] = nc;
    if (nc > INT32_MAX) {
        free(mark);
        return ohm_fail(err, OHM_ERR_USAGE, "mg: %lld coarse cells are more than 2^31", (long long)nc);
    }
    free(mark);
    int64_t *shrunk = realloc(*ccell, (size_t)(nc ? nc : 1) * sizeof *shrunk);
    if (shrunk) *ccell = shrunk;
    m->lev[l + 1].n = nc;
    return OHM_OK;
}

/* Level l + 1's stencil, the Galerkin product P^T A P of level l's with
 * piecewise-constant P: exactly sums of conductances (mg.h). */
static int galerkin(ohm_mg *m, int l, ohm_error *err)
{
    const mg_level *L = &m->lev[l];
    mg_level *C = &m->lev[l + 1];
    int64_t nc = C->n;
    ohm_stencil *cs = &C->own;
    cs->n = nc;
    cs->off = calloc((size_t)(nc ? nc : 1), sizeof *cs->off);
    cs->g = calloc((size_t)(nc ? nc : 1), sizeof *cs->g);
    cs->sink = calloc((size_t)(nc ? nc : 1), sizeof *cs->sink);
    m->bytes += (double)nc * 48;
    if (!cs->off || !cs->g || !cs->sink)
        return ohm_fail(err, OHM_ERR_NOMEM, "mg: out of memory for a coarse level of %lld cells", (long long)nc);
    const ohm_stencil *st = L->st;
    for (int64_t v = 0; v < L->n; ++v) {
        int64_t I = L->agg[v];
        cs->sink[I] += st->sink[v];
        for (int a = 0; a < 3; ++a) {
            int64_t w = ohm_stencil_neighbour(st, v, 2 * a + 1);
            if (w < 0) continue;
            int64_t J = L->agg[w];
            if (J == I) continue; /* inside the block: neither a link nor a sink */
            /* the blocks are neighbours across their +a face: J is I's +a
             * neighbour (I + 1 for +x, coarse cells being in cell order too) */
            cs->g[I][a] += st->g[v][a];
            if (a == 0) continue;
            int64_t delta = J - I;
            if (delta > INT32_MAX) return ohm_fail(err, OHM_ERR_INTERNAL, "mg: a coarse offset overflows");
            cs->off[I][2 * a - 1] = (int32_t)delta;
            cs->off[J][2 * a - 2] = (int32_t)-delta;
        }
    }
    C->st = cs;
    return OHM_OK;
}

/* The coarsest level's dense Cholesky factor. */
static int dense_factor(ohm_mg *m, ohm_error *err)
{
    const mg_level *L = &m->lev[m->nlevels - 1];
    int64_t n = L->n;
    m->ndense = n;
    m->dense = calloc((size_t)(n ? n * n : 1), sizeof *m->dense);
    m->bytes += (double)n * (double)n * 8;
    if (!m->dense) return ohm_fail(err, OHM_ERR_NOMEM, "mg: out of memory for the coarsest level");
    double *A = m->dense;
    const ohm_stencil *st = L->st;
    for (int64_t v = 0; v < n; ++v) {
        A[v * n + v] = ohm_stencil_diag(st, v);
        for (int d = 0; d < 6; ++d) {
            int64_t w = ohm_stencil_neighbour(st, v, d);
            if (w >= 0) A[v * n + w] = -ohm_stencil_link(st, v, d, w);
        }
    }
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

/* The work vectors: the cycle's at every level but the coarsest, a coarse
 * level's right-hand side and correction, the K-cycle's where it runs. */
static int level_vectors(ohm_mg *m, int l, ohm_error *err)
{
    mg_level *L = &m->lev[l];
    int64_t n = L->n;
    int last = l == m->nlevels - 1;
    /* (level 0's also serve the outer iteration: A z lands in t) */
    if ((!last || l == 0) && (!(L->r = vec(m, n)) || !(L->t = vec(m, n)))) goto nomem;
    if (l > 0 && (!(L->b = vec(m, n)) || !(L->x = vec(m, n)))) goto nomem;
    L->kcycle = l > 0 && l <= KCYCLE_LEVELS && !last && (double)n <= KCYCLE_MAX_RATIO * (double)m->lev[l - 1].n;
    if (L->kcycle && (!(L->c1 = vec(m, n)) || !(L->v1 = vec(m, n)) || !(L->c2 = vec(m, n)) ||
                      !(L->v2 = vec(m, n)) || !(L->rt = vec(m, n))))
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
    m->lev[0].st = st;
    m->lev[0].n = st->n;
    m->nlevels = 1;
    const int64_t *cell = layout->cell;
    int64_t dims[3] = {layout->dims[0], layout->dims[1], layout->dims[2]};
    int64_t *owned = NULL; /* a coarse level's cells, needed until the next is built */
    int rc = OHM_OK;
    while (!rc && m->lev[m->nlevels - 1].n > COARSEST_MAX && m->nlevels < LEVELS_MAX) {
        int l = m->nlevels - 1;
        int64_t *ccell = NULL, cdims[3];
        rc = aggregate(m, l, cell, dims, &ccell, cdims, err);
        if (!rc) {
            m->nlevels++;
            rc = galerkin(m, l, err);
        }
        free(owned);
        owned = ccell;
        cell = ccell;
        memcpy(dims, cdims, sizeof dims);
    }
    free(owned);
    if (!rc && m->lev[m->nlevels - 1].n > COARSEST_MAX)
        rc = ohm_fail(err, OHM_ERR_INTERNAL, "mg: %d levels leave %lld cells", m->nlevels,
                      (long long)m->lev[m->nlevels - 1].n);
    if (!rc) rc = dense_factor(m, err);
    for (int l = 0; l < m->nlevels && !rc; ++l) rc = level_vectors(m, l, err);
    int64_t n = st->n;
    if (!rc && (!(m->r = vec(m, n)) || !(m->z = vec(m, n)) || !(m->p = vec(m, n)) || !(m->q = vec(m, n))))
        rc = ohm_fail(err, OHM_ERR_NOMEM, "mg: out of memory for %lld unknowns", (long long)n);
    if (rc) {
        ohm_mg_free(m);
        return rc;
    }
    m->norm_A = ohm_stencil_norm_inf(st);
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

double ohm_mg_bytes_estimate(int64_t n)
{
    /* fine: stencil 48, aggregate map 4, outer r z p q 32, the cycle's r t
     * 16; the coarse levels together about n/7 cells of stencil 48, map 4
     * and up to nine vectors */
    double fine = 48 + 4 + 32 + 16, coarse = (48 + 4 + 72) / 7.0;
    double dense = (double)(n < COARSEST_MAX ? n : COARSEST_MAX);
    return (fine + coarse) * (double)n + 8.0 * dense * dense;
}

/* ---- the outer iteration --------------------------------------------------------------- */

static void precondition(const ohm_mg *m, const double *r, double *z)
{
    if (m->nlevels == 1) dense_solve(m, r, z);
    else cycle(m, 0, r, z);
}

int ohm_mg_solve(ohm_mg *m, double *x, const double *b, double tol, int64_t max_iter, const ohm_log *log,
                 int64_t *iters, double *relres, ohm_error *err)
{
    const mg_level *L0 = &m->lev[0];
    int64_t n = L0->n;
    int th = m->threads;
    double *r = m->r, *z = m->z, *p = m->p, *q = m->q;
    double nb = sqrt(dot(b, b, n, th)), sb = 0;
    int b_nonnegative = 1;
    for (int64_t i = 0; i < n; ++i) {
        sb += fabs(b[i]);
        b_nonnegative &= b[i] >= 0;
    }
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
    int restarts = 0;
    ohm_progress prog;
    ohm_progress_begin(&prog, log, "solve: mg");
    double t_reported = prog.t_begin;
    for (;;) {
        /* the true residual at every (re)start and at the end */
        residual(L0, x, b, r, th);
        double nr = sqrt(dot(r, r, n, th)), sr = 0;
        if (it == 0 && !(nr <= nb)) { /* a warm start worse than zero (or not finite): start cold */
            memset(x, 0, (size_t)n * sizeof *x);
            memcpy(r, b, (size_t)n * sizeof *r);
            nr = nb;
        }
        for (int64_t i = 0; i < n; ++i) sr += r[i];
        *relres = nr / nb;
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
         * Comput. 22, 2000), one direction kept: p = z - beta p with beta
         * making p A-orthogonal to the last, q = A p by the same recurrence */
        precondition(m, r, z);
        memcpy(p, z, (size_t)n * sizeof *p);
        double pq = level_apply_dot(L0, p, q, NULL, th), pr = dot(p, r, n, th);
        while (!CONVERGED(nr, sr) && it < max_iter) {
            if (!(pq > 0)) break; /* converged to round-off (or A not positive definite) */
            kernel ks = {.fn = step_k, .x = p, .y = q, .out = x, .out2 = r, .a = pr / pq};
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
            if (CONVERGED(nr, sr)) break;
            precondition(m, r, z);
            double *w = L0->t; /* A z, into the cycle's temporary (free now) */
            double beta = level_apply_dot(L0, z, w, q, th) / pq;
            kernel kd = {.fn = direction_k, .x = z, .y = w, .z = r, .out = p, .out2 = q, .a = beta};
            pq = run(&kd, n, th);
            pr = kd.sum2;
        }
    }
#undef CONVERGED
    /* A is an M-matrix, so A^-1 >= 0 and a source b >= 0 has x >= 0.  Where
     * the fluence has decayed to ~1e-40 of its peak (a 100 mm voxel, a 1e12
     * contrast) the iteration's error, tol of the peak, leaves values of
     * either sign: taken to the 0 they are within that error of. */
    if (b_nonnegative)
        for (int64_t i = 0; i < n; ++i)
            if (x[i] < 0) x[i] = 0;
    *iters = it;
    ohm_progress_end(&prog);
    return OHM_OK;
}

/* ---- the mg backend (backend.h) ------------------------------------------------------- */

typedef struct mg_state {
    ohm_mg *mg;
    ohm_backend_config cfg;
} mg_state;

static void mg_destroy(void *state)
{
    mg_state *s = state;
    if (!s) return;
    ohm_mg_free(s->mg);
    free(s);
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
    ohm_mg_free(s->mg);
    s->mg = NULL;
    double t0 = ohm_now();
    const ohm_stencil *st = op->stencil;
    if (!st) rc = op->make_stencil(op->maker, &st, err);
    if (!rc) rc = ohm_mg_setup(&s->mg, st, s->cfg.layout, 0, err);
    if (rc) return rc;
    rep->t_precond += ohm_now() - t0;
    rep->precond_setups++;
    rep->levels = ohm_mg_levels(s->mg, NULL);
    snprintf(rep->solver, sizeof rep->solver, "mg");
    double held = ohm_mg_bytes(s->mg) + 48.0 * (double)n; /* and the stencil it reads */
    if (held > rep->bytes) rep->bytes = held;
    return OHM_OK;
}

static int mg_column(void *solver, double *x, const double *b, int64_t *iters, double *relres, ohm_error *err)
{
    mg_state *s = solver;
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
                                        .caps = OHM_BACKEND_STENCIL | OHM_BACKEND_WARM_START};
