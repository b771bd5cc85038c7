/* voxelize.c — mesh -> interior cells + narrow-band distance (see voxelize.h). */
#include "grid/voxelize.h"

#include "base/memory.h"
#include "base/parallel.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* ---- small vector helpers ------------------------------------------------ */

static inline void v_sub(double r[3], const double a[3], const double b[3])
{
    r[0] = a[0] - b[0];
    r[1] = a[1] - b[1];
    r[2] = a[2] - b[2];
}
static inline double v_dot(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
static inline void v_cross(double r[3], const double a[3], const double b[3])
{
    r[0] = a[1] * b[2] - a[2] * b[1];
    r[1] = a[2] * b[0] - a[0] * b[2];
    r[2] = a[0] * b[1] - a[1] * b[0];
}
static inline double v_len(const double a[3]) { return sqrt(v_dot(a, a)); }

static inline const double *tri_vertex(const ohm_mesh *m, size_t t, int c)
{
    return m->verts + 3 * (size_t)m->tris[3 * t + (size_t)c];
}

/* Signed solid angle of triangle (a,b,c) seen from q, over 4*pi: Van Oosterom &
 * Strackee (1983), "The solid angle of a plane triangle". */
static double triangle_winding(const double *A, const double *B, const double *C, const double q[3])
{
    double a[3], b[3], c[3], bc[3];
    v_sub(a, A, q);
    v_sub(b, B, q);
    v_sub(c, C, q);
    double la = v_len(a), lb = v_len(b), lc = v_len(c);
    v_cross(bc, b, c);
    double num = v_dot(a, bc);
    double den = la * lb * lc + v_dot(a, b) * lc + v_dot(b, c) * la + v_dot(c, a) * lb;
    return atan2(num, den) / (2.0 * M_PI);
}

double ohm_winding_number_exact(const ohm_mesh *mesh, const double q[3])
{
    double w = 0.0;
    for (size_t t = 0; t < mesh->ntris; ++t)
        w += triangle_winding(tri_vertex(mesh, t, 0), tri_vertex(mesh, t, 1), tri_vertex(mesh, t, 2), q);
    return w;
}

/* ---- BVH with far-field dipole moments (Barill et al. 2018, Sec. 3) ------- */

enum { BVH_LEAF_SIZE = 8 };
/* A node is "far" from q when |q - centre| > BETA * radius; Barill et al. use
 * 2; a little more keeps the first-order error well under the 1/2 threshold's
 * margin. */
static const double BVH_BETA = 2.5;

typedef struct bvh_node {
    double centre[3];   /* area-weighted centroid                            */
    double normal[3];   /* sum of area vectors (1/2 (b-a) x (c-a))           */
    double radius;      /* max distance from centre to a vertex in the node  */
    int32_t left, right;/* children; -1 for a leaf                           */
    size_t first, count;/* leaf: triangles order[first .. first+count)       */
} bvh_node;

typedef struct bvh {
    bvh_node *nodes;
    size_t nnodes;
    size_t *order;      /* triangle indices, grouped by leaf                 */
    double *centroid;   /* 3 per triangle                                    */
    const ohm_mesh *mesh;
} bvh;

static void bvh_free(bvh *b)
{
    free(b->nodes);
    free(b->order);
    free(b->centroid);
    memset(b, 0, sizeof *b);
}

/* Partition order[first..first+count) around its median along axis (quickselect). */
static void partition_median(size_t *order, const double *centroid, size_t n, int axis)
{
    size_t lo = 0, hi = n - 1, k = n / 2;
    while (lo < hi) {
        double pivot = centroid[3 * order[(lo + hi) / 2] + (size_t)axis];
        size_t i = lo, j = hi;
        while (i <= j) {
            while (centroid[3 * order[i] + (size_t)axis] < pivot) ++i;
            while (centroid[3 * order[j] + (size_t)axis] > pivot) --j;
            if (i <= j) {
                size_t t = order[i];
                order[i] = order[j];
                order[j] = t;
                ++i;
                if (j == 0) break;
                --j;
            }
        }
        if (k <= j) hi = j;
        else if (k >= i) lo = i;
        else break;
    }
}

static void bvh_moments(bvh *b, bvh_node *node)
{
    const ohm_mesh *m = b->mesh;
    double area_sum = 0.0, c[3] = {0, 0, 0}, n[3] = {0, 0, 0};
    for (size_t s = 0; s < node->count; ++s) {
        size_t t = b->order[node->first + s];
        const double *A = tri_vertex(m, t, 0), *B = tri_vertex(m, t, 1), *C = tri_vertex(m, t, 2);
        double e1[3], e2[3], an[3];
        v_sub(e1, B, A);
        v_sub(e2, C, A);
        v_cross(an, e1, e2);
        double area = 0.5 * v_len(an);
        for (int d = 0; d < 3; ++d) {
            n[d] += 0.5 * an[d];
            c[d] += area * b->centroid[3 * t + (size_t)d];
        }
        area_sum += area;
    }
    for (int d = 0; d < 3; ++d) {
        node->normal[d] = n[d];
        /* Zero-area nodes (degenerate triangles) contribute nothing far away;
         * any centre works, take the plain centroid of the first triangle. */
        node->centre[d] = area_sum > 0 ? c[d] / area_sum : b->centroid[3 * b->order[node->first] + (size_t)d];
    }
    double r = 0.0;
    for (size_t s = 0; s < node->count; ++s) {
        size_t t = b->order[node->first + s];
        for (int v = 0; v < 3; ++v) {
            double dv[3];
            v_sub(dv, tri_vertex(m, t, v), node->centre);
            double l = v_len(dv);
            if (l > r) r = l;
        }
    }
    node->radius = r;
}

static int bvh_build(bvh *b, const ohm_mesh *m, ohm_error *err)
{
    memset(b, 0, sizeof *b);
    b->mesh = m;
    size_t n = m->ntris;
    size_t max_nodes = 2 * (n / BVH_LEAF_SIZE + 1) * 2 + 1;
    b->order = malloc(n * sizeof *b->order);
    b->centroid = malloc(3 * n * sizeof *b->centroid);
    b->nodes = malloc(max_nodes * sizeof *b->nodes);
    if (!b->order || !b->centroid || !b->nodes) {
        bvh_free(b);
        return ohm_fail(err, OHM_ERR_NOMEM, "out of memory building the winding-number hierarchy (%zu triangles)", n);
    }
    for (size_t t = 0; t < n; ++t) {
        b->order[t] = t;
        for (int d = 0; d < 3; ++d)
            b->centroid[3 * t + (size_t)d] =
                (tri_vertex(m, t, 0)[d] + tri_vertex(m, t, 1)[d] + tri_vertex(m, t, 2)[d]) / 3.0;
    }
    /* Build top-down with an explicit stack of node indices. */
    size_t stack[128];
    size_t sp = 0;
    b->nodes[0] = (bvh_node){.left = -1, .right = -1, .first = 0, .count = n};
    b->nnodes = 1;
    stack[sp++] = 0;
    while (sp) {
        size_t ni = stack[--sp];
        bvh_node *node = &b->nodes[ni];
        bvh_moments(b, node);
        if (node->count <= BVH_LEAF_SIZE || b->nnodes + 2 > max_nodes || sp + 2 > 128) continue;
        double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (size_t s = 0; s < node->count; ++s) {
            const double *c = &b->centroid[3 * b->order[node->first + s]];
            for (int d = 0; d < 3; ++d) {
                if (c[d] < lo[d]) lo[d] = c[d];
                if (c[d] > hi[d]) hi[d] = c[d];
            }
        }
        int axis = 0;
        for (int d = 1; d < 3; ++d)
            if (hi[d] - lo[d] > hi[axis] - lo[axis]) axis = d;
        partition_median(b->order + node->first, b->centroid, node->count, axis);
        size_t half = node->count / 2;
        size_t li = b->nnodes++, ri = b->nnodes++;
        b->nodes[li] = (bvh_node){.left = -1, .right = -1, .first = node->first, .count = half};
        b->nodes[ri] = (bvh_node){.left = -1, .right = -1, .first = node->first + half, .count = node->count - half};
        node = &b->nodes[ni];
        node->left = (int32_t)li;
        node->right = (int32_t)ri;
        stack[sp++] = li;
        stack[sp++] = ri;
    }
    return OHM_OK;
}

static double bvh_winding(const bvh *b, const double q[3])
{
    const ohm_mesh *m = b->mesh;
    size_t stack[128];
    size_t sp = 0;
    double w = 0.0, far = 0.0;
    stack[sp++] = 0;
    while (sp) {
        const bvh_node *node = &b->nodes[stack[--sp]];
        double d[3];
        v_sub(d, node->centre, q);
        double dist = v_len(d);
        if (dist > BVH_BETA * node->radius) {
            /* Dipole term: a patch of area vector N at distance d subtends
             * N.d/|d|^3 steradians. */
            far += v_dot(node->normal, d) / (dist * dist * dist);
        } else if (node->left < 0) {
            for (size_t s = 0; s < node->count; ++s) {
                size_t t = b->order[node->first + s];
                w += triangle_winding(tri_vertex(m, t, 0), tri_vertex(m, t, 1), tri_vertex(m, t, 2), q);
            }
        } else {
            stack[sp++] = (size_t)node->left;
            stack[sp++] = (size_t)node->right;
        }
    }
    return w + far / (4.0 * M_PI);
}

/* ---- point-triangle distance (Ericson, Real-Time Collision Detection 5.1.5) */

static double point_triangle_dist2(const double p[3], const double *a, const double *b, const double *c)
{
    double ab[3], ac[3], ap[3], bp[3], cp[3], closest[3];
    v_sub(ab, b, a);
    v_sub(ac, c, a);
    v_sub(ap, p, a);
    double d1 = v_dot(ab, ap), d2 = v_dot(ac, ap);
    if (d1 <= 0 && d2 <= 0) {
        memcpy(closest, a, sizeof closest);
        goto done;
    }
    v_sub(bp, p, b);
    double d3 = v_dot(ab, bp), d4 = v_dot(ac, bp);
    if (d3 >= 0 && d4 <= d3) {
        memcpy(closest, b, sizeof closest);
        goto done;
    }
    double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) {
        double v = d1 / (d1 - d3);
        for (int i = 0; i < 3; ++i) closest[i] = a[i] + v * ab[i];
        goto done;
    }
    v_sub(cp, p, c);
    double d5 = v_dot(ab, cp), d6 = v_dot(ac, cp);
    if (d6 >= 0 && d5 <= d6) {
        memcpy(closest, c, sizeof closest);
        goto done;
    }
    double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) {
        double w = d2 / (d2 - d6);
        for (int i = 0; i < 3; ++i) closest[i] = a[i] + w * ac[i];
        goto done;
    }
    double va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
        double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        for (int i = 0; i < 3; ++i) closest[i] = b[i] + w * (c[i] - b[i]);
        goto done;
    }
    {
        double denom = va + vb + vc;
        if (!(denom > 0)) { /* degenerate triangle: fall back to its vertices */
            double best = INFINITY;
            const double *vs[3] = {a, b, c};
            for (int k = 0; k < 3; ++k) {
                double dv[3];
                v_sub(dv, p, vs[k]);
                double d2v = v_dot(dv, dv);
                if (d2v < best) best = d2v;
            }
            return best;
        }
        double v = vb / denom, w = vc / denom;
        for (int i = 0; i < 3; ++i) closest[i] = a[i] + ab[i] * v + ac[i] * w;
    }
