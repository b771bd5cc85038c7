/* test_scan_extent.c — a scan's object ends where the scan ends (docs/scans.md;
 * the rule is in src/input/scan.h).  Every scene runs through the action
 * chain, as `ohm -read ... -voxelize threshold=...` runs it:
 *
 *  - MCX's cube60 set-up: 61^3 voxels of ones on the nodes 0..60 mm give
 *    exactly the 60^3 cells of 1 mm between them, at any threshold up to the
 *    value (the margin used to fill: 68^3 cells), and a smaller cube of ones
 *    is lit by a pencil beam that starts 2 mm outside it (it was refused as
 *    "inside the object"): power in = 1 W at eta 1, conserved.
 *  - A .vdb of values 1..2 over background 0 is its active box; with a
 *    background of 3, above the threshold, still its box, never past it;
 *    and outside the box the scan reads as the grid's background.
 *  - A scan cropped inside an object (no background anywhere) is its box,
 *    and a light from outside lights its whole top.
 *  - The two-layer slab: a .vdb of 120 x 120 x 48 voxels of
 *    0.25 mm, density 1 in the top 3 mm and 2 below, background 0, through a
 *    transfer function, voxel=0.5, lit from above: the object has the data's
 *    volume within a voxel layer, and the exitance at the top's centre is
 *    within 3% of the exact two-layer 1-D diffusion solution
 *    (studies/reference.h).  That needs the slab's lateral walls where the
 *    data ends: grown into the margin the slab was 8.6% off. */
#include "check.h"
#include "tmp_files.h" /* zlib.h before cholmod.h, which defines _LARGEFILE64_SOURCE */
#include "run_chain.h"
#include "ohm_vdb.h"
#include "input/scan.h"
#include "input/transfer.h"
#include "physics/fresnel.h"
#include "solvers/solve.h"
#include "studies/reference.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* A .vdb of one float grid "density": dims voxels from index 0, origin 0,
 * value(i, j, k, user) each, the rest of the world its background. */
typedef float (*voxel_value)(int i, int j, int k, const void *user);
static const char *write_vdb(const char *name, const int dims[3], voxel_value value, const void *user,
                             float background, double voxel)
{
    const char *path = tmp_path(name);
    size_t n = (size_t)dims[0] * (size_t)dims[1] * (size_t)dims[2], v = 0;
    int32_t *ijk = malloc(3 * n * sizeof *ijk);
    float *values = malloc(n * sizeof *values);
    ohm_error err;
    ohm_error_clear(&err);
    ohm_vdb_grid *g = NULL;
    const double origin[3] = {0, 0, 0};
    int rc = ijk && values ? 0 : -1;
    for (int k = 0; k < dims[2] && !rc; ++k)
        for (int j = 0; j < dims[1]; ++j)
            for (int i = 0; i < dims[0]; ++i, ++v) {
                ijk[3 * v] = i, ijk[3 * v + 1] = j, ijk[3 * v + 2] = k;
                values[v] = value(i, j, k, user);
            }
    if (!rc) rc = ohm_vdb_grid_create(&g, "density", OHM_VDB_CLASS_FOG_VOLUME, background, voxel, origin, &err);
    if (!rc) rc = ohm_vdb_grid_set_values(g, ijk, values, n, &err);
    if (!rc) rc = ohm_vdb_write(path, &g, 1, &err);
    CHECK_MSG(rc == 0, "writing %s: %s", path, err.msg);
    ohm_vdb_grid_free(g);
    free(ijk);
    free(values);
    return path;
}

/* 32-bit float raw volume of n voxels */
static const char *write_raw(const char *name, const float *values, size_t n)
{
    return write_tmp(name, values, n * sizeof *values);
}

