/* test_cg.c — the MIC(0)-preconditioned conjugate gradients of cg.h against
 * the Cholesky factor: the same solution on an inhomogeneous medium with a
 * 1e4 contrast, warm starts that pay, iteration growth slower than h^-1
 * (MIC's point), and the half-space reference met equally by both. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "solvers/cg.h"
#include "check.h"
#include "solvers/direct.h"
#include "physics/network.h"
#include "studies/validate.h"

/* A box of nx^3 interior cells (and a one-cell margin) of size h. */
static int make_box(ohm_voxel_grid *g, int nx, double h)
{
    memset(g, 0, sizeof *g);
    int d = nx + 2;
    g->dims[0] = g->dims[1] = g->dims[2] = d;
    g->h = h;
    size_t cells = (size_t)d * d * d;
    g->inside = calloc(cells, 1);
    if (!g->inside) return -1;
    for (int k = 1; k <= nx; ++k)
        for (int j = 1; j <= nx; ++j)
            for (int i = 1; i <= nx; ++i) g->inside[ohm_voxel_index(g, i, j, k)] = 1;
    g->interior_cells = (size_t)nx * nx * nx;
    return 0;
}

static double lcg(uint64_t *s) /* deterministic [0, 1) */
{
    *s = *s * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(*s >> 11) / 9007199254740992.0;
}

/* A for the box with per-cell sigma_s' from 1 to 1e4 (two blocks) and the
 * Robin boundary. */
static cholmod_sparse *assemble(ohm_network *net, const ohm_voxel_grid *g, ohm_coeff *ss, cholmod_common *cc)
{
    ohm_error err;
    ohm_error_clear(&err);
    if (ohm_network_build(net, g, NULL, &err)) return NULL;
    ohm_channel_medium med;
    memset(&med, 0, sizeof med);
    med.sigma_a0 = 0.01;
    med.sigma_s0 = 1.0;
    med.sigma_s = ss;
    med.eta = 1.3;
    cholmod_sparse *A = NULL;
    if (ohm_network_assemble(&A, NULL, NULL, net, &med, OHM_BOUNDARY_ROBIN, cc, &err)) return NULL;
    return A;
}

static int64_t cg_iterations_for_box(int nx, double L)
{
    ohm_voxel_grid g;
    if (make_box(&g, nx, L / nx)) return -1;
    ohm_cholesky s;
    ohm_error err;
    ohm_error_clear(&err);
    ohm_cholesky_start(&s, &err);
    ohm_network net;
    cholmod_sparse *A = assemble(&net, &g, NULL, &s.cc);
    int64_t n = net.n, its = -1;
    double *b = calloc((size_t)n, sizeof *b), *x = calloc((size_t)n, sizeof *x), relres = 0;
    b[0] = 1.0; /* a corner source */
    ohm_cg cg;
    if (A && b && x && !ohm_cg_setup(&cg, A, &err)) {
        if (ohm_cg_solve(&cg, x, b, 1e-10, 100000, &its, &relres, &err)) its = -1;
        ohm_cg_free(&cg);
    }
    free(b), free(x);
    cholmod_l_free_sparse(&A, &s.cc);
    ohm_network_free(&net);
    ohm_cholesky_finish(&s);
    ohm_voxel_grid_free(&g);
    return its;
}

