/* test_clear_exchange.c — the radiosity–diffusion coupling across clear
 * regions (physics/clear_exchange.h; docs/transport.md): the coupled matrix
 * is symmetric (reciprocity, face pairs seen from either side), a network of
 * conductances (every row sums to its sinks: conservation by construction)
 * and positive definite (CHOLMOD factorizes it); a solve conserves power to
 * 1e-10, with direct, cg and auto alike (mg refuses; auto takes cg); a mask with no clear cell
 * gives the plain network bit for bit; and
 * on the transport study's cube with a clear void the bulk fluence around the
 * void agrees with ohm's Monte Carlo tracer within 2% in the mean bias,
 * closer than diffusion alone. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "clear_scenes.h"
#include "physics/clear_exchange.h"
#include "physics/stencil.h"
#include "studies/block_medium.h"

static ohm_channel_medium scene_medium(const clear_scene *sc)
{
    ohm_channel_medium med;
    memset(&med, 0, sizeof med);
    med.sigma_a = sc->sa;
    med.sigma_s = sc->ss;
    med.eta = sc->eta;
    return med;
}

/* The coupled matrix of a scene, with its ga and gb. */
static cholmod_sparse *coupled(const clear_scene *sc, const ohm_network *net, const uint8_t *clear, double **ga,
                               double **gb, cholmod_common *cc)
{
    ohm_error err;
    ohm_channel_medium med = scene_medium(sc);
    *ga = malloc((size_t)net->n * sizeof **ga);
    *gb = malloc((size_t)net->nfaces * sizeof **gb);
    cholmod_sparse *A = NULL;
    ohm_clear_exchange ce;
    CHECK_MSG(ohm_clear_exchange_build(&ce, net, clear, NULL, &err) == 0, "%s", err.msg);
    CHECK_MSG(ohm_network_assemble(&A, *ga, *gb, net, &med, OHM_BOUNDARY_ROBIN, cc, &err) == 0, "%s", err.msg);
    CHECK_MSG(ohm_clear_exchange_apply(&A, *ga, *gb, &ce, &med, OHM_BOUNDARY_ROBIN, cc, &err) == 0, "%s", err.msg);
    ohm_clear_exchange_free(&ce);
    return A;
}

/* A network of conductances: upper triangle in order, positive diagonal,
 * negative links, and every row of the
 * symmetric matrix sums to the row's sinks (ground + boundary): what enters
 * a cell's links leaves another's, so the power books close. */
static void check_network_form(const cholmod_sparse *A, const ohm_network *net, const uint8_t *clear,
                               const double *ga, const double *gb)
{
    int64_t n = net->n, bad_order = 0, bad_sign = 0;
    const int64_t *Ap = A->p, *Ai = A->i;
    const double *Ax = A->x;
    double *rowsum = calloc((size_t)n, sizeof *rowsum), *diag = calloc((size_t)n, sizeof *diag);
    for (int64_t j = 0; j < n; ++j)
        for (int64_t k = Ap[j]; k < Ap[j + 1]; ++k) {
            int64_t i = Ai[k];
            if (i > j || (k > Ap[j] && Ai[k - 1] >= i)) bad_order++;
            if (i == j) {
                bad_sign += !(Ax[k] > 0);
                rowsum[j] += Ax[k];
                diag[j] = Ax[k];
                continue;
            }
            bad_sign += !(Ax[k] < 0);
            rowsum[i] += Ax[k];
            rowsum[j] += Ax[k];
        }
    CHECK(bad_order == 0);
    CHECK(bad_sign == 0);
    double worst = 0;
    for (int64_t v = 0, f = 0; v < n; ++v) {
        double sink = ga[v];
        for (; f < net->nfaces && net->face_unknown[f] == v; ++f) sink += gb[f];
        if (clear[v] && sink == 0) sink = diag[v]; /* a clear cell that is no node: the identity */
        worst = fmax(worst, fabs(rowsum[v] - sink) / diag[v]);
    }
    CHECK_MSG(worst < 1e-12, "a row's links and sinks differ by %.3g of its diagonal", worst);
    free(rowsum), free(diag);
}