static void test_cube60(void)
{
    enum { N = 61 };
    float *ones = malloc((size_t)N * N * N * sizeof *ones);
    if (!ones) return;
    for (size_t v = 0; v < (size_t)N * N * N; ++v) ones[v] = 1.0f;
    const char *cube = write_raw("cube60.raw", ones, (size_t)N * N * N);
    free(ones);
    char lines[1024];
    const double thresholds[] = {1.0, 0.5, 0.0, -1e6};
    for (size_t t = 0; t < sizeof thresholds / sizeof *thresholds; ++t) {
        snprintf(lines, sizeof lines, "read file=%s dims=61,61,61 type=f32 spacing=1\nvoxelize voxel=1 threshold=%g\n",
                 cube, thresholds[t]);
        long long cells = object_cells(lines);
        CHECK_MSG(cells == 60LL * 60 * 60, "cube of ones at threshold %g: %lld cells, expected 60^3 = 216000",
                  thresholds[t], cells);
    }
    snprintf(lines, sizeof lines, "read file=%s dims=61,61,61 type=f32 spacing=1\nvoxelize voxel=1 threshold=1.01\n",
             cube);
    CHECK_MSG(object_cells(lines) == 0, "a threshold above every value leaves no cell");

    /* lit from outside: a 21^3 cube (20^3 cells), the beam 2 mm above its
     * face, along +z into it (cube60's source, on a smaller cube) */
    enum { S = 21 };
    float small[S * S * S];
    for (size_t v = 0; v < (size_t)S * S * S; ++v) small[v] = 1.0f;
    const char *c21 = write_raw("cube20.raw", small, (size_t)S * S * S);
    snprintf(lines, sizeof lines,
             "read file=%s dims=21,21,21 type=f32 spacing=1\nvoxelize voxel=1 threshold=0.5\n"
             "material sigma_a=0.005 sigma_s=1 eta=1\nlight type=pencil pos=10,10,-2 dir=0,0,1 intensity=1\nsolve\n",
             c21);
    ohm_state s;
    if (run_lines(&s, lines) == 0) {
        const ohm_solution *sol = ohm_state_solution(&s);
        CHECK(s.grid.interior_cells == 20u * 20 * 20);
        CHECK(sol != NULL);
        if (sol) {
            /* eta 1: nothing is reflected, the beam's 1 W all enters */
            CHECK_REL(sol->power_entered, 1.0, 1e-12);
            CHECK_MSG(ohm_solution_conservation_error(sol) < 1e-10, "conservation %.3g",
                      ohm_solution_conservation_error(sol));
            CHECK_MSG(sol->power_absorbed > 0 && sol->power_out > 0, "absorbed %g, out %g", sol->power_absorbed,
                      sol->power_out);
        }
    }
    ohm_state_free(&s);
}

static float alternating(int i, int j, int k, const void *user)
{
    (void)user;
    return 1.0f + (float)((i + j + k) % 2);
}

static void test_vdb_box(void)
{
    const int dims[3] = {10, 8, 6};
    const long long box = 9LL * 7 * 5; /* cells of 1 mm between the voxel centres */
    char lines[1024];
    const char *zero = write_vdb("box0.vdb", dims, alternating, NULL, 0.0f, 1.0);
    snprintf(lines, sizeof lines, "read file=%s\nvoxelize voxel=1 threshold=0.5\n", zero);
    CHECK_MSG(object_cells(lines) == box, "values 1..2 over background 0: expected the active box's %lld cells", box);
    /* a background above the threshold: the object still ends at the box */
    const char *three = write_vdb("box3.vdb", dims, alternating, NULL, 3.0f, 1.0);
    snprintf(lines, sizeof lines, "read file=%s\nvoxelize voxel=1 threshold=0.5\n", three);
    CHECK_MSG(object_cells(lines) == box, "background 3 above threshold 0.5: expected the box's %lld cells", box);
    snprintf(lines, sizeof lines, "read file=%s\nvoxelize voxel=1 threshold=2.5\n", three);
    CHECK_MSG(object_cells(lines) == 0, "no voxel reaches 2.5: the background past the box is no object");

    /* outside its box a .vdb reads as its own background, not its lowest value */
    ohm_scan scan;
    ohm_error err;
    ohm_error_clear(&err);
    if (ohm_scan_read(&scan, three, NULL, &err) == 0) {
        const double far[3] = {100, 4, 3}, inside[3] = {1, 0, 0}, edge[3] = {-0.5, 0, 0};
        CHECK_MSG(scan.background == 3.0 && scan.min == 1.0, "background %g, min %g", scan.background, scan.min);
        CHECK(ohm_scan_sample(&scan, far) == 3.0);
        CHECK(ohm_scan_sample(&scan, inside) == 2.0);
        CHECK(ohm_scan_box_distance(&scan, far) > 90 && ohm_scan_box_distance(&scan, inside) < 0);
        CHECK(fabs(ohm_scan_box_distance(&scan, edge) - 0.5) < 1e-4);
        CHECK(ohm_scan_sample_clamped(&scan, edge) == 1.0); /* voxel (0,0,0)'s value */
        ohm_scan_free(&scan);
    } else {
        CHECK_MSG(0, "%s", err.msg);
    }
}

