/* solvers/mg_coarsen.c — see mg_coarsen.h: a level's unknowns grouped
 * into the next level's by blocks and strong links, and the Galerkin sums
 * of the coarse operator, slab by slab of the coarse grid. */
#include "solvers/mg_coarsen.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "base/parallel.h"
#include "physics/stencil.h"

void ohm_mg_sparse_free(ohm_mg_sparse *sp)
{
    free(sp->rp);
    free(sp->rp32);
    free(sp->col);
    free(sp->g);
    free(sp->sink);
    free(sp->sink_f);
    memset(sp, 0, sizeof *sp);
}

int ohm_mg_sparse_compact(ohm_mg_sparse *sp)
{
    if (sp->sink_f) return 0;
    int64_t n = sp->n;
    int narrow = sp->nnz <= INT32_MAX;
    float *sink_f = malloc((size_t)(n ? n : 1) * sizeof *sink_f);
    int32_t *rp32 = narrow ? malloc((size_t)(n + 1) * sizeof *rp32) : NULL;
    if (!sink_f || (narrow && !rp32)) {
        free(sink_f), free(rp32);
        return -1;
    }
    for (int64_t v = 0; v < n; ++v) sink_f[v] = (float)sp->sink[v]; /* the cycle's rows' (float) sink */
    free(sp->sink);
    sp->sink = NULL;
    sp->sink_f = sink_f;
    if (narrow) {
        for (int64_t v = 0; v <= n; ++v) rp32[v] = (int32_t)sp->rp[v];
        free(sp->rp);
        sp->rp = NULL;
        sp->rp32 = rp32;
    }
    return 0;
}

void ohm_mg_coarse_free(ohm_mg_coarse *c)
{
    free(c->agg);
    free(c->fine_at);
    free(c->coarse_at);
    free(c->cell);
    ohm_mg_sparse_free(&c->sp);
    memset(c, 0, sizeof *c);
}

/* ---- a level's links ------------------------------------------------------------------ */

enum { FACE_LINKS = 6 };

/* Row v's links to its face neighbours in the stencil (o: its run's -y,
 * +y, -z, +z offsets): their unknowns into w, conductances into g; the
 * count.  A link is where its conductance is > 0 (stencil_form.h; the
 * clear regions' coupling zeroes those of a clear cell). */
static int face_links(const ohm_stencil *st, int64_t v, const int32_t o[4], int64_t w[FACE_LINKS],
                      float g[FACE_LINKS])
{
    int k = 0;
    if (v + 1 < st->n && st->gx[v] > 0) w[k] = v + 1, g[k++] = st->gx[v];
    if (v > 0 && st->gx[v - 1] > 0) w[k] = v - 1, g[k++] = st->gx[v - 1];
    if (o[1] && st->gy[v] > 0) w[k] = v + o[1], g[k++] = st->gy[v];
    if (o[0] && st->gy[v + o[0]] > 0) w[k] = v + o[0], g[k++] = st->gy[v + o[0]];
    if (o[3] && st->gz[v] > 0) w[k] = v + o[3], g[k++] = st->gz[v];
    if (o[2] && st->gz[v + o[2]] > 0) w[k] = v + o[2], g[k++] = st->gz[v + o[2]];
    return k;
}

/* Walks a level's rows in increasing order: the stencil's run by a cursor. */
typedef struct row_walk {
    const ohm_mg_operator *op;
    int64_t run;
    int64_t w[FACE_LINKS];
    float g[FACE_LINKS];
} row_walk;

static row_walk walk_from(const ohm_mg_operator *op, int64_t v)
{
    row_walk r = {.op = op};
    if (op->st && op->st->n > 0) r.run = ohm_stencil_run_of(op->st, v < op->st->n ? v : op->st->n - 1);
    return r;
}

/* Row v's links within the grid (the stencil's face links, or a sparse
 * row): count, and the arrays holding them (w as int64 or col as int32). */
typedef struct row_links {
    int64_t count;
    const int64_t *w;
    const int32_t *col;
    const float *g;
} row_links;

