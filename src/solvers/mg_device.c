/* solvers/mg_device.c — see mg_device.h.  The host side of mg_device.cl:
 * its buffers, and the multigrid's operations (mg_ops.h) as launches of its
 * kernels; the cycle and the outer iteration that call them are
 * mg_cycle.c's, the host's too. */
#include "solvers/mg_device.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "device/session.h"
#include "solvers/mg_device_cl.h" /* ohm_mg_device_source: mg_device.cl as a string, generated */
#include "solvers/backend.h"
#include "solvers/mg_cycle.h"

/* Work-groups a kernel runs at most (grid-stride loops cover the rest):
 * enough to fill a GPU's cores, few enough that a reduction's partial sums
 * are read back in one small transfer. */
enum { MAX_GROUPS = 1024, WG_MAX = 256 };

/* device=auto leaves a grid smaller than this on the host: here the host's
 * whole solve of 40^3 block-medium cells takes 0.02 s (docs/gpu.md), the
 * order of what a device solve spends on its ~800 kernel launches and ~40
 * synchronous read-backs of partial sums alone (14 iterations), before the
 * set-up.  To be re-measured on a GPU (docs/gpu.md). */
enum { AUTO_MIN_CELLS = 1 << 16 };

enum kernel_id {
    K_NET_RESIDUAL,
    K_NET_APPLY_DOTS,
    K_STEP,
    K_TO_SINGLE,
    K_MIXED_DOT,
    K_DIRECTION,
    K_CLAMP,
    K_JACOBI0,
    K_JACOBI,
    K_CHEB,
    K_CYC_RESIDUAL,
    K_GATHER,
    K_PROLONG,
    K_CYC_APPLY_DOT,
    K_DOT,
    K_COMBINE,
    K_FILL_ZERO,
    K_DENSE_SOLVE,
    K_JACOBI_SP, /* a coarse level's (sparse rows) */
    K_CHEB_SP,
    K_CYC_RESIDUAL_SP,
    K_CYC_APPLY_DOT_SP,
    K_COUNT
};
static const char *const kernel_names[K_COUNT] = {
    "net_residual", "net_apply_dots", "outer_step", "to_single", "mixed_dot",    "direction", "clamp_negative",
    "jacobi0",      "jacobi",         "cheb", "cyc_residual", "gather",   "prolong",   "cyc_apply_dot",
    "cycle_dot",    "combine",        "fill_zero",   "dense_solve", "jacobi_sp", "cheb_sp", "cyc_residual_sp",
    "cyc_apply_dot_sp"};

typedef struct dev_level {
    int64_t n, nc; /* its cells, the next level's (0 at the coarsest) */
    int kcycle;
    int sparse;                          /* a coarse level's rows: off holds rp, c (column, g) */
    cl_mem xs, xc, xg;                   /* level 0's links beyond the grid (has_x), else the device's none */
    int has_x;
    cl_mem off, c, invd;                 /* the stencil                          */
    cl_mem agg, start, children;         /* into the next level, and back        */
    cl_mem b, x, t;                      /* right-hand side, correction, temporary */
    cl_mem c1, v1, c2, v2, rt;           /* the K-cycle's                        */
} dev_level;

struct ohm_mg_device {
    ohm_device_session s;      /* the device, its queue, the buffers' bytes, launch failures */
    cl_program program;
    cl_kernel k[K_COUNT];
    size_t wg;                 /* work-group size                    */
    int64_t n;
    const ohm_stencil *fine;
    double norm_A;
    cl_mem g, sink;            /* the network's stencil (off: level 0's) */
    cl_mem x, b, r, p, ap;     /* the outer iteration's (ap = A p), double */
    cl_mem dense, dense_y;
    int64_t ndense;
    cl_mem partial;
    cl_mem none;               /* a buffer no kernel reads: for has_x 0 */
    double *partial_host;
    dev_level lev[OHM_MG_LEVELS_MAX];
    int nlevels;
    double *host_r;            /* r read back, where the solve stagnates */
    ohm_mg_machine machine;    /* the hierarchy on the device, for mg_cycle.c */
};

/* ---- buffers and launches -------------------------------------------------------------- */

static const char ADVICE[] = "use a smaller dim= or device=host";

static int buffer(ohm_mg_device *d, cl_mem *mem, size_t bytes, const void *host, ohm_error *err)
{
    return ohm_device_buffer(&d->s, mem, bytes, host, ADVICE, err);
}

static void arg(ohm_mg_device *d, enum kernel_id k, cl_uint i, size_t size, const void *value)
{
    ohm_device_arg(&d->s, d->k[k], i, size, value);
}
#define ARG_MEM(k, i, m) arg(d, k, i, sizeof(cl_mem), &(m))
#define ARG_VAL(k, i, type, v)                                                                                  \
    do {                                                                                                        \
        type value_ = (v);                                                                                      \
        arg(d, k, i, sizeof value_, &value_);                                                                   \
    } while (0)