/* CHOLMOD's Cholesky factorization succeeds: positive definite. */
static void check_positive_definite(cholmod_sparse *A, cholmod_common *cc)
{
    cholmod_factor *L = cholmod_l_analyze(A, cc);
    int ok = L && cholmod_l_factorize(A, L, cc) && cc->status == CHOLMOD_OK && L->minor == L->n;
    CHECK_MSG(ok, "the coupled matrix is not positive definite (CHOLMOD status %d)", cc->status);
    cholmod_l_free_factor(&L, cc);
}

/* Reciprocity: the coupling of a clear region that has no symmetry, built
 * on the grid and on its mirror image in x (which visits every face pair
 * from the other side), links the same cells by the same conductances. */
static void l_region(const clear_scene *sc, double x, double y, double z, double *sa, double *ss)
{
    (void)sc;
    int in = (z > 4 && z < 8 && x > 3 && x < 13 && y > 3 && y < 7) || (z > 4 && z < 14 && x > 3 && x < 6 && y > 3 &&
                                                                        y < 9);
    *sa = in ? 0.0 : 0.01;
    *ss = in ? 0.001 : 1.0;
}
static void l_region_flipped(const clear_scene *sc, double x, double y, double z, double *sa, double *ss)
{
    l_region(sc, sc->nx * sc->h - x, y, z, sa, ss);
}

typedef struct link {
    int32_t a[3], b[3];
    double g;
} link;

static int link_cmp(const void *p, const void *q)
{
    const link *x = p, *y = q;
    int c = memcmp(x->a, y->a, sizeof x->a);
    return c ? c : memcmp(x->b, y->b, sizeof x->b);
}

/* The exchange links of a scene as cell pairs (x flipped when asked), sorted. */
static link *exchange_links(const clear_scene *sc, int flip, int64_t *count)
{
    ohm_error err;
    ohm_network net;
    CHECK(ohm_network_build(&net, &sc->grid, NULL, &err) == 0);
    ohm_clear_exchange ce;
    CHECK_MSG(ohm_clear_exchange_build(&ce, &net, sc->clear, NULL, &err) == 0, "%s", err.msg);
    link *l = malloc((size_t)(ce.npairs ? ce.npairs : 1) * sizeof *l);
    for (int64_t k = 0; k < ce.npairs; ++k) {
        int32_t a[3], b[3];
        ohm_voxel_coords(&sc->grid, ohm_network_cell(&net, ce.pair_u[k]), a);
        ohm_voxel_coords(&sc->grid, ohm_network_cell(&net, ce.pair_v[k]), b);
        if (flip) a[0] = sc->grid.dims[0] - 1 - a[0], b[0] = sc->grid.dims[0] - 1 - b[0];
        int swap = memcmp(a, b, sizeof a) > 0;
        memcpy(l[k].a, swap ? b : a, sizeof a);
        memcpy(l[k].b, swap ? a : b, sizeof b);
        l[k].g = ce.pair_w[k];
    }
    qsort(l, (size_t)ce.npairs, sizeof *l, link_cmp);
    *count = ce.npairs;
    ohm_clear_exchange_free(&ce);
    ohm_network_free(&net);
    return l;
}

static void test_reciprocity(void)
{
    ohm_error err;
    clear_scene a = {.nx = 16, .ny = 12, .nz = 18, .h = 1.0, .eta = 1.37, .medium = l_region};
    clear_scene b = a;
    b.medium = l_region_flipped;
    CHECK(clear_scene_make(&a, &err) == 0 && clear_scene_make(&b, &err) == 0);
    int64_t na, nb;
    link *la = exchange_links(&a, 0, &na), *lb = exchange_links(&b, 1, &nb);
    CHECK(na > 0 && na == nb);
    double worst = 0;
    int64_t mismatched = 0;
    for (int64_t k = 0; k < na && na == nb; ++k) {
        if (link_cmp(&la[k], &lb[k])) {
            mismatched++;
            continue;
        }
        worst = fmax(worst, fabs(la[k].g - lb[k].g) / la[k].g);
    }
    CHECK_MSG(mismatched == 0, "%lld links join other cells in the mirrored region", (long long)mismatched);
    CHECK_MSG(worst < 1e-9, "a link differs by %.3g seen from the other side", worst);
    free(la), free(lb);
    clear_scene_free(&a), clear_scene_free(&b);
}