static row_links links_of(row_walk *r, int64_t v)
{
    const ohm_mg_operator *op = r->op;
    if (op->sp) {
        const ohm_mg_sparse *sp = op->sp;
        return (row_links){sp->rp[v + 1] - sp->rp[v], NULL, sp->col + sp->rp[v], sp->g + sp->rp[v]};
    }
    int64_t run = ohm_stencil_run(op->st, v, &r->run);
    int k = face_links(op->st, v, op->st->run_off[run], r->w, r->g);
    return (row_links){k, r->w, NULL, r->g};
}

static inline int64_t link_to(const row_links *l, int64_t k) { return l->w ? l->w[k] : (int64_t)l->col[k]; }

/* Pieces a pass over a level's rows is cut into, whatever the cores (so
 * that the work balances), and the fewest rows worth a thread. */
enum { PIECES = 64, PARALLEL_MIN = 1 << 16 };

typedef struct rows_pass {
    const ohm_mg_operator *op;
    int64_t n, pieces;
    float *rowmax;
} rows_pass;

static void largest_links_piece(void *user, int64_t i)
{
    const rows_pass *p = user;
    int64_t lo = p->n * i / p->pieces, hi = p->n * (i + 1) / p->pieces;
    row_walk r = walk_from(p->op, lo);
    for (int64_t v = lo; v < hi; ++v) {
        row_links l = links_of(&r, v);
        float m = 0;
        for (int64_t k = 0; k < l.count; ++k) m = fmaxf(m, l.g[k]);
        p->rowmax[v] = m;
    }
}

/* Each row's largest link (0: none), for the strength test. */
static void largest_links(const ohm_mg_operator *op, int64_t n, float *rowmax, int threads)
{
    rows_pass p = {op, n, n >= PARALLEL_MIN ? PIECES : 1, rowmax};
    ohm_parallel_for(p.pieces, threads, largest_links_piece, &p);
}

/* ---- grouping ------------------------------------------------------------------------- */

/* The level's places in cell order, one unknown at a time. */
typedef struct place_walk {
    const ohm_mg_places *pl;
    ohm_cell_cursor cursor;
} place_walk;

static int64_t next_place(place_walk *p, int64_t v)
{
    return p->pl->cells ? ohm_cell_cursor_next(&p->cursor) : p->pl->cell[v];
}

/* The first of the n unknowns whose cell is c or later. */
static int64_t first_at(const ohm_mg_places *pl, int64_t n, int64_t c)
{
    if (pl->cells) return ohm_cell_index_rank(pl->cells, (size_t)c);
    int64_t lo = 0, hi = n; /* cells are non-decreasing */
    while (lo < hi) {
        int64_t mid = lo + (hi - lo) / 2;
        if (pl->cell[mid] < c) lo = mid + 1;
        else hi = mid;
    }
    return lo;
}

static int64_t find_root(int64_t *parent, int64_t i)
{
    while (parent[i] != i) i = parent[i] = parent[parent[i]]; /* path halving */
    return i;
}

static void join(int64_t *parent, int64_t a, int64_t b)
{
    a = find_root(parent, a), b = find_root(parent, b);
    if (a < b) parent[b] = a;
    else if (b < a) parent[a] = b;
}

/* Growable arrays of the grouping and the sums. */
typedef struct scratch {
    int64_t *q, *parent, *order, *rootid; /* a slab's: plane place, union-find, by place, part */
    float *big;                           /* a slab's: a part's largest link, at its root    */
    unsigned char *cut;                   /* cplane: a weak link inside the block             */
    int64_t cap;                          /* their room                                      */
    int64_t *head;                        /* cplane + 1: counting sort, first link-less one  */
} scratch;

static int slab_room(scratch *s, int64_t m)
{
    if (m <= s->cap) return 0;
    int64_t cap = m > 2 * s->cap ? m : 2 * s->cap;
    int64_t **a[] = {&s->q, &s->parent, &s->order, &s->rootid};
    for (size_t i = 0; i < sizeof a / sizeof *a; ++i) {
        int64_t *p = realloc(*a[i], (size_t)cap * sizeof *p);
        if (!p) return -1;
        *a[i] = p;
    }
    float *big = realloc(s->big, (size_t)cap * sizeof *big);
    if (!big) return -1;
    s->big = big;
    s->cap = cap;
    return 0;
}