/* kernel k's arguments first .. first + count - 1: the buffers mem */
static void mem_args(ohm_mg_device *d, enum kernel_id k, cl_uint first, int count, const cl_mem *mem)
{
    for (int i = 0; i < count; ++i) arg(d, k, first + (cl_uint)i, sizeof(cl_mem), &mem[i]);
}

static size_t groups_for(const ohm_mg_device *d, int64_t n)
{
    size_t groups = (size_t)((n + (int64_t)d->wg - 1) / (int64_t)d->wg);
    return groups < 1 ? 1 : groups > MAX_GROUPS ? MAX_GROUPS : groups;
}

/* kernel k over n items (grid-stride), or over one work-group (single) */
static void launch(ohm_mg_device *d, enum kernel_id k, int64_t n, int single)
{
    ohm_device_launch(&d->s, d->k[k], single ? d->wg : groups_for(d, n) * d->wg, d->wg);
}

/* a reduction kernel over n items: its two sums, added group by group in
 * order (its last argument is the partial sums' buffer) */
static void reduce(ohm_mg_device *d, enum kernel_id k, int64_t n, cl_uint partial_arg, double sums[2])
{
    ARG_MEM(k, partial_arg, d->partial);
    launch(d, k, n, 0);
    size_t groups = groups_for(d, n);
    sums[0] = sums[1] = 0;
    if (d->s.status != CL_SUCCESS) return;
    cl_int st = d->s.cl.EnqueueReadBuffer(d->s.q.queue, d->partial, CL_TRUE, 0, 2 * groups * sizeof(double),
                                          d->partial_host, 0, NULL, NULL);
    if (st != CL_SUCCESS) {
        d->s.status = st;
        return;
    }
    for (size_t g = 0; g < groups; ++g) {
        sums[0] += d->partial_host[2 * g];
        sums[1] += d->partial_host[2 * g + 1];
    }
}

/* ---- a level's operations (mg_ops.h) ------------------------------------------------------ */

/* Where a stencil kernel's four arguments for the links beyond the grid
 * begin (mg_device.cl's EXTRA_ARGS, last in each), or 0: it has none. */
static cl_uint extra_arg(enum kernel_id k)
{
    switch (k) {
    case K_NET_RESIDUAL:
    case K_NET_APPLY_DOTS:
    case K_JACOBI:
    case K_CYC_APPLY_DOT: return 8;
    case K_CHEB: return 11;
    case K_CYC_RESIDUAL: return 6;
    default: return 0;
    }
}

/* level L's links beyond the grid as kernel k's last four arguments */
static void set_extras(ohm_mg_device *d, enum kernel_id k, const dev_level *L)
{
    cl_uint a = extra_arg(k);
    ARG_MEM(k, a, L->xs);
    ARG_MEM(k, a + 1, L->xc);
    ARG_MEM(k, a + 2, L->xg);
    ARG_VAL(k, a + 3, cl_int, L->has_x);
}

/* kernel k of level L's form (a coarse level's sparse rows have their
 * own), its operator set as its first two arguments (and a stencil's
 * links beyond the grid as its last four) */
static enum kernel_id set_stencil(ohm_mg_device *d, enum kernel_id k, const dev_level *L)
{
    if (L->sparse)
        k = k == K_JACOBI ? K_JACOBI_SP : k == K_CHEB ? K_CHEB_SP : k == K_CYC_RESIDUAL ? K_CYC_RESIDUAL_SP
                                                                                         : K_CYC_APPLY_DOT_SP;
    else set_extras(d, k, L);
    ARG_MEM(k, 0, L->off);
    ARG_MEM(k, 1, L->c);
    return k;
}

/* two Chebyshev steps for A out = b from y (NULL: zero), the first into tmp */
static void smooth(ohm_mg_device *d, const dev_level *L, const cl_mem *y, cl_mem b, cl_mem tmp, cl_mem out)
{
    double w0, a, a2;
    ohm_mg_smoother(&w0, &a, &a2);
    if (!y) {
        ARG_MEM(K_JACOBI0, 0, b);
        ARG_MEM(K_JACOBI0, 1, L->invd);
        ARG_MEM(K_JACOBI0, 2, tmp);
        ARG_VAL(K_JACOBI0, 3, float, (float)w0);
        ARG_VAL(K_JACOBI0, 4, cl_long, L->n);
        launch(d, K_JACOBI0, L->n, 0);
    } else {
        enum kernel_id kj = set_stencil(d, K_JACOBI, L);
        ARG_MEM(kj, 2, L->invd);
        ARG_MEM(kj, 3, *y);
        ARG_MEM(kj, 4, b);
        ARG_MEM(kj, 5, tmp);
        ARG_VAL(kj, 6, float, (float)w0);
        ARG_VAL(kj, 7, cl_long, L->n);
        launch(d, kj, L->n, 0);
    }
    enum kernel_id kc = set_stencil(d, K_CHEB, L);
    ARG_MEM(kc, 2, L->invd);
    ARG_MEM(kc, 3, tmp);
    cl_mem prev = y ? *y : tmp; /* unread without has_y */
    ARG_MEM(kc, 4, prev);
    ARG_VAL(kc, 5, cl_int, y != NULL);
    ARG_MEM(kc, 6, b);
    ARG_MEM(kc, 7, out);
    ARG_VAL(kc, 8, float, (float)a);
    ARG_VAL(kc, 9, float, (float)a2);
    ARG_VAL(kc, 10, cl_long, L->n);
    launch(d, kc, L->n, 0);
}

