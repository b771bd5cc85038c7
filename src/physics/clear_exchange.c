/* clear_exchange.c — the radiosity–diffusion coupling across clear regions
 * (clear_exchange.h; its physics: docs/transport.md, "Transport across clear
 * regions: radiosity–diffusion"). */
#include "physics/clear_exchange.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "base/log.h"
#include "physics/fresnel.h"
#include "physics/stencil.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

void ohm_clear_exchange_free(ohm_clear_exchange *ce)
{
    if (!ce) return;
    free(ce->node_unknown);
    free(ce->wall_diffusive);
    free(ce->wall_node);
    free(ce->escape_face);
    free(ce->pair_u);
    free(ce->pair_v);
    free(ce->pair_w);
    free(ce->pair_r);
    free(ce->self_w);
    free(ce->self_r);
    free(ce->fill_unknown);
    free(ce->fill_from);
    memset(ce, 0, sizeof *ce);
}

/* A face of the clear region's wall, in the grid's index coordinates (cell
 * (i,j,k) spans i +- 1/2): its centre, its normal into the clear region
 * (axis and sign), and its node. */
typedef struct wall_face {
    double x[3];
    int axis, sign;
    int32_t node;
} wall_face;

/* What the visibility rays read: a byte per grid cell (1: a clear unknown),
 * and the mirror planes that fold an unfolded ray back into the grid. */
typedef struct clear_geometry {
    const ohm_voxel_grid *grid;
    uint8_t *clear_cell;
    int32_t low[3], high[3]; /* mirror planes (network.h), -1: none */
    int nimages;             /* mirror images of the domain, the domain itself first */
    int image_axes[8];       /* bit a: reflected across axis a's plane */
    double plane[3];         /* axis a's plane, in index coordinates */
} clear_geometry;

static int fold(const clear_geometry *g, int32_t c[3])
{
    for (int a = 0; a < 3; ++a) {
        if (g->low[a] >= 0 && c[a] < g->low[a]) c[a] = 2 * g->low[a] - 1 - c[a];
        if (g->high[a] >= 0 && c[a] > g->high[a]) c[a] = 2 * g->high[a] + 1 - c[a];
        if (c[a] < 0 || c[a] >= g->grid->dims[a]) return 0;
    }
    return 1;
}

static int cell_is_clear(const clear_geometry *g, const int32_t c_in[3])
{
    int32_t c[3] = {c_in[0], c_in[1], c_in[2]};
    if (!fold(g, c)) return 0;
    return g->clear_cell[ohm_voxel_index(g->grid, c[0], c[1], c[2])];
}

/* Whether the segment P -> Q (unfolded index coordinates, each end just
 * inside its face's clear cell) runs through clear cells only: a 3-D DDA
 * (Amanatides & Woo, Eurographics 1987) over the cells it crosses. */
static int visible(const clear_geometry *g, const double P[3], const double Q[3])
{
    int32_t c[3], e[3];
    int step[3];
    double tmax[3], tdelta[3];
    int64_t left = 3;
    for (int a = 0; a < 3; ++a) {
        c[a] = (int32_t)floor(P[a] + 0.5);
        e[a] = (int32_t)floor(Q[a] + 0.5);
        left += labs((long)(e[a] - c[a]));
        double d = Q[a] - P[a];
        step[a] = d > 0 ? 1 : d < 0 ? -1 : 0;
        tdelta[a] = step[a] ? 1.0 / fabs(d) : INFINITY;
        tmax[a] = step[a] ? ((c[a] + 0.5 * step[a]) - P[a]) / d : INFINITY;
    }
    while (left-- > 0) {
        if (c[0] == e[0] && c[1] == e[1] && c[2] == e[2]) return 1;
        int a = tmax[0] < tmax[1] ? (tmax[0] < tmax[2] ? 0 : 2) : (tmax[1] < tmax[2] ? 1 : 2);
        c[a] += step[a];
        tmax[a] += tdelta[a];
        if (!cell_is_clear(g, c)) return 0;
    }
    return c[0] == e[0] && c[1] == e[1] && c[2] == e[2];
}

/* Face q reflected by image k: its centre and normal. */
static void image_of(const clear_geometry *g, int k, const wall_face *q, double x[3], double n[3])
{
    for (int a = 0; a < 3; ++a) {
        x[a] = q->x[a];
        n[a] = a == q->axis ? q->sign : 0;
        if (g->image_axes[k] & (1 << a)) {
            x[a] = 2.0 * g->plane[a] - x[a];
            n[a] = -n[a];
        }
    }
}

/* Below this centre distance (cells) the differential view factor is far
 * from the face-to-face one (adjacent faces at a concave edge: 1/pi for
 * the exact 0.200): both faces are cut into SUB x SUB parts. */
enum { SUB = 4 };
static const double NEAR_CELLS = 3.0;

/* a_p F_pq (in cell areas) between face p and the image (x, n) of a face,
 * differential cos_p cos_q / (pi r^2) a_q, subdivided when near. */
