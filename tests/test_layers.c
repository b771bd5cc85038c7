/* test_layers.c — physics acceptance test for inhomogeneous media (docs/materials.md):
 * a two-layer slab whose materials come from a transfer function, solved by
 * ohm_solve, against an independent analytic 1-D two-layer diffusion solution.
 *
 * Making the 3-D problem truly 1-D.  Mirror (zero-flux) planes exist only on
 * the LOW side of each axis (network.h), so a 1 x 1 x N column would still
 * lose light through its high x and y faces.  Instead the slab is a W x W x N
 * box with mirrors on the low x and y sides: by symmetry it is the centre
 * quarter of a 2W x 2W slab, uniformly lit from above.  The column next to
 * both mirrors (i = j = 1) is W cells from every real lateral wall; the wall's
 * influence decays laterally at least like exp(-k W h) with k >= sigma_tr of
 * the more transparent layer (0.25/mm here; the slab's lowest mode decays
 * faster still), so with W h = 24 mm it is below 1e-3 of the fluence.  That
 * column is then the 1-D problem:
 *
 *     -(D phi')' + sigma_a phi = q(x),  x = depth below the lit surface,
 *     D phi'(0) = phi(0)/(2A),  -D phi'(L) = phi(L)/(2A)   (partial current,
 *                                          the continuum limit of robin G_b),
 *     phi and D phi' continuous at the interface,
 *
 * with the source of deposit=exponential at normal incidence:
 * q(x) = sigma_s'(x) T I exp(-tau(x)), tau the optical depth in sigma_t',
 * T = 1 - F_r(eta, 1).  In each layer phi is a particular exponential plus
 * C1 e^{kx} + C2 e^{-kx}, k^2 = sigma_a/D; the four constants come from a 4x4
 * system solved here.  Nothing of ohm's solver is used for the reference.
 * Measured: largest difference 0.39% at h = 0.2 mm (1.39% at h = 0.4 mm: the
 * second-order convergence of the finite volumes, largest next to the lit
 * surface).
 *
 * Second part: a contrast of 1e6 in sigma_s' across one face must still give
 * a backward error (sol.residual) below 1e-10 and exact power conservation. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "physics/light.h"
#include "physics/material.h"
#include "solvers/solve.h"
#include "studies/reference.h"
#include "input/transfer.h"

static const ohm_log quiet = {.verbosity = 0};

static int make_box(ohm_voxel_grid *g, int nx, int ny, int nz, double h)
{
    memset(g, 0, sizeof *g);
    g->dims[0] = nx + 2;
    g->dims[1] = ny + 2;
    g->dims[2] = nz + 2;
    g->h = h;
    g->band = h;
    for (int a = 0; a < 3; ++a) g->origin[a] = -0.5 * h;
    size_t n = (size_t)g->dims[0] * (size_t)g->dims[1] * (size_t)g->dims[2];
    g->inside = calloc(n, 1);
    if (!g->inside) return -1;
    for (int k = 1; k <= nz; ++k)
        for (int j = 1; j <= ny; ++j)
            for (int i = 1; i <= nx; ++i) g->inside[ohm_voxel_index(g, i, j, k)] = 1;
    g->interior_cells = (size_t)nx * (size_t)ny * (size_t)nz;
    return 0;
}

static ohm_material grey(double eta)
{
    ohm_material m;
    memset(&m, 0, sizeof m);
    m.kind = OHM_MATERIAL_OPTICAL;
    m.channels = 1;
    m.sigma_a[0] = 0.05; /* unused: per-unknown arrays override it */
    m.sigma_s[0] = 1.0;
    m.eta = eta;
    snprintf(m.name, sizeof m.name, "layers");
    return m;
}

/* The reference must satisfy its own equations: check the residuals (the
 * interior ODE, both Robin boundaries, flux continuity and the interface
 * condition at L0). */