int main(void)
{
    /* --- CG = the factor, on a 1e4-contrast medium ------------------------- */
    ohm_voxel_grid g;
    CHECK(make_box(&g, 20, 0.5) == 0);
    ohm_cholesky s;
    ohm_error err;
    ohm_error_clear(&err);
    CHECK(ohm_cholesky_start(&s, &err) == 0);
    int64_t n = (int64_t)g.interior_cells;
    ohm_coeff *ss = malloc((size_t)n * sizeof *ss);
    for (int64_t v = 0; v < n; ++v) ss[v] = v < n / 2 ? 1.0f : 1e4f;
    ohm_network net;
    cholmod_sparse *A = assemble(&net, &g, ss, &s.cc);
    CHECK(A != NULL);
    double *b = malloc((size_t)n * sizeof *b), *xd = malloc((size_t)n * sizeof *xd);
    double *xc = calloc((size_t)n, sizeof *xc), *b2 = malloc((size_t)n * sizeof *b2);
    uint64_t seed = 42;
    for (int64_t v = 0; v < n; ++v) b[v] = lcg(&seed);
    cholmod_factor *L = NULL;
    double berr = 0;
    CHECK(ohm_cholesky_analyze(&s, A, "metis", NULL, NULL, NULL, &err) == 0);
    CHECK(ohm_cholesky_factorize(&L, &s, A, NULL, NULL, &err) == 0);
    CHECK(ohm_cholesky_solve(xd, &s, L, A, b, 1, &berr, NULL, &err) == 0);
    ohm_cg cg;
    CHECK(ohm_cg_setup(&cg, A, &err) == 0);
    int64_t its_cold = 0, its = 0;
    double relres = 0;
    CHECK(ohm_cg_solve(&cg, xc, b, 1e-12, 100000, &its_cold, &relres, &err) == 0);
    CHECK_MSG(relres <= 1e-12, "relres %g", relres);
    double dmax = 0, xmax = 0;
    for (int64_t v = 0; v < n; ++v) {
        dmax = fmax(dmax, fabs(xc[v] - xd[v]));
        xmax = fmax(xmax, fabs(xd[v]));
    }
    CHECK_MSG(dmax <= 1e-9 * xmax, "cg vs factor: %g of %g", dmax, xmax);
    /* started at the answer: nothing to do */
    CHECK(ohm_cg_solve(&cg, xc, b, 1e-10, 100000, &its, &relres, &err) == 0);
    CHECK_MSG(its == 0, "%lld iterations from the solution", (long long)its);
    /* a right-hand side 1% away: the warm start saves iterations */
    for (int64_t v = 0; v < n; ++v) b2[v] = b[v] * (1.0 + 0.01 * lcg(&seed));
    int64_t its_warm = 0, its_b2_cold = 0;
    CHECK(ohm_cg_solve(&cg, xc, b2, 1e-12, 100000, &its_warm, &relres, &err) == 0);
    memset(xc, 0, (size_t)n * sizeof *xc);
    CHECK(ohm_cg_solve(&cg, xc, b2, 1e-12, 100000, &its_b2_cold, &relres, &err) == 0);
    CHECK_MSG(its_warm < its_b2_cold, "warm %lld, cold %lld", (long long)its_warm, (long long)its_b2_cold);
    /* capped: the failure names the residual */
    memset(xc, 0, (size_t)n * sizeof *xc);
    CHECK(ohm_cg_solve(&cg, xc, b, 1e-12, 2, &its, &relres, &err) == OHM_ERR_NUMERIC);
    CHECK(strstr(err.msg, "did not converge") != NULL);
    ohm_cg_free(&cg);
    ohm_cholesky_factor_free(&L, &s);
    cholmod_l_free_sparse(&A, &s.cc);
    ohm_network_free(&net);
    ohm_cholesky_finish(&s);
    ohm_voxel_grid_free(&g);
    free(ss), free(b), free(xd), free(xc), free(b2);
    fprintf(stderr, "cg: 1e4 contrast, 8000 cells: %lld iterations cold; a 1%% change: %lld warm, %lld cold\n",
            (long long)its_cold, (long long)its_warm, (long long)its_b2_cold);

    /* --- MIC's point: iterations grow more slowly than h^-1 ------------------- */
    int64_t i16 = cg_iterations_for_box(16, 20.0), i32 = cg_iterations_for_box(32, 20.0);
    CHECK(i16 > 0 && i32 > 0);
    double growth = log((double)i32 / (double)i16) / log(2.0);
    fprintf(stderr, "cg: 20 mm box, h 1.25 -> 0.625 mm: %lld -> %lld iterations (h^-%.2f)\n", (long long)i16,
            (long long)i32, growth);
    CHECK_MSG(growth < 0.8, "iterations grow as h^-%.2f", growth);

    /* --- the half-space reference, met equally by both ------------------------ */
    const ohm_log quiet = {.verbosity = 0};
    ohm_halfspace_result rd, rc;
    CHECK(ohm_halfspace_accuracy(&rd, 0.5, 0, &quiet, &err) == 0);
    CHECK(ohm_halfspace_accuracy(&rc, 0.5, 1, &quiet, &err) == 0);
    CHECK_REL(rc.mean, rd.mean, 1e-6);
    CHECK_REL(rc.worst, rd.worst, 1e-6);
    CHECK(rd.mean < 0.02); /* 1.41% at h = 0.5 (docs/accuracy.md) */
    return check_summary();
}
