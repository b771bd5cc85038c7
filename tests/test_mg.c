/* test_mg.c — the geometric multigrid of mg.h against the Cholesky factor
 * and against itself as the grid grows:
 *   - the stencil is the assembled matrix (same products A x, same norm);
 *   - on irregular objects (a ball with a hole, a separate speck, a
 *     one-voxel-thin sheet) with a 1e6 contrast, per boundary mode, mg's
 *     solution is the factor's to 1e-8 in every cell;
 *   - the Galerkin coarse levels conserve: with a uniform source, the power
 *     sunk (sum of sink x) equals the power put in to round-off;
 *   - on the block medium (random blocks of 1 and 1e6 in sigma_s'), iterations to
 *     1e-10 grow by at most 25% from 32^3 to 64^3 cells and stay <= 30;
 *   - a warm start from the answer takes no iteration; a capped solve fails
 *     naming its residual;
 *   - the stencil's runs are A's neighbours; a solve is the same bits on
 *     one core and on two. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "blocks.h"
#include "check.h"
#include "physics/network.h"
#include "physics/stencil.h"
#include "solvers/backend.h"
#include "solvers/cg.h"
#include "solvers/direct.h"
#include "solvers/grid_order.h"
#include "solvers/mg.h"

/* A ball of radius 11 with a hole through it, a speck apart from it, and a
 * one-voxel-thin sheet touching nothing: the shapes a geometric coarsening
 * must not trip on. */
static int make_irregular(ohm_voxel_grid *g)
{
    if (ohm_cube_grid(g, 30, 0.5)) return -1;
    for (int k = 0; k < 30; ++k)
        for (int j = 0; j < 30; ++j)
            for (int i = 0; i < 30; ++i) {
                double x = i - 13.5, y = j - 13.5, z = k - 13.5;
                int ball = x * x + y * y + z * z < 121 && !(x * x + y * y < 9);
                int speck = i == 27 && j == 27 && k >= 26 && k <= 27;
                int sheet = i == 27 && j >= 2 && j < 20 && k >= 2 && k < 20;
                g->inside[ohm_voxel_index(g, i, j, k)] = (uint8_t)(ball || speck || sheet);
            }
    ohm_grid_count_inside(g);
    return 0;
}

/* The stencil's runs (network.h) against A's links: they cover the
 * unknowns in order, each is longest (its neighbours' offsets differ), and
 * every unknown's y and z neighbours are where A couples it. */
static void check_runs(const ohm_stencil *st, const cholmod_sparse *A, const ohm_network *net)
{
    int64_t n = st->n, sy = net->grid->dims[0], sz = sy * net->grid->dims[1];
    int32_t(*expect)[4] = calloc((size_t)n, sizeof *expect);
    const int64_t *Ap = A->p, *Ai = A->i;
    for (int64_t u = 0; u < n; ++u) /* A's upper triangle: column u's rows w < u are its lower neighbours */
        for (int64_t p = Ap[u]; p < Ap[u + 1]; ++p) {
            int64_t w = Ai[p], cells = ohm_network_cell(net, u) - ohm_network_cell(net, w);
            int a = cells == sy ? 0 : cells == sz ? 2 : -1; /* -y or -z; -x needs no offset */
            if (w == u || a < 0) continue;
            expect[u][a] = (int32_t)(w - u);
            expect[w][a + 1] = (int32_t)(u - w);
        }
    size_t wrong = 0, short_runs = 0;
    CHECK(st->nruns >= 1 && st->run_start[0] == 0 && st->run_start[st->nruns] == n);
    for (int64_t r = 0; r < st->nruns; ++r) {
        CHECK(st->run_start[r] < st->run_start[r + 1]);
        if (r + 1 < st->nruns && memcmp(st->run_off[r], st->run_off[r + 1], sizeof st->run_off[r]) == 0) ++short_runs;
        for (int64_t v = st->run_start[r]; v < st->run_start[r + 1]; ++v)
            wrong += memcmp(st->run_off[r], expect[v], sizeof expect[v]) != 0;
    }
    CHECK_MSG(wrong == 0, "%zu unknowns' runs name other neighbours than A's", wrong);
    CHECK_MSG(short_runs == 0, "%zu runs could have been joined to the next", short_runs);
    free(expect);
}