static void check_reference(const ohm_ref_two_layer *s, const ohm_ref_layer layer[2], double TI)
{
    const double d = 1e-4;
    double x[3] = {0.3 * s->L0, 0.7 * s->L0, s->L0 + 0.5 * s->L1};
    for (int q = 0; q < 3; ++q) {
        int in0 = x[q] <= s->L0;
        const ohm_ref_layer *l = &layer[in0 ? 0 : 1];
        double D = s->D[in0 ? 0 : 1];
        double tau = in0 ? s->t[0] * x[q] : s->t[0] * s->L0 + s->t[1] * (x[q] - s->L0);
        double f0 = ohm_ref_two_layer_phi(s, x[q]), fp = ohm_ref_two_layer_phi(s, x[q] + d),
               fm = ohm_ref_two_layer_phi(s, x[q] - d);
        double lhs = -D * (fp - 2 * f0 + fm) / (d * d) + l->sigma_a * f0, rhs = l->sigma_s * TI * exp(-tau);
        CHECK_REL(lhs, rhs, 1e-5);
    }
    double A0 = ohm_boundary_A(layer[0].eta, OHM_FRESNEL_EXACT), A1 = ohm_boundary_A(layer[1].eta, OHM_FRESNEL_EXACT);
    double g0 = (ohm_ref_two_layer_phi(s, d) - ohm_ref_two_layer_phi(s, 0)) / d;
    CHECK_REL(s->D[0] * g0, ohm_ref_two_layer_phi(s, 0) / (2 * A0), 1e-3);
    double L = s->L0 + s->L1, gL = (ohm_ref_two_layer_phi(s, L) - ohm_ref_two_layer_phi(s, L - d)) / d;
    CHECK_REL(-s->D[1] * gL, ohm_ref_two_layer_phi(s, L) / (2 * A1), 1e-3);
    double phi_l = ohm_ref_two_layer_phi(s, s->L0), phi_r = ohm_ref_two_layer_phi(s, s->L0 + 1e-12);
    double jl = -s->D[0] * (phi_l - ohm_ref_two_layer_phi(s, s->L0 - d)) / d;
    double jr = -s->D[1] * (ohm_ref_two_layer_phi(s, s->L0 + d) - phi_r) / d;
    CHECK_REL(jl, jr, 1e-3);
    double c1a, c2a, c1b, c2b;
    ohm_fresnel_moments(layer[0].eta / layer[1].eta, &c1a, &c2a);
    ohm_fresnel_moments(layer[1].eta / layer[0].eta, &c1b, &c2b);
    double jump = 0.25 * (1 - 2 * c1a) * phi_l - 0.25 * (1 - 2 * c1b) * phi_r, want = 1.5 * (c2a + c2b) * jl;
    CHECK_MSG(fabs(jump - want) <= 1e-3 * fabs(phi_l) * 0.25, "interface condition: %.6g vs %.6g", jump, want);
}

