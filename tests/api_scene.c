/* api_scene.c — the public API (include/ohm.h), through libohm.so only:
 *  - errors: every failure leaves a message naming what is wrong, never NULL;
 *    free functions accept NULL;
 *  - a scene built step by step conserves power and reports it;
 *  - the log and progress callbacks receive the run's messages;
 *  - relighting reuses the factor (no factorization after the first solve)
 *    and gives, for each light, the fluence a fresh scene's solve gives, to
 *    1e-12;
 *  - a mesh handed over as arrays gives the same cells and fluence as the
 *    same mesh read from its file; a density volume handed over as an array
 *    voxelizes by threshold to the cells above it;
 *  - a process that loads libohm still maps its large blocks and returns
 *    them when freed (a dependency's constructor turns that off: base/memory.c). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "ohm.h"

#if defined(__GLIBC__) && !defined(__SANITIZE_ADDRESS__)
#include <malloc.h>
#endif

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

typedef struct captured {
    int messages, warnings, progress_calls;
    char last[512];
} captured;

static void on_log(void *user, int level, const char *text)
{
    captured *c = user;
    c->messages++;
    c->warnings += level == OHM_LOG_WARNING;
    snprintf(c->last, sizeof c->last, "%s", text);
}

static void on_progress(void *user, const char *what, double fraction)
{
    captured *c = user;
    if (what && fraction >= 0 && fraction <= 1) c->progress_calls++;
}

static ohm_scene *cube_scene(ohm_context *ctx, const char *dim)
{
    ohm_scene *scene = NULL;
    const char *read[] = {"file=samples/larger_sphere.off", "size=20", NULL};
    const char *vox[] = {dim, NULL};
    const char *mat[] = {"preset=skin1", NULL};
    if (ohm_scene_new(&scene, ctx) || ohm_scene_run(scene, "read", read) || ohm_scene_run(scene, "voxelize", vox) ||
        ohm_scene_run(scene, "material", mat)) {
        CHECK_MSG(0, "%s", ohm_error_last());
        ohm_scene_free(scene);
        return NULL;
    }
    return scene;
}

static void errors(void)
{
    ohm_context_free(NULL);
    ohm_scene_free(NULL);
    CHECK(ohm_error_last() != NULL);
    int major = -1, minor = -1, patch = -1;
    const char *v = ohm_version(&major, &minor, &patch);
    char expect[32];
    snprintf(expect, sizeof expect, "%d.%d.%d", OHM_VERSION_MAJOR, OHM_VERSION_MINOR, OHM_VERSION_PATCH);
    CHECK_MSG(strcmp(v, expect) == 0 && major == OHM_VERSION_MAJOR && minor == OHM_VERSION_MINOR &&
                  patch == OHM_VERSION_PATCH,
              "library %s, header %s", v, expect);

    ohm_context *ctx = NULL;
    CHECK(ohm_context_new(&ctx) == OHM_OK);
    ohm_context_set_verbosity(ctx, 0);
    ohm_scene *scene = NULL;
    CHECK(ohm_scene_new(&scene, NULL) == OHM_ERR_USAGE && scene == NULL);
    CHECK(strstr(ohm_error_last(), "no context") != NULL);
    CHECK(ohm_scene_new(&scene, ctx) == OHM_OK);
    const char *typo[] = {"dimm=8", NULL};
    CHECK(ohm_scene_run(scene, "voxelize", typo) == OHM_ERR_USAGE);
    CHECK_MSG(strstr(ohm_error_last(), "did you mean 'dim'") != NULL, "%s", ohm_error_last());
    CHECK(ohm_error_last_code() == OHM_ERR_USAGE);
    CHECK(ohm_scene_run(scene, "raed", NULL) == OHM_ERR_USAGE);
    CHECK_MSG(strstr(ohm_error_last(), "'-read'") != NULL, "%s", ohm_error_last());
    const char *missing[] = {"file=samples/no-such-file.obj", NULL};
    CHECK(ohm_scene_run(scene, "read", missing) < 0);
    CHECK_MSG(strstr(ohm_error_last(), "no-such-file.obj") != NULL, "%s", ohm_error_last());
    CHECK(ohm_scene_relight(scene) == OHM_ERR_INVALID);
    CHECK_MSG(strstr(ohm_error_last(), "solve first") != NULL, "%s", ohm_error_last());
    ohm_grid_info gi = OHM_GRID_INFO_INIT;
    CHECK(ohm_scene_grid(&gi, scene) == OHM_ERR_INVALID);
    CHECK_MSG(strstr(ohm_error_last(), "voxelize first") != NULL, "%s", ohm_error_last());
    const double pos[] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const int64_t bad[] = {0, 1, 3};
    CHECK(ohm_scene_set_mesh(scene, pos, 3, bad, 1, "tri") == OHM_ERR_INVALID);
    CHECK_MSG(strstr(ohm_error_last(), "tri: triangle 0 refers to vertex 3") != NULL, "%s", ohm_error_last());
    const float vals[8] = {0};
    const int64_t dims[3] = {2, 2, 2};
    const double singular[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0};
    CHECK(ohm_scene_set_density(scene, vals, dims, singular, "flat") == OHM_ERR_INVALID);
    CHECK_MSG(strstr(ohm_error_last(), "flat: index_to_world is singular") != NULL, "%s", ohm_error_last());
    ohm_scene_free(scene);
    ohm_context_free(ctx);
}

/* Fluence of channel 0, frame 0, over the grid (malloc'd), or NULL. */
static double *fluence_of(const ohm_scene *scene, size_t *count)
{
    ohm_grid_info gi = OHM_GRID_INFO_INIT;
    if (ohm_scene_grid(&gi, scene)) return NULL;
    *count = (size_t)gi.cells;
    double *phi = malloc(*count * sizeof *phi);
    if (phi && ohm_scene_fluence(phi, *count, scene, 0, 0)) {
        CHECK_MSG(0, "%s", ohm_error_last());
        free(phi);
        return NULL;
    }
    return phi;
}

