/* test_clear.c — clear regions (physics/clear_regions.h, docs/transport.md):
 * the rule finds the clear void of the transport study's cube and the CSF
 * layer of a head slab and nothing in a homogeneous skin cube; clear=off
 * leaves the solve as it was, to the bit; clear=effective conserves power to
 * 1e-10 and leaves mg a well-conditioned operator (few iterations). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "physics/clear_regions.h"
#include "solvers/solve.h"
#include "studies/scene.h"

/* The transport study's medium (validate_transport.c) and its clear void. */
static const double SA = 0.005, SS = 0.99, VOID_SA = 0.0001, VOID_SS = 0.01;
/* The head slab: scalp and skull, CSF, brain (1/mm; depths in mm). */
static const double SCALP_SA = 0.019, SCALP_SS = 0.86, CSF_SA = 0.0004, CSF_SS = 0.001, BRAIN_SA = 0.02,
                    BRAIN_SS = 1.0, SCALP_MM = 10.0, CSF_MM = 2.0;

/* An air-like cavity: D = 1/(3 sigma_t') of 3 m, ten thousand times the tissue's. */
static const double AIR_SA = 1e-5, AIR_SS = 1e-4;

typedef enum scene_kind { SCENE_VOID, SCENE_SLAB, SCENE_AIR, SCENE_SHELL } scene_kind;

/* Cell (i,j,k)'s centre depth and distance to the sphere's centre (the
 * box's cells are 1-based inside: scene.h). */
static int in_void(const ohm_voxel_grid *g, int i, int j, int k, double depth, double radius)
{
    double x = (i - 0.5) * g->h, y = (j - 0.5) * g->h, z = (k - 0.5) * g->h - depth;
    return x * x + y * y + z * z < radius * radius;
}

/* Per-unknown media of the scene (interior cells in cell order); *clear_cells
 * counts the cells made clear. */
static void scene_media(ohm_coeff *sa, ohm_coeff *ss, int64_t *clear_cells, const ohm_voxel_grid *g,
                        scene_kind kind, double depth, double radius)
{
    int64_t u = 0;
    *clear_cells = 0;
    for (int k = 0; k < g->dims[2]; ++k)
        for (int j = 0; j < g->dims[1]; ++j)
            for (int i = 0; i < g->dims[0]; ++i) {
                if (!g->inside[ohm_voxel_index(g, i, j, k)]) continue;
                double z = (k - 0.5) * g->h;
                int clear;
                if (kind == SCENE_SHELL) { /* CSF in a 2 mm shell around a ball of brain */
                    clear = in_void(g, i, j, k, depth, radius + CSF_MM) && !in_void(g, i, j, k, depth, radius);
                    sa[u] = (ohm_coeff)(clear ? CSF_SA : BRAIN_SA);
                    ss[u] = (ohm_coeff)(clear ? CSF_SS : BRAIN_SS);
                } else if (kind == SCENE_VOID || kind == SCENE_AIR) {
                    clear = in_void(g, i, j, k, depth, radius);
                    sa[u] = (ohm_coeff)(clear ? (kind == SCENE_AIR ? AIR_SA : VOID_SA) : SA);
                    ss[u] = (ohm_coeff)(clear ? (kind == SCENE_AIR ? AIR_SS : VOID_SS) : SS);
                } else {
                    clear = z > SCALP_MM && z < SCALP_MM + CSF_MM;
                    sa[u] = (ohm_coeff)(z < SCALP_MM ? SCALP_SA : clear ? CSF_SA : BRAIN_SA);
                    ss[u] = (ohm_coeff)(z < SCALP_MM ? SCALP_SS : clear ? CSF_SS : BRAIN_SS);
                }
                *clear_cells += clear;
                ++u;
            }
}

static ohm_channel_medium medium_of(const ohm_coeff *sa, const ohm_coeff *ss, double sa0, double ss0)
{
    ohm_channel_medium m;
    memset(&m, 0, sizeof m);
    m.sigma_a = sa;
    m.sigma_s = ss;
    m.sigma_a0 = sa0;
    m.sigma_s0 = ss0;
    m.eta = 1.37;
    return m;
}