/* Slab K's unknowns v0 .. v0 + m - 1 (their plane places in s->q) joined:
 * by strong links within a block (and link-less ones per block), or all
 * of a block's (whole). */
static void join_slab(const ohm_mg_operator *op, const float *rowmax, double theta, int whole, int64_t v0, int64_t m,
                      scratch *s)
{
    int64_t *first = s->head; /* a block's first link-less (or, whole, any) unknown */
    for (int64_t i = 0; i < m; ++i) {
        s->parent[i] = i;
        first[s->q[i]] = -1;
        s->cut[s->q[i]] = 0;
    }
    row_walk r = walk_from(op, v0);
    for (int64_t i = 0; i < m; ++i) {
        int64_t v = v0 + i, q = s->q[i];
        if (whole || rowmax[v] == 0) {
            if (first[q] < 0) first[q] = i;
            else join(s->parent, first[q], i);
            if (whole) continue;
        }
        row_links l = links_of(&r, v);
        for (int64_t k = 0; k < l.count; ++k) {
            int64_t w = link_to(&l, k);
            if (w <= v || w >= v0 + m || s->q[w - v0] != q) continue; /* each link once, inside the block */
            if (l.g[k] >= theta * fmaxf(rowmax[v], rowmax[w])) join(s->parent, i, w - v0);
            else s->cut[q] = 1;
        }
    }
}

/* Parts of one block with no weak link inside it (its unknowns order[0 ..
 * count-1]: parts only because the object's edge or a hole cuts the block)
 * whose media are alike (their largest links within a factor 1/theta)
 * joined, the first such part taking the rest: parts of their own would
 * cost the level a stencil's loops (mg.c keeps a level of whole blocks as
 * a stencil) and help nothing, as fixed blocks showed on uniform media.
 * Not where a weak link cuts the block: joining parts that a thin layer of
 * another medium separates took the family's two-level blocks from 16 to
 * 58 iterations at 54^3. */
static void join_alike(const int64_t *order, int64_t count, int64_t v0, const float *rowmax, double theta,
                       scratch *s)
{
    int64_t *lead = s->rootid; /* the parts kept so far: their roots; free until numbered */
    int64_t nlead = 0;
    for (int64_t k = 0; k < count; ++k) { /* each part's largest link, at its root (zeroed before) */
        int64_t i = order[k], root = find_root(s->parent, i);
        s->big[root] = fmaxf(s->big[root], rowmax[v0 + i]);
    }
    for (int64_t k = 0; k < count; ++k) {
        int64_t i = order[k], root = find_root(s->parent, i);
        if (root != i) continue; /* each part once, by its root (its first unknown) */
        float g = s->big[root];
        int64_t into = -1;
        for (int64_t j = 0; j < nlead && into < 0; ++j) {
            float h = s->big[lead[j]];
            if (g == 0 ? h == 0 : h > 0 && fminf(g, h) >= (float)theta * fmaxf(g, h)) into = lead[j];
        }
        if (into >= 0) join(s->parent, into, root);
        else lead[nlead++] = root;
    }
}

typedef struct slab_range slab_range;
static int64_t push_part(slab_range *r, int64_t cell);

/* The slab's parts numbered by place, then by first unknown: agg of its
 * unknowns, the coarse unknowns' cells; alike parts of a block joined
 * first (not when whole: one part a block already). */
static int number_slab(int64_t K, int64_t v0, int64_t m, int64_t cplane, const float *rowmax, double theta, int whole,
                       scratch *s, slab_range *range, int32_t *agg)
{
    int64_t *head = s->head;
    memset(head, 0, (size_t)(cplane + 1) * sizeof *head);
    for (int64_t i = 0; i < m; ++i) head[s->q[i] + 1]++;
    for (int64_t q = 0; q < cplane; ++q) head[q + 1] += head[q];
    for (int64_t i = 0; i < m; ++i) s->order[head[s->q[i]]++] = i; /* head[q] is now q's end */
    if (!whole) {
        for (int64_t i = 0; i < m; ++i) s->big[i] = 0;
        for (int64_t k = 0; k < m;) { /* block by block: order[k ..] share q */
            int64_t q = s->q[s->order[k]], end = head[q];
            if (!s->cut[q]) join_alike(s->order + k, end - k, v0, rowmax, theta, s);
            k = end;
        }
    }
    for (int64_t i = 0; i < m; ++i) s->rootid[i] = -1;
    for (int64_t k = 0; k < m; ++k) {
        int64_t i = s->order[k], root = find_root(s->parent, i);
        if (s->rootid[root] < 0) {
            s->rootid[root] = push_part(range, s->q[i] + cplane * K);
            if (s->rootid[root] < 0) return -1;
        }
        agg[v0 + i] = (int32_t)s->rootid[root];
    }
    return 0;
}