static void test_two_layers(void)
{
    /* layer A (density 0, top) and layer B (density 1, bottom) */
    static const char tf_text[] = "ohm-transfer 1 eta=1.3\n"
                                  "# density  sigma_a  sigma_s'\n"
                                  "0  0.02  1.0\n"
                                  "1  0.1   2.0\n";
    ohm_error err;
    ohm_error_clear(&err);
    ohm_transfer tf;
    int rc = ohm_transfer_parse(&tf, tf_text, sizeof tf_text - 1, "layers.transfer", &err);
    CHECK_MSG(rc == 0, "%s", err.msg);
    if (rc) return;

    const double h = 0.2, LA = 2.0, LB = 2.0;
    const int W = 120, NA = (int)lround(LA / h), NB = (int)lround(LB / h), N = NA + NB;
    ohm_voxel_grid g;
    CHECK(make_box(&g, W, W, N, h) == 0);
    /* the solver numbers unknowns as the interior cells in x-fastest order */
    size_t n = (size_t)W * W * N;
    ohm_coeff *sa = malloc(n * sizeof *sa), *ss = malloc(n * sizeof *ss);
    CHECK(sa && ss);
    if (!sa || !ss) goto out;
    for (int k = 1; k <= N; ++k) {
        /* the light comes from +z: the top NA layers (highest k) are layer A */
        double density = k > NB ? 0.0 : 1.0;
        double a, s;
        ohm_transfer_eval(&tf, density, &a, &s);
        for (size_t q = 0; q < (size_t)W * W; ++q) {
            size_t u = (size_t)(k - 1) * W * W + q;
            sa[u] = (ohm_coeff)a;
            ss[u] = (ohm_coeff)s;
        }
    }

    ohm_material m = grey(tf.eta);
    ohm_light light;
    memset(&light, 0, sizeof light);
    light.type = OHM_LIGHT_DIRECTIONAL;
    light.dir[2] = -1.0;
    light.intensity[0] = 1.0;
    light.channels = 1;
    ohm_mirrors mirror = {{1, 1, -1}, {-1, -1, -1}};
    ohm_solve_params p;
    memset(&p, 0, sizeof p);
    p.op.boundary = OHM_BOUNDARY_ROBIN;
    p.num.ordering = "metis";
    p.src.deposit = OHM_DEPOSIT_EXPONENTIAL;
    p.src.shadows = OHM_SHADOWS_NONE;
    p.op.mirrors = &mirror;
    p.src.orientation = 1;
    p.media.sigma_a[0] = sa;
    p.media.sigma_s[0] = ss;
    ohm_solution sol;
    rc = ohm_solve(&sol, &g, &m, &light, 1, &p, &quiet, &err);
    CHECK_MSG(rc == 0, "%s", err.msg);
    if (rc) goto out;
    CHECK(sol.n == (int64_t)n);
    /* the unknown numbering this test assumes */
    CHECK(ohm_network_unknown(&sol.net, ohm_voxel_index(&g, 1, 1, 1)) == 0);
    CHECK(ohm_network_unknown(&sol.net, ohm_voxel_index(&g, 2, 1, 1)) == 1);
    CHECK(ohm_network_unknown(&sol.net, ohm_voxel_index(&g, 1, 1, 2)) == (int64_t)W * W);

    double cons = ohm_solution_conservation_error(&sol);
    CHECK_MSG(cons < 1e-10, "conservation error %.3g", cons);
    CHECK_MSG(sol.residual < 1e-10, "backward error %.3g", sol.residual);

    double T = 1.0 - ohm_fresnel_reflectance(tf.eta, 1.0);
    /* the power that went in, per unit lit area, is T I: check the light's bookkeeping */
    CHECK_REL(sol.power_incident, 1.0 * (W * h) * (W * h), 1e-12);
    const ohm_ref_layer layers[2] = {{0.02, 1.0, tf.eta, LA}, {0.1, 2.0, tf.eta, LB}};
    ohm_ref_two_layer ref;
    CHECK(ohm_ref_two_layer_init(&ref, layers, T * 1.0) == 0);
    check_reference(&ref, layers, T * 1.0);
    /* and with an index step (network.h's interface; validate.c solves it) */
    const ohm_ref_layer stepped[2] = {{0.02, 1.0, 1.3, LA}, {0.1, 2.0, 1.6, LB}};
    ohm_ref_two_layer ref_step;
    CHECK(ohm_ref_two_layer_init(&ref_step, stepped, T * 1.0) == 0);
    check_reference(&ref_step, stepped, T * 1.0);
    double jump = ohm_ref_two_layer_phi(&ref_step, LA + 1e-12) / ohm_ref_two_layer_phi(&ref_step, LA);
    CHECK_MSG(jump > 1.2 && jump < (1.6 / 1.3) * (1.6 / 1.3), "phi jumps %.4g across 1.3 | 1.6", jump);

    double worst = 0, worst_x = 0, worst_lat = 0;
    for (int k = 1; k <= N; ++k) {
        double x = (N - k + 0.5) * h; /* depth of the cell centre below the lit surface */
        double phi = sol.fluence[0][ohm_network_unknown(&sol.net, ohm_voxel_index(&g, 1, 1, k))];
        double e = fabs(phi - ohm_ref_two_layer_phi(&ref, x)) / ohm_ref_two_layer_phi(&ref, x);
        if (e > worst) {
            worst = e;
            worst_x = x;
        }
        /* the column a quarter of the way to the walls must agree too (1-D) */
        double phi_q = sol.fluence[0][ohm_network_unknown(&sol.net, ohm_voxel_index(&g, W / 4, W / 4, k))];
        double el = fabs(phi_q - phi) / phi;
        if (el > worst_lat) worst_lat = el;
    }
    printf("two-layer slab (h=%.2g mm, %d x %d x %d cells): largest |phi - phi_1D|/phi_1D = %.3g%% at depth "
           "%.2f mm; lateral variation %.2g; conservation %.2g; backward error %.2g\n",
           h, W, W, N, 100 * worst, worst_x, worst_lat, cons, sol.residual);
    CHECK_MSG(worst < 0.02, "two-layer error %.3g%% > 2%%", 100 * worst);
    CHECK_MSG(worst_lat < 1e-3, "not 1-D: lateral variation %.3g", worst_lat);
    ohm_solution_free(&sol);
out:
    free(sa);
    free(ss);
    ohm_voxel_grid_free(&g);
    ohm_transfer_free(&tf);
}