/* mg against the factor on grid g, boundary b: the largest cell difference
 * relative to the largest fluence. */
static double against_factor(const ohm_voxel_grid *g, const ohm_coeff *ss, ohm_boundary b, int64_t *its_out)
{
    ohm_error err;
    ohm_error_clear(&err);
    ohm_network net;
    ohm_cholesky s;
    CHECK(ohm_cholesky_start(&s, &err) == 0);
    CHECK(ohm_network_build(&net, g, NULL, &err) == 0);
    ohm_channel_medium med;
    ohm_block_medium(&med, ss, 0.01);
    cholmod_sparse *A = NULL;
    ohm_stencil st = {0};
    CHECK_MSG(ohm_network_assemble(&A, NULL, NULL, &net, &med, b, &s.cc, &err) == 0, "%s", err.msg);
    CHECK_MSG(ohm_network_stencil(&st, NULL, NULL, &net, &med, b, &err) == 0, "%s", err.msg);
    int64_t n = net.n;
    double *bv = malloc((size_t)n * sizeof *bv), *xd = malloc((size_t)n * sizeof *xd);
    double *xm = calloc((size_t)n, sizeof *xm), *y1 = malloc((size_t)n * sizeof *y1), *y2 = malloc((size_t)n * 8);
    uint64_t seed = 7;
    for (int64_t v = 0; v < n; ++v) bv[v] = ohm_lcg(&seed) < 0.05 ? ohm_lcg(&seed) : 0.0;
    bv[n / 2] = 1.0;
    /* the stencil is A */
    ohm_sym_upper_mult(A, bv, y1);
    ohm_stencil_apply(&st, bv, y2, 2);
    double dy = 0, ymax = 0;
    for (int64_t v = 0; v < n; ++v) {
        dy = fmax(dy, fabs(y1[v] - y2[v]));
        ymax = fmax(ymax, fabs(y1[v]));
    }
    CHECK_MSG(dy <= 1e-14 * ymax, "stencil vs A: %g of %g", dy, ymax);
    CHECK_REL(ohm_stencil_norm_inf(&st), ohm_sym_upper_norm_inf(A), 1e-14);
    check_runs(&st, A, &net);
    /* the factor's solution */
    cholmod_factor *L = NULL;
    double berr = 0;
    CHECK(ohm_cholesky_analyze(&s, A, "metis", NULL, NULL, NULL, &err) == 0);
    CHECK(ohm_cholesky_factorize(&L, &s, A, NULL, NULL, &err) == 0);
    CHECK(ohm_cholesky_solve(xd, &s, L, A, bv, 1, &berr, NULL, &err) == 0);
    /* mg's */
    ohm_grid_layout layout = ohm_grid_layout_of(&net);
    ohm_mg *mg = NULL;
    int64_t its = -1;
    double relres = 0, dmax = INFINITY, xmax = 0;
    CHECK_MSG(ohm_mg_setup(&mg, &st, &layout, 2, &err) == 0, "%s", err.msg);
    if (mg) {
        CHECK_MSG(ohm_mg_solve(mg, xm, bv, 1e-10, 500, NULL, &its, &relres, &err) == 0, "%s", err.msg);
        dmax = 0;
        for (int64_t v = 0; v < n; ++v) {
            dmax = fmax(dmax, fabs(xm[v] - xd[v]));
            xmax = fmax(xmax, fabs(xd[v]));
        }
        dmax /= xmax;
        /* started at the answer: nothing to do */
        int64_t again = -1;
        CHECK(ohm_mg_solve(mg, xm, bv, 1e-10, 500, NULL, &again, &relres, &err) == 0 && again == 0);
        /* capped: the failure names the residual */
        memset(xm, 0, (size_t)n * sizeof *xm);
        CHECK(ohm_mg_solve(mg, xm, bv, 1e-10, 1, NULL, &again, &relres, &err) == OHM_ERR_NUMERIC &&
              strstr(err.msg, "did not converge") != NULL);
    }
    *its_out = its;
    ohm_mg_free(mg);
    ohm_stencil_free(&st);
    ohm_cholesky_factor_free(&L, &s);
    cholmod_l_free_sparse(&A, &s.cc);
    ohm_network_free(&net);
    ohm_cholesky_finish(&s);
    free(bv), free(xd), free(xm), free(y1), free(y2);
    return dmax;
}