static void test_matrix(void)
{
    ohm_error err;
    clear_scene sc = {.nx = 14, .ny = 14, .nz = 24, .h = 1.0, .eta = 1.37, .g = 0.01, .medium = void_medium,
                      .sphere_c = 10.0, .sphere_r = 5.0};
    CHECK(clear_scene_make(&sc, &err) == 0);
    ohm_mirrors mirror = {{1, 1, -1}, {-1, -1, -1}};
    ohm_network net;
    CHECK(ohm_network_build(&net, &sc.grid, &mirror, &err) == 0);
    cholmod_common cc;
    cholmod_l_start(&cc);
    cc.print = 0;
    double *ga, *gb;
    cholmod_sparse *A = coupled(&sc, &net, sc.clear, &ga, &gb, &cc);
    CHECK(A && A->stype == 1);
    if (A) {
        check_network_form(A, &net, sc.clear, ga, gb);
        check_positive_definite(A, &cc);
    }
    cholmod_l_free_sparse(&A, &cc);
    free(ga), free(gb);
    /* a mask with no clear cell: the network's matrix as assembled, bit for bit */
    uint8_t *none = calloc(sc.n, 1);
    ohm_channel_medium med = scene_medium(&sc);
    cholmod_sparse *P = NULL;
    double *ga0 = malloc(sc.n * sizeof *ga0), *gb0 = malloc((size_t)net.nfaces * sizeof *gb0);
    CHECK(ohm_network_assemble(&P, ga0, gb0, &net, &med, OHM_BOUNDARY_ROBIN, &cc, &err) == 0);
    cholmod_sparse *Q = coupled(&sc, &net, none, &ga, &gb, &cc);
    CHECK(P && Q && P->nzmax == Q->nzmax);
    if (P && Q && P->nzmax == Q->nzmax) {
        CHECK(!memcmp(P->p, Q->p, (sc.n + 1) * sizeof(int64_t)));
        CHECK(!memcmp(P->i, Q->i, P->nzmax * sizeof(int64_t)));
        CHECK(!memcmp(P->x, Q->x, P->nzmax * sizeof(double)));
        CHECK(!memcmp(ga, ga0, sc.n * sizeof *ga));
        CHECK(!memcmp(gb, gb0, (size_t)net.nfaces * sizeof *gb));
    }
    cholmod_l_free_sparse(&P, &cc);
    cholmod_l_free_sparse(&Q, &cc);
    free(ga), free(gb), free(ga0), free(gb0), free(none);
    cholmod_l_finish(&cc);
    ohm_network_free(&net);
    clear_scene_free(&sc);
}

/* The coupled stencil (what mg reads) is the coupled matrix: A x agrees
 * row by row to the links' single precision, both give the same ga and gb,
 * and the stencil's rows sum to its sinks (flux form: the links' terms
 * cancel in pairs), the books' premise. */
