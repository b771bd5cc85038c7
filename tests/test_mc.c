/* test_mc.c — the Monte Carlo transport reference (mc.h) against published
 * transport values, each within a tolerance set by the noise both sides state:
 *
 *  - a matched slab (n = 1; mu_a 1/mm, mu_s 9/mm, g 0.75, 0.2 mm thick): van de
 *    Hulst's Rd = 0.09739, Tt = 0.66096, the check of MCML (Wang, Jacques &
 *    Zheng 1995, Table 2);
 *  - a semi-infinite medium under air (n = 1.5, albedo 0.9, g = 0): MCML's
 *    Rd = 0.220348 +- 0.000916 (sample1.mci, run 2, of MCML 2.0);
 *  - MCX's cube60 benchmark (60 mm cube of 1 mm voxels, mu_a 0.005, mu_s 1,
 *    g 0.01, no boundary reflection, pencil beam at grid (29, 29, 0), a 5 ns
 *    time gate at n = 1.37): absorbed 17.69708% (1e8 photons, fangq/mcx PR #267);
 *
 * and its own bookkeeping: power in = absorbed + out + gated to round-off, a
 * seed repeats a run bit for bit, and the standard errors are honest (two
 * seeds differ cell by cell by about sqrt(se1^2 + se2^2)). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "light.h"
#include "mc.h"
#include "network.h"

/* nx x ny x nz cells of size h with one outside cell around them; the box's
 * low corner at world 0.  No distance field: face normals. */
static void make_box(ohm_voxel_grid *g, int nx, int ny, int nz, double h)
{
    memset(g, 0, sizeof *g);
    g->dims[0] = nx + 2, g->dims[1] = ny + 2, g->dims[2] = nz + 2;
    g->h = h;
    g->band = h;
    for (int a = 0; a < 3; ++a) g->origin[a] = -0.5 * h;
    g->inside = calloc((size_t)g->dims[0] * g->dims[1] * g->dims[2], 1);
    for (int k = 1; k <= nz; ++k)
        for (int j = 1; j <= ny; ++j)
            for (int i = 1; i <= nx; ++i) g->inside[ohm_voxel_index(g, i, j, k)] = 1;
    g->interior_cells = (size_t)nx * ny * nz;
}

typedef struct scene {
    ohm_voxel_grid grid;
    ohm_network net;
    ohm_channel_medium med;
    ohm_light_entries in;
    double *fluence, *fluence_se, *face, *exit_se;
    ohm_mc_result res;
} scene;

/* A box lit by a pencil beam of 1 W travelling -z onto its top face at (x, y). */
static int scene_init(scene *s, int nx, int ny, int nz, double h, double sa, double ss_reduced, double eta, double x,
                      double y)
{
    memset(s, 0, sizeof *s);
    make_box(&s->grid, nx, ny, nz, h);
    ohm_error err = {0};
    if (ohm_network_build(&s->net, &s->grid, NULL, &err)) return -1;
    s->med.sigma_a0 = sa;
    s->med.sigma_s0 = ss_reduced;
    s->med.eta = eta;
    ohm_light l;
    memset(&l, 0, sizeof l);
    l.type = OHM_LIGHT_PENCIL;
    l.pos[0] = x, l.pos[1] = y, l.pos[2] = nz * h + 1.0;
    l.dir[2] = -1.0;
    l.intensity[0] = 1.0;
    l.channels = 1;
    if (ohm_light_entries_add(&s->in, &s->net, &l, 1, eta, NULL, &err)) return -1;
    size_t n = (size_t)s->net.n, nf = (size_t)s->net.nfaces;
    s->fluence = calloc(n, sizeof(double));
    s->fluence_se = calloc(n, sizeof(double));
    s->exit_se = calloc(n, sizeof(double));
    s->face = calloc(nf, sizeof(double));
    s->res = (ohm_mc_result){.fluence = s->fluence, .fluence_se = s->fluence_se, .face_exitance = s->face,
                             .exitance_se = s->exit_se};
    return 0;
}