static double face_exchange(const wall_face *p, const double xq[3], const double nq[3], double r)
{
    double np[3] = {0, 0, 0};
    np[p->axis] = p->sign;
    if (r >= NEAR_CELLS) {
        double d[3] = {xq[0] - p->x[0], xq[1] - p->x[1], xq[2] - p->x[2]};
        double cp = (np[0] * d[0] + np[1] * d[1] + np[2] * d[2]) / r;
        double cq = -(nq[0] * d[0] + nq[1] * d[1] + nq[2] * d[2]) / r;
        return cp > 0 && cq > 0 ? cp * cq / (M_PI * r * r) : 0.0;
    }
    int qa = nq[0] != 0 ? 0 : nq[1] != 0 ? 1 : 2;
    int pt[2] = {(p->axis + 1) % 3, (p->axis + 2) % 3}, qt[2] = {(qa + 1) % 3, (qa + 2) % 3};
    double sum = 0;
    for (int i = 0; i < SUB * SUB; ++i) {
        double a[3] = {p->x[0], p->x[1], p->x[2]};
        a[pt[0]] += ((i % SUB) + 0.5) / SUB - 0.5;
        a[pt[1]] += ((i / SUB) + 0.5) / SUB - 0.5;
        for (int j = 0; j < SUB * SUB; ++j) {
            double b[3] = {xq[0], xq[1], xq[2]};
            b[qt[0]] += ((j % SUB) + 0.5) / SUB - 0.5;
            b[qt[1]] += ((j / SUB) + 0.5) / SUB - 0.5;
            double d[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
            double r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            double cp = np[0] * d[0] + np[1] * d[1] + np[2] * d[2];
            double cq = -(nq[0] * d[0] + nq[1] * d[1] + nq[2] * d[2]);
            if (cp > 0 && cq > 0 && r2 > 0) sum += cp * cq / (M_PI * r2 * r2);
        }
    }
    return sum / (double)(SUB * SUB * SUB * SUB);
}

/* Growable arrays (elements of size bytes). */
static int grow(void **p, int64_t *cap, int64_t need, size_t size)
{
    if (need <= *cap) return 0;
    int64_t c = *cap ? *cap : 256;
    while (c < need) c *= 2;
    void *q = realloc(*p, (size_t)c * size);
    if (!q) return -1;
    *p = q;
    *cap = c;
    return 0;
}

/* Step 1: the wall faces (a clear unknown's faces to a diffusive unknown or
 * to outside the object; mirror faces are neither), the nodes, the walls
 * and the escapes. */
static int find_faces(ohm_clear_exchange *ce, const clear_geometry *g, int32_t *node_of, wall_face **faces_out,
                      int64_t **face_first_out)
{
    const ohm_network *net = ce->net;
    const ohm_voxel_grid *grid = net->grid;
    int64_t cap_f = 0, cap_n = 0, cap_w = 0, cap_w2 = 0, cap_e = 0, nf = 0;
    wall_face *faces = NULL;
    int64_t *first = NULL; /* per node: its first face; nnodes + 1 */
    int64_t cap_first = 0;
    static const int32_t off[6][3] = {{-1, 0, 0}, {1, 0, 0}, {0, -1, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1}};
    ohm_cell_cursor cur = ohm_network_cells(net, 0);
    for (int64_t v = 0; v < net->n; ++v) {
        int64_t cell = ohm_cell_cursor_next(&cur);
        node_of[v] = -1;
        if (!ce->clear[v]) continue;
        int32_t ijk[3];
        ohm_voxel_coords(grid, cell, ijk);
        int64_t nf0 = nf;
        for (int d = 0; d < 6; ++d) {
            int a = d >> 1;
            int32_t x = ijk[a];
            if ((d & 1) ? x == g->high[a] : x == g->low[a]) continue; /* a mirror face */
            int32_t nb[3] = {ijk[0] + off[d][0], ijk[1] + off[d][1], ijk[2] + off[d][2]};
            int outside = nb[a] < 0 || nb[a] >= grid->dims[a];
            int64_t u = -1;
            if (!outside) {
                u = ohm_network_unknown(net, ohm_voxel_index(grid, nb[0], nb[1], nb[2]));
                outside = u < 0;
            }
            if (!outside && ce->clear[u]) continue;
            if (grow((void **)&faces, &cap_f, nf + 1, sizeof *faces)) return -1;
            wall_face *w = &faces[nf++];
            for (int q = 0; q < 3; ++q) w->x[q] = ijk[q] + 0.5 * off[d][q];
            w->axis = a;
            w->sign = (d & 1) ? -1 : 1; /* into the clear cell: away from the wall */
            w->node = (int32_t)ce->nnodes;
            if (outside) {
                int64_t f = ohm_network_face(net, v, d);
                if (f < 0) return -2; /* not a boundary face: a band's closure */
                if (grow((void **)&ce->escape_face, &cap_e, ce->nescape + 1, sizeof(int64_t))) return -1;
                ce->escape_face[ce->nescape++] = f;
            } else {
                if (grow((void **)&ce->wall_diffusive, &cap_w, ce->nwall + 1, sizeof(int64_t)) ||
                    grow((void **)&ce->wall_node, &cap_w2, ce->nwall + 1, sizeof(int64_t)))
                    return -1;
                ce->wall_diffusive[ce->nwall] = u;
                ce->wall_node[ce->nwall++] = v;
            }
        }
        if (nf > nf0) {
            if (grow((void **)&ce->node_unknown, &cap_n, ce->nnodes + 1, sizeof(int64_t))) return -1;
            if (grow((void **)&first, &cap_first, ce->nnodes + 2, sizeof(int64_t))) return -1;
            first[ce->nnodes] = nf0;
            node_of[v] = (int32_t)ce->nnodes;
            ce->node_unknown[ce->nnodes++] = v;
        }
    }
    if (grow((void **)&first, &cap_first, ce->nnodes + 1, sizeof(int64_t))) return -1;
    first[ce->nnodes] = nf;
    ce->faces = nf;
    *faces_out = faces;
    *face_first_out = first;
    return 0;
}

/* Faces sorted into cubic buckets of the distance cut's size, so that a
 * face meets only the faces within reach: the set-up grows with the
 * region's surface times the faces within reach of each, not with the
 * surface squared.  Without a cut: one bucket. */
typedef struct buckets {
    double size;        /* cells */
    double lo[3];       /* the faces' low corner */
    int32_t dims[3];
    int64_t *start;     /* dims product + 1 */
    int64_t *face;      /* faces, bucket by bucket */
} buckets;

static int64_t bucket_coord(const buckets *b, const double x[3], int a)
{
    int64_t c = (int64_t)floor((x[a] - b->lo[a]) / b->size);
    return c < 0 ? 0 : c >= b->dims[a] ? b->dims[a] - 1 : c;
}

static int buckets_make(buckets *b, const wall_face *faces, int64_t nf, double size)
{
    double hi[3];
    for (int a = 0; a < 3; ++a) b->lo[a] = INFINITY, hi[a] = -INFINITY;
    for (int64_t f = 0; f < nf; ++f)
        for (int a = 0; a < 3; ++a) b->lo[a] = fmin(b->lo[a], faces[f].x[a]), hi[a] = fmax(hi[a], faces[f].x[a]);
    double widest = 0;
    for (int a = 0; a < 3; ++a) widest = fmax(widest, hi[a] - b->lo[a]);
    b->size = size > 0 ? size : widest + 1.0;
    int64_t total = 1;
    for (int a = 0; a < 3; ++a) {
        b->dims[a] = (int32_t)((hi[a] - b->lo[a]) / b->size) + 1;
        total *= b->dims[a];
    }
    b->start = calloc((size_t)total + 1, sizeof *b->start);
    b->face = malloc((size_t)(nf ? nf : 1) * sizeof *b->face);
    if (!b->start || !b->face) return -1;
    int64_t *id = malloc((size_t)(nf ? nf : 1) * sizeof *id);
    if (!id) return -1;
    for (int64_t f = 0; f < nf; ++f) {
        id[f] = (bucket_coord(b, faces[f].x, 2) * b->dims[1] + bucket_coord(b, faces[f].x, 1)) * b->dims[0] +
                bucket_coord(b, faces[f].x, 0);
        b->start[id[f] + 1]++;
    }
    for (int64_t k = 0; k < total; ++k) b->start[k + 1] += b->start[k];
    int64_t *fill = malloc((size_t)total * sizeof *fill);
    if (!fill) {
        free(id);
        return -1;
    }
    memcpy(fill, b->start, (size_t)total * sizeof *fill);
    for (int64_t f = 0; f < nf; ++f) b->face[fill[id[f]]++] = f; /* in face order within a bucket */
    free(fill);
    free(id);
    return 0;
}

static void buckets_free(buckets *b)
{
    free(b->start);
    free(b->face);
}

/* What one node's faces gather: a dense row over the nodes, and the nodes
 * it touched. */
typedef struct gather {
    double *w, *r;
    int64_t *touched, ntouched;
} gather;

/* Face p against image k of face q (p's node u <= q's node): a ray for
 * visibility when they face each other within reach, and their a_p F_pq
 * into u's row (or u's own sum). */
static void pair_term(ohm_clear_exchange *ce, const clear_geometry *g, const wall_face *fp, const double P[3],
                      const wall_face *fq, int k, double max_cells, gather *row, int64_t u)
{
    const double eps = 1e-6;
    double xq[3], nq[3];
    image_of(g, k, fq, xq, nq);
    double d[3] = {xq[0] - fp->x[0], xq[1] - fp->x[1], xq[2] - fp->x[2]};
    double r = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if (max_cells > 0 && r > max_cells) return;
    /* facing each other (their centres), before any ray */
    double cp = d[fp->axis] * fp->sign;
    double cq = -(nq[0] * d[0] + nq[1] * d[1] + nq[2] * d[2]);
    if (!(cp > 0 && cq > 0)) return;
    double Q[3] = {xq[0] + eps * nq[0], xq[1] + eps * nq[1], xq[2] + eps * nq[2]};
    ce->rays++;
    if (!visible(g, P, Q)) return;
    double w = face_exchange(fp, xq, nq, r);
    int64_t v = fq->node;
    if (v == u) {
        ce->self_w[u] += w;
        ce->self_r[u] += w * r;
        return;
    }
    if (row->w[v] == 0) row->touched[row->ntouched++] = v;
    row->w[v] += w;
    row->r[v] += w * r;
}

/* Step 2: every pair of faces that see each other (directly or by their
 * mirror images) through clear cells, summed per pair of nodes: node u's
 * faces against those of every node v >= u, into a dense scratch row.  An
 * image of q near p is q near the same image of p (reflections are
 * isometries and their own inverses): the buckets are searched around p's
 * images. */
enum { CANCELLED = -3 }; /* exchange_pairs: the log's cancel flag was set */

static int exchange_pairs(ohm_clear_exchange *ce, const clear_geometry *g, const wall_face *faces,
                          const int64_t *first, double max_cells, const ohm_log *log)
{
    ohm_progress progress;
    ohm_progress_begin(&progress, log, "clear regions' coupling");
    int64_t nn = ce->nnodes, cap = 0;
    gather row = {calloc((size_t)(nn ? nn : 1), sizeof(double)), calloc((size_t)(nn ? nn : 1), sizeof(double)),
                  malloc((size_t)(nn ? nn : 1) * sizeof(int64_t)), 0};
    ce->self_w = calloc((size_t)(nn ? nn : 1), sizeof *ce->self_w);
    ce->self_r = calloc((size_t)(nn ? nn : 1), sizeof *ce->self_r);
    buckets b = {0};
    if (!row.w || !row.r || !row.touched || !ce->self_w || !ce->self_r ||
        buckets_make(&b, faces, first[nn], max_cells))
        goto nomem;
    for (int64_t u = 0; u < nn; ++u) {
        if (u % 256 == 0 && ohm_progress_update(&progress, (double)u / (double)nn)) {
            free(row.w), free(row.r), free(row.touched);
            buckets_free(&b);
            return CANCELLED;
        }
        row.ntouched = 0;
        for (int64_t p = first[u]; p < first[u + 1]; ++p) {
            const wall_face *fp = &faces[p];
            double P[3] = {fp->x[0], fp->x[1], fp->x[2]};
            P[fp->axis] += 1e-6 * fp->sign;
            for (int k = 0; k < g->nimages; ++k) {
                wall_face ip = *fp; /* p's image k: where q's image k must lie */
                double n_unused[3];
                image_of(g, k, fp, ip.x, n_unused);
                int64_t lo[3], hi[3];
                for (int a = 0; a < 3; ++a) {
                    double reach = max_cells > 0 ? max_cells : INFINITY;
                    double xl[3] = {ip.x[0], ip.x[1], ip.x[2]}, xh[3] = {ip.x[0], ip.x[1], ip.x[2]};
                    xl[a] -= reach;
                    xh[a] += reach;
                    lo[a] = isfinite(reach) ? bucket_coord(&b, xl, a) : 0;
                    hi[a] = isfinite(reach) ? bucket_coord(&b, xh, a) : b.dims[a] - 1;
                }
                for (int64_t bz = lo[2]; bz <= hi[2]; ++bz)
                    for (int64_t by = lo[1]; by <= hi[1]; ++by)
                        for (int64_t bx = lo[0]; bx <= hi[0]; ++bx) {
                            int64_t id = (bz * b.dims[1] + by) * b.dims[0] + bx;
                            for (int64_t s = b.start[id]; s < b.start[id + 1]; ++s) {
                                int64_t q = b.face[s];
                                if (q < first[u] || (q == p && k == 0)) continue;
                                pair_term(ce, g, fp, P, &faces[q], k, max_cells, &row, u);
                            }
                        }
            }
        }
        for (int64_t t = 0; t < row.ntouched; ++t) {
            int64_t v = row.touched[t];
            if (grow((void **)&ce->pair_u, &cap, ce->npairs + 1, sizeof *ce->pair_u)) goto nomem;
            int32_t *pv = realloc(ce->pair_v, (size_t)cap * sizeof *pv);
            double *pw = pv ? realloc(ce->pair_w, (size_t)cap * sizeof *pw) : NULL;
            if (pv) ce->pair_v = pv;
            if (pw) ce->pair_w = pw;
            float *pr = pw ? realloc(ce->pair_r, (size_t)cap * sizeof *pr) : NULL;
            if (!pr) goto nomem;
            ce->pair_r = pr;
            ce->pair_u[ce->npairs] = (int32_t)u; /* node numbers; unknowns after the renormalisation */
            ce->pair_v[ce->npairs] = (int32_t)v;
            ce->pair_w[ce->npairs] = row.w[v];
            ce->pair_r[ce->npairs] = (float)(row.r[v] / row.w[v]);
            ce->npairs++;
            row.w[v] = row.r[v] = 0;
        }
        if (ce->self_w[u] > 0) ce->self_r[u] /= ce->self_w[u];
    }
    free(row.w), free(row.r), free(row.touched);
    buckets_free(&b);
    ohm_progress_end(&progress);
    return 0;
nomem:
    free(row.w), free(row.r), free(row.touched);
    buckets_free(&b);
    return -1;
}

/* Step 3: the symmetric renormalisation (Sinkhorn-Knopp on a symmetric
 * matrix): factors d with sum_q d_p W_pq d_q = (faces of p) for every node,
 * so every face's view factors sum to 1 as in the continuum: what the voxel
 * staircase and the distance cut lose is given to the pairs kept, none of it
 * to absorption, and reciprocity (W symmetric) is kept. */
static int renormalise(ohm_clear_exchange *ce, const int64_t *first)
{
    int64_t nn = ce->nnodes;
    double *d = malloc((size_t)(nn ? nn : 1) * sizeof *d), *y = malloc((size_t)(nn ? nn : 1) * sizeof *y);
    if (!d || !y) {
        free(d), free(y);
        return -1;
    }
    for (int64_t u = 0; u < nn; ++u) d[u] = 1.0;
    for (int it = 0; it < 500; ++it) {
        for (int64_t u = 0; u < nn; ++u) y[u] = ce->self_w[u] * d[u];
        for (int64_t k = 0; k < ce->npairs; ++k) {
            y[ce->pair_u[k]] += ce->pair_w[k] * d[ce->pair_v[k]];
            y[ce->pair_v[k]] += ce->pair_w[k] * d[ce->pair_u[k]];
        }
        double worst = 0;
        for (int64_t u = 0; u < nn; ++u) {
            double rs = d[u] * y[u], target = (double)(first[u + 1] - first[u]);
            if (!(rs > 0)) continue; /* a node that sees nothing: walls only */
            worst = fmax(worst, fabs(rs / target - 1.0));
            d[u] *= sqrt(target / rs);
        }
        if (worst < 1e-12) break;
    }
    ce->renorm_min = INFINITY;
    ce->renorm_max = 0;
    for (int64_t u = 0; u < nn; ++u) {
        ce->self_w[u] *= d[u] * d[u];
        if (ce->self_w[u] > 0 || first[u + 1] > first[u]) {
            ce->renorm_min = fmin(ce->renorm_min, d[u] * d[u]);
            ce->renorm_max = fmax(ce->renorm_max, d[u] * d[u]);
        }
    }
    for (int64_t k = 0; k < ce->npairs; ++k) ce->pair_w[k] *= d[ce->pair_u[k]] * d[ce->pair_v[k]];
    free(d), free(y);
    return 0;
}

/* Step 4: each clear unknown that is no node, and its nearest node through
 * clear cells (a breadth-first search from every node at once). */
static int nearest_nodes(ohm_clear_exchange *ce, const clear_geometry *g, const int32_t *node_of)
{
    const ohm_network *net = ce->net;
    const ohm_voxel_grid *grid = net->grid;
    int64_t n = net->n, nf = ce->nclear - ce->nnodes;
    ce->nfill = 0;
    if (nf <= 0) return 0;
    int64_t *from = malloc((size_t)n * sizeof *from), *queue = malloc((size_t)ce->nclear * sizeof *queue);
    ce->fill_unknown = malloc((size_t)nf * sizeof *ce->fill_unknown);
    ce->fill_from = malloc((size_t)nf * sizeof *ce->fill_from);
    if (!from || !queue || !ce->fill_unknown || !ce->fill_from) {
        free(from), free(queue);
        return -1;
    }
    int64_t head = 0, tail = 0;
    for (int64_t v = 0; v < n; ++v) {
        from[v] = node_of[v] >= 0 ? v : -1;
        if (node_of[v] >= 0) queue[tail++] = v;
    }
    while (head < tail) {
        int64_t v = queue[head++];
        int32_t ijk[3];
        ohm_voxel_coords(grid, ohm_network_cell(net, v), ijk);
        for (int d = 0; d < 6; ++d) {
            int32_t nb[3] = {ijk[0], ijk[1], ijk[2]};
            nb[d >> 1] += (d & 1) ? 1 : -1;
            if (nb[d >> 1] < 0 || nb[d >> 1] >= grid->dims[d >> 1]) continue;
            size_t c = ohm_voxel_index(grid, nb[0], nb[1], nb[2]);
            if (!g->clear_cell[c]) continue;
            int64_t u = ohm_network_unknown(net, c);
            if (u < 0 || from[u] >= 0) continue;
            from[u] = from[v];
            queue[tail++] = u;
        }
    }
    for (int64_t v = 0; v < n; ++v)
        if (ce->clear[v] && node_of[v] < 0) {
            ce->fill_unknown[ce->nfill] = v;
            ce->fill_from[ce->nfill++] = from[v]; /* every clear piece has a wall face: never -1 */
        }
    free(from), free(queue);
    return 0;
}

int ohm_clear_exchange_build(ohm_clear_exchange *ce, const ohm_network *net, const uint8_t *clear,
                             const ohm_clear_exchange_params *params, ohm_error *err)
{
    memset(ce, 0, sizeof *ce);
    ce->net = net;
    ce->clear = clear;
    double t0 = ohm_now();
    for (int64_t v = 0; v < net->n; ++v) ce->nclear += clear[v] != 0;
    if (!ce->nclear) return OHM_OK;
    if (net->n > INT32_MAX)
        return ohm_fail(err, OHM_ERR_USAGE, "clear regions: %lld unknowns are more than the coupling's 32-bit "
                        "unknowns hold", (long long)net->n);
    if (net->active)
        return ohm_fail(err, OHM_ERR_USAGE, "clear regions: the coupling needs every interior cell (no depth band: "
                                            "band_k=0)");
    clear_geometry g;
    memset(&g, 0, sizeof g);
    g.grid = net->grid;
    int nax = 0, axes[3];
    for (int a = 0; a < 3; ++a) {
        g.low[a] = net->mirror.low[a];
        g.high[a] = net->mirror.high[a];
        if (g.low[a] >= 0 && g.high[a] >= 0)
            return ohm_fail(err, OHM_ERR_USAGE, "clear regions: mirror planes on both sides of an axis are not "
                                                "supported by the coupling");
        if (g.low[a] >= 0) g.plane[a] = g.low[a] - 0.5;
        if (g.high[a] >= 0) g.plane[a] = g.high[a] + 0.5;
        if (g.low[a] >= 0 || g.high[a] >= 0) axes[nax++] = a;
    }
    g.nimages = 1 << nax;
    for (int k = 0; k < g.nimages; ++k) {
        g.image_axes[k] = 0;
        for (int b = 0; b < nax; ++b)
            if (k & (1 << b)) g.image_axes[k] |= 1 << axes[b];
    }
    const ohm_voxel_grid *grid = net->grid;
    size_t ncells = (size_t)grid->dims[0] * grid->dims[1] * grid->dims[2];
    g.clear_cell = calloc(ncells, 1);
    int32_t *node_of = malloc((size_t)net->n * sizeof *node_of);
    wall_face *faces = NULL;
    int64_t *first = NULL;
    int rc = g.clear_cell && node_of ? 0 : -1;
    if (!rc) {
        ohm_cell_cursor cur = ohm_network_cells(net, 0);
        for (int64_t v = 0; v < net->n; ++v) {
            int64_t c = ohm_cell_cursor_next(&cur);
            g.clear_cell[c] = clear[v] != 0;
        }
        rc = find_faces(ce, &g, node_of, &faces, &first);
    }
    double max_cells = params && params->max_distance > 0 ? params->max_distance / grid->h : 0;
    if (!rc) rc = exchange_pairs(ce, &g, faces, first, max_cells, params ? params->log : NULL);
    if (!rc) rc = renormalise(ce, first);
    if (!rc) rc = nearest_nodes(ce, &g, node_of);
    if (!rc) { /* node numbers to unknowns, the cell areas to mm^2 */
        double a = grid->h * grid->h;
        for (int64_t k = 0; k < ce->npairs; ++k) {
            ce->pair_u[k] = (int32_t)ce->node_unknown[ce->pair_u[k]];
            ce->pair_v[k] = (int32_t)ce->node_unknown[ce->pair_v[k]];
            ce->pair_w[k] *= a;
            ce->pair_r[k] *= (float)grid->h;
        }
        for (int64_t u = 0; u < ce->nnodes; ++u) {
            ce->self_w[u] *= a;
            ce->self_r[u] *= grid->h;
        }
    }
    free(g.clear_cell);
    free(node_of);
    free(faces);
    free(first);
    ce->seconds = ohm_now() - t0;
    if (rc == CANCELLED) {
        ohm_clear_exchange_free(ce);
        return ohm_fail_cancelled(err, "clear regions' coupling");
    }
    if (rc == -2) {
        ohm_clear_exchange_free(ce);
        return ohm_fail(err, OHM_ERR_INTERNAL, "clear regions: a clear cell's outer face is no boundary face");
    }
    if (rc) {
        ohm_clear_exchange_free(ce);
        return ohm_fail(err, OHM_ERR_NOMEM, "clear regions: out of memory for the coupling of %lld clear cells",
                        (long long)ce->nclear);
    }
    return OHM_OK;
}

/* ---- the coupled matrix, per medium ---- */

static double cell_eta(const ohm_channel_medium *m, int64_t v)
{
    return m->eta_v ? m->eta_v[v] : m->eta;
}

static double cell_D(const ohm_channel_medium *m, int64_t v)
{
    double sa, ss;
    ohm_medium_coefficients(m, v, &sa, &ss);
    return 1.0 / (3.0 * (sa + ss));
}

/* The boundary constant of a step of relative index m (fresnel.h), the
 * last one remembered: a region's walls have few distinct steps. */
typedef struct step_cache {
    double m, A, c1;
    int set;
} step_cache;

static void step_at(step_cache *c, double m)
{
    if (c->set && c->m == m) return;
    double c1, c2;
    ohm_fresnel_moments(m, &c1, &c2);
    c->m = m;
    c->A = ohm_boundary_A_of_moments(c1, c2);
    c->c1 = c1;
    c->set = 1;
}

/* The wall face (docs/transport.md): on the diffusive side the partial
 * currents of diffusion (P1) meet the step's Fresnel moments, which gives
 * the net flux J = (phi_f - 4 m^2 G) / (2A), G the irradiance arriving
 * from the clear side; on the clear side the radiance is two diffuse
 * half-ranges, the outgoing B = G + J and the incoming G, whose fluence
 * is phi_c = 2 (B + G).  Eliminating G: J = (phi_f - m^2 phi_c) / (2 (A - m^2)),
 * in the scaled unknowns s_v (psi_f - psi_c); in series with half a cell of
 * diffusion.  A >= m^2 always (A's denominator is the hemispherical
 * transmittance, reciprocity); equal (no resistance) without a step. */
static double wall_conductance(step_cache *sc, double h, double D, double s_v, double eta_v, double eta_c)
{
    double m = eta_v / eta_c;
    double extra = 0.0;
    if (m != 1.0) {
        step_at(sc, m);
        extra = 2.0 * (sc->A - m * m);
        if (extra < 0) extra = 0; /* round-off of the quadrature */
    }
    return s_v * h * h / (h / (2.0 * D) + extra);
}

double ohm_clear_wall_conductance(double h, double D, double s_v, double eta_v, double eta_c)
{
    step_cache sc = {0};
    return wall_conductance(&sc, h, D, s_v, eta_v, eta_c);
}

/* An escape face (a node's boundary face): light of the clear side's
 * incoming half-range G leaves through Fresnel with the hemispherical
 * transmittance 1 - 2 C_1 and the rest returns as B = 2 C_1 G; with phi_c =
 * 2 (B + G) the power out per area is (1 - 2 C_1) / (2 (1 + 2 C_1)) phi_c
 * (index-matched: phi_c / 2, robin's A = 1). */
static double escape_conductance(step_cache *sc, double h, double eta_c)
{
    double c1 = 0.0;
    if (eta_c != 1.0) {
        step_at(sc, eta_c);
        c1 = sc->c1;
    }
    return h * h * (1.0 - 2.0 * c1) / (2.0 * (1.0 + 2.0 * c1));
}

typedef struct triple {
    int64_t col, row;
    double val;
} triple;

static int triple_cmp(const void *a, const void *b)
{
    const triple *x = a, *y = b;
    if (x->col != y->col) return x->col < y->col ? -1 : 1;
    return (x->row > y->row) - (x->row < y->row);
}

/* The coupling's values for one medium, what both forms of the coupled
 * operator (the assembled matrix, the stencil) are written from: each wall
 * face's conductance, each node pair's, and ga, gb rewritten where the
 * coupling changes them (a node's ground: absorption on the way; an escape
 * face's conductance; a cell that is no node: none). */
typedef struct coupling_values {
    double *wall_g; /* nwall */
    double *pair_g; /* npairs */
} coupling_values;

static void coupling_values_free(coupling_values *cv)
{
    free(cv->wall_g);
    free(cv->pair_g);
}

static int coupling_values_of(coupling_values *cv, double *ga, double *gb, const ohm_clear_exchange *ce,
                              const ohm_channel_medium *med, ohm_boundary boundary, ohm_error *err)
{
    if (med->resistance_mode)
        return ohm_fail(err, OHM_ERR_USAGE, "clear regions: the coupling needs optical coefficients, not resistance=");
    const ohm_network *net = ce->net;
    const double h = net->grid->h;
    cv->wall_g = malloc((size_t)(ce->nwall ? ce->nwall : 1) * sizeof *cv->wall_g);
    cv->pair_g = malloc((size_t)(ce->npairs ? ce->npairs : 1) * sizeof *cv->pair_g);
    if (!cv->wall_g || !cv->pair_g) {
        coupling_values_free(cv);
        return ohm_fail(err, OHM_ERR_NOMEM, "clear regions: out of memory for the coupling's values");
    }
    step_cache sc = {0};
    for (int64_t w = 0; w < ce->nwall; ++w) {
        int64_t v = ce->wall_diffusive[w], c = ce->wall_node[w];
        cv->wall_g[w] = wall_conductance(&sc, h, cell_D(med, v), ohm_network_unknown_scale(med, v), cell_eta(med, v),
                                         cell_eta(med, c));
    }
    /* the nodes' own sinks: absorption on the way (a ground) and escape */
    for (int64_t u = 0; u < ce->nnodes; ++u) ga[ce->node_unknown[u]] = 0.0;
    for (int64_t k = 0; k < ce->npairs; ++k) {
        int64_t u = ce->pair_u[k], v = ce->pair_v[k];
        double sa = 0.5 * (ohm_medium_sigma_a(med, u) + ohm_medium_sigma_a(med, v));
        double tau = exp(-sa * ce->pair_r[k]);
        double su = ohm_network_unknown_scale(med, u), sv = ohm_network_unknown_scale(med, v);
        cv->pair_g[k] = 0.5 * ce->pair_w[k] * tau * 0.5 * (su + sv);
        double lost = 0.5 * ce->pair_w[k] * (1.0 - tau); /* at each end, of phi (absorbed) */
        ga[u] += lost;
        ga[v] += lost;
    }
    for (int64_t q = 0; q < ce->nnodes; ++q) {
        int64_t u = ce->node_unknown[q];
        double tau = exp(-ohm_medium_sigma_a(med, u) * ce->self_r[q]);
        ga[u] += 0.5 * ce->self_w[q] * (1.0 - tau);
    }
    for (int64_t e = 0; e < ce->nescape; ++e) {
        int64_t f = ce->escape_face[e];
        if (boundary == OHM_BOUNDARY_ROBIN) gb[f] = escape_conductance(&sc, h, cell_eta(med, net->face_unknown[f]));
    }
    for (int64_t f = 0; f < ce->nfill; ++f) ga[ce->fill_unknown[f]] = 0.0;
    return OHM_OK;
}

/* A clear cell's diagonal before its links: a node's sinks (scaled); a cell
 * that is no node has no link and no sink: the identity (its sources are
 * moved, ohm_clear_exchange_move_sources).  sink[] of the clear cells,
 * from ga and gb as coupling_values_of left them. */
static void clear_cells_sinks(const ohm_clear_exchange *ce, const ohm_channel_medium *med, const double *ga,
                              const double *gb, double *sink)
{
    const ohm_network *net = ce->net;
    for (int64_t f = 0; f < ce->nfill; ++f) sink[ce->fill_unknown[f]] = 1.0;
    for (int64_t u = 0; u < ce->nnodes; ++u) {
        int64_t v = ce->node_unknown[u];
        sink[v] = ga[v] * ohm_network_unknown_scale(med, v);
    }
    for (int64_t e = 0; e < ce->nescape; ++e) {
        int64_t f = ce->escape_face[e], v = net->face_unknown[f];
        sink[v] += gb[f] * ohm_network_unknown_scale(med, v);
    }
}

int ohm_clear_exchange_apply(cholmod_sparse **Aptr, double *ga, double *gb, const ohm_clear_exchange *ce,
                             const ohm_channel_medium *med, ohm_boundary boundary, cholmod_common *cc,
                             ohm_error *err)
{
    if (!ce->nclear) return OHM_OK;
    coupling_values cv = {0};
    int rc = coupling_values_of(&cv, ga, gb, ce, med, boundary, err);
    if (rc) return rc;
    const ohm_network *net = ce->net;
    const cholmod_sparse *A = *Aptr;
    const int64_t n = net->n;
    const int64_t *Ap = A->p, *Ai = A->i;
    const double *Ax = A->x;
    const uint8_t *clear = ce->clear;
    int64_t nnew = ce->nwall + ce->npairs;
    double *diag = calloc((size_t)n, sizeof *diag);
    triple *t = malloc((size_t)(nnew ? nnew : 1) * sizeof *t);
    int64_t *count = calloc((size_t)n + 1, sizeof *count);
    if (!diag || !t || !count) {
        free(diag), free(t), free(count), coupling_values_free(&cv);
        return ohm_fail(err, OHM_ERR_NOMEM, "clear regions: out of memory for the coupled matrix");
    }
    /* the clear cells' sinks; the diffusive cells' diagonals without their
     * links to clear cells */
    clear_cells_sinks(ce, med, ga, gb, diag);
    for (int64_t j = 0; j < n; ++j)
        for (int64_t k = Ap[j]; k < Ap[j + 1]; ++k) {
            int64_t i = Ai[k];
            if (i == j) {
                if (!clear[j]) diag[j] += Ax[k];
            } else if (clear[i] != clear[j]) {
                diag[clear[i] ? j : i] += Ax[k]; /* -G of the link dropped */
            } else if (!clear[i]) {
                count[j]++;
            }
        }
    /* the walls (a diffusive unknown and its clear neighbour) and the pairs */
    int64_t nt = 0;
    for (int64_t w = 0; w < ce->nwall; ++w) {
        int64_t v = ce->wall_diffusive[w], c = ce->wall_node[w];
        double g = cv.wall_g[w];
        diag[v] += g;
        diag[c] += g;
        t[nt++] = (triple){v > c ? v : c, v > c ? c : v, -g};
    }
    for (int64_t k = 0; k < ce->npairs; ++k) {
        int64_t u = ce->pair_u[k], v = ce->pair_v[k];
        double g = cv.pair_g[k];
        diag[u] += g;
        diag[v] += g;
        t[nt++] = (triple){v, u, -g};
    }
    coupling_values_free(&cv);
    qsort(t, (size_t)nt, sizeof *t, triple_cmp);
    for (int64_t k = 0; k < nt; ++k) count[t[k].col]++;
    int64_t nnz = 0;
    for (int64_t j = 0; j < n; ++j) nnz += count[j] + 1;
    cholmod_sparse *M = cholmod_l_allocate_sparse((size_t)n, (size_t)n, (size_t)nnz, 1, 1, 1, CHOLMOD_REAL, cc);
    if (!M) {
        free(diag), free(t), free(count);
        return ohm_fail(err, OHM_ERR_NOMEM, "clear regions: out of memory for the coupled matrix (%lld entries)",
                        (long long)nnz);
    }
    int64_t *Mp = M->p, *Mi = M->i;
    double *Mx = M->x;
    int64_t pos = 0, k2 = 0;
    for (int64_t j = 0; j < n; ++j) {
        Mp[j] = pos;
        int64_t k = Ap[j], kend = Ap[j + 1];
        /* merge the kept links (rows < j, ascending) with the new ones */
        for (;;) {
            int64_t ro = k < kend && Ai[k] < j ? Ai[k] : INT64_MAX;
            if (ro != INT64_MAX && (clear[ro] || clear[j])) {
                ++k;
                continue;
            }
            int64_t rn = k2 < nt && t[k2].col == j ? t[k2].row : INT64_MAX;
            if (ro == INT64_MAX && rn == INT64_MAX) break;
            if (ro < rn) {
                Mi[pos] = ro;
                Mx[pos++] = Ax[k++];
            } else {
                Mi[pos] = rn;
                Mx[pos++] = t[k2++].val;
            }
        }
        Mi[pos] = j;
        Mx[pos++] = diag[j];
    }
    Mp[n] = pos;
    free(diag), free(t), free(count);
    cholmod_l_free_sparse(Aptr, cc);
    *Aptr = M;
    return OHM_OK;
}

/* The stencil's slot of the link between face neighbours u < w: gx, gy or
 * gz at u (stencil_form.h: each link stored by its lower unknown); NULL
 * when they are no face neighbours. */
static float *link_slot(ohm_stencil *st, int64_t u, int64_t w)
{
    const int32_t *o = st->run_off[ohm_stencil_run_of(st, u)];
    if (o[1] && w == u + o[1]) return &st->gy[u];
    if (o[3] && w == u + o[3]) return &st->gz[u];
    return w == u + 1 ? &st->gx[u] : NULL; /* the next unknown that is neither: its +x neighbour */
}

/* The pairs as the stencil's links beyond the grid (stencil_form.h's
 * extra rows: each pair in both its rows, the same float in both). */
static int stencil_pairs(ohm_stencil *st, const ohm_clear_exchange *ce, const double *pair_g, ohm_error *err)
{
    const int64_t n = st->n;
    ohm_stencil_drop_extra(st); /* (n fits the 32-bit columns: ohm_clear_exchange_build checked) */
    st->xstart = calloc((size_t)n + 1, sizeof *st->xstart);
    st->xcol = malloc((size_t)(ce->npairs ? 2 * ce->npairs : 1) * sizeof *st->xcol);
    st->xg = malloc((size_t)(ce->npairs ? 2 * ce->npairs : 1) * sizeof *st->xg);
    int64_t *fill = calloc((size_t)n + 1, sizeof *fill);
    if (!st->xstart || !st->xcol || !st->xg || !fill) {
        free(fill);
        return ohm_fail(err, OHM_ERR_NOMEM, "clear regions: out of memory for the coupling's %lld links",
                        (long long)ce->npairs);
    }
    for (int64_t k = 0; k < ce->npairs; ++k) st->xstart[ce->pair_u[k] + 1]++, st->xstart[ce->pair_v[k] + 1]++;
    for (int64_t v = 0; v < n; ++v) st->xstart[v + 1] += st->xstart[v];
    for (int64_t k = 0; k < ce->npairs; ++k) {
        int64_t u = ce->pair_u[k], v = ce->pair_v[k];
        float g = (float)pair_g[k];
        int64_t pu = st->xstart[u] + fill[u]++, pv = st->xstart[v] + fill[v]++;
        st->xcol[pu] = (int32_t)v, st->xg[pu] = g;
        st->xcol[pv] = (int32_t)u, st->xg[pv] = g;
    }
    free(fill);
    return OHM_OK;
}

int ohm_clear_exchange_stencil(ohm_stencil *st, double *ga, double *gb, const ohm_clear_exchange *ce,
                               const ohm_channel_medium *med, ohm_boundary boundary, ohm_error *err)
{
    if (!ce->nclear) return OHM_OK;
    coupling_values cv = {0};
    int rc = coupling_values_of(&cv, ga, gb, ce, med, boundary, err);
    if (rc) return rc;
    const uint8_t *clear = ce->clear;
    /* no link touches a clear cell but the walls' (below) */
    int64_t cursor = 0;
    for (int64_t v = 0; v < st->n; ++v) {
        const int32_t *o = st->run_off[ohm_stencil_run(st, v, &cursor)];
        if (v + 1 < st->n && (clear[v] || clear[v + 1])) st->gx[v] = 0;
        if (o[1] && (clear[v] || clear[v + o[1]])) st->gy[v] = 0;
        if (o[3] && (clear[v] || clear[v + o[3]])) st->gz[v] = 0;
    }
    clear_cells_sinks(ce, med, ga, gb, st->sink);
    for (int64_t w = 0; w < ce->nwall; ++w) {
        int64_t v = ce->wall_diffusive[w], c = ce->wall_node[w];
        float *slot = link_slot(st, v < c ? v : c, v < c ? c : v);
        if (!slot) {
            coupling_values_free(&cv);
            return ohm_fail(err, OHM_ERR_INTERNAL, "clear regions: wall %lld joins unknowns %lld and %lld, which are "
                            "no face neighbours", (long long)w, (long long)v, (long long)c);
        }
        *slot = (float)cv.wall_g[w];
    }
    rc = stencil_pairs(st, ce, cv.pair_g, err);
    coupling_values_free(&cv);
    return rc;
}

void ohm_clear_exchange_move_sources(const ohm_clear_exchange *ce, double *b, size_t ncols)
{
    size_t n = (size_t)ce->net->n;
    for (size_t j = 0; j < ncols; ++j)
        for (int64_t f = 0; f < ce->nfill; ++f) {
            double *col = b + j * n;
            col[ce->fill_from[f]] += col[ce->fill_unknown[f]];
            col[ce->fill_unknown[f]] = 0.0;
        }
}

void ohm_clear_exchange_fill(const ohm_clear_exchange *ce, double *x, size_t ncols)
{
    size_t n = (size_t)ce->net->n;
    for (size_t j = 0; j < ncols; ++j)
        for (int64_t f = 0; f < ce->nfill; ++f) x[j * n + ce->fill_unknown[f]] = x[j * n + ce->fill_from[f]];
}
