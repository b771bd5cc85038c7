/* test_voxelize.c — the inside test against the divergence theorem, on closed,
 * holed, open and overlapping sample meshes. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "input/mesh.h"
#include "grid/voxelize.h"

static const ohm_log quiet = {.verbosity = 0};

static int load(ohm_mesh *m, const char *path)
{
    ohm_error err;
    ohm_error_clear(&err);
    int rc = ohm_mesh_read(m, path, &err);
    CHECK_MSG(rc == 0, "%s: %s", path, err.msg);
    return rc;
}

static int voxelize(ohm_voxel_grid *g, ohm_voxelize_report *rep, const ohm_mesh *m, int dim)
{
    ohm_error err;
    ohm_error_clear(&err);
    ohm_voxelize_params p = {0};
    p.dim = dim;
    int rc = ohm_voxelize(g, rep, m, &p, &quiet, &err);
    CHECK_MSG(rc == 0, "voxelize: %s", err.msg);
    return rc;
}

/* Cells that are outside but cannot reach the grid's border through outside
 * cells: hollow pockets.  A solid object has (almost) none. */
static size_t enclosed_void_cells(const ohm_voxel_grid *g)
{
    size_t n = (size_t)g->dims[0] * g->dims[1] * g->dims[2];
    uint8_t *seen = calloc(n, 1);
    size_t *queue = malloc(n * sizeof *queue);
    size_t head = 0, tail = 0, reached = 0, outside = 0;
    for (int32_t k = 0; k < g->dims[2]; ++k)
        for (int32_t j = 0; j < g->dims[1]; ++j)
            for (int32_t i = 0; i < g->dims[0]; ++i) {
                size_t idx = ohm_voxel_index(g, i, j, k);
                if (g->inside[idx]) continue;
                ++outside;
                int border = i == 0 || j == 0 || k == 0 || i == g->dims[0] - 1 || j == g->dims[1] - 1 ||
                             k == g->dims[2] - 1;
                if (border) {
                    seen[idx] = 1;
                    queue[tail++] = idx;
                }
            }
    while (head < tail) {
        size_t idx = queue[head++];
        ++reached;
        int32_t i = (int32_t)(idx % (size_t)g->dims[0]);
        int32_t j = (int32_t)((idx / (size_t)g->dims[0]) % (size_t)g->dims[1]);
        int32_t k = (int32_t)(idx / ((size_t)g->dims[0] * (size_t)g->dims[1]));
        const int32_t off[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
        for (int f = 0; f < 6; ++f) {
            int32_t a = i + off[f][0], b = j + off[f][1], c = k + off[f][2];
            if (a < 0 || b < 0 || c < 0 || a >= g->dims[0] || b >= g->dims[1] || c >= g->dims[2]) continue;
            size_t nb = ohm_voxel_index(g, a, b, c);
            if (g->inside[nb] || seen[nb]) continue;
            seen[nb] = 1;
            queue[tail++] = nb;
        }
    }
    free(seen);
    free(queue);
    return outside - reached;
}

/* Closed meshes: interior cells x voxel volume = enclosed volume within 2%. */
static void closed_volume(const char *path, int dim, double tol)
{
    ohm_mesh m;
    if (load(&m, path)) return;
    ohm_voxel_grid g;
    ohm_voxelize_report rep;
    if (voxelize(&g, &rep, &m, dim) == 0) {
        double v_mesh = fabs(ohm_mesh_signed_volume(&m));
        double v_cells = (double)g.interior_cells * g.h * g.h * g.h;
        printf("%-28s dim %3d: %zu cells, %.6g vs mesh %.6g (%+.3f%%)\n", path, dim, g.interior_cells, v_cells,
               v_mesh, 100.0 * (v_cells - v_mesh) / v_mesh);
        CHECK_REL(v_cells, v_mesh, tol);
        CHECK(rep.flipped == 0);
        CHECK(enclosed_void_cells(&g) == 0);
        /* dim=N puts exactly N cells across the longest axis of the box */
        int pad = 2 * 4;
        int longest = g.dims[0];
        if (g.dims[1] > longest) longest = g.dims[1];
        if (g.dims[2] > longest) longest = g.dims[2];
        CHECK(longest - pad == dim);
        ohm_voxel_grid_free(&g);
    }
    ohm_mesh_free(&m);
}

/* The fast (BVH, far-field) winding number agrees with the exact sum. */
static void winding_accuracy(const char *path)
{
    ohm_mesh m;
    if (load(&m, path)) return;
    ohm_voxel_grid g;
    ohm_voxelize_report rep;
    if (voxelize(&g, &rep, &m, 24) == 0) {
        /* Every cell centre of a coarse grid, exact: must classify the same. */
        size_t disagree = 0, tested = 0;
        for (int32_t k = 0; k < g.dims[2]; k += 2)
            for (int32_t j = 0; j < g.dims[1]; j += 2)
                for (int32_t i = 0; i < g.dims[0]; i += 2) {
                    double p[3] = {g.origin[0] + g.h * i, g.origin[1] + g.h * j, g.origin[2] + g.h * k};
                    double w = ohm_winding_number_exact(&m, p);
                    if (rep.flipped) w = -w;
                    if ((w > 0.5) != (g.inside[ohm_voxel_index(&g, i, j, k)] != 0)) ++disagree;
                    ++tested;
                }
        CHECK_MSG(disagree == 0, "%s: %zu of %zu cells differ from the exact winding number", path, disagree, tested);
        ohm_voxel_grid_free(&g);
    }
    ohm_mesh_free(&m);
}

/* The open scan of the bunny (holes in its base) is the closed bunny00 scaled
 * by about 1/6.41: the fraction of the bounding box they fill must agree, and
 * the open one must be solid, not a shell. */
static void open_bunny(void)
{
    ohm_mesh closed, open;
    if (load(&closed, "samples/bunny00.off.gz")) return;
    if (load(&open, "samples/stanford-bunny.obj.gz")) {
        ohm_mesh_free(&closed);
        return;
    }
    ohm_voxel_grid gc, go;
    ohm_voxelize_report rc, ro;
    if (voxelize(&gc, &rc, &closed, 64) == 0) {
        if (voxelize(&go, &ro, &open, 64) == 0) {
            double lo[3], hi[3];
            ohm_mesh_bounds(&closed, lo, hi);
            double box_c = (hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]);
            ohm_mesh_bounds(&open, lo, hi);
            double box_o = (hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]);
            double fc = gc.interior_cells * gc.h * gc.h * gc.h / box_c;
            double fo = go.interior_cells * go.h * go.h * go.h / box_o;
            printf("bunny fill fraction: closed %.4f, open %.4f (%+.2f%%)\n", fc, fo, 100 * (fo - fc) / fc);
            CHECK_REL(fo, fc, 0.03);
            CHECK(enclosed_void_cells(&go) == 0);
            /* the scale between them, from the boxes */
            CHECK_REL(cbrt(box_c / box_o), 6.41, 0.02);
            ohm_voxel_grid_free(&go);
        }
        ohm_voxel_grid_free(&gc);
    }
    ohm_mesh_free(&closed);
    ohm_mesh_free(&open);
}