/* A run of consecutive coarse slabs, one job of a pass: its parts (numbered
 * from 0 here, then moved to their place), its scratch, its coarse rows. */
struct slab_range {
    int64_t k0, k1;
    int64_t nc, cell_cap, base; /* its parts; the first's number in the level */
    int64_t *cell;
    int64_t *rp, nnz, nnz_base; /* its rows' starts (from 0), entries, the first's place */
    int32_t *col;
    float *g;
    int failed;
};

/* A new part of the range at cell: its number in the range, or -1 (out of
 * memory, or more than a 32-bit map holds) */
static int64_t push_part(slab_range *r, int64_t cell)
{
    if (r->nc >= INT32_MAX) return -1;
    if (r->nc == r->cell_cap) {
        int64_t grown = r->cell_cap ? 2 * r->cell_cap : 1024;
        int64_t *p = realloc(r->cell, (size_t)grown * sizeof *p);
        if (!p) return -1;
        r->cell = p, r->cell_cap = grown;
    }
    r->cell[r->nc] = cell;
    return r->nc++;
}

/* What every job of a coarsening reads. */
typedef struct coarsening {
    const ohm_mg_operator *op;
    int64_t n;
    const ohm_mg_places *pl;
    const float *rowmax;
    double theta;
    int whole;
    ohm_mg_coarse *out;
    slab_range *range;
} coarsening;

/* Range r's unknowns into its parts: agg (numbered in the range), its
 * slabs' starts (coarse ones in the range), its parts' cells. */
static void group_range(void *user, int64_t ri)
{
    coarsening *cg = user;
    slab_range *R = &cg->range[ri];
    ohm_mg_coarse *out = cg->out;
    const ohm_mg_places *pl = cg->pl;
    const int64_t *dims = pl->dims, *cdims = out->cdims;
    int64_t n = cg->n, plane = dims[0] * dims[1], cplane = cdims[0] * cdims[1];
    scratch s = {.head = malloc((size_t)(cplane + 1) * sizeof *s.head), .cut = calloc((size_t)cplane + 1, 1)};
    R->nc = 0;
    R->failed = !s.head || !s.cut;
    place_walk p = {.pl = pl};
    int64_t v = first_at(pl, n, R->k0 * 2 * plane), c = 0; /* c: v's cell */
    if (pl->cells) p.cursor = ohm_cell_index_cursor(pl->cells, v);
    if (v < n) c = next_place(&p, v);
    for (int64_t K = R->k0; K < R->k1 && !R->failed; ++K) {
        int64_t v0 = v;
        out->fine_at[K] = v0;
        out->coarse_at[K] = R->nc;
        for (; v < n && c / plane / 2 == K; ++v) {
            if (slab_room(&s, v - v0 + 1)) {
                R->failed = 1;
                break;
            }
            int64_t i = c % dims[0], j = c / dims[0] % dims[1];
            s.q[v - v0] = i / 2 + cdims[0] * (j / 2);
            if (v + 1 < n) c = next_place(&p, v + 1);
        }
        if (R->failed) break;
        join_slab(cg->op, cg->rowmax, cg->theta, cg->whole, v0, v - v0, &s);
        if (number_slab(K, v0, v - v0, cplane, cg->rowmax, cg->theta, cg->whole, &s, R, out->agg)) R->failed = 1;
    }
    free(s.q), free(s.parent), free(s.order), free(s.rootid), free(s.big), free(s.head), free(s.cut);
}

/* Range r's parts to their numbers in the level: base added to its agg and
 * coarse slab starts, its cells into the level's. */