static double max_rel_diff(const double *a, const double *b, size_t n)
{
    double worst = 0, scale = 0;
    for (size_t i = 0; i < n; ++i) {
        worst = fmax(worst, fabs(a[i] - b[i]));
        scale = fmax(scale, fabs(b[i]));
    }
    return scale > 0 ? worst / scale : worst;
}

/* A polling context (ohm_context_poll_progress): no callback, nothing on
 * stderr; ohm_context_progress gives the latest report, and a step's last
 * is its end (fraction 1). */
static void polled_progress(void)
{
    ohm_context *ctx = NULL;
    CHECK(ohm_context_new(&ctx) == OHM_OK);
    ohm_context_poll_progress(ctx);
    char what[64] = "x";
    double fraction = -1;
    CHECK(ohm_context_progress(ctx, what, sizeof what, &fraction) == OHM_OK && what[0] == 0 && fraction == 0);
    ohm_scene *scene = cube_scene(ctx, "dim=20");
    if (!scene) return;
    const char *light[] = {"type=directional", "dir=0,-1,0", NULL};
    CHECK(ohm_scene_add_light(scene, light) == OHM_OK);
    CHECK(ohm_scene_solve(scene, NULL) == OHM_OK);
    CHECK(ohm_context_progress(ctx, what, sizeof what, &fraction) == OHM_OK);
    CHECK_MSG(strncmp(what, "solve", 5) == 0 && fraction == 1.0, "last report %s %g", what, fraction);
    char shortened[4];
    CHECK(ohm_context_progress(ctx, shortened, sizeof shortened, NULL) == OHM_OK && strlen(shortened) == 3);
    CHECK(ohm_context_progress(NULL, what, sizeof what, &fraction) == OHM_ERR_USAGE);
    ohm_scene_free(scene);
    ohm_context_free(ctx);
}

