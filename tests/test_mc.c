/* test_mc.c — the Monte Carlo transport reference (mc.h):
 *
 *  - against published transport values (ohm_validate_mc, validate.h): van de
 *    Hulst's matched slab (MCML's check), MCML's half-space under air, MCX's
 *    cube60 absorbed fraction, and the half-space under a clear layer of
 *    index 1 (the Fresnel interface inside the object, between cells), each
 *    within 4 combined standard errors;
 *  - its bookkeeping through ohm_solve: power in = absorbed + out to
 *    round-off, the faces' exitance summing to what left;
 *  - a seed repeats a run bit for bit, another seed gives another sample, and
 *    the standard errors are honest: two seeds differ cell by cell by about
 *    sqrt(se1^2 + se2^2). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "studies/scene.h"
#include "solvers/solve.h"
#include "studies/validate.h"

static void test_published(void)
{
    ohm_validation v;
    memset(&v, 0, sizeof v);
    ohm_log quiet = {.verbosity = 0};
    ohm_error err = {0};
    CHECK(ohm_validate_mc(&v, 100000, 7, 0, (ohm_device_request){OHM_DEVICE_HOST, 0}, &quiet, &err) == 0);
    ohm_validation_print(stdout, &v);
    CHECK(v.n == 6);
    for (int i = 0; i < v.n; ++i)
        CHECK_MSG(v.rows[i].pass, "%s: %.6g against %.6g", v.rows[i].name, v.rows[i].measured, v.rows[i].expected);
}

/* A 16^3 box of 0.5 mm cells (sigma_a 0.05, sigma_s' 1, eta 1.3) lit by a
 * pencil beam down onto its top face, traced with seed and 2 threads. */
static int solve_box(ohm_solution *sol, ohm_voxel_grid *g, const char *solver, uint64_t seed, int total, double x,
                     int handoff)
{
    ohm_error err = {0};
    if (ohm_scene_box(g, 16, 16, 16, 0.5, &err)) return -1;
    ohm_material m = ohm_scene_grey(0.05, 1.0);
    m.g = 0.5;
    ohm_light l = ohm_scene_pencil((const double[3]){x, x, 9.0}, (const double[3]){0, 0, -1.0});
    ohm_solve_params p;
    memset(&p, 0, sizeof p);
    ohm_solver_kind_parse(&p.num.solver, solver, NULL); /* the name, as -solve solver= reads it */
    p.src.total_fluence = total;
    p.mc = (ohm_mc_params){.photons = 32000, .seed = seed, .threads = 2, .handoff = handoff};
    ohm_log quiet = {.verbosity = 0};
    int rc = ohm_solve(sol, g, &m, &l, 1, &p, &quiet, &err);
    if (rc) fprintf(stderr, "ohm_solve: %s\n", err.msg);
    return rc;
}

static int trace_box(ohm_solution *sol, ohm_voxel_grid *g, uint64_t seed)
{
    return solve_box(sol, g, "mc", seed, 0, 4.0, 0);
}

/* fluence=total adds the unscattered beam: diffusion adds it in closed form
 * (ohm_source_unscattered_face), the Monte Carlo traces it; with one seed the
 * traced difference is exactly the photons' first flights.  Down the beam's
 * column (normal incidence: the beam stays in it) the two agree within the
 * traced noise, and nothing changes off the column. */
static void test_total_fluence(void)
{
    ohm_voxel_grid g[4];
    ohm_solution s[4];
    CHECK(solve_box(&s[0], &g[0], "direct", 1, 0, 4.25, 0) == 0);
    CHECK(solve_box(&s[1], &g[1], "direct", 1, 1, 4.25, 0) == 0);
    CHECK(solve_box(&s[2], &g[2], "mc", 1, 0, 4.25, 0) == 0);
    CHECK(solve_box(&s[3], &g[3], "mc", 1, 1, 4.25, 0) == 0);
    CHECK(s[0].power_absorbed == s[1].power_absorbed && s[2].power_absorbed == s[3].power_absorbed);
    /* the column below (4.25, 4.25): cell i = j = 9 (1-based, 0.5 mm cells), top k = 16 */
    int checked = 0;
    for (int k = 16; k >= 14; --k) {
        int64_t v = ohm_network_unknown(&s[0].net, ohm_voxel_index(&g[0], 9, 9, k));
        double d = s[1].fluence[0][v] - s[0].fluence[0][v], m = s[3].fluence[0][v] - s[2].fluence[0][v];
        /* the traced value's noise: ~1/sqrt(photons entering the cell unscattered), the
         * beam's e^(-sigma_t z) of 32000 (sigma_t = 0.05 + 1/(1 - 0.5)) */
        double tol = 4.0 / sqrt(32000.0 * exp(-2.05 * 0.5 * (16 - k)));
        printf("unscattered fluence at depth %d: closed form %.5g, traced %.5g (tolerance %.3g)\n", 16 - k, d, m, tol);
        CHECK_REL(d, m, tol);
        ++checked;
    }
    CHECK(checked == 3);
    int64_t off = ohm_network_unknown(&s[0].net, ohm_voxel_index(&g[0], 3, 3, 10));
    CHECK(s[1].fluence[0][off] == s[0].fluence[0][off] && s[3].fluence[0][off] == s[2].fluence[0][off]);
    for (int i = 0; i < 4; ++i) {
        ohm_solution_free(&s[i]);
        ohm_voxel_grid_free(&g[i]);
    }
}