static double level_apply_dot(ohm_mg_device *d, const dev_level *L, cl_mem x, cl_mem y, const cl_mem *q)
{
    enum kernel_id k = set_stencil(d, K_CYC_APPLY_DOT, L);
    ARG_MEM(k, 2, x);
    ARG_MEM(k, 3, y);
    cl_mem other = q ? *q : x; /* unread without has_q */
    ARG_MEM(k, 4, other);
    ARG_VAL(k, 5, cl_int, q != NULL);
    ARG_VAL(k, 6, cl_long, L->n);
    double s[2];
    reduce(d, k, L->n, 7, s);
    return s[0];
}

static double dot(ohm_mg_device *d, cl_mem x, cl_mem y, int64_t n)
{
    ARG_MEM(K_DOT, 0, x);
    ARG_MEM(K_DOT, 1, y);
    ARG_VAL(K_DOT, 2, cl_long, n);
    double s[2];
    reduce(d, K_DOT, n, 3, s);
    return s[0];
}

/* out = a x + a2 y (y NULL: a x) */
static void combine(ohm_mg_device *d, cl_mem out, double a, cl_mem x, double a2, const cl_mem *y, int64_t n)
{
    ARG_MEM(K_COMBINE, 0, x);
    cl_mem second = y ? *y : x; /* unread without has_y */
    ARG_MEM(K_COMBINE, 1, second);
    ARG_VAL(K_COMBINE, 2, cl_int, y != NULL);
    ARG_MEM(K_COMBINE, 3, out);
    ARG_VAL(K_COMBINE, 4, double, a);
    ARG_VAL(K_COMBINE, 5, double, a2);
    ARG_VAL(K_COMBINE, 6, cl_long, n);
    launch(d, K_COMBINE, n, 0);
}

static void dense_solve(ohm_mg_device *d, cl_mem b, cl_mem x)
{
    ARG_MEM(K_DENSE_SOLVE, 0, d->dense);
    ARG_MEM(K_DENSE_SOLVE, 1, b);
    ARG_MEM(K_DENSE_SOLVE, 2, d->dense_y);
    ARG_MEM(K_DENSE_SOLVE, 3, x);
    ARG_VAL(K_DENSE_SOLVE, 4, cl_long, d->ndense);
    launch(d, K_DENSE_SOLVE, d->ndense, 1);
}

static ohm_mg_device *dev(void *self) { return self; }

static void dev_smooth(void *self, int l, ohm_mg_vec y, ohm_mg_vec b, ohm_mg_vec tmp, ohm_mg_vec out)
{
    cl_mem ym = y;
    smooth(dev(self), &dev(self)->lev[l], y ? &ym : NULL, b, tmp, out);
}

/* scratch = b - A x, summed into the coarse cells' rc */
static void dev_restrict(void *self, int l, ohm_mg_vec x, ohm_mg_vec b, ohm_mg_vec scratch, ohm_mg_vec rc)
{
    ohm_mg_device *d = self;
    const dev_level *L = &d->lev[l];
    enum kernel_id k = set_stencil(d, K_CYC_RESIDUAL, L);
    mem_args(d, k, 2, 3, (cl_mem[]){x, b, scratch});
    ARG_VAL(k, 5, cl_long, L->n);
    launch(d, k, L->n, 0);
    mem_args(d, K_GATHER, 0, 4, (cl_mem[]){scratch, L->start, L->children, rc});
    ARG_VAL(K_GATHER, 4, cl_long, L->nc);
    launch(d, K_GATHER, L->nc, 0);
}

static void dev_prolong(void *self, int l, ohm_mg_vec x, ohm_mg_vec e, ohm_mg_vec out)
{
    ohm_mg_device *d = self;
    const dev_level *L = &d->lev[l];
    mem_args(d, K_PROLONG, 0, 4, (cl_mem[]){x, e, L->agg, out});
    ARG_VAL(K_PROLONG, 4, cl_long, L->n);
    launch(d, K_PROLONG, L->n, 0);
}

