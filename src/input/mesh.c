/* mesh.c — what ohm needs to know about a triangle mesh: bounds, enclosed
 * volume, and a topology report (holes, non-manifold and flipped edges,
 * degenerate triangles, pieces, unused vertices).  Readers are in mesh_io.c. */
#include "input/mesh.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

void ohm_mesh_free(ohm_mesh *m)
{
    if (!m) return;
    free(m->verts);
    free(m->tris);
    memset(m, 0, sizeof *m);
}

static int valid_index(const ohm_mesh *m, int64_t i)
{
    return i >= 0 && (uint64_t)i < m->nverts;
}

void ohm_mesh_bounds(const ohm_mesh *m, double lo[3], double hi[3])
{
    int any = 0;
    for (int k = 0; k < 3; ++k) {
        lo[k] = HUGE_VAL;
        hi[k] = -HUGE_VAL;
    }
    if (m && m->tris && m->verts) {
        for (size_t i = 0; i < 3 * m->ntris; ++i) {
            int64_t v = m->tris[i];
            if (!valid_index(m, v)) continue;
            const double *p = m->verts + 3 * (size_t)v;
            for (int k = 0; k < 3; ++k) {
                if (p[k] < lo[k]) lo[k] = p[k];
                if (p[k] > hi[k]) hi[k] = p[k];
            }
            any = 1;
        }
    }
    if (!any)
        for (int k = 0; k < 3; ++k) lo[k] = hi[k] = 0;
}

double ohm_mesh_signed_volume(const ohm_mesh *m)
{
    if (!m || !m->tris || !m->verts || m->ntris == 0) return 0;
    /* The sum is translation-invariant only for closed meshes, but shifting to
     * the box centre keeps the products small, so round-off stays relative to
     * the mesh size rather than to its distance from the origin. */
    double lo[3], hi[3], o[3];
    ohm_mesh_bounds(m, lo, hi);
    for (int k = 0; k < 3; ++k) o[k] = 0.5 * (lo[k] + hi[k]);
    double sum = 0, comp = 0; /* Neumaier summation */
    for (size_t t = 0; t < m->ntris; ++t) {
        const int64_t *tri = m->tris + 3 * t;
        if (!valid_index(m, tri[0]) || !valid_index(m, tri[1]) || !valid_index(m, tri[2])) continue;
        double p[3][3];
        for (int c = 0; c < 3; ++c)
            for (int k = 0; k < 3; ++k) p[c][k] = m->verts[3 * (size_t)tri[c] + k] - o[k];
        double det = p[0][0] * (p[1][1] * p[2][2] - p[1][2] * p[2][1]) -
                     p[0][1] * (p[1][0] * p[2][2] - p[1][2] * p[2][0]) +
                     p[0][2] * (p[1][0] * p[2][1] - p[1][1] * p[2][0]);
        double s = sum + det;
        comp += fabs(sum) >= fabs(det) ? (sum - s) + det : (det - s) + sum;
        sum = s;
    }
    return (sum + comp) / 6.0;
}

void ohm_mesh_scale(ohm_mesh *m, double s)
{
    if (!m || !m->verts) return;
    for (size_t i = 0; i < 3 * m->nverts; ++i) m->verts[i] *= s;
}

/* An undirected edge {lo, hi} with hi stored as (hi << 1 | dir): dir is 0 when
 * the triangle runs lo -> hi.  Sorting groups uses of one edge together. */
typedef struct edge {
    uint64_t lo, hi_dir;
} edge;

static int edge_cmp(const void *pa, const void *pb)
{
    const edge *a = pa, *b = pb;
    if (a->lo != b->lo) return a->lo < b->lo ? -1 : 1;
    if (a->hi_dir != b->hi_dir) return a->hi_dir < b->hi_dir ? -1 : 1;
    return 0;
}

static size_t uf_find(size_t *parent, size_t x)
{
    while (parent[x] != x) {
        parent[x] = parent[parent[x]]; /* path halving */
        x = parent[x];
    }
    return x;
}