static void test_cropped(void)
{
    /* a CT cropped inside the body: every voxel tissue, none background */
    enum { NX = 12, NY = 10, NZ = 8 };
    float v[NX * NY * NZ];
    for (int k = 0; k < NZ; ++k)
        for (int j = 0; j < NY; ++j)
            for (int i = 0; i < NX; ++i) v[(k * NY + j) * NX + i] = 500.0f + 37.0f * (float)((7 * i + 3 * j + k) % 5);
    const char *raw = write_tmp_gz("cropped.raw.gz", v, sizeof v);
    char lines[1024];
    snprintf(lines, sizeof lines,
             "read file=%s dims=12,10,8 type=f32 spacing=1\nvoxelize voxel=1 threshold=400\n"
             "material sigma_a=0.01 sigma_s=1\nlight type=directional dir=0,0,-1 intensity=1\nsolve\n",
             raw);
    ohm_state s;
    if (run_lines(&s, lines) == 0) {
        CHECK_MSG(s.grid.interior_cells == 11u * 9 * 7, "cropped scan: %zu cells, expected its box's 693",
                  s.grid.interior_cells);
        const ohm_solution *sol = ohm_state_solution(&s);
        if (sol) {
            /* the whole top, 11 x 9 faces of 1 mm^2, lit at 1 W/mm^2 */
            CHECK_REL(sol->power_incident, 99.0, 1e-12);
            CHECK_MSG(ohm_solution_conservation_error(sol) < 1e-10, "conservation %.3g",
                      ohm_solution_conservation_error(sol));
        }
    }
    ohm_state_free(&s);
}

typedef struct slab {
    int top_voxels; /* the voxels of density 1 at the top (highest k) */
    int nz;
} slab;

static float slab_density(int i, int j, int k, const void *user)
{
    (void)i, (void)j;
    const slab *sl = user;
    return k >= sl->nz - sl->top_voxels ? 1.0f : 2.0f;
}