/* y NULL: into the level's v2, which nothing reads */
static double dev_apply_dot(void *self, int l, ohm_mg_vec x, ohm_mg_vec y, ohm_mg_vec q)
{
    ohm_mg_device *d = self;
    const dev_level *L = &d->lev[l];
    cl_mem qm = q;
    return level_apply_dot(d, L, x, y ? (cl_mem)y : L->v2, q ? &qm : NULL);
}

static double dev_dot(void *self, int l, ohm_mg_vec x, ohm_mg_vec y) { return dot(dev(self), x, y, dev(self)->lev[l].n); }

static void dev_combine(void *self, int l, ohm_mg_vec out, double a, ohm_mg_vec x, double a2, ohm_mg_vec y)
{
    cl_mem ym = y;
    combine(dev(self), out, a, x, a2, y ? &ym : NULL, dev(self)->lev[l].n);
}

static void dev_zero(void *self, int l, ohm_mg_vec x)
{
    ohm_mg_device *d = self;
    cl_mem xm = x;
    ARG_MEM(K_FILL_ZERO, 0, xm);
    ARG_VAL(K_FILL_ZERO, 1, cl_long, d->lev[l].n);
    launch(d, K_FILL_ZERO, d->lev[l].n, 0);
}

static void dev_coarsest(void *self, ohm_mg_vec b, ohm_mg_vec x) { dense_solve(dev(self), b, x); }

static void device_machine(ohm_mg_device *d);

/* ---- set-up ------------------------------------------------------------------------------- */

/* each coarse cell's fine cells, for the restriction's gather: start[I] ..
 * start[I + 1] in children (a counting sort of agg) */
static int children_of(int64_t **start, int32_t **children, const int32_t *agg, int64_t n, int64_t nc)
{
    *start = calloc((size_t)nc + 1, sizeof **start);
    *children = malloc((size_t)(n ? n : 1) * sizeof **children);
    if (!*start || !*children) return -1;
    for (int64_t v = 0; v < n; ++v) (*start)[agg[v] + 1]++;
    for (int64_t I = 0; I < nc; ++I) (*start)[I + 1] += (*start)[I];
    int64_t *fill = malloc((size_t)(nc ? nc : 1) * sizeof *fill);
    if (!fill) return -1;
    memcpy(fill, *start, (size_t)nc * sizeof *fill);
    for (int64_t v = 0; v < n; ++v) (*children)[fill[agg[v]]++] = (int32_t)v;
    free(fill);
    return 0;
}

/* the bytes the device will hold, before anything is copied */
static double device_bytes(const ohm_mg_view *v)
{
    double bytes = (double)v->fine->n * (3 * 4 + 8 + 5 * 8); /* g, sink; x b r p q */
    for (int l = 0; l < v->nlevels; ++l) {
        double n = (double)v->lev[l].n;
        const ohm_mg_sparse *sp = v->lev[l].sp;
        bytes += sp ? 8 * (n + 1) + 8 * ((double)sp->nnz + n) + 4 * n /* rp, (column, g), invd */
                    : n * (16 + 16 + 4);                                     /* off, c, invd */
        if (l < v->nlevels - 1) bytes += n * (4 + 4) + 8 * (double)v->lev[l + 1].n + n * 3 * 4; /* agg, children, start; b x t */
        if (v->lev[l].kcycle) bytes += 5 * 4 * n;
    }
    const ohm_stencil *st = v->fine; /* the links beyond the grid */
    if (st->xstart)
        bytes += (double)sizeof *st->xstart * (double)(st->n + 1) +
                 (double)(sizeof *st->xcol + sizeof *st->xg) * (double)st->xstart[st->n];
    return bytes + 8.0 * (double)v->ndense * ((double)v->ndense + 1);
}

/* The device's kernels read a stencil cell by cell, as the grid's
 * work-items do (a work-item per cell, where the host's rows go run by
 * run): these are the host copies for the upload, or NULL. */

/* st's -y, +y, -z, +z offsets for every cell, from its runs */
static int32_t (*cell_offsets(const ohm_stencil *st))[4]
{
    int32_t(*off)[4] = malloc((size_t)(st->n ? st->n : 1) * sizeof *off);
    for (int64_t r = 0; off && r < st->nruns; ++r)
        for (int64_t v = st->run_start[r]; v < st->run_start[r + 1]; ++v) memcpy(off[v], st->run_off[r], sizeof *off);
    return off;
}

/* st's +x, +y, +z links side by side, with its sink when with_sink (the
 * cycle's float4: the host's values, its cycle reading the sink as a float
 * too), else 3 per cell (the outer iteration's) */
static float *cell_links(const ohm_stencil *st, int with_sink)
{
    int w = with_sink ? 4 : 3;
    float *c = malloc((size_t)(st->n ? st->n : 1) * (size_t)w * sizeof *c);
    for (int64_t v = 0; c && v < st->n; ++v) {
        c[w * v] = st->gx[v];
        c[w * v + 1] = st->gy[v];
        c[w * v + 2] = st->gz[v];
        if (with_sink) c[w * v + 3] = (float)st->sink[v];
    }
    return c;
}

