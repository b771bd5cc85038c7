/* solvers/mg_coarsen.c — see mg_coarsen.h: a level's unknowns grouped
 * into the next level's by blocks and strong links, and the Galerkin sums
 * of the coarse operator, slab by slab of the coarse grid. */
#include "solvers/mg_coarsen.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "physics/stencil.h"

void ohm_mg_sparse_free(ohm_mg_sparse *sp)
{
    free(sp->rp);
    free(sp->col);
    free(sp->g);
    free(sp->sink);
    memset(sp, 0, sizeof *sp);
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

/* Each row's largest link (0: none), for the strength test. */
static void largest_links(const ohm_mg_operator *op, int64_t n, float *rowmax)
{
    row_walk r = walk_from(op, 0);
    for (int64_t v = 0; v < n; ++v) {
        row_links l = links_of(&r, v);
        float m = 0;
        for (int64_t k = 0; k < l.count; ++k) m = fmaxf(m, l.g[k]);
        rowmax[v] = m;
    }
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

static int push_cell(ohm_mg_coarse *out, int64_t *cap, int64_t cell)
{
    if (out->nc == *cap) {
        int64_t grown = *cap ? 2 * *cap : 1024;
        int64_t *p = realloc(out->cell, (size_t)grown * sizeof *p);
        if (!p) return -1;
        out->cell = p, *cap = grown;
    }
    out->cell[out->nc++] = cell;
    return 0;
}

/* Slab K's unknowns v0 .. v0 + m - 1 (their plane places in s->q) joined:
 * by strong links within a block (and link-less ones per block), or all
 * of a block's (whole). */
static void join_slab(const ohm_mg_operator *op, const float *rowmax, double theta, int whole, int64_t v0, int64_t m,
                      int64_t cplane, scratch *s)
{
    int64_t *first = s->head; /* a block's first link-less (or, whole, any) unknown */
    for (int64_t i = 0; i < m; ++i) {
        s->parent[i] = i;
        first[s->q[i]] = -1;
        s->cut[s->q[i]] = 0;
    }
    (void)cplane;
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

/* The slab's parts numbered by place, then by first unknown: agg of its
 * unknowns, the coarse unknowns' cells; alike parts of a block joined
 * first (not when whole: one part a block already). */
static int number_slab(int64_t K, int64_t v0, int64_t m, int64_t cplane, const float *rowmax, double theta, int whole,
                       scratch *s, ohm_mg_coarse *out, int64_t *cell_cap)
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
            s->rootid[root] = out->nc;
            if (push_cell(out, cell_cap, s->q[i] + cplane * K)) return -1;
        }
        out->agg[v0 + i] = (int32_t)s->rootid[root];
    }
    return 0;
}