static void place_range(void *user, int64_t ri)
{
    coarsening *cg = user;
    const slab_range *R = &cg->range[ri];
    ohm_mg_coarse *out = cg->out;
    for (int64_t K = R->k0; K < R->k1; ++K) out->coarse_at[K] += R->base;
    for (int64_t v = out->fine_at[R->k0]; v < out->fine_at[R->k1]; ++v) out->agg[v] += (int32_t)R->base;
    if (R->nc) memcpy(out->cell + R->base, R->cell, (size_t)R->nc * sizeof *R->cell); /* (none: no array) */
}

/* The level's unknowns into coarse unknowns: out's agg, slabs, cells, nc,
 * range by range on up to threads cores. */
static int group_level(coarsening *cg, int64_t nranges, int threads)
{
    ohm_mg_coarse *out = cg->out;
    for (int64_t r = 0; r < nranges; ++r) cg->range[r].nc = 0;
    ohm_parallel_for(nranges, threads, group_range, cg);
    int64_t nc = 0;
    for (int64_t r = 0; r < nranges; ++r) {
        if (cg->range[r].failed) return -1;
        cg->range[r].base = nc;
        nc += cg->range[r].nc;
    }
    if (nc > INT32_MAX) return -1; /* the map is 32-bit */
    out->fine_at[out->nslabs] = cg->n;
    out->coarse_at[out->nslabs] = nc;
    out->nc = nc;
    free(out->cell);
    if (!(out->cell = malloc((size_t)(nc ? nc : 1) * sizeof *out->cell))) return -1;
    ohm_parallel_for(nranges, threads, place_range, cg);
    return 0;
}

/* ---- the coarse operator -------------------------------------------------------------- */

typedef struct triplet {
    int64_t row; /* in the slab */
    int32_t col;
    float g;
} triplet;

typedef struct sums {
    triplet *t;
    int64_t nt, tcap;
    int64_t *count;   /* a slab's rows + 1                               */
    int64_t ccap;
    triplet *sorted;  /* t by row                                         */
    int64_t *mark;    /* column - base: the row that last met it         */
    int64_t *slot;    /* column - base: its entry in that row            */
    int64_t span;     /* room of mark and slot                            */
    int64_t cap;      /* room of the range's col and g                    */
    double *acc;      /* the row at hand's sums, in double                */
    int64_t acap;     /* room of acc                                      */
} sums;

static int emit(sums *u, int64_t row, int64_t col, float g)
{
    if (u->nt == u->tcap) {
        int64_t grown = u->tcap ? 2 * u->tcap : 4096;
        triplet *p = realloc(u->t, (size_t)grown * sizeof *p);
        if (!p) return -1;
        u->t = p, u->tcap = grown;
    }
    u->t[u->nt++] = (triplet){row, (int32_t)col, g};
    return 0;
}

/* Slab K's fine rows' links between groups, as (coarse row, coarse
 * column, g), and its groups' sinks. */
static int slab_links(const ohm_mg_operator *op, ohm_mg_coarse *c, int64_t K, sums *u)
{
    const int32_t *agg = c->agg;
    int64_t f0 = c->fine_at[K], f1 = c->fine_at[K + 1], r0 = c->coarse_at[K];
    const ohm_stencil *st = op->st;
    double *sink = c->sp.sink;
    u->nt = 0;
    row_walk r = walk_from(op, f0);
    for (int64_t v = f0; v < f1; ++v) {
        int64_t I = agg[v];
        sink[I] += st ? st->sink[v] : op->sp->sink[v];
        row_links l = links_of(&r, v);
        for (int64_t k = 0; k < l.count; ++k) {
            int64_t J = agg[link_to(&l, k)];
            if (J != I && emit(u, I - r0, J, l.g[k])) return -1;
        }
        if (st && st->xstart) /* the links beyond the grid */
            for (int64_t k = st->xstart[v]; k < st->xstart[v + 1]; ++k) {
                int64_t J = agg[st->xcol[k]];
                if (J != I && emit(u, I - r0, J, st->xg[k])) return -1;
            }
    }
    return 0;
}