static int scene_trace(scene *s, int64_t photons, uint64_t seed, double g, int threads, double max_path)
{
    ohm_mc_params p = {.photons = photons, .seed = seed, .g = g, .threads = threads, .max_path = max_path};
    ohm_error err = {0};
    int rc = ohm_mc_trace(&s->res, &s->net, &s->med, s->in.entry, s->in.count, 0, &p, &err);
    if (rc) fprintf(stderr, "ohm_mc_trace: %s\n", err.msg);
    return rc;
}

static void scene_free(scene *s)
{
    ohm_light_entries_free(&s->in);
    ohm_network_free(&s->net);
    ohm_voxel_grid_free(&s->grid);
    free(s->fluence), free(s->fluence_se), free(s->exit_se), free(s->face);
}

/* Power leaving through faces of direction d (0..5: -x +x -y +y -z +z). */
static double out_through(const scene *s, int d)
{
    double sum = 0, area = s->grid.h * s->grid.h;
    for (int64_t f = 0; f < s->net.nfaces; ++f)
        if (s->net.face_dir[f] == d) sum += s->face[f] * area;
    return sum;
}

static void check_conservation(const scene *s)
{
    const ohm_mc_result *r = &s->res;
    double booked = r->power_absorbed + r->power_out + r->power_gated;
    CHECK_MSG(fabs(booked - r->power_in) <= 1e-12 * r->power_in, "in %.15g, absorbed + out + gated %.15g",
              r->power_in, booked);
    double faces = 0;
    for (int d = 0; d < 6; ++d) faces += out_through(s, d);
    CHECK_REL(faces, r->power_out, 1e-12);
}

/* van de Hulst's matched slab: the total reflectance and transmittance.
 * Per photon each is a 0/1 outcome (n = 1: nothing reflects at the faces), so
 * its standard error is sqrt(p (1 - p) / N); van de Hulst's values are exact
 * to their last digit. */
static void test_matched_slab(void)
{
    scene s;
    CHECK(scene_init(&s, 100, 100, 2, 0.1, 1.0, 9.0 * (1 - 0.75), 1.0, 5.0, 5.0) == 0);
    const int64_t N = 200000;
    CHECK(scene_trace(&s, N, 7, 0.75, 0, 0) == 0);
    double Rd = out_through(&s, 5), Tt = out_through(&s, 4);
    double se_R = sqrt(0.09739 * (1 - 0.09739) / N), se_T = sqrt(0.66096 * (1 - 0.66096) / N);
    printf("matched slab: Rd %.5f (van de Hulst 0.09739 +- %.5f), Tt %.5f (0.66096 +- %.5f), %.0f photons/ms\n", Rd,
           se_R, Tt, se_T, 1e-3 * (double)s.res.photons / s.res.seconds);
    CHECK_MSG(fabs(Rd - 0.09739) < 4 * se_R, "Rd %.5f", Rd);
    CHECK_MSG(fabs(Tt - 0.66096) < 4 * se_T, "Tt %.5f", Tt);
    /* the sides are 5 mm from the beam: nothing reaches them */
    CHECK(out_through(&s, 0) + out_through(&s, 1) + out_through(&s, 2) + out_through(&s, 3) < 1e-4);
    check_conservation(&s);
    scene_free(&s);
}

/* MCML's semi-infinite medium under air: Fresnel at entry (the 4% specular
 * reflection is not part of Rd) and at every internal reflection. */
static void test_mismatched_halfspace(void)
{
    scene s;
    CHECK(scene_init(&s, 40, 40, 40, 0.1, 1.0, 9.0, 1.5, 2.0, 2.0) == 0);
    const int64_t N = 100000;
    CHECK(scene_trace(&s, N, 11, 0.0, 0, 0) == 0);
    double incident = s.in.entry[0].incident[0];
    double Rsp = 1.0 - s.res.power_in / incident, Rd = out_through(&s, 5) / incident;
    double se = sqrt(0.000916 * 0.000916 + pow(s.res.power_out_se / incident, 2));
    printf("semi-infinite, n 1.5: Rsp %.5f (0.04), Rd %.5f +- %.5f (MCML 0.220348 +- 0.000916)\n", Rsp, Rd,
           s.res.power_out_se / incident);
    CHECK(fabs(Rsp - 0.04) < 1e-12);
    CHECK_MSG(fabs(Rd - 0.220348) < 4 * se, "Rd %.5f, combined standard error %.5f", Rd, se);
    /* 4 mm of a medium whose diffusion length is 0.18 mm: semi-infinite */
    CHECK(out_through(&s, 4) < 1e-6);
    check_conservation(&s);
    scene_free(&s);
}