done:;
    double dv[3];
    v_sub(dv, p, closest);
    return v_dot(dv, dv);
}

/* ---- the voxelizer ------------------------------------------------------- */

void ohm_voxel_grid_free(ohm_voxel_grid *g)
{
    if (!g) return;
    free(g->inside);
    ohm_cell_index_free(&g->near);
    free(g->near_dist);
    memset(g, 0, sizeof *g);
}

/* The dense distance field a voxelizer fills, +INFINITY everywhere; NULL when
 * out of memory. */
static float *dense_distance(size_t ncells)
{
    float *dist = malloc((ncells ? ncells : 1) * sizeof *dist);
    if (dist)
        for (size_t c = 0; c < ncells; ++c) dist[c] = INFINITY;
    return dist;
}

/* Keep the band of the dense field (its finite values) and free the field:
 * the grid outlives the voxelizer, and only the exporters' level set and the
 * surface normals read distances, all within the band. */
static int keep_band(ohm_voxel_grid *g, float *dist, ohm_error *err)
{
    size_t n = (size_t)g->dims[0] * (size_t)g->dims[1] * (size_t)g->dims[2];
    if (ohm_cell_index_alloc(&g->near, n)) goto nomem;
    for (size_t c = 0; c < n; ++c)
        if (isfinite(dist[c])) ohm_cell_index_add(&g->near, c);
    ohm_cell_index_finish(&g->near, n);
    g->near_dist = malloc((size_t)(g->near.count ? g->near.count : 1) * sizeof *g->near_dist);
    if (!g->near_dist) goto nomem;
    int64_t b = 0;
    for (size_t c = 0; c < n; ++c)
        if (isfinite(dist[c])) g->near_dist[b++] = dist[c];
    free(dist);
    return OHM_OK;
nomem:
    free(dist);
    ohm_voxel_grid_free(g);
    return ohm_fail(err, OHM_ERR_NOMEM, "voxelize: out of memory for the distance band");
}