static void test_stencil_form(void)
{
    ohm_error err;
    clear_scene sc = {.nx = 14, .ny = 14, .nz = 24, .h = 1.0, .eta = 1.37, .g = 0.01, .medium = void_medium,
                      .sphere_c = 10.0, .sphere_r = 5.0};
    CHECK(clear_scene_make(&sc, &err) == 0);
    ohm_mirrors mirror = {{1, 1, -1}, {-1, -1, -1}};
    ohm_network net;
    CHECK(ohm_network_build(&net, &sc.grid, &mirror, &err) == 0);
    cholmod_common cc;
    cholmod_l_start(&cc);
    cc.print = 0;
    double *ga, *gb;
    cholmod_sparse *A = coupled(&sc, &net, sc.clear, &ga, &gb, &cc);
    ohm_channel_medium med = scene_medium(&sc);
    ohm_clear_exchange ce;
    CHECK(ohm_clear_exchange_build(&ce, &net, sc.clear, NULL, &err) == 0);
    ohm_stencil st = {0};
    double *sga = malloc(sc.n * sizeof *sga), *sgb = malloc((size_t)net.nfaces * sizeof *sgb);
    CHECK_MSG(ohm_network_stencil(&st, sga, sgb, &net, &med, OHM_BOUNDARY_ROBIN, &err) == 0, "%s", err.msg);
    CHECK_MSG(ohm_clear_exchange_stencil(&st, sga, sgb, &ce, &med, OHM_BOUNDARY_ROBIN, &err) == 0, "%s", err.msg);
    CHECK(st.xstart && st.xstart[st.n] == 2 * ce.npairs && ce.npairs > 0);
    CHECK(!memcmp(ga, sga, sc.n * sizeof *ga));
    CHECK(!memcmp(gb, sgb, (size_t)net.nfaces * sizeof *gb));
    double *x = malloc(sc.n * sizeof *x), *ys = malloc(sc.n * sizeof *ys), *ym = calloc(sc.n, sizeof *ym);
    uint64_t seed = 7;
    for (size_t v = 0; v < sc.n; ++v) x[v] = 0.5 + ohm_lcg(&seed);
    ohm_stencil_apply(&st, x, ys, 1);
    /* y = A x from the upper triangle */
    const int64_t *Ap = A->p, *Ai = A->i;
    const double *Ax = A->x;
    for (size_t j = 0; j < sc.n; ++j)
        for (int64_t k = Ap[j]; k < Ap[j + 1]; ++k) {
            size_t i = (size_t)Ai[k];
            ym[i] += Ax[k] * x[j];
            if (i != j) ym[j] += Ax[k] * x[i];
        }
    double worst = 0, rows = 0, sinks = 0, diag_worst = 0;
    for (size_t v = 0; v < sc.n; ++v) {
        double scale = fabs(ym[v]) + ohm_stencil_diag(&st, (int64_t)v) * x[v];
        worst = fmax(worst, fabs(ys[v] - ym[v]) / scale);
        rows += ys[v];
        sinks += st.sink[v] * x[v];
        for (int64_t k = Ap[v]; k < Ap[v + 1]; ++k)
            if ((size_t)Ai[k] == v)
                diag_worst = fmax(diag_worst, fabs(ohm_stencil_diag(&st, (int64_t)v) / Ax[k] - 1.0));
    }
    printf("coupled stencil against the coupled matrix: A x within %.2g of the row's scale, diagonal within %.2g; "
           "sum of rows %.17g, of sinks x %.17g\n",
           worst, diag_worst, rows, sinks);
    CHECK_MSG(worst <= 1e-6, "A x differs by %.3g", worst); /* the links' floats: 6e-8 each */
    CHECK_MSG(diag_worst <= 1e-6, "diagonal differs by %.3g", diag_worst);
    CHECK_MSG(fabs(rows - sinks) <= 1e-12 * sinks, "rows sum %.17g, sinks %.17g", rows, sinks);
    free(x), free(ys), free(ym), free(sga), free(sgb), free(ga), free(gb);
    ohm_stencil_free(&st);
    ohm_clear_exchange_free(&ce);
    cholmod_l_free_sparse(&A, &cc);
    cholmod_l_finish(&cc);
    ohm_network_free(&net);
    clear_scene_free(&sc);
}

/* The largest |a - b| over n values; with b NULL, the largest |a|. */
static double max_off(const double *a, const double *b, size_t n)
{
    double m = 0;
    for (size_t i = 0; i < n; ++i) m = fmax(m, fabs(a[i] - (b ? b[i] : 0.0)));
    return m;
}

/* Solves: the books close with the coupling, also where the clear region
 * meets the object's surface (the head slab's CSF at the box's sides); no
 * clear cell in the mask is the solve without one, bit for bit. */