/* Open or overlapping meshes: a solid interior that fills a plausible part of
 * the box. */
static void open_mesh(const char *path, double min_fill, double max_fill, int expect_flipped)
{
    ohm_mesh m;
    if (load(&m, path)) return;
    ohm_voxel_grid g;
    ohm_voxelize_report rep;
    if (voxelize(&g, &rep, &m, 64) == 0) {
        double lo[3], hi[3];
        ohm_mesh_bounds(&m, lo, hi);
        double box = (hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]);
        double fill = g.interior_cells * g.h * g.h * g.h / box;
        size_t voids = enclosed_void_cells(&g);
        printf("%-28s fill %.4f, enclosed voids %zu, flipped %d, ambiguous %zu\n", path, fill, voids, rep.flipped,
               rep.ambiguous);
        CHECK_MSG(fill > min_fill && fill < max_fill, "%s: fill %.4f outside (%.2f, %.2f)", path, fill, min_fill,
                  max_fill);
        CHECK_MSG(voids == 0, "%s: %zu hollow cells", path, voids);
        CHECK(rep.flipped == expect_flipped);
        ohm_voxel_grid_free(&g);
    }
    ohm_mesh_free(&m);
}

/* A unit cube offset from the origin: exact cell counts are known. */
static void cube_exact(void)
{
    double v[8][3];
    for (int c = 0; c < 8; ++c) {
        v[c][0] = 10 + (c & 1) * 8.0;
        v[c][1] = -3 + ((c >> 1) & 1) * 8.0;
        v[c][2] = 5 + ((c >> 2) & 1) * 8.0;
    }
    static const int64_t f[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                                     {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
    ohm_mesh m = {0};
    m.nverts = 8;
    m.ntris = 12;
    m.verts = malloc(sizeof v);
    m.tris = malloc(sizeof f);
    memcpy(m.verts, v, sizeof v);
    memcpy(m.tris, f, sizeof f);
    CHECK_REL(ohm_mesh_signed_volume(&m), 512.0, 1e-12);
    ohm_voxel_grid g;
    ohm_voxelize_report rep;
    if (voxelize(&g, &rep, &m, 16) == 0) {
        CHECK(g.interior_cells == 16 * 16 * 16);
        CHECK_REL(g.h, 0.5, 1e-12);
        /* the first interior cell's centre sits half a voxel inside the corner */
        size_t first = 0;
        while (!g.inside[first]) ++first;
        int32_t i = (int32_t)(first % (size_t)g.dims[0]);
        CHECK_REL(g.origin[0] + i * g.h, 10.25, 1e-12);
        /* distance band: a cell just outside a face is h/2 from it */
        CHECK(fabs(ohm_voxel_dist(&g, first) - 0.25) < 1e-6);
        ohm_voxel_grid_free(&g);
    }
    /* wound inside-out: same cells, reported flipped */
    for (int t = 0; t < 12; ++t) {
        int64_t tmp = m.tris[3 * t + 1];
        m.tris[3 * t + 1] = m.tris[3 * t + 2];
        m.tris[3 * t + 2] = tmp;
    }
    if (voxelize(&g, &rep, &m, 16) == 0) {
        CHECK(rep.flipped == 1);
        CHECK(g.interior_cells == 16 * 16 * 16);
        ohm_voxel_grid_free(&g);
    }
    ohm_mesh_free(&m);
}

/* fit: the paper's grid sizes.  Cubic voxels, the largest count on the
 * longest axis, every axis within its count and one of them exactly at it;
 * the margin comes on top as with dim=.  A partial fit is a usage error. */
static void fit_grid(const char *path)
{
    ohm_mesh m;
    if (load(&m, path)) return;
    double lo[3], hi[3];
    ohm_mesh_bounds(&m, lo, hi);
    const int fits[][3] = {{8, 8, 4}, {64, 64, 32}, {32, 16, 32}, {5, 7, 3}};
    for (size_t t = 0; t < sizeof fits / sizeof *fits; ++t) {
        ohm_error err;
        ohm_error_clear(&err);
        ohm_voxelize_params p = {0};
        memcpy(p.fit, fits[t], sizeof p.fit);
        ohm_voxel_grid g;
        ohm_voxelize_report rep;
        int rc = ohm_voxelize(&g, &rep, &m, &p, &quiet, &err);
        CHECK_MSG(rc == 0, "fit: %s", err.msg);
        if (rc) continue;
        /* the counts and the extents, both sorted descending */
        int cnt[3] = {fits[t][0], fits[t][1], fits[t][2]};
        double ext[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
        int core[3], margin = 2 * (3 + 1);
        for (int d = 0; d < 3; ++d) core[d] = g.dims[d] - margin;
        int ax[3] = {0, 1, 2};
        for (int a = 0; a < 3; ++a)
            for (int b = a + 1; b < 3; ++b) {
                if (cnt[b] > cnt[a]) {
                    int x = cnt[a];
                    cnt[a] = cnt[b];
                    cnt[b] = x;
                }
                if (ext[ax[b]] > ext[ax[a]]) {
                    int x = ax[a];
                    ax[a] = ax[b];
                    ax[b] = x;
                }
            }
        int exact = 0;
        double want_h = 0;
        for (int r = 0; r < 3; ++r) {
            CHECK_MSG(core[ax[r]] <= cnt[r], "%s fit %dx%dx%d: axis %d has %d cells > %d", path, fits[t][0],
                      fits[t][1], fits[t][2], ax[r], core[ax[r]], cnt[r]);
            exact |= core[ax[r]] == cnt[r];
            want_h = fmax(want_h, ext[ax[r]] / cnt[r]);
        }
        CHECK_MSG(exact, "%s fit %dx%dx%d: no axis uses its full count", path, fits[t][0], fits[t][1], fits[t][2]);
        CHECK_REL(g.h, want_h, 1e-12);
        CHECK(g.interior_cells > 0);
        ohm_voxel_grid_free(&g);
    }
    /* fit wins over dim; a partial fit is refused */
    ohm_error err;
    ohm_error_clear(&err);
    ohm_voxelize_params p = {0};
    p.dim = 100;
    p.fit[0] = 8, p.fit[1] = 8;
    ohm_voxel_grid g;
    ohm_voxelize_report rep;
    CHECK(ohm_voxelize(&g, &rep, &m, &p, &quiet, &err) == OHM_ERR_USAGE);
    CHECK(strstr(err.msg, "fit") != NULL);
    ohm_mesh_free(&m);
}

int main(void)
{
    fit_grid("samples/spot.obj");
    fit_grid("samples/cow.obj");
    cube_exact();
    winding_accuracy("samples/spot.obj");
    winding_accuracy("samples/teapot.obj");
    const char *closed[] = {"samples/spot.obj", "samples/cow.obj", "samples/bunny00.off.gz", "samples/knot1.off",
                            "samples/larger_sphere.off"};
    for (size_t i = 0; i < sizeof closed / sizeof *closed; ++i) closed_volume(closed[i], 64, 0.02);
    open_bunny();
    open_mesh("samples/ChineseDragon-10kv.off.gz", 0.05, 0.6, 0);
    open_mesh("samples/head.off", 0.3, 0.8, 1);
    open_mesh("samples/teapot.obj", 0.2, 0.7, 0);
    return check_summary();
}