/* MCX's cube60: no reflection at the faces (DoMismatch 0: eta 1 here), the
 * beam at grid coordinate (29, 29) on z = 0, light absorbed within 5 ns at
 * c / 1.37.  (Our beam comes down onto the top face: the same by symmetry.) */
static void test_cube60(void)
{
    scene s;
    CHECK(scene_init(&s, 60, 60, 60, 1.0, 0.005, 1.0 * (1 - 0.01), 1.0, 29.0, 29.0) == 0);
    const int64_t N = 32000;
    const double gate = 5.0 * 299.792458 / 1.37; /* mm travelled in 5 ns */
    CHECK(scene_trace(&s, N, 3, 0.01, 0, gate) == 0);
    double absorbed = s.res.power_absorbed / s.res.power_in, se = s.res.power_absorbed_se / s.res.power_in;
    printf("cube60: absorbed %.5f%% +- %.5f%% (MCX 17.69708%%), gated %.3g%%, %.0f photons/ms on %d threads, %.0f "
           "segments per photon\n",
           100 * absorbed, 100 * se, 100 * s.res.power_gated / s.res.power_in,
           1e-3 * (double)s.res.photons / s.res.seconds, s.res.threads, (double)s.res.events / (double)s.res.photons);
    CHECK(se > 0 && se < 0.005);
    CHECK_MSG(fabs(absorbed - 0.1769708) < 4 * se, "absorbed %.5f, standard error %.5f", absorbed, se);
    check_conservation(&s);
    scene_free(&s);
}

/* The same seed and threads repeat a run exactly; another seed gives another
 * sample, and the differences, in units of the stated standard errors, are
 * about standard normal: their rms lies near 1. */
static void test_seed_and_errors(void)
{
    scene a, b;
    CHECK(scene_init(&a, 16, 16, 16, 0.5, 0.05, 1.0, 1.3, 4.0, 4.0) == 0);
    CHECK(scene_init(&b, 16, 16, 16, 0.5, 0.05, 1.0, 1.3, 4.0, 4.0) == 0);
    CHECK(scene_trace(&a, 32000, 5, 0.5, 2, 0) == 0);
    CHECK(scene_trace(&b, 32000, 5, 0.5, 2, 0) == 0);
    size_t n = (size_t)a.net.n;
    CHECK(memcmp(a.fluence, b.fluence, n * sizeof(double)) == 0);
    CHECK(memcmp(a.face, b.face, (size_t)a.net.nfaces * sizeof(double)) == 0);
    CHECK(scene_trace(&b, 32000, 6, 0.5, 2, 0) == 0);
    CHECK(memcmp(a.fluence, b.fluence, n * sizeof(double)) != 0);
    double sum2 = 0;
    size_t used = 0;
    for (size_t v = 0; v < n; ++v) {
        double se2 = a.fluence_se[v] * a.fluence_se[v] + b.fluence_se[v] * b.fluence_se[v];
        /* cells the light reaches well: their spread is estimated from 16 batches */
        if (!(a.fluence_se[v] < 0.1 * a.fluence[v])) continue;
        double z = (a.fluence[v] - b.fluence[v]) / sqrt(se2);
        sum2 += z * z;
        ++used;
    }
    double rms = sqrt(sum2 / (double)used);
    printf("seeds 5 and 6: %zu cells, rms difference %.3f standard errors\n", used, rms);
    CHECK(used > 500);
    CHECK_MSG(rms > 0.8 && rms < 1.2, "rms %.3f", rms);
    check_conservation(&a);
    scene_free(&a);
    scene_free(&b);
}

int main(void)
{
    test_matched_slab();
    test_mismatched_halfspace();
    test_cube60();
    test_seed_and_errors();
    return check_summary();
}