static void solve_and_relight(void)
{
    ohm_context *ctx = NULL;
    captured cap;
    memset(&cap, 0, sizeof cap);
    CHECK(ohm_context_new(&ctx) == OHM_OK);
    ohm_context_set_log(ctx, on_log, &cap);
    ohm_context_set_progress(ctx, on_progress, &cap);
    ohm_scene *scene = cube_scene(ctx, "dim=20");
    if (!scene) return;
    CHECK_MSG(cap.messages >= 3, "%d messages through the callback", cap.messages);
    const char *dirs[3][4] = {{"type=directional", "dir=0,-1,0", NULL},
                              {"type=directional", "dir=1,0,0", NULL},
                              {"type=point", "pos=0,40,10", "intensity=2000", NULL}};
    /* the factor, named: relighting it is what this tests (the default,
     * solver=auto, takes multigrid for one light) */
    const char *direct[] = {"solver=direct", NULL};
    CHECK(ohm_scene_add_light(scene, dirs[0]) == OHM_OK);
    CHECK(ohm_scene_solve(scene, direct) == OHM_OK);
    CHECK_MSG(strstr(cap.last, "") != NULL && cap.messages > 5, "%d messages", cap.messages);
    CHECK_MSG(cap.progress_calls >= 1, "%d progress calls", cap.progress_calls);
    ohm_result_info r = OHM_RESULT_INFO_INIT;
    CHECK(ohm_scene_result(&r, scene) == OHM_OK);
    int factors = r.factorizations;
    CHECK_MSG(factors == 3, "%d factorizations for skin1's 3 channels", factors);
    CHECK(r.channels == 3 && r.frames == 1 && r.unknowns > 1000);
    CHECK_MSG(fabs(r.power_in - r.power_absorbed - r.power_out) <= 1e-12 * r.power_in,
              "in %.17g absorbed %.17g out %.17g", r.power_in, r.power_absorbed, r.power_out);
    CHECK(r.power_in > 0 && r.power_in <= r.power_entered && r.power_entered <= r.power_incident);
    double stat_out = 0;
    CHECK(ohm_scene_stat(&stat_out, scene, "power_out") == OHM_OK && stat_out == r.power_out);
    const char *solver = NULL;
    CHECK(ohm_scene_stat_text(&solver, scene, "solver") == OHM_OK && solver && strcmp(solver, "direct") == 0);

    /* the exitance is what leaves: summed over cells' faces, power_out
     * (per channel 0: face area h^2 times the mean of a cell's faces times
     * their count is not recoverable here, so check its sign and support) */
    size_t n = 0;
    double *phi0 = fluence_of(scene, &n);
    double *ex = malloc(n * sizeof *ex);
    uint8_t *inside = malloc(n);
    CHECK(ex && inside && ohm_scene_exitance(ex, n, scene, 0, 0) == OHM_OK && ohm_scene_inside(inside, n, scene) == 0);
    size_t lit = 0, outside_nonzero = 0;
    for (size_t i = 0; ex && inside && i < n; ++i) {
        lit += ex[i] > 0;
        outside_nonzero += !inside[i] && (ex[i] != 0 || phi0[i] != 0);
    }
    CHECK_MSG(lit > 100 && outside_nonzero == 0, "%zu cells with exitance, %zu outside cells with values", lit,
              outside_nonzero);
    free(ex);
    free(inside);
    float *vx = NULL;
    size_t nv = 0;
    double nverts = 0;
    CHECK(ohm_scene_stat(&nverts, scene, "mesh_vertices") == OHM_OK);
    nv = (size_t)nverts * 3;
    vx = malloc(nv * sizeof *vx);
    CHECK(vx && ohm_scene_vertex_exitance(vx, nv, scene, 0) == OHM_OK);
    size_t vpos = 0;
    for (size_t i = 0; vx && i < nv; ++i) vpos += vx[i] > 0;
    CHECK_MSG(vpos > nv / 4, "%zu of %zu vertex values lit", vpos, nv);
    free(vx);

    /* relight: new lights, the same factors; each equals a fresh scene's solve */
    for (int k = 1; k < 3; ++k) {
        CHECK(ohm_scene_clear_lights(scene) == OHM_OK);
        CHECK(ohm_scene_result(&r, scene) == OHM_ERR_INVALID); /* stale until relit */
        CHECK(ohm_scene_add_light(scene, dirs[k]) == OHM_OK);
        CHECK(ohm_scene_relight(scene) == OHM_OK);
        CHECK(ohm_scene_result(&r, scene) == OHM_OK);
        CHECK_MSG(r.factorizations == factors, "relight %d: %d factorizations, expected %d", k, r.factorizations,
                  factors);
        CHECK(fabs(r.power_in - r.power_absorbed - r.power_out) <= 1e-12 * r.power_in);
        size_t n1 = 0, n2 = 0;
        double *relit = fluence_of(scene, &n1);
        ohm_scene *fresh = cube_scene(ctx, "dim=20");
        double *ref = NULL;
        if (fresh && ohm_scene_add_light(fresh, dirs[k]) == OHM_OK && ohm_scene_solve(fresh, direct) == OHM_OK)
            ref = fluence_of(fresh, &n2);
        CHECK(relit && ref && n1 == n2);
        if (relit && ref && n1 == n2)
            CHECK_MSG(max_rel_diff(relit, ref, n1) <= 1e-12, "relight %d differs from a fresh solve by %.3g", k,
                      max_rel_diff(relit, ref, n1));
        free(relit);
        free(ref);
        ohm_scene_free(fresh);
    }
    /* a new material needs a new solve */
    const char *marble[] = {"preset=marble", NULL};
    CHECK(ohm_scene_run(scene, "material", marble) == OHM_OK);
    CHECK(ohm_scene_relight(scene) == OHM_ERR_INVALID);
    free(phi0);
    ohm_scene_free(scene);
    ohm_context_free(ctx);
}