/* The quarter box's mirrors (validate_transport.c). */
static const ohm_mirrors MIRROR = {{1, 1, -1}, {-1, -1, -1}};

/* Detection on a scene: one clear region holding exactly the clear cells. */
static void check_found(const ohm_voxel_grid *g, scene_kind kind, double depth, double radius, double thick_lo,
                        double thick_hi, const char *what)
{
    ohm_error err = {0};
    ohm_network net;
    CHECK(ohm_network_build(&net, g, &MIRROR, &err) == 0);
    int64_t n = net.n, clear_cells = 0;
    ohm_coeff *sa = malloc((size_t)n * sizeof *sa), *ss = malloc((size_t)n * sizeof *ss);
    scene_media(sa, ss, &clear_cells, g, kind, depth, radius);
    ohm_channel_medium m = medium_of(sa, ss, 0, 0);
    ohm_clear_regions r;
    CHECK(ohm_clear_regions_find(&r, &net, &m, 1, &err) == 0);
    printf("%s: %lld candidates, %d region(s), %lld cells (%lld clear in the scene), thickness %.3f mm, optical thickness %.4f\n",
           what, (long long)r.candidate_cells, r.count, (long long)r.clear_cells, (long long)clear_cells, r.count ? r.region[0].thickness_mm : 0.0,
           r.count ? r.region[0].optical_thickness : 0.0);
    CHECK_MSG(r.count == 1, "%s: %d regions", what, r.count);
    CHECK_MSG(r.clear_cells == clear_cells, "%s: %lld cells found, %lld clear", what, (long long)r.clear_cells,
              (long long)clear_cells);
    int64_t agree = 0;
    for (int64_t v = 0; v < n; ++v) agree += ohm_clear_is_clear(&r, v) == (ss[v] < 0.1f);
    CHECK_MSG(agree == n, "%s: %lld of %lld cells classified as the scene has them", what, (long long)agree,
              (long long)n);
    if (r.count == 1) {
        CHECK_MSG(r.region[0].thickness_mm >= thick_lo && r.region[0].thickness_mm <= thick_hi,
                  "%s: thickness %g mm outside [%g, %g]", what, r.region[0].thickness_mm, thick_lo, thick_hi);
        CHECK(r.region[0].optical_thickness < OHM_CLEAR_OPTICAL_THICKNESS);
        CHECK(fabs(r.region[0].volume_mm3 - (double)clear_cells * g->h * g->h * g->h) < 1e-9);
    }
    ohm_clear_regions_free(&r);
    free(sa), free(ss);
    ohm_network_free(&net);
}

/* A homogeneous skin cube (Jensen's skin1, three channels; the red one's
 * 1/sigma_t' = 1.3 mm exceeds the 1 mm cell: every cell a candidate): the
 * cube's optical thickness is far above the threshold, so nothing is clear. */
static void check_skin_has_none(void)
{
    ohm_error err = {0};
    ohm_voxel_grid g;
    CHECK(ohm_scene_box(&g, 20, 20, 20, 1.0, &err) == 0);
    ohm_network net;
    CHECK(ohm_network_build(&net, &g, NULL, &err) == 0);
    ohm_material skin;
    CHECK(ohm_material_preset(&skin, "skin1", &err) == 0);
    ohm_channel_medium m[3];
    for (int c = 0; c < 3; ++c) m[c] = medium_of(NULL, NULL, skin.sigma_a[c], skin.sigma_s[c]);
    ohm_clear_regions r;
    CHECK(ohm_clear_regions_find(&r, &net, m, 3, &err) == 0);
    printf("skin1 cube: %lld candidate cells, %d clear regions\n", (long long)r.candidate_cells, r.count);
    CHECK(r.candidate_cells == net.n);
    CHECK(r.count == 0 && r.clear_cells == 0 && !r.region_of_cell);
    for (int64_t v = 0; v < net.n; ++v) CHECK(!ohm_clear_is_clear(&r, v));
    ohm_clear_regions_free(&r);
    ohm_network_free(&net);
    ohm_voxel_grid_free(&g);
}

/* A pencil-beam solve of a scene at clear=mode with solver kind; with mask,
 * the radiosity coupling of those unknowns within reach mm instead. */