static inline void cell_centre(const ohm_voxel_grid *g, int32_t i, int32_t j, int32_t k, double p[3])
{
    p[0] = g->origin[0] + g->h * i;
    p[1] = g->origin[1] + g->h * j;
    p[2] = g->origin[2] + g->h * k;
}

/* Fill dist (dense, grid g's cells) with the exact distance to the mesh for
 * every cell within the band of some triangle.  1 when the run was
 * cancelled on the way (dist is then partial). */
static int distance_band(float *dist, const ohm_voxel_grid *g, const ohm_mesh *m, const ohm_log *log)
{
    ohm_progress prog;
    ohm_progress_begin(&prog, log, "voxelize: distance band");
    for (size_t t = 0; t < m->ntris; ++t) {
        if ((t & 1023) == 0 && ohm_progress_update(&prog, (double)t / (double)m->ntris)) return 1;
        const double *a = tri_vertex(m, t, 0), *b = tri_vertex(m, t, 1), *c = tri_vertex(m, t, 2);
        int32_t lo[3], hi[3];
        for (int d = 0; d < 3; ++d) {
            double mn = fmin(a[d], fmin(b[d], c[d])) - g->band, mx = fmax(a[d], fmax(b[d], c[d])) + g->band;
            double il = ceil((mn - g->origin[d]) / g->h), ih = floor((mx - g->origin[d]) / g->h);
            lo[d] = il < 0 ? 0 : (int32_t)il;
            hi[d] = ih > g->dims[d] - 1 ? g->dims[d] - 1 : (int32_t)ih;
        }
        for (int32_t k = lo[2]; k <= hi[2]; ++k)
            for (int32_t j = lo[1]; j <= hi[1]; ++j)
                for (int32_t i = lo[0]; i <= hi[0]; ++i) {
                    double p[3];
                    cell_centre(g, i, j, k, p);
                    size_t idx = ohm_voxel_index(g, i, j, k);
                    double d2 = point_triangle_dist2(p, a, b, c);
                    double dd = sqrt(d2);
                    if (dd <= g->band && dd < dist[idx]) dist[idx] = (float)dd;
                }
    }
    ohm_progress_end(&prog);
    return 0;
}