/* A coarse level's rows as mg_device.cl's sp_row reads them: each row's
 * sink first (column -1), then its links; into L's off (rp) and c. */
static int upload_rows(ohm_mg_device *d, dev_level *L, const ohm_mg_sparse *sp, ohm_error *err)
{
    int64_t n = sp->n, entries = sp->nnz + n;
    int64_t *rp = malloc((size_t)(n + 1) * sizeof *rp);
    cl_float2 *cv = malloc((size_t)(entries ? entries : 1) * sizeof *cv);
    int rc = !rp || !cv ? ohm_fail(err, OHM_ERR_NOMEM, "mg: out of memory for a coarse level's copy") : OHM_OK;
    for (int64_t v = 0; !rc && v < n; ++v) {
        int64_t e = rp[v] = ohm_mg_sparse_start(sp, v) + v;
        int32_t none = -1;
        memcpy(&cv[e].s[0], &none, sizeof none);
        cv[e].s[1] = ohm_mg_sparse_sink(sp, v);
        for (int64_t k = ohm_mg_sparse_start(sp, v); k < ohm_mg_sparse_start(sp, v + 1); ++k) {
            ++e;
            memcpy(&cv[e].s[0], &sp->col[k], sizeof sp->col[k]);
            cv[e].s[1] = sp->g[k];
        }
    }
    if (!rc) {
        rp[n] = entries;
        L->sparse = 1;
        rc = buffer(d, &L->off, (size_t)(n + 1) * sizeof *rp, rp, err);
    }
    if (!rc) rc = buffer(d, &L->c, (size_t)(entries ? entries : 1) * sizeof *cv, cv, err);
    free(rp);
    free(cv);
    return rc;
}

/* Level 0's stencil, as the kernels read it cell by cell, into L's off and c. */
static int upload_stencil(ohm_mg_device *d, dev_level *L, const ohm_stencil *st, int l, ohm_error *err)
{
    float *c = cell_links(st, 1);
    int32_t(*off)[4] = cell_offsets(st);
    int rc = !c || !off ? ohm_fail(err, OHM_ERR_NOMEM, "mg: out of memory for level %d's copy", l)
                        : buffer(d, &L->off, (size_t)st->n * sizeof *off, off, err);
    if (!rc) rc = buffer(d, &L->c, (size_t)st->n * 4 * sizeof(float), c, err);
    free(c);
    free(off);
    return rc;
}

static int upload_level(ohm_mg_device *d, const ohm_mg_view *v, int l, ohm_error *err)
{
    const ohm_mg_level_view *lv = &v->lev[l];
    dev_level *L = &d->lev[l];
    int64_t n = lv->n;
    size_t f = sizeof(float);
    L->n = n;
    L->kcycle = lv->kcycle;
    L->nc = l < v->nlevels - 1 ? v->lev[l + 1].n : 0;
    int rc = lv->sp ? upload_rows(d, L, lv->sp, err) : upload_stencil(d, L, lv->st, l, err);
    L->xs = L->xc = L->xg = d->none;
    if (!rc && lv->st && lv->st->xstart) { /* level 0's links beyond the grid */
        const ohm_stencil *st = lv->st;
        int64_t nx = st->xstart[n];
        L->has_x = 1;
        L->xs = L->xc = L->xg = NULL;
        rc = buffer(d, &L->xs, (size_t)(n + 1) * sizeof *st->xstart, st->xstart, err);
        if (!rc) rc = buffer(d, &L->xc, (size_t)(nx ? nx : 1) * sizeof *st->xcol, nx ? (const void *)st->xcol : st->xstart, err);
        if (!rc) rc = buffer(d, &L->xg, (size_t)(nx ? nx : 1) * sizeof *st->xg, nx ? (const void *)st->xg : st->xstart, err);
    }
    if (!rc) rc = buffer(d, &L->invd, (size_t)n * f, lv->invd, err);
    if (!rc) rc = buffer(d, &L->b, (size_t)n * f, NULL, err);
    if (!rc) rc = buffer(d, &L->x, (size_t)n * f, NULL, err);
    if (!rc && L->nc) {
        int64_t *start = NULL;
        int32_t *children = NULL;
        if (children_of(&start, &children, lv->agg, n, L->nc))
            rc = ohm_fail(err, OHM_ERR_NOMEM, "mg: out of memory for level %d's map", l);
        if (!rc) rc = buffer(d, &L->agg, (size_t)n * sizeof *lv->agg, lv->agg, err);
        if (!rc) rc = buffer(d, &L->start, (size_t)(L->nc + 1) * sizeof *start, start, err);
        if (!rc) rc = buffer(d, &L->children, (size_t)n * sizeof *children, children, err);
        free(start);
        free(children);
        if (!rc) rc = buffer(d, &L->t, (size_t)n * f, NULL, err);
    }
    cl_mem *kv[] = {&L->c1, &L->v1, &L->c2, &L->v2, &L->rt};
    for (size_t i = 0; !rc && L->kcycle && i < sizeof kv / sizeof *kv; ++i) rc = buffer(d, kv[i], (size_t)n * f, NULL, err);
    return rc;
}

