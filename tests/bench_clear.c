/* bench_clear.c — the radiosity–diffusion coupling across clear regions
 * (physics/clear_exchange.h) measured against ohm's Monte Carlo tracer, and
 * its size and set-up time against the region's surface; prints, asserts
 * nothing (tests/test_clear_exchange.c does).  docs/transport.md, "Transport
 * across clear regions: radiosity–diffusion", holds what it printed.
 *   bench_clear void [photons]   the transport study's cube with a clear void
 *   bench_clear head [photons [reach]]  the three-layer head slab (CSF),
 *                                the coupling's distance cut (mm, 10)
 *   bench_clear gap [photons [reach]]   an air gap of index 1.0 under 6 mm of tissue
 *   bench_clear growth           links and set-up time against the surface */
#include <stdio.h>

#include "base/log.h"
#include "physics/clear_exchange.h"
#include "clear_scenes.h"

static int fail(const ohm_error *err)
{
    fprintf(stderr, "bench_clear: %s\n", err->msg);
    return 1;
}

static void coupling_report(const clear_scene *sc)
{
    ohm_network net;
    ohm_error err;
    ohm_mirrors mirror = {{1, 1, -1}, {-1, -1, -1}};
    if (ohm_network_build(&net, &sc->grid, &mirror, &err)) return;
    ohm_clear_exchange ce;
    ohm_clear_exchange_params cp = {.max_distance = sc->reach};
    if (!ohm_clear_exchange_build(&ce, &net, sc->clear, &cp, &err)) {
        printf("  coupling: %lld clear cells, %lld nodes, %lld faces (%lld walls, %lld escapes), %lld node pairs, "
               "%lld rays, renorm %.3f..%.3f, set-up %.3f s\n",
               (long long)ce.nclear, (long long)ce.nnodes, (long long)ce.faces, (long long)ce.nwall,
               (long long)ce.nescape, (long long)ce.npairs, (long long)ce.rays, ce.renorm_min, ce.renorm_max,
               ce.seconds);
        ohm_clear_exchange_free(&ce);
    }
    ohm_network_free(&net);
}

/* The Monte Carlo reference (seed 1), diffusion alone and coupled (the
 * hybrid's photons given), each timed. */
static int solve_three(const clear_scene *sc, int64_t photons, int64_t hybrid, ohm_solution *ref, ohm_solution *off,
                       ohm_solution *on, double *t_mc, double *t_off, double *t_on, ohm_error *err)
{
    ohm_mc_params mc = {.photons = photons, .seed = 1};
    double t0 = ohm_now();
    int rc = clear_scene_solve(ref, sc, NULL, &mc, 0, err);
    *t_mc = ohm_now() - t0;
    t0 = ohm_now();
    if (!rc) rc = clear_scene_solve(off, sc, NULL, NULL, hybrid, err);
    *t_off = ohm_now() - t0;
    t0 = ohm_now();
    if (!rc) rc = clear_scene_solve(on, sc, sc->clear, NULL, hybrid, err);
    *t_on = ohm_now() - t0;
    return rc;
}

static int run_void(int64_t photons)
{
    ohm_error err;
    clear_scene sc = {.nx = 30, .ny = 30, .nz = 60, .h = 1.0, .eta = 1.37, .g = 0.01, .medium = void_medium,
                      .sphere_c = 21.0, .sphere_r = 10.0};
    if (clear_scene_make(&sc, &err)) return fail(&err);
    ohm_solution ref, off, on;
    double t_mc, t_off, t_on;
    if (solve_three(&sc, photons, photons, &ref, &off, &on, &t_mc, &t_off, &t_on, &err)) return fail(&err);
    printf("void scene (cube n1.37 60 mm, sphere r 10 mm sigma_s' 0.01, h 1 mm; mc %.3g photons, %.1f s)\n",
           (double)photons, t_mc);
    const ohm_solution *d[2] = {&off, &on};
    const char *name[2] = {"diffusion (clear=off)", "radiosity-diffusion"};
    for (int q = 0; q < 2; ++q) {
        ohm_block_error all = clear_scene_bulk(&sc, d[q], &ref, 0), tissue = clear_scene_bulk(&sc, d[q], &ref, 1);
        ohm_block_error away = clear_scene_bulk(&sc, d[q], &ref, 2);
        double ad = (d[q]->power_absorbed + d[q]->power_entered - d[q]->power_in) / d[q]->power_incident;
        double am = (ref.power_absorbed + ref.power_entered - ref.power_in) / ref.power_incident;
        printf("  %-22s bulk mean %.2f%% rms %.2f%% bias %+.2f%% (%lld blocks); outside clear cells mean %.2f%% bias "
               "%+.2f%% (%lld); beyond 2 mfp of the void mean %.2f%% rms %.2f%% bias %+.2f%% (%lld); absorbed %+.2f%%; "
               "conservation %.2g\n",
               name[q], 100 * all.mean_abs, 100 * all.rms, 100 * all.bias, (long long)all.blocks, 100 * tissue.mean_abs,
               100 * tissue.bias, (long long)tissue.blocks, 100 * away.mean_abs, 100 * away.rms, 100 * away.bias, (long long)away.blocks,
               100 * (ad / am - 1), ohm_solution_conservation_error(d[q]));
    }
    printf("  solve (hybrid, set-up included): diffusion alone %.2f s, coupled %.2f s\n", t_off, t_on);
    coupling_report(&sc);
    ohm_solution_free(&ref), ohm_solution_free(&off), ohm_solution_free(&on);
    clear_scene_free(&sc);
    return 0;
}