static void test_solves(void)
{
    ohm_error err;
    clear_scene sc = {.nx = 16, .ny = 16, .nz = 20, .h = 1.0, .eta = 1.37, .g = 0.01, .medium = head_medium};
    CHECK(clear_scene_make(&sc, &err) == 0);
    ohm_solution on, plain, none;
    CHECK_MSG(clear_scene_solve(&on, &sc, sc.clear, NULL, 0, &err) == 0, "%s", err.msg);
    double ce = ohm_solution_conservation_error(&on);
    CHECK_MSG(ce <= 1e-10, "conservation %.3g with the coupling", ce);
    CHECK(on.power_out > 0 && on.power_absorbed > 0);
    uint8_t *zero = calloc(sc.n, 1);
    CHECK(clear_scene_solve(&plain, &sc, NULL, NULL, 0, &err) == 0);
    CHECK(clear_scene_solve(&none, &sc, zero, NULL, 0, &err) == 0);
    /* (to 1e-12 of the peak, not bit for bit: the factor's BLAS takes as
     * many threads as there are idle cores, and its sums' order with them) */
    CHECK(max_off(plain.fluence[0], none.fluence[0], sc.n) <= 1e-12 * max_off(plain.fluence[0], NULL, sc.n));
    CHECK(max_off(plain.face_exitance[0], none.face_exitance[0], (size_t)plain.net.nfaces) <=
          1e-12 * max_off(plain.face_exitance[0], NULL, (size_t)plain.net.nfaces));
    /* and the mask is used */
    CHECK(max_off(plain.fluence[0], on.fluence[0], sc.n) > 1e-3 * max_off(plain.fluence[0], NULL, sc.n));
    /* cg solves the coupled matrix, and mg its stencil form (the pairs as
     * links beyond the grid, in its coarse levels too), to the direct
     * solve's answer; mg conserves power to 1e-10 and converges in few
     * iterations (a clear cell's huge D is no longer in the operator) */
    ohm_solution cg, mg;
    CHECK_MSG(clear_scene_solve_with(&cg, &sc, sc.clear, NULL, 0, OHM_SOLVER_CG, &err) == 0, "%s", err.msg);
    double worst = 0;
    for (size_t v = 0; v < sc.n; ++v) worst = fmax(worst, fabs(cg.fluence[0][v] - on.fluence[0][v]) / on.fluence[0][v]);
    CHECK_MSG(worst < 1e-6, "cg differs from direct by %.3g", worst);
    ohm_solution_free(&cg);
    CHECK_MSG(clear_scene_solve_with(&mg, &sc, sc.clear, NULL, 0, OHM_SOLVER_MG, &err) == 0, "%s", err.msg);
    worst = 0;
    for (size_t v = 0; v < sc.n; ++v) worst = fmax(worst, fabs(mg.fluence[0][v] - on.fluence[0][v]) / on.fluence[0][v]);
    double mg_ce = ohm_solution_conservation_error(&mg);
    printf("mg on the coupled stencil: %lld iterations, %.2g off direct, conservation %.2g\n",
           (long long)mg.cg_iterations, worst, mg_ce);
    CHECK_MSG(worst < 1e-6, "mg differs from direct by %.3g", worst);
    CHECK_MSG(mg_ce <= 1e-10, "mg's conservation %.3g with the coupling", mg_ce);
    CHECK_MSG(mg.cg_iterations > 0 && mg.cg_iterations <= 30, "mg took %lld iterations", (long long)mg.cg_iterations);
    ohm_solution_free(&mg);
    /* auto, which probes mg first */
    ohm_solution au;
    CHECK_MSG(clear_scene_solve_with(&au, &sc, sc.clear, NULL, 0, OHM_SOLVER_AUTO, &err) == 0, "%s", err.msg);
    worst = 0;
    for (size_t v = 0; v < sc.n; ++v) worst = fmax(worst, fabs(au.fluence[0][v] - on.fluence[0][v]) / on.fluence[0][v]);
    CHECK_MSG(worst < 1e-6, "auto differs from direct by %.3g", worst);
    ohm_solution_free(&au);
    ohm_solution_free(&on), ohm_solution_free(&plain), ohm_solution_free(&none);
    free(zero);
    clear_scene_free(&sc);
}