/* The scene's solve parameters: its media (given to the solve), the
 * mirrors, clear= and the solver. */
static ohm_solve_params scene_params(const ohm_voxel_grid *g, scene_kind kind, double depth, double radius,
                                     ohm_clear_mode mode, ohm_solver_kind solver)
{
    ohm_solve_params p;
    memset(&p, 0, sizeof p);
    p.op.mirrors = &MIRROR;
    p.op.clear = mode;
    p.num.solver = solver;
    size_t n = g->interior_cells;
    ohm_coeff *sa = malloc(n * sizeof *sa), *ss = malloc(n * sizeof *ss);
    int64_t clear_cells;
    scene_media(sa, ss, &clear_cells, g, kind, depth, radius);
    p.media.sigma_a[0] = sa;
    p.media.sigma_s[0] = ss;
    p.media.give_media = 1;
    return p;
}

static int scene_solve_coupled(ohm_solution *sol, const ohm_voxel_grid *g, scene_kind kind, double depth,
                               double radius, ohm_clear_mode mode, ohm_solver_kind solver, const uint8_t *mask,
                               double reach)
{
    ohm_error err = {0};
    ohm_log log = {.verbosity = 0};
    ohm_material m = ohm_scene_grey(SA, SS);
    m.eta = 1.37;
    ohm_light beam = ohm_scene_pencil((const double[3]){0, 0, -1.0}, (const double[3]){0, 0, 1.0});
    ohm_solve_params p = scene_params(g, kind, depth, radius, mode, solver);
    p.op.clear_cells = mask;
    p.op.clear_reach = reach;
    int rc = ohm_solve(sol, g, &m, &beam, 1, &p, &log, &err);
    if (rc) fprintf(stderr, "solve: %s\n", err.msg);
    return rc;
}

static int scene_solve(ohm_solution *sol, const ohm_voxel_grid *g, scene_kind kind, double depth, double radius,
                       ohm_clear_mode mode, ohm_solver_kind solver)
{
    return scene_solve_coupled(sol, g, kind, depth, radius, mode, solver, NULL, 0);
}

static int same_bits(const ohm_solution *a, const ohm_solution *b)
{
    return a->n == b->n && memcmp(a->fluence[0], b->fluence[0], (size_t)a->n * sizeof(double)) == 0 &&
           a->power_out == b->power_out && a->power_absorbed == b->power_absorbed;
}

/* Two factor solves of the same coupling: the same nodes and pairs, the
 * fluence to 1e-10 of the peak and the books to 1e-10.  Not their bits: the
 * factor's BLAS takes as many threads as there are idle cores, and its sums'
 * order changes with them (as under ctest -j); a coupling that differed by
 * one pair would move the fluence by far more. */
static int same_coupled(const ohm_solution *a, const ohm_solution *b)
{
    if (a->n != b->n || a->clear_nodes != b->clear_nodes || a->clear_pairs != b->clear_pairs) return 0;
    double peak = 0, off = 0;
    for (int64_t v = 0; v < a->n; ++v) {
        peak = fmax(peak, fabs(a->fluence[0][v]));
        off = fmax(off, fabs(a->fluence[0][v] - b->fluence[0][v]));
    }
    return off <= 1e-10 * peak && fabs(a->power_out - b->power_out) <= 1e-10 * fabs(a->power_out) &&
           fabs(a->power_absorbed - b->power_absorbed) <= 1e-10 * fabs(a->power_absorbed);
}

/* A relight with the clear regions' coupling: a solver kept (keep=1) and
 * solved for one beam, then for another (the coupling and the hierarchy
 * reused, the solve warm-started), against a fresh solve for the second:
 * the same fluence to 1e-8 of the peak, both conserving to 1e-10; by mg
 * and by the factor. */