/* A contrast of 1e6 in sigma_s' across one face (the plane between the two
 * halves of a box) keeps the backward error below 1e-10. */
static void test_contrast(void)
{
    static const char tf_text[] = "ohm-transfer 1\n"
                                  "0  0.01  1\n"
                                  "1  0.01  1e6\n";
    ohm_error err;
    ohm_error_clear(&err);
    ohm_transfer tf;
    int rc = ohm_transfer_parse(&tf, tf_text, sizeof tf_text - 1, "contrast.transfer", &err);
    CHECK_MSG(rc == 0, "%s", err.msg);
    if (rc) return;
    const int nx = 12, ny = 12, nz = 12;
    ohm_voxel_grid g;
    CHECK(make_box(&g, nx, ny, nz, 0.25) == 0);
    size_t n = (size_t)nx * ny * nz;
    ohm_coeff *sa = malloc(n * sizeof *sa), *ss = malloc(n * sizeof *ss);
    CHECK(sa && ss);
    if (sa && ss) {
        for (size_t u = 0; u < n; ++u) {
            int i = (int)(u % (size_t)nx) + 1; /* x-fastest */
            double sa_u, ss_u;
            ohm_transfer_eval(&tf, i > nx / 2 ? 1.0 : 0.0, &sa_u, &ss_u);
            sa[u] = (ohm_coeff)sa_u, ss[u] = (ohm_coeff)ss_u;
        }
        CHECK(ss[0] == 1.0 && ss[nx - 1] == 1e6);
        ohm_material m = grey(tf.eta);
        ohm_light light;
        memset(&light, 0, sizeof light);
        light.type = OHM_LIGHT_DIRECTIONAL;
        light.dir[0] = 0.6;
        light.dir[2] = -0.8;
        light.intensity[0] = 1.0;
        light.channels = 1;
        for (int b = 0; b < 2; ++b) {
            ohm_solve_params p;
            memset(&p, 0, sizeof p);
            p.op.boundary = b ? OHM_BOUNDARY_NEUMANN : OHM_BOUNDARY_ROBIN;
            p.num.ordering = "amd";
            p.src.deposit = OHM_DEPOSIT_EXPONENTIAL;
            p.src.orientation = 1;
            p.media.sigma_a[0] = sa;
            p.media.sigma_s[0] = ss;
            ohm_solution sol;
            rc = ohm_solve(&sol, &g, &m, &light, 1, &p, &quiet, &err);
            CHECK_MSG(rc == 0, "%s", err.msg);
            if (rc) continue;
            double cons = ohm_solution_conservation_error(&sol);
            printf("sigma_s' contrast 1e6 (%s): backward error %.2g, conservation %.2g\n",
                   ohm_boundary_name(p.op.boundary), sol.residual, cons);
            CHECK_MSG(sol.residual < 1e-10, "backward error %.3g", sol.residual);
            CHECK_MSG(cons < 1e-10, "conservation %.3g", cons);
            int finite = 1;
            for (int64_t u = 0; u < sol.n; ++u)
                if (!isfinite(sol.fluence[0][u]) || sol.fluence[0][u] < 0) finite = 0;
            CHECK(finite);
            ohm_solution_free(&sol);
        }
    }
    free(sa);
    free(ss);
    ohm_voxel_grid_free(&g);
    ohm_transfer_free(&tf);
}