/* The block medium of nx^3 cells in blocks of `block` cells (sigma_a
 * 0.01), its network and stencil, for a test; 0, or -1 (checked). */
typedef struct block_case {
    ohm_voxel_grid g;
    ohm_coeff *ss;
    ohm_network net;
    ohm_stencil st;
    ohm_grid_layout layout;
} block_case;

static int block_case_open(block_case *c, int nx, int block)
{
    memset(c, 0, sizeof *c);
    ohm_error err;
    ohm_error_clear(&err);
    int ok = ohm_block_medium_grid(&c->g, nx, &c->ss, block) == 0 &&
             block_stencil(&c->net, &c->st, &c->g, c->ss, 0.01, &err) == 0;
    CHECK_MSG(ok, "the block medium at %d^3: %s", nx, err.msg);
    if (ok) c->layout = ohm_grid_layout_of(&c->net);
    return ok ? 0 : -1;
}

static void block_case_close(block_case *c)
{
    ohm_stencil_free(&c->st);
    ohm_network_free(&c->net);
    ohm_voxel_grid_free(&c->g);
    free(c->ss);
}

/* A uniform source on a box: what the solution sinks (ground and boundary)
 * is what went in, to round-off, through every level's correction. */
static void conservation(void)
{
    block_case c;
    if (block_case_open(&c, 40, 5)) return;
    ohm_error err;
    ohm_error_clear(&err);
    int64_t n = c.net.n, its = 0;
    double *b = malloc((size_t)n * 8), *x = calloc((size_t)n, 8), relres = 0;
    for (int64_t v = 0; v < n; ++v) b[v] = 1.0 / (double)n;
    ohm_mg *mg = NULL;
    CHECK(ohm_mg_setup(&mg, &c.st, &c.layout, 2, &err) == 0);
    CHECK(mg && ohm_mg_solve(mg, x, b, 1e-12, 500, NULL, &its, &relres, &err) == 0);
    double sunk = 0;
    for (int64_t v = 0; v < n; ++v) sunk += c.st.sink[v] * x[v];
    CHECK_MSG(fabs(sunk - 1.0) <= 1e-10, "1 W in, %.15g W sunk", sunk);
    int64_t cells = 0;
    int levels = mg ? ohm_mg_levels(mg, &cells) : 0;
    /* the coarse levels together: an eighth, a 64th ... of n where blocks
     * are whole (n/7); the parts of blocks that the medium's jumps cut
     * make it about n/5 here (mg_coarsen.h) */
    CHECK_MSG(levels >= 3 && cells < n + n / 4, "%d levels, %lld cells for %lld", levels, (long long)cells,
              (long long)n);
    ohm_mg_free(mg);
    block_case_close(&c);
    free(b), free(x);
}

/* A solve gives the same bits on one core as on two (mg.c: the loops are
 * cut into the same pieces whatever the cores, their sums added in order,
 * the vector lanes' sums fixed by each stretch): 48^3 cells, above the size
 * where the kernels start sharing work. */
static void same_bits_on_any_cores(void)
{
    block_case c;
    if (block_case_open(&c, 48, 8)) return;
    ohm_error err;
    ohm_error_clear(&err);
    int64_t n = c.net.n, its[2] = {-1, -1};
    CHECK_MSG(n > 65536, "%lld cells: too few to share work", (long long)n);
    double *b = malloc((size_t)n * 8), *x[3] = {calloc((size_t)n, 8), calloc((size_t)n, 8), calloc((size_t)n, 8)};
    double relres = 0;
    int64_t its2 = -1;
    uint64_t seed = 5;
    for (int64_t v = 0; v < n; ++v) b[v] = ohm_lcg(&seed);
    /* set up and solved on one core, on two, and set up on two then solved
     * on one (ohm_mg_set_threads: a busy machine's idle cores) */
    for (int t = 0; t < 3; ++t) {
        ohm_mg *mg = NULL;
        CHECK_MSG(ohm_mg_setup(&mg, &c.st, &c.layout, t == 0 ? 1 : 2, &err) == 0, "%s", err.msg);
        if (mg && t == 2) ohm_mg_set_threads(mg, 1);
        CHECK_MSG(mg && ohm_mg_solve(mg, x[t], b, 1e-10, 500, NULL, t < 2 ? &its[t] : &its2, &relres, &err) == 0,
                  "%s", err.msg);
        ohm_mg_free(mg);
    }
    CHECK_MSG(its[0] > 0 && its[0] == its[1] && its2 == its[0], "%lld iterations on one core, %lld on two, %lld",
              (long long)its[0], (long long)its[1], (long long)its2);
    CHECK_MSG(memcmp(x[0], x[1], (size_t)n * sizeof *x[0]) == 0, "the solutions on one and two cores differ");
    CHECK_MSG(memcmp(x[0], x[2], (size_t)n * sizeof *x[0]) == 0, "set up on two cores, solved on one: differs");
    block_case_close(&c);
    free(b), free(x[0]), free(x[1]), free(x[2]);
}