static int build_kernels(ohm_mg_device *d, ohm_error *err)
{
    d->wg = ohm_device_group_size(&d->s, WG_MAX);
    char options[64];
    snprintf(options, sizeof options, "-D WG=%zu", d->wg);
    return ohm_device_kernels(&d->s, &d->program, d->k, kernel_names, K_COUNT, ohm_mg_device_source, options, err);
}

static int upload(ohm_mg_device *d, const ohm_mg_view *v, ohm_error *err)
{
    const ohm_stencil *st = v->fine;
    int64_t n = st->n;
    size_t dn = (size_t)n * sizeof(double);
    d->fine = st;
    d->n = n;
    d->norm_A = v->norm_A;
    d->nlevels = v->nlevels;
    d->ndense = v->ndense;
    int rc = buffer(d, &d->none, sizeof(cl_long), NULL, err);
    for (int l = 0; !rc && l < v->nlevels; ++l) rc = upload_level(d, v, l, err);
    float *g = rc ? NULL : cell_links(st, 0);
    if (!rc && !g) rc = ohm_fail(err, OHM_ERR_NOMEM, "mg: out of memory for the stencil's copy");
    if (!rc) rc = buffer(d, &d->g, (size_t)n * 3 * sizeof *g, g, err);
    free(g);
    if (!rc) rc = buffer(d, &d->sink, dn, st->sink, err);
    cl_mem *outer[] = {&d->x, &d->b, &d->r, &d->p, &d->ap};
    for (size_t i = 0; !rc && i < sizeof outer / sizeof *outer; ++i) rc = buffer(d, outer[i], dn, NULL, err);
    if (!rc) rc = buffer(d, &d->dense, (size_t)(v->ndense * v->ndense) * sizeof(double), v->dense, err);
    if (!rc) rc = buffer(d, &d->dense_y, (size_t)v->ndense * sizeof(double), NULL, err);
    if (!rc) rc = buffer(d, &d->partial, 2 * MAX_GROUPS * sizeof(double), NULL, err);
    if (!rc && !(d->partial_host = malloc(2 * MAX_GROUPS * sizeof(double))))
        rc = ohm_fail(err, OHM_ERR_NOMEM, "mg: out of memory");
    if (!rc) {
        cl_int fin = d->s.cl.Finish(d->s.q.queue);
        if (fin != CL_SUCCESS) rc = ohm_device_failed(&d->s, err, fin, "copying the hierarchy");
    }
    return rc;
}

int ohm_mg_device_open(ohm_mg_device **out, const ohm_mg *mg, const ohm_device_request *req, const ohm_log *log,
                       ohm_error *err)
{
    *out = NULL;
    if (!req || req->kind == OHM_DEVICE_HOST) return OHM_OK;
    ohm_mg_view view;
    ohm_mg_view_of(mg, &view);
    if (req->kind == OHM_DEVICE_AUTO && view.fine->n < AUTO_MIN_CELLS) {
        ohm_log_info(log, "solve: device=auto: %lld cells, fewer than %d: the cycle runs on the host",
                     (long long)view.fine->n, AUTO_MIN_CELLS);
        return OHM_OK;
    }
    ohm_mg_device *d = calloc(1, sizeof *d);
    if (!d) return ohm_fail(err, OHM_ERR_NOMEM, "mg: out of memory");
    int opened = 0;
    int rc = ohm_device_session_open(&d->s, &opened, req, "mg", log, err);
    if (rc || !opened) { /* an error, or device=auto on the host */
        ohm_mg_device_free(d);
        return rc;
    }
    const ohm_device *dev = ohm_device_session_device(&d->s);
    double need = device_bytes(&view);
    if (need > 0.9 * dev->global_bytes)
        rc = ohm_fail(err, OHM_ERR_NOMEM,
                      "mg on %s (opencl:%d): the hierarchy needs %.2f GiB, more than 90%% of the device's %.2f GiB; "
                      "%s",
                      dev->name, d->s.picked, need / (1 << 30), dev->global_bytes / (1 << 30), ADVICE);
    if (!rc) rc = build_kernels(d, err);
    if (!rc) rc = upload(d, &view, err);
    if (!rc) device_machine(d);
    if (rc) {
        ohm_mg_device_free(d);
        return rc;
    }
    ohm_log_info(log, "solve: mg on %s (opencl:%d): %d levels, %.1f MiB on the device, work-groups of %zu",
                 dev->name, d->s.picked, d->nlevels, d->s.bytes / (1 << 20), d->wg);
    *out = d;
    return OHM_OK;
}