/* R(rho) on the lit face in 2 mm rings, and the brain's fluence in 2 mm
 * shells of distance from the entry point, diffusion over Monte Carlo. */
static void head_rows(const clear_scene *sc, const ohm_solution *d, const ohm_solution *mc, const char *name,
                      double deep)
{
    enum { RINGS = 40 };
    double rd[RINGS] = {0}, rm[RINGS] = {0}, rv[RINGS] = {0};
    double bd[RINGS] = {0}, bm[RINGS] = {0}, bv[RINGS] = {0};
    double ld[RINGS] = {0}, lm[RINGS] = {0}, lv[RINGS] = {0}; /* the brain's top 8 mm by distance from the axis */
    const ohm_voxel_grid *g = &sc->grid;
    for (int64_t f = 0; f < d->net.nfaces; ++f) {
        if (d->net.face_dir[f] != 4) continue;
        int32_t c[3];
        ohm_voxel_coords(g, d->net.face_cell[f], c);
        double x = (c[0] - 0.5) * sc->h, y = (c[1] - 0.5) * sc->h;
        int r = (int)(sqrt(x * x + y * y) / 2.0);
        if (r >= RINGS) continue;
        int64_t v = d->net.face_unknown[f];
        rd[r] += d->face_exitance[0][f];
        rm[r] += mc->face_exitance[0][f];
        rv[r] += mc->exitance_se[0][v] * mc->exitance_se[0][v];
    }
    for (int k = 1; k <= sc->nz; ++k)
        for (int j = 1; j <= sc->ny; ++j)
            for (int i = 1; i <= sc->nx; ++i) {
                double c[3];
                clear_scene_centre(sc, i, j, k, c);
                if (c[2] < deep) continue; /* the layer under the clear one only */
                int r = (int)(sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]) / 2.0);
                int64_t v = ohm_network_unknown(&d->net, ohm_voxel_index(g, i, j, k));
                int l = (int)(sqrt(c[0] * c[0] + c[1] * c[1]) / 2.0);
                if (l < RINGS && c[2] < deep + 8.0) {
                    ld[l] += d->fluence[0][v];
                    lm[l] += mc->fluence[0][v];
                    lv[l] += mc->fluence_se[0][v] * mc->fluence_se[0][v];
                }
                if (r >= RINGS) continue;
                bd[r] += d->fluence[0][v];
                bm[r] += mc->fluence[0][v];
                bv[r] += mc->fluence_se[0][v] * mc->fluence_se[0][v];
            }
    printf("  %s\n    R(rho) d/mc:", name);
    double worst_r = 0, worst_b = 0;
    for (int r = 10; r < 20; ++r) {
        double e = rd[r] / rm[r] - 1;
        printf(" %d:%+.1f%%(se %.1f%%)", 2 * r + 1, 100 * e, 100 * sqrt(rv[r]) / rm[r]);
        worst_r = fmax(worst_r, fabs(e));
    }
    printf("\n    below the clear layer, phi by distance from the entry d/mc:");
    for (int r = 5; r < 15; ++r) {
        double e = bd[r] / bm[r] - 1;
        printf(" %d:%+.1f%%(se %.1f%%)", 2 * r + 1, 100 * e, 100 * sqrt(bv[r]) / bm[r]);
        worst_b = fmax(worst_b, fabs(e));
    }
    double worst_l = 0;
    printf("\n    below, %g-%g mm deep, phi by distance from the axis d/mc:", deep, deep + 8.0);
    for (int r = 5; r < 15; ++r) {
        double e = ld[r] / lm[r] - 1;
        printf(" %d:%+.1f%%(se %.1f%%)", 2 * r + 1, 100 * e, 100 * sqrt(lv[r]) / lm[r]);
        worst_l = fmax(worst_l, fabs(e));
    }
    printf("\n    worst R(20-40 mm) %.1f%%, worst brain phi (10-30 mm from the entry) %.1f%%, (10-30 mm from the "
           "axis) %.1f%%, conservation %.2g\n",
           100 * worst_r, 100 * worst_b, 100 * worst_l, ohm_solution_conservation_error(d));
}