/* Iterations on the block medium (blocks of 8 cells, 1e6 contrast) of
 * nx^3 cells, a point source in a corner block. */
static int64_t block_iterations(int nx)
{
    ohm_voxel_grid g;
    ohm_coeff *ss = NULL;
    if (ohm_block_medium_grid(&g, nx, &ss, 8)) return -1;
    ohm_error err;
    ohm_error_clear(&err);
    ohm_network net;
    ohm_channel_medium med;
    ohm_block_medium(&med, ss, 0.01);
    ohm_stencil st = {0};
    int64_t its = -1;
    if (!ohm_network_build(&net, &g, NULL, &err)) {
        if (!ohm_network_stencil(&st, NULL, NULL, &net, &med, OHM_BOUNDARY_ROBIN, &err)) {
            int64_t n = net.n;
            double *b = calloc((size_t)n, 8), *x = calloc((size_t)n, 8), relres = 0;
            uint64_t seed = 3;
            for (int64_t v = 0; v < n; ++v) b[v] = ohm_lcg(&seed);
            ohm_grid_layout layout = ohm_grid_layout_of(&net);
            ohm_mg *mg = NULL;
            if (b && x && !ohm_mg_setup(&mg, &st, &layout, 0, &err) &&
                ohm_mg_solve(mg, x, b, 1e-10, 500, NULL, &its, &relres, &err))
                its = -1;
            ohm_mg_free(mg);
            free(b), free(x);
        }
        ohm_network_free(&net);
    }
    ohm_stencil_free(&st);
    ohm_voxel_grid_free(&g);
    free(ss);
    return its;
}

int main(void)
{
    ohm_voxel_grid g;
    CHECK(make_irregular(&g) == 0);
    ohm_coeff *ss = malloc(g.interior_cells * sizeof *ss);
    uint64_t seed = 11;
    for (size_t v = 0; v < g.interior_cells; ++v) ss[v] = ohm_lcg(&seed) < 0.5 ? 1.0f : 1e6f;
    static const ohm_boundary modes[] = {OHM_BOUNDARY_ROBIN, OHM_BOUNDARY_NEUMANN, OHM_BOUNDARY_DIRICHLET};
    for (int q = 0; q < 3; ++q) {
        int64_t its = 0;
        double d = against_factor(&g, ss, modes[q], &its);
        CHECK_MSG(d <= 1e-8, "boundary=%s: mg vs factor %.3g", ohm_boundary_name(modes[q]), d);
        fprintf(stderr, "mg: irregular object, %zu cells, 1e6 contrast, boundary=%s: %lld iterations, %.2g off the factor\n",
                g.interior_cells, ohm_boundary_name(modes[q]), (long long)its, d);
    }
    free(ss);
    ohm_voxel_grid_free(&g);

    conservation();
    same_bits_on_any_cores();

    int64_t small = block_iterations(32), large = block_iterations(64);
    fprintf(stderr, "mg: block medium, 1e6 contrast: %lld iterations at 32^3, %lld at 64^3\n", (long long)small,
            (long long)large);
    CHECK_MSG(small > 0 && large > 0 && large <= 30 && 4 * large <= 5 * small, "iterations %lld -> %lld",
              (long long)small, (long long)large);
    return check_summary();
}