int ohm_mesh_topology_compute(ohm_mesh_topology *out, const ohm_mesh *m, ohm_error *err)
{
    memset(out, 0, sizeof *out);
    if (!m) return ohm_fail(err, OHM_ERR_USAGE, "mesh topology: no mesh given");
    size_t nv = m->nverts, nt = m->ntris;
    if (nt > 0 && (!m->tris || !m->verts))
        return ohm_fail(err, OHM_ERR_INVALID, "mesh topology: mesh has %zu triangles but no data", nt);
    for (size_t i = 0; i < 3 * nt; ++i)
        if (!valid_index(m, m->tris[i]))
            return ohm_fail(err, OHM_ERR_INVALID,
                            "mesh topology: triangle %zu refers to vertex %lld, mesh has %zu vertices", i / 3,
                            (long long)m->tris[i], nv);
    if (nt > SIZE_MAX / 3 / sizeof(edge) || nv > SIZE_MAX / sizeof(size_t))
        return ohm_fail(err, OHM_ERR_NOMEM, "mesh topology: mesh too large (%zu triangles)", nt);
    edge *e = malloc((nt > 0 ? 3 * nt : 1) * sizeof *e);
    size_t *parent = malloc((nv ? nv : 1) * sizeof *parent);
    unsigned char *used = calloc(nv ? nv : 1, 1);
    if (!e || !parent || !used) {
        free(e);
        free(parent);
        free(used);
        return ohm_fail(err, OHM_ERR_NOMEM, "mesh topology: out of memory for %zu triangles, %zu vertices",
                        nt, nv);
    }
    for (size_t i = 0; i < nv; ++i) parent[i] = i;

    size_t ne = 0;
    for (size_t t = 0; t < nt; ++t) {
        const int64_t *tri = m->tris + 3 * t;
        size_t v[3] = {(size_t)tri[0], (size_t)tri[1], (size_t)tri[2]};
        for (int c = 0; c < 3; ++c) used[v[c]] = 1;
        for (int c = 1; c < 3; ++c) { /* union by smaller root index */
            size_t a = uf_find(parent, v[0]), b = uf_find(parent, v[c]);
            if (a < b) parent[b] = a;
            else if (b < a) parent[a] = b;
        }
        if (v[0] == v[1] || v[1] == v[2] || v[2] == v[0]) {
            /* no meaningful edges: keep it out of the edge statistics */
            out->degenerate_tris++;
            continue;
        }
        const double *p0 = m->verts + 3 * v[0], *p1 = m->verts + 3 * v[1], *p2 = m->verts + 3 * v[2];
        double a[3], b[3];
        for (int k = 0; k < 3; ++k) {
            a[k] = p1[k] - p0[k];
            b[k] = p2[k] - p0[k];
        }
        double cx = a[1] * b[2] - a[2] * b[1], cy = a[2] * b[0] - a[0] * b[2], cz = a[0] * b[1] - a[1] * b[0];
        if (cx == 0 && cy == 0 && cz == 0) out->degenerate_tris++;
        for (int c = 0; c < 3; ++c) {
            uint64_t s = v[c], d = v[(c + 1) % 3];
            e[ne].lo = s < d ? s : d;
            e[ne].hi_dir = (s < d ? d : s) << 1 | (s < d ? 0u : 1u);
            ++ne;
        }
    }
    qsort(e, ne, sizeof *e, edge_cmp);
    for (size_t i = 0; i < ne;) {
        size_t j = i, fwd = 0;
        while (j < ne && e[j].lo == e[i].lo && (e[j].hi_dir >> 1) == (e[i].hi_dir >> 1)) {
            fwd += (e[j].hi_dir & 1) == 0;
            ++j;
        }
        size_t k = j - i, bwd = k - fwd, most = fwd > bwd ? fwd : bwd;
        if (k == 1) out->boundary_edges++;
        if (k > 2) out->nonmanifold_edges++;
        /* consistent orientation pairs every use with an opposite one; flag the
         * edge when one direction is used more often than that allows */
        if (k > 1 && most > (k + 1) / 2) out->misoriented_edges++;
        i = j;
    }
    for (size_t i = 0; i < nv; ++i) {
        if (!used[i]) out->unused_verts++;
        else if (uf_find(parent, i) == i) out->components++;
    }
    free(e);
    free(parent);
    free(used);
    return OHM_OK;
}