/* Block size of the coarse pass: a block whose cells are all farther than h
 * from every triangle contains no surface, so the winding number is harmonic
 * (constant, for a closed mesh) inside it and its corners decide it. */
enum { BLOCK = 4 };
static const double FILL_MARGIN = 0.25; /* corners must agree beyond 1/2 +- this */

/* Cubic voxel size that fits the box lo..hi into fit[] cells, the largest
 * count on the longest axis (both sorted, ties in axis order): the largest
 * extent / count over the axes, so no axis needs more cells than it is given. */
static double fit_voxel_size(const double lo[3], const double hi[3], const int fit[3])
{
    int axis[3] = {0, 1, 2};
    int count[3] = {fit[0], fit[1], fit[2]};
    for (int a = 0; a < 3; ++a)
        for (int b = a + 1; b < 3; ++b) {
            if (hi[axis[b]] - lo[axis[b]] > hi[axis[a]] - lo[axis[a]]) {
                int t = axis[a];
                axis[a] = axis[b];
                axis[b] = t;
            }
            if (count[b] > count[a]) {
                int t = count[a];
                count[a] = count[b];
                count[b] = t;
            }
        }
    double h = 0.0;
    for (int r = 0; r < 3; ++r) h = fmax(h, (hi[axis[r]] - lo[axis[r]]) / count[r]);
    return h;
}

/* The grid over box [lo, hi] (world mm): voxel size from fit / dim / voxel,
 * a margin of band_voxels + 1 cells, cells zeroed and distances +inf. */