static void test_two_layer_slab(void)
{
    const int dims[3] = {120, 120, 48};
    const double spacing = 0.25, h = 0.5;
    const slab sl = {12, 48}; /* the top 3 mm */
    const char *vdb = write_vdb("slab.vdb", dims, slab_density, &sl, 0.0f, spacing);
    static const char tf_text[] = "ohm-transfer 1 eta=1.3\n"
                                  "# density  sigma_a  sigma_s'\n"
                                  "1  0.02  1.0\n"
                                  "2  0.1   2.0\n";
    const char *tf = write_tmp("slab.transfer", tf_text, sizeof tf_text - 1);
    char lines[1024];
    snprintf(lines, sizeof lines,
             "read file=%s\nvoxelize voxel=%g threshold=0.5\nmaterial transfer=%s\n"
             "light type=directional dir=0,0,-1 intensity=1\nsolve\n",
             vdb, h, tf);
    ohm_state s;
    if (run_lines(&s, lines) != 0) {
        ohm_state_free(&s);
        return;
    }
    const ohm_voxel_grid *g = &s.grid;
    /* the data's volume: the hull of the voxel centres, 29.75 x 29.75 x 11.75 mm */
    const double data = (119 * spacing) * (119 * spacing) * (47 * spacing);
    const double layer = 2 * (119 * spacing * 119 * spacing + 2 * 119 * spacing * 47 * spacing) * h;
    const double volume = (double)g->interior_cells * h * h * h;
    printf("two-layer slab from a .vdb: %zu cells, %.6g mm^3 (the data %.6g mm^3, a voxel layer %.4g mm^3)\n",
           g->interior_cells, volume, data, layer);
    CHECK_MSG(fabs(volume - data) <= layer, "the object is %.6g mm^3, the data %.6g mm^3: more than a voxel layer "
                                            "(%.4g mm^3) apart", volume, data, layer);

    const ohm_solution *sol = ohm_state_solution(&s);
    double *exitance = sol ? malloc((size_t)sol->n * sizeof *exitance) : NULL;
    if (!exitance) {
        CHECK_MSG(0, "no solution");
        ohm_state_free(&s);
        return;
    }
    ohm_solution_exitance_frame(exitance, sol, 0, 0);
    /* the top cell of the column nearest the slab's centre (x = y = 14.875) */
    int ic = (int)lround((14.875 - g->origin[0]) / h), jc = (int)lround((14.875 - g->origin[1]) / h), kc = -1;
    for (int k = g->dims[2] - 1; k >= 0 && kc < 0; --k)
        if (g->inside[ohm_voxel_index(g, ic, jc, k)]) kc = k;
    CHECK(kc >= 0);
    if (kc >= 0) {
        int64_t u = ohm_network_unknown(&sol->net, ohm_voxel_index(g, ic, jc, kc));
        /* the data's layers, each voxel a cube about its centre: 3 mm of
         * density 1 over 9 mm of 2; the object's column has the same */
        const double L0 = sl.top_voxels * spacing, L1 = (sl.nz - sl.top_voxels) * spacing;
        int top = 0, all = 0;
        for (int k = kc; k >= 0 && g->inside[ohm_voxel_index(g, ic, jc, k)]; --k, ++all) {
            const double c[3] = {g->origin[0] + h * ic, g->origin[1] + h * jc, g->origin[2] + h * k};
            top += ohm_scan_sample(&s.scan, c) < 1.5;
        }
        CHECK_MSG(fabs(top * h - L0) < 1e-9 && fabs(all * h - (L0 + L1)) < 1e-9,
                  "the centre column is %g mm of density 1 over %g mm, the data %g over %g", top * h,
                  (all - top) * h, L0, L1);
        const double eta = 1.3, T = 1.0 - ohm_fresnel_reflectance(eta, 1.0);
        const ohm_ref_layer layers[2] = {{0.02, 1.0, eta, L0}, {0.1, 2.0, eta, L1}};
        ohm_ref_two_layer ref;
        CHECK(ohm_ref_two_layer_init(&ref, layers, T) == 0);
        const double want = ohm_ref_two_layer_phi(&ref, 0) / (2 * ohm_boundary_A(eta, OHM_FRESNEL_EXACT));
        const double got = exitance[u], rel = fabs(got - want) / want;
        printf("two-layer slab: top exitance at the centre %.6g W/mm^2, exact two-layer diffusion %.6g "
               "(layers %.3g + %.3g mm): %.2f%% apart\n",
               got, want, L0, L1, 100 * rel);
        CHECK_MSG(rel < 0.03, "top exitance %.6g vs exact %.6g: %.2f%% apart (at most 3%%)", got, want, 100 * rel);
        CHECK_MSG(ohm_solution_conservation_error(sol) < 1e-10, "conservation %.3g",
                  ohm_solution_conservation_error(sol));
    }
    free(exitance);
    ohm_state_free(&s);
}

int main(void)
{
    if (tmp_begin("ohm_scan_extent")) return 1;
    test_cube60();
    test_vdb_box();
    test_cropped();
    test_two_layer_slab();
    cleanup_tmp();
    return check_summary();
}