static int entry_room(sums *u, slab_range *R, int64_t need)
{
    if (need <= u->cap) return 0;
    int64_t cap = need > 2 * u->cap ? need : 2 * u->cap;
    int32_t *col = realloc(R->col, (size_t)cap * sizeof *col);
    if (col) R->col = col;
    float *g = realloc(R->g, (size_t)cap * sizeof *g);
    if (g) R->g = g;
    if (!col || !g) return -1;
    u->cap = cap;
    return 0;
}

/* mark and slot for columns base .. base + span - 1.  A stale mark is an
 * earlier row's (rows go in increasing order), never the row at hand, so
 * a new base needs no clearing; new room is cleared. */
static int column_room(sums *u, int64_t span)
{
    if (span <= u->span) return 0;
    int64_t *mark = realloc(u->mark, (size_t)span * sizeof *mark);
    if (mark) u->mark = mark;
    int64_t *slot = realloc(u->slot, (size_t)span * sizeof *slot);
    if (slot) u->slot = slot;
    if (!mark || !slot) return -1;
    for (int64_t j = u->span; j < span; ++j) u->mark[j] = -1;
    u->span = span;
    return 0;
}

/* The slab's rows from its triplets, into the range's: each column's
 * links summed. */
static int slab_rows(const ohm_mg_coarse *c, int64_t K, sums *u, slab_range *R)
{
    int64_t r0 = c->coarse_at[K], rows = c->coarse_at[K + 1] - r0, first = r0 - c->coarse_at[R->k0];
    if (rows + 1 > u->ccap) {
        int64_t *p = realloc(u->count, (size_t)(rows + 1) * sizeof *p);
        if (!p) return -1;
        u->count = p, u->ccap = rows + 1;
    }
    triplet *sorted = realloc(u->sorted, (size_t)(u->nt ? u->nt : 1) * sizeof *sorted);
    if (!sorted) return -1;
    u->sorted = sorted;
    int64_t lo = INT64_MAX, hi = -1; /* the columns met */
    memset(u->count, 0, (size_t)(rows + 1) * sizeof *u->count);
    for (int64_t t = 0; t < u->nt; ++t) {
        u->count[u->t[t].row + 1]++;
        if (u->t[t].col < lo) lo = u->t[t].col;
        if (u->t[t].col > hi) hi = u->t[t].col;
    }
    for (int64_t i = 0; i < rows; ++i) u->count[i + 1] += u->count[i];
    for (int64_t t = 0; t < u->nt; ++t) sorted[u->count[u->t[t].row]++] = u->t[t];
    if (entry_room(u, R, R->nnz + u->nt) || (u->nt && column_room(u, hi - lo + 1))) return -1;
    int64_t nnz = R->nnz, t = 0;
    for (int64_t i = 0; i < rows; ++i) {
        int64_t I = r0 + i, start = nnz, t0 = t;
        while (t < u->nt && sorted[t].row == i) ++t;
        if (t - t0 > u->acap) { /* room for the row's sums: at most a link each */
            double *acc = realloc(u->acc, (size_t)(t - t0) * sizeof *acc);
            if (!acc) return -1;
            u->acc = acc, u->acap = t - t0;
        }
        for (int64_t e = t0; e < t; ++e) {
            int64_t J = sorted[e].col, j = J - lo;
            if (u->mark[j] != I) {
                u->mark[j] = I;
                u->slot[j] = nnz;
                R->col[nnz] = (int32_t)J;
                u->acc[nnz++ - start] = 0;
            }
            u->acc[u->slot[j] - start] += sorted[e].g;
        }
        for (int64_t k = start; k < nnz; ++k) R->g[k] = (float)u->acc[k - start];
        R->rp[first + i + 1] = nnz;
    }
    R->nnz = nnz;
    return 0;
}

/* Range r's coarse rows (its sinks into the level's, its rows into its own
 * arrays). */
static void range_rows(void *user, int64_t ri)
{
    coarsening *cg = user;
    slab_range *R = &cg->range[ri];
    ohm_mg_coarse *c = cg->out;
    int64_t rows = c->coarse_at[R->k1] - c->coarse_at[R->k0];
    sums u = {0};
    R->nnz = 0;
    R->rp = calloc((size_t)rows + 1, sizeof *R->rp);
    R->failed = !R->rp;
    for (int64_t K = R->k0; K < R->k1 && !R->failed; ++K)
        R->failed = slab_links(cg->op, c, K, &u) || slab_rows(c, K, &u, R);
    free(u.t), free(u.count), free(u.sorted), free(u.mark), free(u.slot), free(u.acc);
}