static int layout_grid(ohm_voxel_grid *out, const double lo[3], const double hi[3], double extent,
                       const ohm_voxelize_params *params, ohm_error *err)
{
    double h;
    int fitted = params->fit[0] > 0 || params->fit[1] > 0 || params->fit[2] > 0;
    if (fitted) {
        if (!(params->fit[0] > 0 && params->fit[1] > 0 && params->fit[2] > 0))
            return ohm_fail(err, OHM_ERR_USAGE, "voxelize: fit needs three positive cell counts, got %d x %d x %d",
                            params->fit[0], params->fit[1], params->fit[2]);
        h = fit_voxel_size(lo, hi, params->fit);
    } else if (params->dim > 0) {
        h = extent / params->dim;
    } else if (params->voxel > 0 && isfinite(params->voxel)) {
        h = params->voxel;
    } else {
        return ohm_fail(err, OHM_ERR_USAGE, "voxelize: give dim=N (cells along the longest axis) or voxel=SIZE > 0");
    }
    int band_voxels = params->band_voxels > 0 ? params->band_voxels : 3;
    int pad = band_voxels + 1;
    double max_cells = params->max_cells > 0 ? params->max_cells : 2147483648.0;
    double ncells = 1.0;
    int32_t core[3];
    for (int d = 0; d < 3; ++d) {
        /* Cells needed to cover the box; the tolerance keeps dim=N from
         * becoming N+1 through rounding. */
        double n = ceil((hi[d] - lo[d]) / h - 1e-9);
        if (n < 1) n = 1;
        if (n + 2.0 * pad > 2147483647.0 / 2)
            return ohm_fail(err, OHM_ERR_INVALID, "voxelize: voxel size %g mm is too small for a %g mm object", h, extent);
        core[d] = (int32_t)n;
        ncells *= n + 2.0 * pad;
    }
    if (ncells > max_cells)
        return ohm_fail(err, OHM_ERR_NOMEM,
                        "voxelize: a %d x %d x %d grid (%.3g cells, about %.1f GiB) exceeds the limit of %.3g cells; "
                        "use a smaller dim= or a larger voxel=",
                        core[0] + 2 * pad, core[1] + 2 * pad, core[2] + 2 * pad, ncells, ncells * 5.0 / (1 << 30),
                        max_cells);

    if (!isfinite(h * h * h) || !(h * h * h > 0))
        return ohm_fail(err, OHM_ERR_INVALID,
                        "voxelize: a %g mm voxel has no finite volume: the object's coordinates are out of range "
                        "(%g mm across)",
                        h, extent);
    /* inside flags (1 byte) + distances (4) + the inside test's or the
     * field's per-cell work (8): estimate before allocating */
    double need = ncells * 13.0, limit = ohm_memory_limit(params->max_memory);
    if (need > limit) {
        char nb[32], lb[32];
        return ohm_fail(err, OHM_ERR_NOMEM,
                        "voxelize: a %d x %d x %d grid needs about %s, more than the %s %s; use a smaller dim= or a "
                        "larger voxel=",
                        core[0] + 2 * pad, core[1] + 2 * pad, core[2] + 2 * pad, ohm_format_bytes(need, nb, 32),
                        ohm_format_bytes(limit, lb, 32), params->max_memory > 0 ? "max_memory= allows" : "available");
    }

    out->h = h;
    out->band = band_voxels * h;
    for (int d = 0; d < 3; ++d) {
        out->dims[d] = core[d] + 2 * pad;
        /* Centre the covered box on the mesh's box, then step back over the
         * margin; +h/2 because indices are cell centres. */
        double start = 0.5 * (lo[d] + hi[d]) - 0.5 * core[d] * h;
        out->origin[d] = start - pad * h + 0.5 * h;
    }
    size_t n = (size_t)out->dims[0] * (size_t)out->dims[1] * (size_t)out->dims[2];
    out->inside = calloc(n, 1);
    if (!out->inside) {
        ohm_voxel_grid_free(out);
        return ohm_fail(err, OHM_ERR_NOMEM, "voxelize: out of memory for %zu cells", n);
    }

    return OHM_OK;
}

/* The fine pass of ohm_voxelize, one z slice per job: each slice writes its
 * own cells of inside[] and its own two counts (winding numbers evaluated,
 * ambiguous cells), so the result is the same on any number of threads.  The
 * pass is ~90% of voxelizing a mesh (perf, spot at dim 410: 3.1e6 winding
 * numbers, 9.5 s on one core). */
enum { FINE_ROUND = 8 }; /* slices per thread between progress updates */

typedef struct fine_pass {
    ohm_voxel_grid *grid;
    const bvh *tree;
    const uint8_t *decided;
    double orient;
    int32_t k0;     /* this round's first slice   */
    size_t *counts; /* 2 per slice                */
} fine_pass;

static void fine_pass_slice(void *user, int64_t job)
{
    fine_pass *f = user;
    ohm_voxel_grid *g = f->grid;
    int32_t k = f->k0 + (int32_t)job;
    size_t exact = 0, ambiguous = 0;
    for (int32_t j = 0; j < g->dims[1]; ++j)
        for (int32_t i = 0; i < g->dims[0]; ++i) {
            size_t idx = ohm_voxel_index(g, i, j, k);
            if (f->decided[idx]) continue;
            double p[3];
            cell_centre(g, i, j, k, p);
            double w = f->orient * bvh_winding(f->tree, p);
            exact++;
            if (w > 0.4 && w < 0.6) ambiguous++;
            g->inside[idx] = w > 0.5;
        }
    f->counts[2 * (size_t)k] = exact;
    f->counts[2 * (size_t)k + 1] = ambiguous;
}

/* The mesh's box and its longest side, checked: finite, not a point, not
 * flat. */
static int mesh_box(double lo[3], double hi[3], double *extent, const ohm_mesh *mesh, ohm_error *err)
{
    ohm_mesh_bounds(mesh, lo, hi);
    *extent = 0.0;
    for (int d = 0; d < 3; ++d) {
        if (!isfinite(lo[d]) || !isfinite(hi[d]))
            return ohm_fail(err, OHM_ERR_INVALID, "voxelize: mesh bounds are not finite");
        if (hi[d] - lo[d] > *extent) *extent = hi[d] - lo[d];
    }
    if (!(*extent > 0)) return ohm_fail(err, OHM_ERR_INVALID, "voxelize: mesh has zero extent (all vertices coincide)");
    /* a sheet in a coordinate plane encloses nothing: every cell near it has
     * a winding number of about 1/2, and rounding would pick a few at random */
    for (int d = 0; d < 3; ++d)
        if (!(hi[d] - lo[d] > 1e-9 * *extent))
            return ohm_fail(err, OHM_ERR_INVALID,
                            "voxelize: the mesh is flat (zero thickness along %c, at %g): it encloses no volume",
                            "xyz"[d], lo[d]);
    return OHM_OK;
}

