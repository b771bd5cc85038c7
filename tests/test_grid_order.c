/* test_grid_order.c — the geometric nested dissection (solvers/grid_order.h)
 * on a box, a concave frame, a scan-like blob of random density and a
 * one-cell-thick plate: a valid permutation of the unknowns; the factor it
 * orders solves the network to the same solution as METIS's to 1e-12; and
 * its fill stays within 10% of METIS's on the box (the grid graph itself,
 * where plane separators must do as well as a graph partitioner) and within
 * 1.5x on the other shapes; and ordering=auto's choices between them.  Fill
 * counts are deterministic, so they may be asserted; times are not. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "physics/network.h"
#include "solvers/direct.h"
#include "solvers/grid_order.h"

static double lcg(uint64_t *s) /* deterministic [0, 1) */
{
    *s = *s * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(*s >> 11) / 9007199254740992.0;
}

enum shape { BOX, FRAME, BLOB, PLATE };
static const char *const SHAPE_NAME[] = {"box", "frame", "blob", "plate"};

/* A d^3 grid (margin included) with the shape's cells inside. */
static int make_shape(ohm_voxel_grid *g, enum shape shape, int d)
{
    memset(g, 0, sizeof *g);
    g->dims[0] = g->dims[1] = g->dims[2] = d;
    g->h = 1.0;
    g->inside = calloc((size_t)d * d * d, 1);
    if (!g->inside) return -1;
    /* the blob: a smooth random field (a few Gaussian bumps), thresholded */
    double bump[6][4];
    uint64_t seed = 5;
    for (int b = 0; b < 6; ++b)
        for (int a = 0; a < 4; ++a) bump[b][a] = a < 3 ? 2 + (d - 4) * lcg(&seed) : 2 + 0.2 * d * lcg(&seed);
    for (int k = 1; k < d - 1; ++k)
        for (int j = 1; j < d - 1; ++j)
            for (int i = 1; i < d - 1; ++i) {
                int in = 1, m = d / 3;
                if (shape == FRAME) in = !(i >= m && i < d - m && j >= m && j < d - m); /* a hole along z */
                if (shape == PLATE) in = k == d / 2;
                if (shape == BLOB) {
                    double f = 0;
                    for (int b = 0; b < 6; ++b) {
                        double x = i - bump[b][0], y = j - bump[b][1], z = k - bump[b][2], r = bump[b][3];
                        f += exp(-(x * x + y * y + z * z) / (r * r));
                    }
                    in = f > 0.5;
                }
                if (in) {
                    g->inside[ohm_voxel_index(g, i, j, k)] = 1;
                    ++g->interior_cells;
                }
            }
    return 0;
}

/* A with a per-cell sigma_s' contrast of 1e3 (random), the Robin boundary. */
static cholmod_sparse *assemble(ohm_network *net, const ohm_voxel_grid *g, ohm_coeff **ss, cholmod_common *cc)
{
    ohm_error err;
    ohm_error_clear(&err);
    if (ohm_network_build(net, g, NULL, &err)) return NULL;
    *ss = malloc((size_t)net->n * sizeof **ss);
    uint64_t seed = 11;
    for (int64_t v = 0; v < net->n; ++v) (*ss)[v] = (ohm_coeff)pow(10.0, 3.0 * lcg(&seed));
    ohm_channel_medium med;
    memset(&med, 0, sizeof med);
    med.sigma_a0 = 0.01;
    med.sigma_s0 = 1.0;
    med.sigma_s = *ss;
    med.eta = 1.3;
    cholmod_sparse *A = NULL;
    if (ohm_network_assemble(&A, NULL, NULL, net, &med, OHM_BOUNDARY_ROBIN, cc, &err)) return NULL;
    return A;
}

static int is_permutation(const int64_t *perm, int64_t n)
{
    unsigned char *seen = calloc((size_t)(n ? n : 1), 1);
    int ok = seen != NULL;
    for (int64_t k = 0; k < n && ok; ++k) {
        ok = perm[k] >= 0 && perm[k] < n && !seen[perm[k]];
        if (ok) seen[perm[k]] = 1;
    }
    free(seen);
    return ok;
}