/* A sphere as arrays (a UV sphere of radius 10 mm) against itself as OFF. */
static void mesh_arrays(void)
{
    enum { RINGS = 12, SEGS = 24 };
    size_t nv = 2 + (RINGS - 1) * SEGS, nt = 2 * SEGS * (RINGS - 1);
    double *pos = malloc(3 * nv * sizeof *pos);
    int64_t *tri = malloc(3 * nt * sizeof *tri);
    pos[0] = 0, pos[1] = 0, pos[2] = 10;
    pos[3] = 0, pos[4] = 0, pos[5] = -10;
    for (int r = 1; r < RINGS; ++r)
        for (int s = 0; s < SEGS; ++s) {
            double th = M_PI * r / RINGS, ph = 2 * M_PI * s / SEGS;
            size_t v = 2 + (size_t)(r - 1) * SEGS + (size_t)s;
            pos[3 * v] = 10 * sin(th) * cos(ph);
            pos[3 * v + 1] = 10 * sin(th) * sin(ph);
            pos[3 * v + 2] = 10 * cos(th);
        }
    size_t t = 0;
#define RV(r, s) ((int64_t)(2 + (size_t)((r) - 1) * SEGS + (size_t)(((s) + SEGS) % SEGS)))
    for (int s = 0; s < SEGS; ++s) {
        tri[3 * t] = 0, tri[3 * t + 1] = RV(1, s), tri[3 * t + 2] = RV(1, s + 1), ++t;
        tri[3 * t] = 1, tri[3 * t + 1] = RV(RINGS - 1, s + 1), tri[3 * t + 2] = RV(RINGS - 1, s), ++t;
    }
    for (int r = 1; r < RINGS - 1; ++r)
        for (int s = 0; s < SEGS; ++s) {
            tri[3 * t] = RV(r, s), tri[3 * t + 1] = RV(r + 1, s), tri[3 * t + 2] = RV(r + 1, s + 1), ++t;
            tri[3 * t] = RV(r, s), tri[3 * t + 1] = RV(r + 1, s + 1), tri[3 * t + 2] = RV(r, s + 1), ++t;
        }
#undef RV
    CHECK(t == nt);
    /* the same mesh as an OFF file */
    const char *off = "api_sphere.off";
    FILE *f = fopen(off, "w");
    CHECK(f != NULL);
    if (!f) return;
    fprintf(f, "OFF\n%zu %zu 0\n", nv, nt);
    for (size_t v = 0; v < nv; ++v) fprintf(f, "%.17g %.17g %.17g\n", pos[3 * v], pos[3 * v + 1], pos[3 * v + 2]);
    for (size_t q = 0; q < nt; ++q) fprintf(f, "3 %lld %lld %lld\n", (long long)tri[3 * q], (long long)tri[3 * q + 1],
                                            (long long)tri[3 * q + 2]);
    fclose(f);

    ohm_context *ctx = NULL;
    CHECK(ohm_context_new(&ctx) == OHM_OK);
    ohm_context_set_verbosity(ctx, 0);
    const char *vox[] = {"dim=16", NULL}, *mat[] = {"preset=marble", NULL};
    const char *light[] = {"type=directional", "dir=0,0,-1", NULL};
    const char *read[] = {"file=api_sphere.off", NULL};
    ohm_scene *a = NULL, *b = NULL;
    CHECK(ohm_scene_new(&a, ctx) == 0 && ohm_scene_new(&b, ctx) == 0);
    CHECK(ohm_scene_set_mesh(a, pos, nv, tri, nt, "uv sphere") == OHM_OK);
    CHECK(ohm_scene_run(b, "read", read) == OHM_OK);
    ohm_scene *both[2] = {a, b};
    for (int q = 0; q < 2; ++q)
        CHECK_MSG(ohm_scene_run(both[q], "voxelize", vox) == 0 && ohm_scene_run(both[q], "material", mat) == 0 &&
                      ohm_scene_add_light(both[q], light) == 0 && ohm_scene_solve(both[q], NULL) == 0,
                  "%s", ohm_error_last());
    size_t na = 0, nb = 0;
    double *pa = fluence_of(a, &na), *pb = fluence_of(b, &nb);
    CHECK(pa && pb && na == nb && na > 0);
    if (pa && pb && na == nb) CHECK_MSG(max_rel_diff(pa, pb, na) == 0, "arrays and file differ by %.3g", max_rel_diff(pa, pb, na));
    free(pa);
    free(pb);
    ohm_scene_free(a);
    ohm_scene_free(b);
    remove(off);
    free(pos);
    free(tri);

    /* a density volume by threshold: the cells whose density is above it */
    enum { N = 12 };
    float *vol = malloc(N * N * N * sizeof *vol);
    size_t above = 0;
    for (int k = 0; k < N; ++k)
        for (int j = 0; j < N; ++j)
            for (int i = 0; i < N; ++i) {
                int in = i >= 3 && i < 9 && j >= 2 && j < 10 && k >= 4 && k < 8;
                vol[i + N * (j + N * k)] = in ? 100.0f : 0.0f;
                above += in;
            }
    const int64_t dims[3] = {N, N, N};
    const double m[12] = {2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0}; /* 2 mm voxels, as a raw file's spacing=2 */
    const char *raw = "api_box.raw";
    f = fopen(raw, "wb");
    CHECK(f && fwrite(vol, sizeof *vol, N * N * N, f) == N * N * N);
    if (f) fclose(f);
    const char *read_raw[] = {"file=api_box.raw", "dims=12,12,12", "type=f32", "spacing=2", NULL};
    const char *thr[] = {"threshold=50", "voxel=0.5", NULL};
    ohm_scene *d = NULL, *e = NULL;
    CHECK(ohm_scene_new(&d, ctx) == 0 && ohm_scene_new(&e, ctx) == 0);
    CHECK(ohm_scene_set_density(d, vol, dims, m, "box volume") == OHM_OK);
    CHECK_MSG(ohm_scene_run(e, "read", read_raw) == OHM_OK, "%s", ohm_error_last());
    CHECK_MSG(ohm_scene_run(d, "voxelize", thr) == OHM_OK && ohm_scene_run(e, "voxelize", thr) == OHM_OK, "%s",
              ohm_error_last());
    ohm_grid_info gd = OHM_GRID_INFO_INIT, ge = OHM_GRID_INFO_INIT;
    CHECK(ohm_scene_grid(&gd, d) == OHM_OK && ohm_scene_grid(&ge, e) == OHM_OK);
    CHECK_MSG(gd.interior_cells == ge.interior_cells && gd.cells == ge.cells && gd.voxel == ge.voxel,
              "array: %lld of %lld cells, file: %lld of %lld", (long long)gd.interior_cells, (long long)gd.cells,
              (long long)ge.interior_cells, (long long)ge.cells);
    /* the iso-surface at 50 lies halfway between voxel centres: the object is
     * the box of the voxels above it, 12 x 16 x 8 mm, to within half a cell
     * of its 832 mm^2 surface */
    double volume = (double)gd.interior_cells * gd.voxel * gd.voxel * gd.voxel, box = 8.0 * (double)above;
    CHECK_MSG(fabs(volume - box) <= 0.5 * gd.voxel * 832.0, "object %.1f mm^3, box %.1f mm^3", volume, box);
    /* a uniform array is its box, the 11^3 steps of 2 mm between its
     * outermost voxel centres, never the grid's margin (docs/scans.md) */
    for (size_t v = 0; v < (size_t)N * N * N; ++v) vol[v] = 100.0f;
    const char *thr1[] = {"threshold=50", "voxel=1", NULL};
    CHECK(ohm_scene_set_density(d, vol, dims, m, "uniform volume") == OHM_OK);
    CHECK_MSG(ohm_scene_run(d, "voxelize", thr1) == OHM_OK && ohm_scene_grid(&gd, d) == OHM_OK, "%s",
              ohm_error_last());
    CHECK_MSG(gd.interior_cells == 22LL * 22 * 22, "uniform array: %lld cells, expected its box's 22^3",
              (long long)gd.interior_cells);
    ohm_scene_free(e);
    remove(raw);
    ohm_scene_free(d);
    free(vol);
    ohm_context_free(ctx);
}