/* The inside test's working state: blocks of BLOCK^3 cells with winding
 * numbers at their lattice corners (the coarse pass), and which cells they
 * decided (the fine pass evaluates the rest). */
typedef struct inside_test {
    ohm_voxel_grid *grid;
    const bvh *tree;
    double orient;                  /* -1: the mesh is wound inside-out        */
    int32_t nb[3], nl[3];           /* blocks, lattice points per axis          */
    uint8_t *block_near;            /* a block holds a cell within h of the mesh */
    double *lattice_w;              /* winding numbers at lattice points (NaN: not yet) */
    uint8_t *decided;               /* per cell: the coarse pass set it         */
    size_t *slice_counts;           /* the fine pass's, 2 per slice             */
    ohm_voxelize_report *rep;
} inside_test;

static size_t block_index(const inside_test *t, int32_t bx, int32_t by, int32_t bz)
{
    return (size_t)bx + (size_t)t->nb[0] * ((size_t)by + (size_t)t->nb[1] * (size_t)bz);
}

static void inside_test_free(inside_test *t)
{
    free(t->block_near);
    free(t->lattice_w);
    free(t->decided);
    free(t->slice_counts);
}

static int inside_test_alloc(inside_test *t, ohm_voxel_grid *g, ohm_error *err)
{
    size_t n = (size_t)g->dims[0] * (size_t)g->dims[1] * (size_t)g->dims[2];
    for (int d = 0; d < 3; ++d) {
        t->nb[d] = (g->dims[d] - 1 + BLOCK - 1) / BLOCK; /* blocks per axis */
        t->nl[d] = t->nb[d] + 1;                         /* lattice points  */
    }
    size_t nblocks = (size_t)t->nb[0] * (size_t)t->nb[1] * (size_t)t->nb[2];
    size_t nlattice = (size_t)t->nl[0] * (size_t)t->nl[1] * (size_t)t->nl[2];
    t->block_near = calloc(nblocks ? nblocks : 1, 1);
    t->lattice_w = malloc((nlattice ? nlattice : 1) * sizeof *t->lattice_w);
    t->decided = calloc(n, 1);
    t->slice_counts = calloc(2 * (size_t)g->dims[2], sizeof *t->slice_counts);
    if (!t->block_near || !t->lattice_w || !t->decided || !t->slice_counts) {
        inside_test_free(t);
        return ohm_fail(err, OHM_ERR_NOMEM, "voxelize: out of memory for the inside test");
    }
    for (size_t l = 0; l < nlattice; ++l) t->lattice_w[l] = NAN;
    return OHM_OK;
}

/* Mark every block whose closed cell range holds a cell within h of the
 * mesh (> sqrt(3)/2 h: no triangle slips between far cells). */
static void mark_near_blocks(inside_test *t, const float *dist)
{
    const ohm_voxel_grid *g = t->grid;
    const float near_dist = (float)g->h;
    for (int32_t k = 0; k < g->dims[2]; ++k)
        for (int32_t j = 0; j < g->dims[1]; ++j)
            for (int32_t i = 0; i < g->dims[0]; ++i) {
                if (!(dist[ohm_voxel_index(g, i, j, k)] <= near_dist)) continue;
                int32_t c[3] = {i, j, k}, b0[3], b1[3];
                for (int d = 0; d < 3; ++d) {
                    b1[d] = c[d] / BLOCK;
                    b0[d] = (c[d] % BLOCK == 0 && c[d] > 0) ? b1[d] - 1 : b1[d];
                    if (b1[d] >= t->nb[d]) b1[d] = t->nb[d] - 1;
                }
                for (int32_t bz = b0[2]; bz <= b1[2]; ++bz)
                    for (int32_t by = b0[1]; by <= b1[1]; ++by)
                        for (int32_t bx = b0[0]; bx <= b1[0]; ++bx)
                            t->block_near[block_index(t, bx, by, bz)] = 1;
            }
}

/* Block (bx, by, bz), far from the mesh: when its corners' winding numbers
 * agree, every cell of it takes that side. */