/* x = A^-1 b with one ordering (auto: weighing costs); nnz(L) into *lnz,
 * the ordering used into chosen[16]. */
static int solve_with(double *x, double *lnz, char *chosen, cholmod_sparse *A, const char *ordering,
                      const ohm_grid_layout *layout, const ohm_ordering_costs *costs, const double *b)
{
    ohm_error err;
    ohm_error_clear(&err);
    ohm_cholesky s;
    cholmod_factor *L = NULL;
    double berr = 1;
    int rc = ohm_cholesky_start(&s, &err);
    if (!rc) rc = ohm_cholesky_analyze(&s, A, ordering, layout, costs, NULL, &err);
    if (!rc) rc = ohm_cholesky_factorize(&L, &s, A, NULL, NULL, &err);
    if (!rc) rc = ohm_cholesky_solve(x, &s, L, A, b, 1, &berr, NULL, &err);
    if (rc) fprintf(stderr, "ordering=%s: %s\n", ordering, err.msg);
    *lnz = s.nnz_L;
    snprintf(chosen, 16, "%s", s.ordering);
    ohm_cholesky_factor_free(&L, &s);
    ohm_cholesky_finish(&s);
    return rc;
}

/* ordering=auto.  On an object from a mesh (METIS expected to leave the
 * grid's fill) METIS can never pay for its analysis: grid.  On a scan with a
 * million solves to come the predicted saving dwarfs any analysis time, and
 * a grid factor that does not fit in memory is worth a second analysis: in
 * both METIS is analysed too and the smaller measured fill is kept.
 * Without the layout: METIS.  Every choice solves to METIS's solution. */
static void check_auto(enum shape shape, cholmod_sparse *A, const ohm_grid_layout *layout, const double *b,
                       const double *xm, double lnz_grid, double lnz_metis)
{
    const struct {
        ohm_ordering_costs costs;
        int with_layout;
        const char *expect; /* NULL: the smaller fill */
    } cases[] = {{{3, 3, 1, 0, 0}, 1, "grid"},
                 {{1, 1e6, 1, 0, 0}, 1, "grid"},
                 {{1, 1e6, 1, 0, 1}, 1, NULL},
                 {{3, 3, 1, 1, 0}, 1, NULL}, /* one byte allowed: the grid's factor does not fit */
                 {{3, 3, 1, 0, 1}, 0, "metis"}};
    int64_t n = (int64_t)A->nrow;
    double *x = malloc((size_t)n * sizeof *x);
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        double lnz = 0;
        char used[16] = "";
        CHECK(solve_with(x, &lnz, used, A, "auto", cases[i].with_layout ? layout : NULL, &cases[i].costs, b) == 0);
        const char *expect = cases[i].expect ? cases[i].expect : lnz_metis < lnz_grid ? "metis" : "grid";
        CHECK_MSG(strcmp(used, expect) == 0, "%s: auto case %zu chose %s, expected %s", SHAPE_NAME[shape], i, used,
                  expect);
        CHECK_MSG(lnz == (strcmp(used, "metis") == 0 ? lnz_metis : lnz_grid), "%s: auto case %zu: nnz(L) %.4g",
                  SHAPE_NAME[shape], i, lnz);
        double worst = 0, scale = 0;
        for (int64_t v = 0; v < n; ++v) {
            worst = fmax(worst, fabs(x[v] - xm[v]));
            scale = fmax(scale, fabs(xm[v]));
        }
        CHECK_MSG(worst <= 1e-12 * scale, "%s: auto case %zu differs from METIS by %.3g", SHAPE_NAME[shape], i, worst);
    }
    free(x);
}