static int estimate_at(ohm_estimate_info *e, const ohm_scene *scene, int dim, const char *solver, const char *solves,
                       const char *max_memory)
{
    char d[32], sv[32], n[32], mm[48];
    snprintf(d, sizeof d, "dim=%d", dim);
    snprintf(sv, sizeof sv, "solver=%s", solver);
    snprintf(n, sizeof n, "solves=%s", solves);
    snprintf(mm, sizeof mm, "max_memory=%s", max_memory);
    const char *opts[] = {d, sv, n, mm, NULL};
    *e = (ohm_estimate_info)OHM_ESTIMATE_INFO_INIT;
    return ohm_scene_estimate(e, scene, opts);
}

/* ohm_scene_estimate: the library's own prediction of a solve's memory and
 * of solver=auto's choice, before anything is built (what the Blender
 * add-on asks instead of carrying a model of its own) */
static void estimates(void)
{
    ohm_context *ctx = NULL;
    CHECK(ohm_context_new(&ctx) == OHM_OK);
    ohm_context_set_verbosity(ctx, 0);
    ohm_scene *scene = cube_scene(ctx, "dim=24");
    if (!scene) return;
    ohm_grid_info g = OHM_GRID_INFO_INIT;
    ohm_estimate_info e, f;
    CHECK(ohm_scene_grid(&g, scene) == OHM_OK);
    /* the interior cells at the grid's own dim: the sphere's volume over h^3 */
    CHECK_MSG(estimate_at(&e, scene, 24, "mg", "1", "100000") == OHM_OK, "%s", ohm_error_last());
    CHECK_MSG(fabs((double)e.interior_cells - (double)g.interior_cells) < 0.15 * (double)g.interior_cells,
              "predicted %lld interior cells, voxelized %lld", (long long)e.interior_cells,
              (long long)g.interior_cells);
    CHECK(strcmp(e.solver, "mg") == 0 && strcmp(e.reason, "asked for") == 0 && e.margin > 1);
    /* a finer grid takes more with every solver, the factor more than in
     * proportion to the cells (its fill grows faster than n) */
    CHECK(estimate_at(&f, scene, 96, "mg", "1", "100000") == OHM_OK);
    CHECK(f.bytes_direct > e.bytes_direct && f.bytes_mg > e.bytes_mg && f.bytes_cg > e.bytes_cg &&
          f.bytes_amg > e.bytes_amg && f.bytes_auto > e.bytes_auto);
    double cells = (double)f.interior_cells / (double)e.interior_cells;
    CHECK_MSG((f.bytes_direct - e.bytes_direct) / (f.bytes_mg - e.bytes_mg) > 1.0 &&
                  f.bytes_direct - e.bytes_direct > cells * 0.5 * (e.bytes_direct - 95.0 * 1048576.0),
              "direct %g -> %g B, mg %g -> %g B", e.bytes_direct, f.bytes_direct, e.bytes_mg, f.bytes_mg);
    /* the largest dim named fits under max_memory with the margin, one more does not */
    CHECK(estimate_at(&e, scene, 24, "direct", "1", "400") == OHM_OK);
    int best = e.largest_dim;
    CHECK_MSG(best >= 4 && e.largest_dim_mg > best, "largest dim %d, with mg %d", best, e.largest_dim_mg);
    CHECK(estimate_at(&f, scene, best, "direct", "1", "400") == OHM_OK && f.margin * f.bytes_direct <= f.bytes_allowed);
    CHECK(estimate_at(&f, scene, best + 1, "direct", "1", "400") == OHM_OK && f.margin * f.bytes_direct > f.bytes_allowed);
    /* auto: the factor for many relights of a small grid; for one solve,
     * the probe's own (mg); never one that does not fit */
    CHECK(estimate_at(&e, scene, 24, "auto", "1000", "100000") == OHM_OK);
    CHECK_MSG(strcmp(e.solver, "direct") == 0 && strstr(e.reason, "direct") && strstr(e.reason, "mg"), "%s: %s",
              e.solver, e.reason);
    CHECK(estimate_at(&e, scene, 160, "auto", "1", "100000") == OHM_OK);
    CHECK_MSG(strcmp(e.solver, "mg") == 0, "%s: %s", e.solver, e.reason);
    CHECK(estimate_at(&e, scene, 400, "auto", "1000000", "2000") == OHM_OK);
    CHECK_MSG(strcmp(e.solver, "direct") != 0 && strstr(e.reason, "direct") && strstr(e.reason, "does not fit"),
              "%s: %s", e.solver, e.reason);
    /* bad calls: no dim=, a struct without its size, a scene without a mesh */
    const char *no_dim[] = {"solver=mg", NULL};
    e = (ohm_estimate_info)OHM_ESTIMATE_INFO_INIT;
    CHECK(ohm_scene_estimate(&e, scene, no_dim) == OHM_ERR_USAGE && strstr(ohm_error_last(), "needs dim="));
    const char *dim[] = {"dim=24", NULL};
    e.size = 0;
    CHECK(ohm_scene_estimate(&e, scene, dim) == OHM_ERR_USAGE && strstr(ohm_error_last(), "OHM_ESTIMATE_INFO_INIT"));
    ohm_scene *empty = NULL;
    CHECK(ohm_scene_new(&empty, ctx) == OHM_OK);
    CHECK(estimate_at(&e, empty, 24, "mg", "1", "100") == OHM_ERR_INVALID);
    /* a solve by default (solver=auto) says in the statistics what it took and why */
    const char *light[] = {"type=directional", "dir=0,-1,0", NULL};
    const char *text = NULL;
    CHECK(ohm_scene_add_light(scene, light) == OHM_OK && ohm_scene_solve(scene, NULL) == OHM_OK);
    CHECK_MSG(ohm_scene_stat_text(&text, scene, "solver_reason") == OHM_OK && text && strstr(text, "auto chooses"),
              "%s", text ? text : "");
    CHECK(ohm_scene_stat_text(&text, scene, "solver") == OHM_OK && text && strcmp(text, "mg") == 0);
    /* ... and the relight, a warm column timed, the choice and its prediction */
    CHECK(ohm_scene_relight(scene) == OHM_OK);
    CHECK_MSG(ohm_scene_stat_text(&text, scene, "solver_reason") == OHM_OK && text && strstr(text, "predicted"), "%s",
              text ? text : "");
    ohm_scene_free(empty);
    ohm_scene_free(scene);
    ohm_context_free(ctx);
}