/* Range r's rows into the level's, their links as floats. */
static void place_rows(void *user, int64_t ri)
{
    coarsening *cg = user;
    const slab_range *R = &cg->range[ri];
    ohm_mg_sparse *sp = &cg->out->sp;
    int64_t I0 = cg->out->coarse_at[R->k0], rows = cg->out->coarse_at[R->k1] - I0;
    for (int64_t i = 0; i < rows; ++i) sp->rp[I0 + i + 1] = R->nnz_base + R->rp[i + 1];
    if (!R->nnz) return; /* (no arrays) */
    memcpy(sp->col + R->nnz_base, R->col, (size_t)R->nnz * sizeof *R->col);
    memcpy(sp->g + R->nnz_base, R->g, (size_t)R->nnz * sizeof *R->g);
}

/* Each link one float in both of its rows: row I's sum for I < J (the
 * two rows sum the same fine links in different orders).  By pieces of
 * rows: a piece writes only its rows' entries of columns below the row,
 * which no piece reads. */
static void symmetric_piece(void *user, int64_t i)
{
    const ohm_mg_sparse *sp = user;
    int64_t lo = sp->n * i / PIECES, hi = sp->n * (i + 1) / PIECES;
    for (int64_t I = lo; I < hi; ++I)
        for (int64_t k = sp->rp[I]; k < sp->rp[I + 1]; ++k) {
            int64_t J = sp->col[k];
            if (J < I) continue;
            for (int64_t k2 = sp->rp[J]; k2 < sp->rp[J + 1]; ++k2)
                if (sp->col[k2] == I) {
                    sp->g[k2] = sp->g[k];
                    break;
                }
        }
}

static int galerkin(coarsening *cg, int64_t nranges, int threads)
{
    ohm_mg_coarse *c = cg->out;
    ohm_mg_sparse *sp = &c->sp;
    int64_t nc = c->nc;
    size_t m = (size_t)(nc ? nc : 1);
    sp->n = nc;
    sp->rp = calloc(m + 1, sizeof *sp->rp);
    sp->sink = calloc(m, sizeof *sp->sink);
    if (!sp->rp || !sp->sink) return -1;
    ohm_parallel_for(nranges, threads, range_rows, cg);
    int64_t nnz = 0, rc = 0;
    for (int64_t r = 0; r < nranges; ++r) {
        rc |= cg->range[r].failed;
        cg->range[r].nnz_base = nnz;
        nnz += cg->range[r].nnz;
    }
    sp->nnz = nnz;
    sp->col = malloc((size_t)(nnz ? nnz : 1) * sizeof *sp->col);
    sp->g = malloc((size_t)(nnz ? nnz : 1) * sizeof *sp->g);
    if (rc || !sp->col || !sp->g) return -1;
    ohm_parallel_for(nranges, threads, place_rows, cg);
    ohm_parallel_for(nc >= PARALLEL_MIN ? PIECES : 1, threads, symmetric_piece, sp);
    return 0;
}

/* ---- one step ------------------------------------------------------------------------- */