/* The hybrid (solve.h, mc.handoff): photons traced to their handoff, then
 * diffusion.  Its books close exactly (in = what entered = absorbed + out,
 * the faces' exitance summing to out); the handed-off weight keeps its
 * place; and a handoff no photon lives to reach (1000 reduced scatterings,
 * where the weight falls below 1e-6 after ~600) leaves nothing to diffusion:
 * the same seed then gives exactly the Monte Carlo's fluence and exitance. */
static void test_hybrid(void)
{
    ohm_voxel_grid g[3];
    ohm_solution h, never, mc;
    CHECK(solve_box(&h, &g[0], "direct", 3, 0, 4.0, 2) == 0);
    CHECK(solve_box(&never, &g[1], "direct", 3, 0, 4.0, 1000) == 0);
    CHECK(solve_box(&mc, &g[2], "mc", 3, 0, 4.0, 0) == 0);
    CHECK(h.mc_photons == 32000 && strcmp(h.solver, "direct") == 0);
    CHECK_MSG(fabs(h.power_in - h.power_absorbed - h.power_out) <= 1e-10 * h.power_in, "in %.15g absorbed %.15g out %.15g",
              h.power_in, h.power_absorbed, h.power_out);
    CHECK_REL(h.power_in, h.power_entered, 1e-12);
    double faces = 0, h2 = g[0].h * g[0].h;
    for (int64_t f = 0; f < h.net.nfaces; ++f) faces += h.face_exitance[0][f] * h2;
    CHECK_REL(faces, h.power_out, 1e-12);
    double worst = 0;
    for (int64_t v = 0; v < mc.n; ++v)
        if (mc.fluence[0][v] > 0) worst = fmax(worst, fabs(never.fluence[0][v] - mc.fluence[0][v]) / mc.fluence[0][v]);
    for (int64_t f = 0; f < mc.net.nfaces; ++f)
        if (mc.face_exitance[0][f] > 0)
            worst = fmax(worst, fabs(never.face_exitance[0][f] - mc.face_exitance[0][f]) / mc.face_exitance[0][f]);
    printf("hybrid with an unreachable handoff against the Monte Carlo: largest difference %.3g\n", worst);
    CHECK_MSG(worst < 1e-12, "hybrid(1000) differs from mc by %.3g", worst);
    CHECK_REL(never.power_out, mc.power_out, 1e-12);
    ohm_solution_free(&h);
    ohm_solution_free(&never);
    ohm_solution_free(&mc);
    for (int i = 0; i < 3; ++i) ohm_voxel_grid_free(&g[i]);
}

/* An anisotropy per cell (g_v, from a transfer function's g column): van de
 * Hulst's matched slab (mu_a 1, mu_s 9 /mm, g 0.75, 0.2 mm; R_d 0.09739) with
 * g only in the per-cell array (the material's g is 0) reproduces the
 * published reflectance, and bit for bit the same run with the material's g. */
static int slab_run(ohm_solution *sol, ohm_voxel_grid *g, int per_cell, double *rd)
{
    ohm_error err = {0};
    if (ohm_scene_box(g, 100, 100, 2, 0.1, &err)) return -1;
    size_t n = g->interior_cells;
    double *gv = malloc(n * sizeof *gv);
    if (!gv) return -1;
    for (size_t u = 0; u < n; ++u) gv[u] = 0.75;
    ohm_material m = ohm_scene_grey(1.0, 9.0 * (1 - 0.75));
    m.eta = 1.0;
    m.g = per_cell ? 0.0 : 0.75;
    ohm_light l = ohm_scene_pencil((const double[3]){5.0, 5.0, 1.0}, (const double[3]){0, 0, -1.0});
    ohm_solve_params p;
    memset(&p, 0, sizeof p);
    p.num.solver = OHM_SOLVER_MC;
    p.media.g_v = per_cell ? gv : NULL;
    p.mc = (ohm_mc_params){.photons = 100000, .seed = 9, .threads = 2};
    ohm_log quiet = {.verbosity = 0};
    int rc = ohm_solve(sol, g, &m, &l, 1, &p, &quiet, &err);
    if (rc) fprintf(stderr, "ohm_solve: %s\n", err.msg);
    free(gv);
    if (rc) return rc;
    double out = 0, area = g->h * g->h;
    for (int64_t f = 0; f < sol->net.nfaces; ++f)
        if (sol->net.face_dir[f] == 5) out += sol->face_exitance[0][f] * area;
    *rd = out / sol->power_incident;
    return 0;
}