static void coarse_block(inside_test *t, int32_t bx, int32_t by, int32_t bz)
{
    ohm_voxel_grid *g = t->grid;
    const int32_t *dims = g->dims, *nb = t->nb, *nl = t->nl;
    double wmin = INFINITY, wmax = -INFINITY;
    for (int corner = 0; corner < 8; ++corner) {
        int32_t lx = bx + (corner & 1), ly = by + ((corner >> 1) & 1), lz = bz + ((corner >> 2) & 1);
        size_t li = (size_t)lx + (size_t)nl[0] * ((size_t)ly + (size_t)nl[1] * (size_t)lz);
        if (isnan(t->lattice_w[li])) {
            double p[3];
            int32_t ci = lx * BLOCK, cj = ly * BLOCK, ck = lz * BLOCK;
            if (ci > dims[0] - 1) ci = dims[0] - 1;
            if (cj > dims[1] - 1) cj = dims[1] - 1;
            if (ck > dims[2] - 1) ck = dims[2] - 1;
            cell_centre(g, ci, cj, ck, p);
            t->lattice_w[li] = t->orient * bvh_winding(t->tree, p);
            t->rep->winding_exact++;
        }
        wmin = fmin(wmin, t->lattice_w[li]);
        wmax = fmax(wmax, t->lattice_w[li]);
    }
    int side;
    if (wmin > 0.5 + FILL_MARGIN) side = 1;
    else if (wmax < 0.5 - FILL_MARGIN) side = 0;
    else return;
    int32_t i1 = (bx + 1) * BLOCK, j1 = (by + 1) * BLOCK, k1 = (bz + 1) * BLOCK;
    if (bx == nb[0] - 1) i1 = dims[0];
    if (by == nb[1] - 1) j1 = dims[1];
    if (bz == nb[2] - 1) k1 = dims[2];
    for (int32_t k = bz * BLOCK; k < k1; ++k)
        for (int32_t j = by * BLOCK; j < j1; ++j)
            for (int32_t i = bx * BLOCK; i < i1; ++i) {
                size_t idx = ohm_voxel_index(g, i, j, k);
                g->inside[idx] = (uint8_t)side;
                t->decided[idx] = 1;
                t->rep->winding_filled++;
            }
}

/* Coarse pass, then fine pass: inside[] for every cell.  1 when the run was
 * cancelled on the way. */
static int inside_test_run(inside_test *t, ohm_progress *prog)
{
    const int32_t *dims = t->grid->dims, *nb = t->nb;
    for (int32_t bz = 0; bz < nb[2]; ++bz) {
        if (ohm_progress_update(prog, 0.5 * bz / nb[2])) return 1;
        for (int32_t by = 0; by < nb[1]; ++by)
            for (int32_t bx = 0; bx < nb[0]; ++bx)
                if (!t->block_near[block_index(t, bx, by, bz)]) coarse_block(t, bx, by, bz);
    }
    /* Fine pass: every cell the blocks did not decide, slice by slice on
     * every core, a round of FINE_ROUND slices per thread between progress
     * updates (the progress line is the caller's thread's alone). */
    fine_pass fine = {
        .grid = t->grid, .tree = t->tree, .decided = t->decided, .orient = t->orient, .counts = t->slice_counts};
    int threads = ohm_usable_cores();
    int32_t round = FINE_ROUND * threads;
    for (int32_t k0 = 0; k0 < dims[2]; k0 += round) {
        if (ohm_progress_update(prog, 0.5 + 0.5 * k0 / dims[2])) return 1;
        fine.k0 = k0;
        ohm_parallel_for(k0 + round < dims[2] ? round : dims[2] - k0, threads, fine_pass_slice, &fine);
    }
    for (int32_t k = 0; k < dims[2]; ++k) {
        t->rep->winding_exact += t->slice_counts[2 * (size_t)k];
        t->rep->ambiguous += t->slice_counts[2 * (size_t)k + 1];
    }
    return 0;
}