int ohm_mg_coarsen(const ohm_mg_operator *op, int64_t n, const ohm_mg_places *places, double theta, int threads,
                   ohm_mg_coarse *out, ohm_error *err)
{
    memset(out, 0, sizeof *out);
    for (int a = 0; a < 3; ++a) out->cdims[a] = (places->dims[a] + 1) / 2;
    out->nslabs = out->cdims[2];
    if (threads < 1) threads = 1;
    /* ranges of slabs: a few per core, so that uneven slabs balance; one
     * below a size worth a thread.  The numbering and the sums do not
     * depend on them (parts go slab by slab, rows are summed whole). */
    int64_t nranges = n >= PARALLEL_MIN ? 4 * (int64_t)threads : 1;
    if (nranges > out->nslabs) nranges = out->nslabs > 0 ? out->nslabs : 1;
    size_t m = (size_t)(n ? n : 1);
    float *rowmax = malloc(m * sizeof *rowmax);
    slab_range *range = calloc((size_t)nranges, sizeof *range);
    out->agg = malloc(m * sizeof *out->agg);
    out->fine_at = malloc((size_t)(out->nslabs + 1) * sizeof *out->fine_at);
    out->coarse_at = malloc((size_t)(out->nslabs + 1) * sizeof *out->coarse_at);
    int rc = !rowmax || !range || !out->agg || !out->fine_at || !out->coarse_at;
    for (int64_t r = 0; !rc && r < nranges; ++r) {
        range[r].k0 = out->nslabs * r / nranges;
        range[r].k1 = out->nslabs * (r + 1) / nranges;
    }
    coarsening cg = {op, n, places, rowmax, theta, 0, out, range};
    if (!rc) {
        largest_links(op, n, rowmax, threads);
        rc = group_level(&cg, nranges, threads);
        if (!rc && (double)out->nc > OHM_MG_KEEP_MAX * (double)n) {
            out->whole_blocks = cg.whole = 1;
            rc = group_level(&cg, nranges, threads);
        }
    }
    free(rowmax);
    if (!rc) rc = galerkin(&cg, nranges, threads);
    for (int64_t r = 0; range && r < nranges; ++r) {
        free(range[r].cell), free(range[r].rp), free(range[r].col), free(range[r].g);
    }
    free(range);
    if (rc) {
        ohm_mg_coarse_free(out);
        return ohm_fail(err, OHM_ERR_NOMEM, "mg: out of memory coarsening %lld cells, or more than 2^31 coarse ones",
                        (long long)n);
    }
    return OHM_OK;
}

/* ---- a whole-block level as a stencil ------------------------------------------------- */

int ohm_mg_sparse_as_stencil(const ohm_mg_sparse *sp, const int64_t *cell, const int64_t cdims[3], ohm_stencil *st,
                             int *is_stencil, ohm_error *err)
{
    memset(st, 0, sizeof *st);
    *is_stencil = 0;
    int64_t n = sp->n, row = cdims[0], plane = cdims[0] * cdims[1];
    for (int64_t v = 1; v < n; ++v)
        if (cell[v] == cell[v - 1]) return OHM_OK; /* parts share a cell: rows */
    size_t m = (size_t)(n ? n : 1);
    st->n = n;
    st->gx = calloc(m, sizeof *st->gx);
    st->gy = calloc(m, sizeof *st->gy);
    st->gz = calloc(m, sizeof *st->gz);
    st->sink = malloc(m * sizeof *st->sink);
    int32_t(*off)[4] = calloc(m, sizeof *off);
    if (!st->gx || !st->gy || !st->gz || !st->sink || !off) {
        free(off);
        ohm_stencil_free(st);
        return ohm_fail(err, OHM_ERR_NOMEM, "mg: out of memory for a coarse level of %lld cells", (long long)n);
    }
    memcpy(st->sink, sp->sink, m * sizeof *st->sink);
    /* each link's conductance by its lower unknown and axis; the y and z
     * neighbours' offsets (the unknowns are in cell order, so a +x
     * neighbour is the next unknown) */
    for (int64_t v = 0; v < n; ++v)
        for (int64_t k = sp->rp[v]; k < sp->rp[v + 1]; ++k) {
            int64_t w = sp->col[k], d = cell[w] - cell[v];
            if (d == 1) st->gx[v] = sp->g[k];
            else if (d == row) st->gy[v] = sp->g[k], off[v][1] = (int32_t)(w - v);
            else if (d == -row) off[v][0] = (int32_t)(w - v);
            else if (d == plane) st->gz[v] = sp->g[k], off[v][3] = (int32_t)(w - v);
            else if (d == -plane) off[v][2] = (int32_t)(w - v);
            else if (d != -1) { /* not a face neighbour: no stencil */
                free(off);
                ohm_stencil_free(st);
                return OHM_OK;
            }
        }
    int rc = ohm_stencil_set_runs(st, (const int32_t(*)[4])off, err);
    free(off);
    if (rc) ohm_stencil_free(st);
    else *is_stencil = 1;
    return rc;
}