const char *ohm_mg_device_name(const ohm_mg_device *d) { return d->s.q.device->name; }

double ohm_mg_device_bytes(const ohm_mg_device *d) { return d->s.bytes; }

void ohm_mg_device_free(ohm_mg_device *d)
{
    if (!d) return;
    for (int l = 0; l < d->nlevels; ++l) {
        dev_level *L = &d->lev[l];
        cl_mem *m[] = {&L->off, &L->c,  &L->invd, &L->agg, &L->start, &L->children, &L->b, &L->x,
                       &L->t,   &L->c1, &L->v1,   &L->c2,  &L->v2,    &L->rt};
        for (size_t i = 0; i < sizeof m / sizeof *m; ++i) ohm_device_release(&d->s, m[i]);
        cl_mem *x[] = {&L->xs, &L->xc, &L->xg}; /* the level's own, or the device's none */
        for (size_t i = 0; L->has_x && i < sizeof x / sizeof *x; ++i) ohm_device_release(&d->s, x[i]);
    }
    cl_mem *m[] = {&d->g, &d->sink, &d->x, &d->b, &d->r, &d->p, &d->ap, &d->dense, &d->dense_y, &d->partial, &d->none};
    for (size_t i = 0; i < sizeof m / sizeof *m; ++i) ohm_device_release(&d->s, m[i]);
    for (int k = 0; k < K_COUNT; ++k)
        if (d->k[k]) d->s.cl.ReleaseKernel(d->k[k]);
    if (d->program) d->s.cl.ReleaseProgram(d->program);
    free(d->partial_host);
    free(d->host_r);
    ohm_device_session_close(&d->s);
    free(d);
}

/* ---- the outer iteration's operations (mg_ops.h) ------------------------------------------ */

/* the network's stencil as kernel k's first three arguments (off: level 0's) */
static void set_network(ohm_mg_device *d, enum kernel_id k)
{
    set_extras(d, k, &d->lev[0]);
    ARG_MEM(k, 0, d->lev[0].off);
    ARG_MEM(k, 1, d->g);
    ARG_MEM(k, 2, d->sink);
}

static int dev_begin(void *self, double *x, const double *b, ohm_error *err)
{
    ohm_mg_device *d = self;
    size_t dn = (size_t)d->n * sizeof(double);
    int rc = ohm_device_copy(&d->s, d->b, (void *)b, dn, 1, err);
    return rc ? rc : ohm_device_copy(&d->s, d->x, x, dn, 1, err);
}

static int dev_end(void *self, double *x, ohm_error *err)
{
    ohm_mg_device *d = self;
    return ohm_device_copy(&d->s, d->x, x, (size_t)d->n * sizeof(double), 0, err);
}

/* r = b - A x on the device: (||r||, sum r) */
static void dev_residual(void *self, double *nr, double *sr)
{
    ohm_mg_device *d = self;
    enum kernel_id k = K_NET_RESIDUAL;
    set_network(d, k);
    ARG_MEM(k, 3, d->x);
    ARG_MEM(k, 4, d->b);
    ARG_MEM(k, 5, d->r);
    ARG_VAL(k, 6, cl_long, d->n);
    double s[2];
    reduce(d, k, d->n, 7, s);
    *nr = sqrt(s[0]);
    *sr = s[1];
}

static int dev_start_cold(void *self, double *x, const double *b, ohm_error *err)
{
    ohm_mg_device *d = self;
    size_t dn = (size_t)d->n * sizeof(double);
    int rc = ohm_device_copy(&d->s, d->x, x, dn, 1, err);
    return rc ? rc : ohm_device_copy(&d->s, d->r, (void *)b, dn, 1, err);
}

/* x's negative values set to 0, not counted (a count would be a read-back) */
static int64_t dev_clamp(void *self)
{
    ohm_mg_device *d = self;
    ARG_MEM(K_CLAMP, 0, d->x);
    ARG_VAL(K_CLAMP, 1, cl_long, d->n);
    launch(d, K_CLAMP, d->n, 0);
    return -1;
}

/* x and r read back to judge: only where the solve stagnates */
static int dev_backward_error(void *self, double *x, const double *b, double *berr, ohm_error *err)
{
    ohm_mg_device *d = self;
    size_t dn = (size_t)d->n * sizeof(double);
    if (!d->host_r && !(d->host_r = malloc(dn))) return ohm_fail(err, OHM_ERR_NOMEM, "mg: out of memory");
    int rc = ohm_device_copy(&d->s, d->x, x, dn, 0, err);
    if (!rc) rc = ohm_device_copy(&d->s, d->r, d->host_r, dn, 0, err);
    if (!rc) *berr = ohm_scaled_backward_error(b, x, d->host_r, (size_t)d->n, d->norm_A);
    return rc;
}