int ohm_voxelize(ohm_voxel_grid *out, ohm_voxelize_report *report, const ohm_mesh *mesh,
                 const ohm_voxelize_params *params, const ohm_log *log, ohm_error *err)
{
    memset(out, 0, sizeof *out);
    ohm_voxelize_report rep;
    memset(&rep, 0, sizeof rep);
    if (!mesh || mesh->ntris == 0) return ohm_fail(err, OHM_ERR_INVALID, "voxelize: no mesh with triangles was read");
    double lo[3], hi[3], extent;
    int rc = mesh_box(lo, hi, &extent, mesh, err);
    if (!rc) rc = layout_grid(out, lo, hi, extent, params, err);
    if (rc) return rc;
    size_t n = (size_t)out->dims[0] * (size_t)out->dims[1] * (size_t)out->dims[2];

    rep.signed_volume = ohm_mesh_signed_volume(mesh);
    rep.flipped = rep.signed_volume < 0;
    float *dist = dense_distance(n);
    if (!dist) {
        ohm_voxel_grid_free(out);
        return ohm_fail(err, OHM_ERR_NOMEM, "voxelize: out of memory for %zu cells", n);
    }
    bvh tree;
    inside_test t = {.grid = out, .tree = &tree, .orient = rep.flipped ? -1.0 : 1.0, .rep = &rep};
    if (distance_band(dist, out, mesh, log)) rc = ohm_fail_cancelled(err, "voxelize");
    if (!rc) rc = bvh_build(&tree, mesh, err);
    if (rc) {
        free(dist);
        ohm_voxel_grid_free(out);
        return rc;
    }
    rc = inside_test_alloc(&t, out, err);
    if (!rc) {
        mark_near_blocks(&t, dist);
        ohm_progress prog;
        ohm_progress_begin(&prog, log, "voxelize: inside test");
        if (inside_test_run(&t, &prog)) rc = ohm_fail_cancelled(err, "voxelize");
        else ohm_progress_end(&prog);
        inside_test_free(&t);
    }
    bvh_free(&tree);
    if (rc) {
        free(dist);
        ohm_voxel_grid_free(out);
        return rc;
    }
    size_t interior = 0;
    for (size_t c = 0; c < n; ++c) interior += out->inside[c];
    out->interior_cells = interior;
    if (report) *report = rep;
    return keep_band(out, dist, err);
}

int ohm_voxelize_field(ohm_voxel_grid *out, const ohm_field *field, const double lo[3], const double hi[3],
                       double threshold, const ohm_voxelize_params *params, const ohm_log *log, ohm_error *err)
{
    memset(out, 0, sizeof *out);
    double extent = 0.0;
    for (int d = 0; d < 3; ++d) {
        if (!isfinite(lo[d]) || !isfinite(hi[d])) return ohm_fail(err, OHM_ERR_INVALID, "voxelize: bounds not finite");
        if (hi[d] - lo[d] > extent) extent = hi[d] - lo[d];
    }
    if (!(extent > 0)) return ohm_fail(err, OHM_ERR_INVALID, "voxelize: the volume has zero extent");
    int rc = layout_grid(out, lo, hi, extent, params, err);
    if (rc) return rc;
    size_t n = (size_t)out->dims[0] * (size_t)out->dims[1] * (size_t)out->dims[2];
    double *f = malloc(n * sizeof *f);
    float *dist = dense_distance(n);
    if (!f || !dist) {
        free(f);
        free(dist);
        ohm_voxel_grid_free(out);
        return ohm_fail(err, OHM_ERR_NOMEM, "voxelize: out of memory for %zu cells", n);
    }
    ohm_progress prog;
    ohm_progress_begin(&prog, log, "voxelize: sampling the volume");
    size_t interior = 0;
    for (int32_t k = 0; k < out->dims[2]; ++k) {
        if (ohm_progress_update(&prog, (double)k / out->dims[2])) {
            free(f);
            free(dist);
            ohm_voxel_grid_free(out);
            return ohm_fail_cancelled(err, "voxelize");
        }
        for (int32_t j = 0; j < out->dims[1]; ++j)
            for (int32_t i = 0; i < out->dims[0]; ++i) {
                double p[3];
                cell_centre(out, i, j, k, p);
                size_t idx = ohm_voxel_index(out, i, j, k);
                f[idx] = field->value(field->user, p);
                int in_domain = !field->domain || field->domain(field->user, p) <= 0;
                out->inside[idx] = in_domain && f[idx] >= threshold;
                interior += out->inside[idx];
            }
    }
    ohm_progress_end(&prog);
    /* distance estimate |f - T| / |grad f| within the band */
    for (int32_t k = 1; k + 1 < out->dims[2]; ++k)
        for (int32_t j = 1; j + 1 < out->dims[1]; ++j)
            for (int32_t i = 1; i + 1 < out->dims[0]; ++i) {
                size_t idx = ohm_voxel_index(out, i, j, k);
                double g[3] = {f[ohm_voxel_index(out, i + 1, j, k)] - f[ohm_voxel_index(out, i - 1, j, k)],
                               f[ohm_voxel_index(out, i, j + 1, k)] - f[ohm_voxel_index(out, i, j - 1, k)],
                               f[ohm_voxel_index(out, i, j, k + 1)] - f[ohm_voxel_index(out, i, j, k - 1)]};
                double grad = sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]) / (2.0 * out->h);
                /* signed, positive outside; a flat field is wholly in or out */
                double s = grad > 0 ? (threshold - f[idx]) / grad : f[idx] >= threshold ? -INFINITY : INFINITY;
                if (field->domain) {
                    double p[3];
                    cell_centre(out, i, j, k, p);
                    s = fmax(s, field->domain(field->user, p)); /* the intersection's distance */
                }
                double d = fabs(s);
                if (d <= out->band) dist[idx] = (float)d;
            }
    free(f);
    out->interior_cells = interior;
    return keep_band(out, dist, err);
}