static void check_relight(const ohm_voxel_grid *g, double depth, double radius, ohm_solver_kind kind)
{
    ohm_error err = {0};
    ohm_log log = {.verbosity = 0};
    ohm_material m = ohm_scene_grey(SA, SS);
    m.eta = 1.37;
    ohm_light first = ohm_scene_pencil((const double[3]){0, 0, -1.0}, (const double[3]){0, 0, 1.0});
    ohm_light second = ohm_scene_pencil((const double[3]){4.0, 3.0, -1.0}, (const double[3]){0, 0, 1.0});
    ohm_solver *s[2] = {NULL, NULL};
    for (int q = 0; q < 2; ++q) {
        ohm_solve_params p = scene_params(g, SCENE_VOID, depth, radius, OHM_CLEAR_RADIOSITY, kind);
        CHECK_MSG(ohm_solver_create(&s[q], g, &m, &p, 1, &log, &err) == 0, "%s", err.msg);
    }
    if (!s[0] || !s[1]) goto done;
    CHECK_MSG(ohm_solver_solve(s[0], &first, 1, &err) == 0, "%s", err.msg); /* then relit: */
    CHECK_MSG(ohm_solver_solve(s[0], &second, 1, &err) == 0, "%s", err.msg);
    CHECK_MSG(ohm_solver_solve(s[1], &second, 1, &err) == 0, "%s", err.msg);
    const ohm_solution *relit = ohm_solver_solution(s[0]), *fresh = ohm_solver_solution(s[1]);
    CHECK(relit->clear_action == OHM_CLEAR_RADIOSITY && relit->clear_pairs > 0);
    double peak = 0, off = 0;
    for (int64_t v = 0; v < fresh->n; ++v) {
        peak = fmax(peak, fresh->fluence[0][v]);
        off = fmax(off, fabs(relit->fluence[0][v] - fresh->fluence[0][v]));
    }
    printf("cube + clear void, clear=radiosity, %s: relit %.2g of the peak off a fresh solve; conservation %.2g, "
           "%.2g\n",
           relit->solver, off / peak, ohm_solution_conservation_error(relit), ohm_solution_conservation_error(fresh));
    CHECK(peak > 0 && off <= 1e-8 * peak);
    CHECK(ohm_solution_conservation_error(relit) <= 1e-10 && ohm_solution_conservation_error(fresh) <= 1e-10);
done:
    ohm_solver_free(s[0]);
    ohm_solver_free(s[1]);
}

/* mg on a scene at clear=off and clear=effective: effective finds one
 * region, conserves power to 1e-10 and converges in few iterations. */
static void check_effective(const ohm_voxel_grid *g, scene_kind kind, double depth, double radius, const char *what)
{
    ohm_solution off, eff;
    CHECK(scene_solve(&off, g, kind, depth, radius, OHM_CLEAR_OFF, OHM_SOLVER_MG) == 0);
    CHECK(scene_solve(&eff, g, kind, depth, radius, OHM_CLEAR_EFFECTIVE, OHM_SOLVER_MG) == 0);
    printf("%s, mg: %lld iterations with clear=off (relative residual %.2g), %lld with clear=effective (%.2g); "
           "conservation %.2g\n",
           what, (long long)off.cg_iterations, off.cg_relres, (long long)eff.cg_iterations, eff.cg_relres,
           ohm_solution_conservation_error(&eff));
    CHECK(eff.clear.count == 1);
    CHECK(ohm_solution_conservation_error(&eff) <= 1e-10);
    CHECK(eff.cg_iterations <= 30);
    ohm_solution_free(&off), ohm_solution_free(&eff);
}