/* The level's unknowns into coarse unknowns: out's agg, slabs, cells, nc. */
static int group_level(const ohm_mg_operator *op, int64_t n, const ohm_mg_places *pl, const float *rowmax,
                       double theta, int whole, scratch *s, ohm_mg_coarse *out)
{
    const int64_t *dims = pl->dims, *cdims = out->cdims;
    int64_t plane = dims[0] * dims[1], cplane = cdims[0] * cdims[1], cell_cap = 0;
    out->nc = 0;
    place_walk p = {.pl = pl};
    if (pl->cells) p.cursor = ohm_cell_index_cursor(pl->cells, 0);
    int64_t v = 0, c = n ? next_place(&p, 0) : 0; /* c: v's cell */
    for (int64_t K = 0; K < out->nslabs; ++K) {
        int64_t v0 = v;
        out->fine_at[K] = v0;
        out->coarse_at[K] = out->nc;
        for (; v < n && c / plane / 2 == K; ++v) {
            if (slab_room(s, v - v0 + 1)) return -1;
            int64_t i = c % dims[0], j = c / dims[0] % dims[1];
            s->q[v - v0] = i / 2 + cdims[0] * (j / 2);
            if (v + 1 < n) c = next_place(&p, v + 1);
        }
        join_slab(op, rowmax, theta, whole, v0, v - v0, cplane, s);
        if (number_slab(K, v0, v - v0, cplane, rowmax, theta, whole, s, out, &cell_cap)) return -1;
    }
    out->fine_at[out->nslabs] = v;
    out->coarse_at[out->nslabs] = out->nc;
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
    int64_t *count;   /* a slab's rows + 1                     */
    int64_t ccap;
    triplet *sorted;  /* t by row                               */
    int64_t *mark;    /* nc: the row that last met this column  */
    int64_t *slot;    /* nc: its entry in that row              */
    double *acc;      /* the entries' sums, in double           */
    int64_t cap;      /* room of sp->col, sp->g, acc            */
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
static int slab_links(const ohm_mg_operator *op, const ohm_mg_coarse *c, int64_t K, sums *u)
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

static int entry_room(sums *u, ohm_mg_sparse *sp, int64_t need)
{
    if (need <= u->cap) return 0;
    int64_t cap = need > 2 * u->cap ? need : 2 * u->cap;
    int32_t *col = realloc(sp->col, (size_t)cap * sizeof *col);
    if (col) sp->col = col;
    double *acc = realloc(u->acc, (size_t)cap * sizeof *acc);
    if (acc) u->acc = acc;
    if (!col || !acc) return -1;
    u->cap = cap;
    return 0;
}

/* The slab's rows from its triplets: each column's links summed. */
static int slab_rows(const ohm_mg_coarse *c, int64_t K, sums *u, ohm_mg_sparse *sp)
{
    int64_t r0 = c->coarse_at[K], rows = c->coarse_at[K + 1] - r0;
    if (rows + 1 > u->ccap) {
        int64_t *p = realloc(u->count, (size_t)(rows + 1) * sizeof *p);
        if (!p) return -1;
        u->count = p, u->ccap = rows + 1;
    }
    triplet *sorted = realloc(u->sorted, (size_t)(u->nt ? u->nt : 1) * sizeof *sorted);
    if (!sorted) return -1;
    u->sorted = sorted;
    memset(u->count, 0, (size_t)(rows + 1) * sizeof *u->count);
    for (int64_t t = 0; t < u->nt; ++t) u->count[u->t[t].row + 1]++;
    for (int64_t i = 0; i < rows; ++i) u->count[i + 1] += u->count[i];
    for (int64_t t = 0; t < u->nt; ++t) sorted[u->count[u->t[t].row]++] = u->t[t];
    int64_t nnz = sp->rp[r0], t = 0;
    if (entry_room(u, sp, nnz + u->nt)) return -1;
    for (int64_t i = 0; i < rows; ++i) {
        int64_t I = r0 + i;
        for (; t < u->nt && sorted[t].row == i; ++t) {
            int64_t J = sorted[t].col;
            if (u->mark[J] != I) {
                u->mark[J] = I;
                u->slot[J] = nnz;
                sp->col[nnz] = (int32_t)J;
                u->acc[nnz++] = 0;
            }
            u->acc[u->slot[J]] += sorted[t].g;
        }
        sp->rp[I + 1] = nnz;
    }
    return 0;
}

/* Each link one float in both of its rows: row I's sum for I < J (the
 * two rows sum the same fine links in different orders). */
static void symmetric_links(ohm_mg_sparse *sp)
{
    for (int64_t I = 0; I < sp->n; ++I)
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

static int galerkin(const ohm_mg_operator *op, ohm_mg_coarse *c)
{
    ohm_mg_sparse *sp = &c->sp;
    int64_t nc = c->nc;
    size_t m = (size_t)(nc ? nc : 1);
    sp->n = nc;
    sp->rp = calloc(m + 1, sizeof *sp->rp);
    sp->sink = calloc(m, sizeof *sp->sink);
    sums u = {.mark = malloc(m * sizeof *u.mark), .slot = malloc(m * sizeof *u.slot)};
    int rc = !sp->rp || !sp->sink || !u.mark || !u.slot || entry_room(&u, sp, 8 * nc + 1);
    for (int64_t I = 0; !rc && I < nc; ++I) u.mark[I] = -1;
    for (int64_t K = 0; !rc && K < c->nslabs; ++K) rc = slab_links(op, c, K, &u) || slab_rows(c, K, &u, sp);
    if (!rc) {
        int64_t nnz = sp->rp[nc];
        sp->g = malloc((size_t)(nnz ? nnz : 1) * sizeof *sp->g);
        rc = !sp->g;
        for (int64_t k = 0; !rc && k < nnz; ++k) sp->g[k] = (float)u.acc[k];
        if (!rc) symmetric_links(sp);
    }
    free(u.t);
    free(u.count);
    free(u.sorted);
    free(u.mark);
    free(u.slot);
    free(u.acc);
    return rc ? -1 : 0;
}

/* ---- one step ------------------------------------------------------------------------- */

int ohm_mg_coarsen(const ohm_mg_operator *op, int64_t n, const ohm_mg_places *places, double theta,
                   ohm_mg_coarse *out, ohm_error *err)
{
    memset(out, 0, sizeof *out);
    for (int a = 0; a < 3; ++a) out->cdims[a] = (places->dims[a] + 1) / 2;
    out->nslabs = out->cdims[2];
    int64_t cplane = out->cdims[0] * out->cdims[1];
    size_t m = (size_t)(n ? n : 1);
    float *rowmax = malloc(m * sizeof *rowmax);
    scratch s = {.head = malloc((size_t)(cplane + 1) * sizeof *s.head), .cut = calloc((size_t)cplane + 1, 1)};
    out->agg = malloc(m * sizeof *out->agg);
    out->fine_at = malloc((size_t)(out->nslabs + 1) * sizeof *out->fine_at);
    out->coarse_at = malloc((size_t)(out->nslabs + 1) * sizeof *out->coarse_at);
    int rc = !rowmax || !s.head || !s.cut || !out->agg || !out->fine_at || !out->coarse_at;
    if (!rc) {
        largest_links(op, n, rowmax);
        rc = group_level(op, n, places, rowmax, theta, 0, &s, out);
        if (!rc && (double)out->nc > OHM_MG_KEEP_MAX * (double)n) {
            out->whole_blocks = 1;
            rc = group_level(op, n, places, rowmax, theta, 1, &s, out);
        }
    }
    free(rowmax);
    free(s.q), free(s.parent), free(s.order), free(s.rootid), free(s.big), free(s.head), free(s.cut);
    if (!rc && out->nc > INT32_MAX) {
        ohm_mg_coarse_free(out);
        return ohm_fail(err, OHM_ERR_USAGE, "mg: %lld coarse cells are more than 2^31", (long long)n);
    }
    if (!rc) rc = galerkin(op, out);
    if (rc) {
        ohm_mg_coarse_free(out);
        return ohm_fail(err, OHM_ERR_NOMEM, "mg: out of memory coarsening %lld cells", (long long)n);
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