/* The environment light through the API: a light like any other (options
 * to ohm_scene_add_light, nothing new in the ABI): power conserved, and a
 * relit sky of twice the radiance gives twice the fluence; a sky= that
 * cannot be read is refused with a message naming it. */
static void environment_light(void)
{
    ohm_context *ctx = NULL;
    CHECK(ohm_context_new(&ctx) == OHM_OK);
    ohm_scene *scene = cube_scene(ctx, "dim=16");
    if (!scene) return;
    const char *sky[] = {"type=environment", "intensity=0.001", NULL}, *brighter[] = {"type=environment",
                                                                                     "intensity=0.002", NULL};
    const char *missing[] = {"type=environment", "sky=no-such-sky.exr", NULL};
    CHECK(ohm_scene_add_light(scene, missing) != OHM_OK);
    CHECK_MSG(strstr(ohm_error_last(), "sky=") && strstr(ohm_error_last(), "no-such-sky.exr"), "%s",
              ohm_error_last());
    CHECK(ohm_scene_add_light(scene, sky) == OHM_OK);
    /* the factor, so that the relight's fluence is the first one's to round-off */
    const char *direct[] = {"solver=direct", NULL};
    CHECK_MSG(ohm_scene_solve(scene, direct) == OHM_OK, "%s", ohm_error_last());
    ohm_result_info r = OHM_RESULT_INFO_INIT;
    CHECK(ohm_scene_result(&r, scene) == OHM_OK);
    CHECK(r.power_incident > 0 && fabs(r.power_absorbed + r.power_out - r.power_in) <= 1e-10 * r.power_in);
    size_t n1 = 0, n2 = 0;
    double *once = fluence_of(scene, &n1);
    CHECK(ohm_scene_clear_lights(scene) == OHM_OK && ohm_scene_add_light(scene, brighter) == OHM_OK);
    CHECK_MSG(ohm_scene_relight(scene) == OHM_OK, "%s", ohm_error_last());
    double *twice = fluence_of(scene, &n2);
    if (once && twice && n1 == n2) {
        for (size_t i = 0; i < n1; ++i) once[i] *= 2;
        CHECK_MSG(max_rel_diff(twice, once, n1) < 1e-9, "relit: %g", max_rel_diff(twice, once, n1));
    }
    free(once);
    free(twice);
    ohm_scene_free(scene);
    ohm_context_free(ctx);
}

/* A 64 MiB array is a mapping of its own while it lives (libohm maps
 * blocks of 8 MiB and more), so that freeing it gives its pages back: with mmap
 * turned off, as SuperLU_DIST's load-time constructor leaves it, it comes
 * from the heap and stays resident after the free.  (glibc only; under
 * ASan the allocator is ASan's.) */
static void large_blocks_mapped(void)
{
#if defined(__GLIBC__) && !defined(__SANITIZE_ADDRESS__)
    size_t before = mallinfo2().hblkhd, size = (size_t)64 << 20;
    char *block = malloc(size);
    CHECK(block != NULL);
    if (!block) return;
    memset(block, 1, size);
    size_t during = mallinfo2().hblkhd;
    printf("large blocks: %zu B mapped with a 64 MiB array, %zu before\n", during, before);
    CHECK(during >= before + size);
    free(block);
#endif
}

int main(void)
{
    large_blocks_mapped();
    errors();
    estimates();
    solve_and_relight();
    polled_progress();
    mesh_arrays();
    environment_light();
    return check_summary();
}