int main(void)
{
    ohm_error err = {0};
    /* the transport study's cube with its clear void, at 2/3 of its size:
     * a 20 x 20 x 40 mm quarter box, the void of radius 40/6 mm at depth 14 mm */
    ohm_voxel_grid cube;
    CHECK(ohm_scene_box(&cube, 20, 20, 40, 1.0, &err) == 0);
    const double depth = 14.0, radius = 40.0 / 6.0;
    /* a ball's mean chord is 4r/3 = 8.9 mm; the staircase of cubes exposes
     * 3/2 of a curved surface's area (the mean of |n_x| + |n_y| + |n_z|), a
     * little more at 6.7 cells to the radius, so less */
    check_found(&cube, SCENE_VOID, depth, radius, 4.0 / 3.0 * radius / 1.6, 4.0 / 3.0 * radius, "cube + clear void");
    ohm_voxel_grid slab;
    CHECK(ohm_scene_box(&slab, 30, 30, 24, 1.0, &err) == 0);
    /* a 2 mm layer's mean chord is 4 mm (2t); its outer sides add a little area */
    check_found(&slab, SCENE_SLAB, 0, 0, 3.0, 4.0, "head slab: CSF");
    check_skin_has_none();

    /* clear=off: nothing looked for, the solve as before (zeroed params are
     * off); auto on a scene with no clear region: the same bits.  By mg,
     * whose sums go in a fixed order on any number of cores: the direct
     * factor's BLAS takes as many threads as there are idle cores, and its
     * bits change with them on a busy machine (as under ctest -j) */
    ohm_solution off, eff, autos;
    CHECK(scene_solve(&off, &cube, SCENE_VOID, depth, 0.0, OHM_CLEAR_OFF, OHM_SOLVER_MG) == 0);
    CHECK(scene_solve(&autos, &cube, SCENE_VOID, depth, 0.0, OHM_CLEAR_AUTO, OHM_SOLVER_MG) == 0);
    CHECK(autos.clear.count == 0 && autos.clear_action == OHM_CLEAR_OFF);
    CHECK(same_bits(&off, &autos));
    ohm_solution_free(&off), ohm_solution_free(&autos);

    /* the void scene: off and effective with mg; effective conserves power
     * and takes few iterations where off's clear cells have D of 33 mm */
    CHECK(scene_solve(&off, &cube, SCENE_VOID, depth, radius, OHM_CLEAR_OFF, OHM_SOLVER_MG) == 0);
    CHECK(scene_solve(&eff, &cube, SCENE_VOID, depth, radius, OHM_CLEAR_EFFECTIVE, OHM_SOLVER_MG) == 0);
    CHECK(scene_solve(&autos, &cube, SCENE_VOID, depth, radius, OHM_CLEAR_AUTO, OHM_SOLVER_MG) == 0);
    printf("cube + clear void, mg: %lld iterations with clear=off, %lld with clear=effective; conservation %.2g, %.2g\n",
           (long long)off.cg_iterations, (long long)eff.cg_iterations, ohm_solution_conservation_error(&off),
           ohm_solution_conservation_error(&eff));
    CHECK(off.clear.count == 0 && eff.clear.count == 1 && eff.clear_action == OHM_CLEAR_EFFECTIVE);
    CHECK(autos.clear_action == OHM_CLEAR_EFFECTIVE && same_bits(&autos, &eff));
    CHECK(!same_bits(&off, &eff));
    CHECK(ohm_solution_conservation_error(&eff) <= 1e-10);
    CHECK(eff.cg_iterations <= 30);
    CHECK(eff.cg_iterations <= off.cg_iterations);
    ohm_solution_free(&off), ohm_solution_free(&eff), ohm_solution_free(&autos);

    /* clear=radiosity: the regions found are coupled by view factors within
     * ohm_clear_reach of their chord, exactly as the coupling given the same
     * mask by hand; power conserved; mg (the coupling in its stencil's
     * links beyond the grid) and auto solve it to the factor's answer */
    ohm_solution rad, hand, auto_solver;
    CHECK(scene_solve(&rad, &cube, SCENE_VOID, depth, radius, OHM_CLEAR_RADIOSITY, OHM_SOLVER_DIRECT) == 0);
    CHECK(rad.clear.count == 1 && rad.clear_action == OHM_CLEAR_RADIOSITY && rad.clear_pairs > 0 &&
          rad.clear_nodes > 0);
    uint8_t *mask = calloc((size_t)rad.n, 1);
    for (int64_t v = 0; v < rad.n && mask; ++v) mask[v] = ohm_clear_is_clear(&rad.clear, v);
    CHECK(mask != NULL);
    CHECK(scene_solve_coupled(&hand, &cube, SCENE_VOID, depth, radius, OHM_CLEAR_OFF, OHM_SOLVER_DIRECT, mask,
                              ohm_clear_reach(rad.clear.region[0].thickness_mm)) == 0);
    CHECK(same_coupled(&rad, &hand));
    CHECK(ohm_solution_conservation_error(&rad) <= 1e-10);
    /* a reach asked (clear_reach=) on the regions found: the pairs within
     * it, as the same mask coupled by hand within it; fewer, the books exact */
    double near = 0.2 * ohm_clear_reach(rad.clear.region[0].thickness_mm); /* less than the void's diameter */
    ohm_solution near_found, near_hand;
    CHECK(scene_solve_coupled(&near_found, &cube, SCENE_VOID, depth, radius, OHM_CLEAR_RADIOSITY, OHM_SOLVER_DIRECT,
                              NULL, near) == 0);
    CHECK(scene_solve_coupled(&near_hand, &cube, SCENE_VOID, depth, radius, OHM_CLEAR_OFF, OHM_SOLVER_DIRECT, mask,
                              near) == 0);
    CHECK(near_found.clear_reach_mm == near && near_found.clear_pairs > 0 && near_found.clear_pairs < rad.clear_pairs);
    CHECK(same_coupled(&near_found, &near_hand));
    CHECK(ohm_solution_conservation_error(&near_found) <= 1e-10);
    ohm_solution_free(&near_found), ohm_solution_free(&near_hand);
    CHECK(scene_solve(&eff, &cube, SCENE_VOID, depth, radius, OHM_CLEAR_EFFECTIVE, OHM_SOLVER_DIRECT) == 0);
    CHECK(!same_bits(&rad, &eff));
    printf("cube + clear void, clear=radiosity: %lld nodes, %lld pairs within %.3g mm; conservation %.2g\n",
           (long long)rad.clear_nodes, (long long)rad.clear_pairs, ohm_clear_reach(rad.clear.region[0].thickness_mm),
           ohm_solution_conservation_error(&rad));
    ohm_solution mg_rad;
    CHECK(scene_solve(&mg_rad, &cube, SCENE_VOID, depth, radius, OHM_CLEAR_RADIOSITY, OHM_SOLVER_MG) == 0);
    CHECK(mg_rad.clear_action == OHM_CLEAR_RADIOSITY && ohm_solution_conservation_error(&mg_rad) <= 1e-10);
    CHECK(mg_rad.cg_iterations > 0 && mg_rad.cg_iterations <= 30);
    double mg_off = 0, peak = 0;
    for (int64_t v = 0; v < rad.n; ++v) {
        peak = fmax(peak, rad.fluence[0][v]);
        mg_off = fmax(mg_off, fabs(mg_rad.fluence[0][v] - rad.fluence[0][v]));
    }
    printf("cube + clear void, clear=radiosity by mg: %lld iterations, %.2g of the peak off the factor's\n",
           (long long)mg_rad.cg_iterations, mg_off / peak);
    CHECK(mg_off <= 1e-6 * peak);
    CHECK(scene_solve(&auto_solver, &cube, SCENE_VOID, depth, radius, OHM_CLEAR_RADIOSITY, OHM_SOLVER_AUTO) == 0);
    CHECK(auto_solver.clear_action == OHM_CLEAR_RADIOSITY && ohm_solution_conservation_error(&auto_solver) <= 1e-10);
    free(mask);
    ohm_solution_free(&rad), ohm_solution_free(&hand), ohm_solution_free(&eff), ohm_solution_free(&auto_solver);
    ohm_solution_free(&mg_rad);

    check_relight(&cube, depth, radius, OHM_SOLVER_MG);
    check_relight(&cube, depth, radius, OHM_SOLVER_DIRECT);

    /* the head slab: effective conserves power, mg converges in few iterations */
    check_effective(&slab, SCENE_SLAB, 0, 0, "head slab");
    /* a larger air cavity (radius 16 mm in a 40 x 40 x 60 mm quarter box) */
    ohm_voxel_grid big;
    CHECK(ohm_scene_box(&big, 40, 40, 60, 1.0, &err) == 0);
    check_effective(&big, SCENE_AIR, 25.0, 16.0, "air cavity");
    /* a 2 mm shell of CSF around a ball of brain of radius 20 mm, the
     * shape the head's CSF has: a thin sheet coarse grids cannot see */
    check_effective(&big, SCENE_SHELL, 30.0, 20.0, "CSF shell");
    ohm_voxel_grid_free(&big);

    ohm_voxel_grid_free(&cube);
    ohm_voxel_grid_free(&slab);
    return check_summary();
}