/* level 0's b = s r, in single precision */
static void dev_rhs(void *self, double s)
{
    ohm_mg_device *d = self;
    ARG_MEM(K_TO_SINGLE, 0, d->r);
    ARG_MEM(K_TO_SINGLE, 1, d->lev[0].b);
    ARG_VAL(K_TO_SINGLE, 2, double, s);
    ARG_VAL(K_TO_SINGLE, 3, cl_long, d->n);
    launch(d, K_TO_SINGLE, d->n, 0);
}

static double dev_mixed_dot(void *self)
{
    ohm_mg_device *d = self;
    double s[2];
    ARG_MEM(K_MIXED_DOT, 0, d->lev[0].x);
    ARG_MEM(K_MIXED_DOT, 1, d->ap);
    ARG_VAL(K_MIXED_DOT, 2, cl_long, d->n);
    reduce(d, K_MIXED_DOT, d->n, 3, s);
    return s[0];
}

/* p = kz z - beta p, in double */
static void dev_direction(void *self, double kz, double beta)
{
    ohm_mg_device *d = self;
    ARG_MEM(K_DIRECTION, 0, d->lev[0].x);
    ARG_MEM(K_DIRECTION, 1, d->p);
    ARG_VAL(K_DIRECTION, 2, double, kz);
    ARG_VAL(K_DIRECTION, 3, double, beta);
    ARG_VAL(K_DIRECTION, 4, cl_long, d->n);
    launch(d, K_DIRECTION, d->n, 0);
}

static void dev_apply_dots(void *self, double *pq, double *pr)
{
    ohm_mg_device *d = self;
    double s[2];
    set_network(d, K_NET_APPLY_DOTS);
    ARG_MEM(K_NET_APPLY_DOTS, 3, d->p);
    ARG_MEM(K_NET_APPLY_DOTS, 4, d->r);
    ARG_MEM(K_NET_APPLY_DOTS, 5, d->ap);
    ARG_VAL(K_NET_APPLY_DOTS, 6, cl_long, d->n);
    reduce(d, K_NET_APPLY_DOTS, d->n, 7, s);
    *pq = s[0];
    *pr = s[1];
}

/* the step, then the next right-hand side scaled by the new residual's
 * norm (a kernel of its own: the step's is a reduction already) */
static double dev_step(void *self, double alpha, double nr, double *nr_after, double *sr_after)
{
    (void)nr;
    ohm_mg_device *d = self;
    double s[2];
    ARG_MEM(K_STEP, 0, d->x);
    ARG_MEM(K_STEP, 1, d->r);
    ARG_MEM(K_STEP, 2, d->p);
    ARG_MEM(K_STEP, 3, d->ap);
    ARG_VAL(K_STEP, 4, double, alpha);
    ARG_VAL(K_STEP, 5, cl_long, d->n);
    reduce(d, K_STEP, d->n, 6, s);
    *nr_after = sqrt(s[0]);
    *sr_after = s[1];
    double scale = ohm_mg_rhs_scale(d->norm_A, *nr_after);
    dev_rhs(d, scale);
    return scale;
}

static int dev_checked(void *self, ohm_error *err) { return ohm_device_checked(&dev(self)->s, err); }

static const ohm_mg_ops device_ops = {
    .smooth = dev_smooth, .restrict_residual = dev_restrict, .prolong_add = dev_prolong, .apply_dot = dev_apply_dot,
    .dot = dev_dot, .combine = dev_combine, .zero = dev_zero, .coarsest_solve = dev_coarsest, .begin = dev_begin,
    .end = dev_end, .residual = dev_residual, .start_cold = dev_start_cold, .clamp = dev_clamp,
    .backward_error = dev_backward_error, .rhs = dev_rhs, .mixed_dot = dev_mixed_dot, .direction = dev_direction,
    .apply_dots = dev_apply_dots, .step = dev_step, .checked = dev_checked};

/* the levels' buffers for mg_cycle.c (a level's v2 is the device's own:
 * dev_apply_dot's) */
static void device_machine(ohm_mg_device *d)
{
    ohm_mg_machine_init(&d->machine, &device_ops, d, d->n, d->norm_A, d->nlevels);
    for (int l = 0; l < d->nlevels; ++l) {
        const dev_level *L = &d->lev[l];
        ohm_mg_machine_level(&d->machine, l, L->n, L->kcycle, (ohm_mg_vec[]){L->b, L->x, L->t, L->c1, L->v1, L->c2, L->rt});
    }
}

int ohm_mg_device_solve(ohm_mg_device *d, double *x, const double *b, double tol, int64_t max_iter,
                        const ohm_log *log, int64_t *iters, double *relres, ohm_error *err)
{
    return ohm_mg_fcg(&d->machine, x, b, tol, max_iter, log, iters, relres, err);
}