static int run_head(int64_t photons, double reach)
{
    ohm_error err;
    clear_scene sc = {.nx = 60, .ny = 60, .nz = 40, .h = 1.0, .eta = 1.37, .g = 0.01, .medium = head_medium,
                      .reach = reach};
    if (clear_scene_make(&sc, &err)) return fail(&err);
    ohm_solution ref, off, on;
    double t_mc, t_off, t_on;
    if (solve_three(&sc, photons, photons / 4, &ref, &off, &on, &t_mc, &t_off, &t_on, &err)) return fail(&err);
    printf("head slab (quarter 60 x 60 x 40 mm, h 1 mm, n 1.37, reach %g mm; mc %.3g photons, %.1f s)\n", reach,
           (double)photons, t_mc);
    head_rows(&sc, &off, &ref, "diffusion (clear=off)", 12.0);
    head_rows(&sc, &on, &ref, "radiosity-diffusion", 12.0);
    printf("  solve (hybrid, set-up included): diffusion alone %.2f s, coupled %.2f s\n", t_off, t_on);
    coupling_report(&sc);
    ohm_solution_free(&ref), ohm_solution_free(&off), ohm_solution_free(&on);
    clear_scene_free(&sc);
    return 0;
}

static int run_gap(int64_t photons, double reach)
{
    ohm_error err;
    clear_scene sc = {.nx = 40, .ny = 40, .nz = 30, .h = 1.0, .eta = 1.37, .g = 0.01, .medium = gap_medium,
                      .reach = reach, .clear_eta = 1.0};
    if (clear_scene_make(&sc, &err)) return fail(&err);
    ohm_solution ref, off, on;
    double t_mc, t_off, t_on;
    if (solve_three(&sc, photons, photons / 4, &ref, &off, &on, &t_mc, &t_off, &t_on, &err)) return fail(&err);
    printf("air gap (quarter 40 x 40 x 30 mm, tissue n 1.37 sigma_a 0.01 sigma_s' 1, 2 mm of n 1.0 6 mm deep, reach "
           "%g mm; mc %.3g photons, %.1f s)\n",
           reach, (double)photons, t_mc);
    head_rows(&sc, &off, &ref, "diffusion (clear=off)", 8.0);
    head_rows(&sc, &on, &ref, "radiosity-diffusion", 8.0);
    printf("  solve (hybrid, set-up included): diffusion alone %.2f s, coupled %.2f s\n", t_off, t_on);
    coupling_report(&sc);
    ohm_solution_free(&ref), ohm_solution_free(&off), ohm_solution_free(&on);
    clear_scene_free(&sc);
    return 0;
}

static int run_growth(void)
{
    printf("growth: the void sphere's radius (h 1 mm, every pair), then the CSF layer's width (reach 10 mm)\n");
    for (double r = 5; r <= 20; r += 5) {
        ohm_error err;
        int side = (int)(2 * r + 12);
        clear_scene sc = {.nx = side / 2 + 2, .ny = side / 2 + 2, .nz = side, .h = 1.0, .eta = 1.37, .g = 0.01,
                          .medium = void_medium, .sphere_c = side / 2.0, .sphere_r = r};
        if (clear_scene_make(&sc, &err)) return fail(&err);
        printf(" sphere r %.0f mm:", r);
        coupling_report(&sc);
        clear_scene_free(&sc);
    }
    for (int w = 15; w <= 120; w *= 2) {
        ohm_error err;
        clear_scene sc = {.nx = w, .ny = w, .nz = 16, .h = 1.0, .eta = 1.37, .g = 0.01, .medium = head_medium,
                          .reach = 10.0};
        if (clear_scene_make(&sc, &err)) return fail(&err);
        printf(" CSF layer %d x %d mm (quarter):", w, w);
        coupling_report(&sc);
        clear_scene_free(&sc);
    }
    return 0;
}

int main(int argc, char **argv)
{
    const char *what = argc > 1 ? argv[1] : "void";
    int64_t photons = argc > 2 ? atoll(argv[2]) : 1000000;
    if (!strcmp(what, "void")) return run_void(photons);
    if (!strcmp(what, "head")) return run_head(photons, argc > 3 ? atof(argv[3]) : 10.0);
    if (!strcmp(what, "growth")) return run_growth();
    if (!strcmp(what, "gap")) return run_gap(photons, argc > 3 ? atof(argv[3]) : 15.0);
    fprintf(stderr, "bench_clear: void | head | gap | growth\n");
    return 2;
}