/* A per-cell index through the solver paths: the 1.3 | 1.6 column (1 x 1 x
 * N, mirrors on both sides of x and y) by the direct factor, by CG (its
 * warm start and solution in the scaled unknowns, network.h), and with two
 * frames of the same light (the second reuses the first): the same fluence. */
static int index_column(ohm_solution *sol, ohm_voxel_grid *g, const char *solver, int frames)
{
    const int n0 = 20, n1 = 20, N = n0 + n1;
    const double h = 0.1;
    if (make_box(g, 1, 1, N, h)) return -1;
    static ohm_coeff sa[40], ss[40];
    static double eta[40];
    for (int u = 0; u < N; ++u) { /* unknown u is cell k = u + 1, layer 0 on top */
        int top = u >= n1;
        sa[u] = top ? 0.02f : 0.1f;
        ss[u] = top ? 1.0f : 2.0f;
        eta[u] = top ? 1.3 : 1.6;
    }
    ohm_material m = grey(1.3);
    ohm_light l[2];
    memset(l, 0, sizeof l);
    for (int f = 0; f < 2; ++f) {
        l[f].type = OHM_LIGHT_DIRECTIONAL;
        l[f].dir[2] = -1.0;
        l[f].intensity[0] = 1.0;
        l[f].channels = 1;
        l[f].frame = frames > 1 ? f + 1 : 0;
    }
    ohm_mirrors mirror = {{1, 1, -1}, {1, 1, -1}};
    ohm_solve_params p;
    memset(&p, 0, sizeof p);
    p.op.boundary = OHM_BOUNDARY_ROBIN;
    p.num.ordering = "amd";
    ohm_solver_kind_parse(&p.num.solver, solver, NULL); /* the name, as -solve solver= reads it */
    p.num.cg_tol = 1e-13;
    p.op.mirrors = &mirror;
    p.media.sigma_a[0] = sa;
    p.media.sigma_s[0] = ss;
    p.media.eta_v = eta;
    ohm_error err;
    ohm_error_clear(&err);
    int rc = ohm_solve(sol, g, &m, l, (size_t)(frames > 1 ? 2 : 1), &p, &quiet, &err);
    if (rc) fprintf(stderr, "index column (%s): %s\n", solver, err.msg);
    return rc;
}

static void test_index_paths(void)
{
    ohm_voxel_grid g[3];
    ohm_solution s[3];
    CHECK(index_column(&s[0], &g[0], "direct", 1) == 0);
    CHECK(index_column(&s[1], &g[1], "cg", 1) == 0);
    CHECK(index_column(&s[2], &g[2], "direct", 2) == 0);
    CHECK(s[2].frames == 2 && s[2].solves_skipped == 1);
    double worst_cg = 0, worst_frame = 0;
    for (int64_t u = 0; u < s[0].n; ++u) {
        double ref = s[0].fluence[0][u];
        worst_cg = fmax(worst_cg, fabs(s[1].fluence[0][u] - ref) / ref);
        worst_frame = fmax(worst_frame, fabs(s[2].fluence[0][s[0].n + u] - ref) / ref);
    }
    printf("per-cell index: cg vs direct %.2g, second frame %.2g\n", worst_cg, worst_frame);
    CHECK_MSG(worst_cg < 1e-9, "cg %.3g", worst_cg);
    CHECK_MSG(worst_frame == 0, "frame 2 %.3g", worst_frame);
    for (int i = 0; i < 3; ++i) {
        CHECK(ohm_solution_conservation_error(&s[i]) < 1e-10);
        ohm_solution_free(&s[i]);
        ohm_voxel_grid_free(&g[i]);
    }
}

int main(void)
{
    test_two_layers();
    test_contrast();
    test_index_paths();
    return check_summary();
}