static void test_per_cell_g(void)
{
    ohm_voxel_grid ga, gb;
    ohm_solution a, b;
    double rd_cell = 0, rd_material = 0;
    CHECK(slab_run(&a, &ga, 1, &rd_cell) == 0);
    CHECK(slab_run(&b, &gb, 0, &rd_material) == 0);
    double se = sqrt(0.09739 * (1 - 0.09739) / 100000.0);
    printf("matched slab with g per cell: R_d %.5f (published 0.09739, 4 se = %.5f)\n", rd_cell, 4 * se);
    CHECK_MSG(fabs(rd_cell - 0.09739) < 4 * se, "R_d %.5f", rd_cell);
    CHECK(rd_cell == rd_material);
    CHECK(memcmp(a.fluence[0], b.fluence[0], (size_t)a.n * sizeof(double)) == 0);
    ohm_solution_free(&a);
    ohm_solution_free(&b);
    ohm_voxel_grid_free(&ga);
    ohm_voxel_grid_free(&gb);
}

/* fluence=total with the same light in two frames solved in separate
 * batches (a tiny batch budget): the second frame is the first, and the
 * books close (the unscattered part was once added twice there). */
static void test_total_repeated_frames(void)
{
    ohm_error err = {0};
    ohm_voxel_grid g;
    CHECK(ohm_scene_box(&g, 8, 8, 8, 0.5, &err) == 0);
    ohm_material m = ohm_scene_grey(0.05, 1.0);
    ohm_light l[2];
    for (int f = 0; f < 2; ++f) {
        l[f] = ohm_scene_directional((const double[3]){0, 0, -1.0});
        l[f].frame = f + 1;
    }
    ohm_solve_params p;
    memset(&p, 0, sizeof p);
    p.src.total_fluence = 1;
    p.num.max_rhs_bytes = 1; /* one frame per batch */
    ohm_solution s;
    ohm_log quiet = {.verbosity = 0};
    CHECK(ohm_solve(&s, &g, &m, l, 2, &p, &quiet, &err) == 0);
    CHECK(s.frames == 2);
    size_t n = (size_t)s.n;
    CHECK(memcmp(s.fluence[0], s.fluence[0] + n, n * sizeof(double)) == 0);
    CHECK_MSG(ohm_solution_conservation_error(&s) < 1e-10, "conservation %.3g", ohm_solution_conservation_error(&s));
    ohm_solution_free(&s);
    ohm_voxel_grid_free(&g);
}

static void test_bookkeeping_and_seeds(void)
{
    ohm_voxel_grid ga, gb;
    ohm_solution a, b;
    CHECK(trace_box(&a, &ga, 5) == 0);
    CHECK(trace_box(&b, &gb, 5) == 0);
    CHECK(strcmp(a.solver, "mc") == 0 && a.mc_photons == 32000 && a.mc_threads == 2);
    CHECK_MSG(fabs(a.power_in - a.power_absorbed - a.power_out) <= 1e-12 * a.power_in, "in %.15g absorbed %.15g out %.15g",
              a.power_in, a.power_absorbed, a.power_out);
    CHECK(a.power_in == a.power_entered && a.power_entered < a.power_incident);
    double faces = 0, h2 = ga.h * ga.h;
    for (int64_t f = 0; f < a.net.nfaces; ++f) faces += a.face_exitance[0][f] * h2;
    CHECK_REL(faces, a.power_out, 1e-12);
    size_t n = (size_t)a.n;
    CHECK(memcmp(a.fluence[0], b.fluence[0], n * sizeof(double)) == 0);
    CHECK(memcmp(a.face_exitance[0], b.face_exitance[0], (size_t)a.net.nfaces * sizeof(double)) == 0);
    ohm_solution_free(&b);
    ohm_voxel_grid_free(&gb);
    CHECK(trace_box(&b, &gb, 6) == 0);
    CHECK(memcmp(a.fluence[0], b.fluence[0], n * sizeof(double)) != 0);
    double sum2 = 0;
    size_t used = 0;
    for (size_t v = 0; v < n; ++v) {
        double sa = a.fluence_se[0][v], sb = b.fluence_se[0][v];
        /* cells the light reaches well: their spread is estimated from 16 batches */
        if (!(sa < 0.1 * a.fluence[0][v])) continue;
        double z = (a.fluence[0][v] - b.fluence[0][v]) / sqrt(sa * sa + sb * sb);
        sum2 += z * z;
        ++used;
    }
    double rms = sqrt(sum2 / (double)used);
    printf("seeds 5 and 6: %zu cells, rms difference %.3f standard errors\n", used, rms);
    CHECK(used > 500);
    CHECK_MSG(rms > 0.8 && rms < 1.2, "rms %.3f", rms);
    ohm_solution_free(&a);
    ohm_solution_free(&b);
    ohm_voxel_grid_free(&ga);
    ohm_voxel_grid_free(&gb);
}

int main(void)
{
    test_published();
    test_bookkeeping_and_seeds();
    test_hybrid();
    test_per_cell_g();
    test_total_repeated_frames();
    test_total_fluence();
    return check_summary();
}