static void check_shape(enum shape shape, int d)
{
    ohm_voxel_grid g;
    CHECK(make_shape(&g, shape, d) == 0);
    ohm_network net;
    ohm_coeff *ss = NULL;
    cholmod_common cc;
    cholmod_l_start(&cc);
    cholmod_sparse *A = assemble(&net, &g, &ss, &cc);
    CHECK(A != NULL);
    if (!A) return;
    int64_t n = net.n;
    ohm_grid_layout layout = ohm_grid_layout_of(&net);
    int64_t *perm = malloc((size_t)n * sizeof *perm);
    ohm_error err;
    ohm_error_clear(&err);
    CHECK(ohm_grid_order(perm, &layout, &err) == 0);
    CHECK_MSG(is_permutation(perm, n), "%s: not a permutation of the %lld unknowns", SHAPE_NAME[shape], (long long)n);
    double *b = calloc((size_t)n, sizeof *b), *xm = malloc((size_t)n * sizeof *xm), *xg = malloc((size_t)n * sizeof *xg);
    uint64_t seed = 3;
    for (int64_t v = 0; v < n; ++v) b[v] = lcg(&seed) < 0.05 ? lcg(&seed) : 0.0;
    double lnz_metis = 0, lnz_grid = 0;
    char used[16];
    CHECK(solve_with(xm, &lnz_metis, used, A, "metis", &layout, NULL, b) == 0);
    CHECK(solve_with(xg, &lnz_grid, used, A, "grid", &layout, NULL, b) == 0);
    double worst = 0, scale = 0;
    for (int64_t v = 0; v < n; ++v) {
        worst = fmax(worst, fabs(xg[v] - xm[v]));
        scale = fmax(scale, fabs(xm[v]));
    }
    CHECK_MSG(worst <= 1e-12 * scale, "%s: grid and METIS solutions differ by %.3g of %.3g", SHAPE_NAME[shape], worst,
              scale);
    /* fill: the box is the grid graph itself, where plane separators must
     * do as well as a graph partitioner; the other shapes within 1.5x */
    double bound = shape == BOX ? 1.10 : 1.5;
    CHECK_MSG(lnz_grid <= bound * lnz_metis, "%s: nnz(L) %.4g with grid, %.4g with METIS (bound %.2fx)",
              SHAPE_NAME[shape], lnz_grid, lnz_metis, bound);
    fprintf(stderr, "%s: %lld unknowns, nnz(L) grid %.4g, METIS %.4g (%.2fx)\n", SHAPE_NAME[shape], (long long)n,
            lnz_grid, lnz_metis, lnz_grid / lnz_metis);
    check_auto(shape, A, &layout, b, xm, lnz_grid, lnz_metis);
    free(perm), free(b), free(xm), free(xg), free(ss);
    cholmod_l_free_sparse(&A, &cc);
    cholmod_l_finish(&cc);
    ohm_network_free(&net);
    ohm_voxel_grid_free(&g);
}

int main(void)
{
    check_shape(BOX, 24);
    check_shape(FRAME, 24);
    check_shape(BLOB, 26);
    check_shape(PLATE, 30);
    /* ordering=grid without the layout: a usage error that says what to do */
    ohm_voxel_grid g;
    CHECK(make_shape(&g, BOX, 6) == 0);
    ohm_network net;
    ohm_coeff *ss = NULL;
    cholmod_common cc;
    cholmod_l_start(&cc);
    cholmod_sparse *A = assemble(&net, &g, &ss, &cc);
    ohm_cholesky s;
    ohm_error err;
    ohm_error_clear(&err);
    CHECK(ohm_cholesky_start(&s, &err) == 0);
    CHECK(ohm_cholesky_analyze(&s, A, "grid", NULL, NULL, NULL, &err) == OHM_ERR_USAGE);
    CHECK(strstr(err.msg, "use metis, amd or nesdis") != NULL);
    ohm_cholesky_finish(&s);
    cholmod_l_free_sparse(&A, &cc);
    cholmod_l_finish(&cc);
    ohm_network_free(&net);
    ohm_voxel_grid_free(&g);
    free(ss);
    return check_summary();
}