/* An air gap (index 1.0) in tissue of index 1.37: with the walls' index
 * step (the partial-current condition's A(m) - m^2) the books close and the
 * fluence is positive; a step makes the wall resist more than half a cell. */
static void test_index_gap(void)
{
    ohm_error err;
    clear_scene sc = {.nx = 16, .ny = 16, .nz = 14, .h = 1.0, .eta = 1.37, .g = 0.01, .medium = gap_medium,
                      .clear_eta = 1.0};
    CHECK(clear_scene_make(&sc, &err) == 0);
    ohm_solution on;
    CHECK_MSG(clear_scene_solve(&on, &sc, sc.clear, NULL, 0, &err) == 0, "%s", err.msg);
    double ce = ohm_solution_conservation_error(&on);
    CHECK_MSG(ce <= 1e-10, "conservation %.3g with an index step at the walls", ce);
    int positive = 1;
    for (size_t v = 0; v < sc.n; ++v) positive &= on.fluence[0][v] > 0;
    CHECK(positive);
    /* without a step the wall is half a cell of diffusion; with one it
     * resists more (A(1.37) > 1.37^2) */
    double D = 1.0 / (3.0 * 1.01);
    CHECK(ohm_clear_wall_conductance(1.0, D, 1.0, 1.37, 1.37) == 2.0 * D);
    CHECK(ohm_clear_wall_conductance(1.0, D, 1.0, 1.37, 1.0) < 2.0 * D);
    CHECK(ohm_clear_wall_conductance(1.0, D, 1.0, 1.0, 1.37) < 2.0 * D);
    ohm_solution_free(&on);
    clear_scene_free(&sc);
}

/* The transport study's cube with a clear void, at 2/3 of its size: the bulk
 * fluence against ohm's tracer (fixed seed), diffusion alone and coupled. */
static void test_void_against_mc(void)
{
    ohm_error err;
    clear_scene sc = {.nx = 20, .ny = 20, .nz = 40, .h = 1.0, .eta = 1.37, .g = 0.01, .medium = void_medium,
                      .sphere_c = 14.0, .sphere_r = 20.0 / 3.0};
    CHECK(clear_scene_make(&sc, &err) == 0);
    ohm_mc_params mc = {.photons = 400000, .seed = 7};
    ohm_solution ref, off, on;
    CHECK_MSG(clear_scene_solve(&ref, &sc, NULL, &mc, 0, &err) == 0, "%s", err.msg);
    CHECK(clear_scene_solve(&off, &sc, NULL, NULL, 200000, &err) == 0);
    CHECK(clear_scene_solve(&on, &sc, sc.clear, NULL, 200000, &err) == 0);
    ohm_block_error eo = clear_scene_bulk(&sc, &off, &ref, 0), ec = clear_scene_bulk(&sc, &on, &ref, 0);
    printf("void scene: bulk bias diffusion alone %+.2f%% (mean |err| %.2f%%), coupled %+.2f%% (%.2f%%), %lld blocks\n",
           100 * eo.bias, 100 * eo.mean_abs, 100 * ec.bias, 100 * ec.mean_abs, (long long)ec.blocks);
    CHECK(ec.blocks > 20);
    CHECK_MSG(fabs(ec.bias) <= 0.02, "coupled bulk bias %+.3f", ec.bias);
    CHECK_MSG(ec.mean_abs < eo.mean_abs, "coupled %.4f, diffusion alone %.4f", ec.mean_abs, eo.mean_abs);
    CHECK(ohm_solution_conservation_error(&on) <= 1e-10);
    ohm_solution_free(&ref), ohm_solution_free(&off), ohm_solution_free(&on);
    clear_scene_free(&sc);
}

int main(void)
{
    test_reciprocity();
    test_matrix();
    test_stencil_form();
    test_solves();
    test_index_gap();
    test_void_against_mc();
    return check_summary();
}
