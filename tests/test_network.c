/* test_network.c — the assembled matrix, checked entry by entry against the
 * formulas of docs/design.md §3 computed here, on a real voxelized mesh. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "physics/material.h"
#include "physics/network.h"
#include "physics/stencil.h"
#include "solvers/solve.h"

static const ohm_log quiet = {.verbosity = 0};

static void check_matrix(const ohm_voxel_grid *g, ohm_boundary bnd, const ohm_coeff *sa, const ohm_coeff *ss, double eta)
{
    ohm_error err;
    ohm_error_clear(&err);
    ohm_network net;
    if (ohm_network_build(&net, g, NULL, &err)) {
        CHECK_MSG(0, "%s", err.msg);
        return;
    }
    cholmod_common cc;
    cholmod_l_start(&cc);
    cholmod_sparse *A = NULL;
    double *ga = malloc((size_t)net.n * sizeof *ga), *gb = malloc((size_t)net.nfaces * sizeof *gb);
    ohm_channel_medium med = {0};
    med.sigma_a = sa;
    med.sigma_s = ss;
    med.eta = eta;
    int rc = ohm_network_assemble(&A, ga, gb, &net, &med, bnd, &cc, &err);
    CHECK_MSG(rc == 0, "%s", err.msg);
    if (rc == 0) {
        const int64_t *Ap = A->p, *Ai = A->i;
        const double *Ax = A->x;
        double h = g->h, Aeta = ohm_boundary_A(eta, OHM_FRESNEL_EXACT);
        CHECK(A->stype == 1 && A->nrow == (size_t)net.n);
        size_t bad_pair = 0, bad_value = 0, bad_sign = 0, bad_diag = 0, pairs = 0;
        double *rowsum = calloc((size_t)net.n, sizeof *rowsum);
        for (int64_t v = 0; v < net.n; ++v) {
            for (int64_t p = Ap[v]; p < Ap[v + 1]; ++p) {
                int64_t w = Ai[p];
                double a = Ax[p];
                if (w == v) {
                    if (!(a > 0)) ++bad_diag;
                    rowsum[v] += a;
                    continue;
                }
                ++pairs;
                /* an off-diagonal entry couples face neighbours only */
                int64_t cv = ohm_network_cell(&net, v), cw = ohm_network_cell(&net, w), diff = cv - cw;
                int64_t sx = 1, sy = g->dims[0], sz = (int64_t)g->dims[0] * g->dims[1];
                if (!(diff == sx || diff == sy || diff == sz)) ++bad_pair;
                if (!(a < 0)) ++bad_sign;
                double Dv = 1.0 / (3 * ((double)sa[v] + ss[v])), Dw = 1.0 / (3 * ((double)sa[w] + ss[w]));
                double expect = -h * 2 * Dv * Dw / (Dv + Dw);
                /* held in single precision (network.h): within a float's
                 * rounding, 2^-24 of the value */
                if (fabs(a - expect) > (0x1p-24 + 1e-14) * fabs(expect)) ++bad_value;
                /* symmetric: the entry serves row v and row w */
                rowsum[v] += a;
                rowsum[w] += a;
            }
        }
        CHECK_MSG(bad_pair == 0, "%zu entries couple non-neighbours", bad_pair);
        CHECK_MSG(bad_sign == 0, "%zu off-diagonals are not negative", bad_sign);
        CHECK_MSG(bad_value == 0, "%zu conductances differ from h * harmonic mean of D", bad_value);
        CHECK_MSG(bad_diag == 0, "%zu diagonals are not positive", bad_diag);
        CHECK(pairs > 0);
        /* each row sums to its own ground + boundary conductance */
        double *expect_sum = calloc((size_t)net.n, sizeof *expect_sum);
        for (int64_t v = 0; v < net.n; ++v) expect_sum[v] = sa[v] * h * h * h;
        for (int64_t f = 0; f < net.nfaces; ++f) {
            int64_t v = net.face_unknown[f];
            double D = 1.0 / (3 * ((double)sa[v] + ss[v]));
            double gbf = bnd == OHM_BOUNDARY_ROBIN ? h * h / (h / (2 * D) + 2 * Aeta)
                         : bnd == OHM_BOUNDARY_DIRICHLET ? 2 * D * h
                                                         : 0.0;
            CHECK(fabs(gb[f] - gbf) <= 1e-15 * fabs(gbf));
            expect_sum[v] += gbf;
        }
        size_t bad_sum = 0;
        for (int64_t v = 0; v < net.n; ++v) {
            double scale = Ax[Ap[v + 1] - 1];
            if (fabs(rowsum[v] - expect_sum[v]) > 1e-12 * scale) ++bad_sum;
        }
        CHECK_MSG(bad_sum == 0, "%zu row sums differ from ground + boundary conductance", bad_sum);
        /* the number of pairs: every interior face once */
        size_t faces_inside = 0;
        for (int64_t v = 0; v < net.n; ++v) {
            size_t c = (size_t)ohm_network_cell(&net, v);
            int32_t i = (int32_t)(c % (size_t)g->dims[0]), j = (int32_t)((c / (size_t)g->dims[0]) % (size_t)g->dims[1]),
                    k = (int32_t)(c / ((size_t)g->dims[0] * (size_t)g->dims[1]));
            for (int d = 1; d < 6; d += 2) {
                int32_t a = i + ohm_face_offset[d][0], b = j + ohm_face_offset[d][1], e = k + ohm_face_offset[d][2];
                if (g->inside[ohm_voxel_index(g, a, b, e)]) ++faces_inside;
            }
        }
        CHECK(faces_inside == pairs);
        CHECK((int64_t)(pairs + (size_t)net.n) == net.nnz);
        free(rowsum);
        free(expect_sum);
    }
    cholmod_l_free_sparse(&A, &cc);
    cholmod_l_finish(&cc);
    free(ga);
    free(gb);
    ohm_network_free(&net);
}

/* A refilled matrix (ohm_network_assemble_into, what ohm_solve does for its
 * second and later channel materials) is bit for bit a fresh assembly of the
 * same medium, whatever medium filled it before; a matrix of another shape is
 * refused. */
static void refill(const ohm_voxel_grid *g, const ohm_coeff *sa, const ohm_coeff *ss)
{
    ohm_error err;
    ohm_network net;
    if (ohm_network_build(&net, g, NULL, &err)) {
        CHECK_MSG(0, "%s", err.msg);
        return;
    }
    cholmod_common cc;
    cholmod_l_start(&cc);
    size_t n = (size_t)net.n, nf = (size_t)net.nfaces;
    double *ga[2] = {malloc(n * sizeof(double)), malloc(n * sizeof(double))};
    double *gb[2] = {malloc(nf * sizeof(double)), malloc(nf * sizeof(double))};
    ohm_channel_medium grey = {0}, varying = {0};
    grey.sigma_a0 = 0.02, grey.sigma_s0 = 1.5, grey.eta = 1.3;
    varying.sigma_a = sa, varying.sigma_s = ss, varying.eta = 1.3;
    cholmod_sparse *fresh = NULL, *reused = NULL;
    int rc = ohm_network_assemble(&fresh, ga[0], gb[0], &net, &varying, OHM_BOUNDARY_ROBIN, &cc, &err);
    CHECK_MSG(rc == 0, "%s", err.msg);
    if (!rc) rc = ohm_network_assemble(&reused, NULL, NULL, &net, &grey, OHM_BOUNDARY_DIRICHLET, &cc, &err);
    CHECK_MSG(rc == 0, "%s", err.msg);
    if (!rc) rc = ohm_network_assemble_into(reused, ga[1], gb[1], &net, &varying, OHM_BOUNDARY_ROBIN, &err);
    CHECK_MSG(rc == 0, "%s", err.msg);
    if (!rc) {
        size_t nnz = (size_t)net.nnz;
        CHECK(!memcmp(fresh->p, reused->p, (n + 1) * sizeof(int64_t)));
        CHECK(!memcmp(fresh->i, reused->i, nnz * sizeof(int64_t)));
        CHECK(!memcmp(fresh->x, reused->x, nnz * sizeof(double)));
        CHECK(!memcmp(ga[0], ga[1], n * sizeof(double)) && !memcmp(gb[0], gb[1], nf * sizeof(double)));
        cholmod_sparse *other = cholmod_l_allocate_sparse(n - 1, n - 1, nnz, 1, 1, 1, CHOLMOD_REAL, &cc);
        CHECK(other && ohm_network_assemble_into(other, NULL, NULL, &net, &grey, OHM_BOUNDARY_ROBIN, &err) != 0);
        cholmod_l_free_sparse(&other, &cc);
    }
    cholmod_l_free_sparse(&fresh, &cc);
    cholmod_l_free_sparse(&reused, &cc);
    cholmod_l_finish(&cc);
    for (int q = 0; q < 2; ++q) free(ga[q]), free(gb[q]);
    ohm_network_free(&net);
}

static void channel_sharing(const ohm_voxel_grid *g)
{
    ohm_light l = {0};
    l.type = OHM_LIGHT_DIRECTIONAL;
    l.dir[1] = -1;
    l.intensity[0] = l.intensity[1] = l.intensity[2] = 1;
    l.channels = 3;
    ohm_solve_params p = {0};
    p.num.ordering = "metis";
    struct {
        double sa[3];
        int channels, factors;
    } cases[] = {{{0.01, 0.01, 0.01}, 1, 1}, {{0.01, 0.02, 0.01}, 3, 2}, {{0.01, 0.02, 0.03}, 3, 3}};
    for (int c = 0; c < 3; ++c) {
        ohm_material m = {0};
        m.kind = OHM_MATERIAL_OPTICAL;
        m.channels = cases[c].channels;
        for (int k = 0; k < 3; ++k) m.sigma_a[k] = cases[c].sa[k], m.sigma_s[k] = 1.0;
        m.eta = 1.3;
        l.channels = cases[c].channels;
        ohm_solution sol;
        ohm_error err;
        int rc = ohm_solve(&sol, g, &m, &l, 1, &p, &quiet, &err);
        CHECK_MSG(rc == 0, "%s", err.msg);
        if (rc) continue;
        CHECK_MSG(sol.factors == cases[c].factors, "case %d: %d factorizations, expected %d", c, sol.factors,
                  cases[c].factors);
        CHECK(sol.channels == cases[c].channels);
        CHECK(ohm_solution_conservation_error(&sol) < 1e-10);
        CHECK(sol.mode_corrections == 0);
        /* equal media, equal light: identical channels */
        if (c == 1) {
            double d = 0;
            for (int64_t v = 0; v < sol.n; ++v) d = fmax(d, fabs(sol.fluence[0][v] - sol.fluence[2][v]));
            CHECK(d == 0.0);
        }
        ohm_solution_free(&sol);
    }
}

/* The unknowns' cells from the network's index (no table of them,
 * network.h): the search and the cursor from any unknown give the interior
 * cells in cell order, and each face's cell is its unknown's. */
static void unknown_cells(const ohm_voxel_grid *g)
{
    ohm_network net;
    ohm_error err;
    if (ohm_network_build(&net, g, NULL, &err)) {
        CHECK_MSG(0, "%s", err.msg);
        return;
    }
    size_t ncells = (size_t)g->dims[0] * (size_t)g->dims[1] * (size_t)g->dims[2];
    int64_t *expect = malloc(ncells * sizeof *expect), n = 0;
    for (size_t c = 0; c < ncells; ++c)
        if (g->inside[c]) expect[n++] = (int64_t)c;
    CHECK(n == net.n);
    size_t bad_search = 0, bad_cursor = 0, bad_from = 0, bad_face = 0;
    ohm_cell_cursor all = ohm_network_cells(&net, 0);
    for (int64_t v = 0; v < n && n == net.n; ++v) {
        bad_search += ohm_network_cell(&net, v) != expect[v];
        bad_cursor += ohm_cell_cursor_next(&all) != expect[v];
        ohm_cell_cursor from = ohm_network_cells(&net, v); /* from every unknown: its next three */
        for (int64_t w = v; w < v + 3 && w < n; ++w) bad_from += ohm_cell_cursor_next(&from) != expect[w];
    }
    for (int64_t f = 0; f < net.nfaces; ++f) bad_face += net.face_cell[f] != expect[net.face_unknown[f]];
    CHECK_MSG(bad_search == 0, "%zu unknowns' cells found wrong", bad_search);
    CHECK_MSG(bad_cursor == 0 && bad_from == 0, "the cursor gave %zu (%zu) cells wrong", bad_cursor, bad_from);
    CHECK_MSG(bad_face == 0, "%zu faces' cells are not their unknowns'", bad_face);
    /* the grid has empty words (64 cells with no unknown) to step over */
    size_t empty_words = 0;
    for (size_t w = 0; w < (ncells + 63) / 64; ++w) empty_words += net.unknowns.bits[w] == 0;
    CHECK(empty_words > 0);
    free(expect);
    ohm_network_free(&net);
}

/* Three pieces that alternate along every row (x 1-3, x 6-7, and x 9 in
 * the row y = 1 only): each unknown's piece from the network's runs, the
 * runs as few as they can be, the per-piece sums, and the singular piece
 * named by one of its cells. */
static void pieces_by_runs(void)
{
    ohm_voxel_grid g;
    memset(&g, 0, sizeof g);
    g.dims[0] = 11, g.dims[1] = 5, g.dims[2] = 4;
    g.h = g.band = 1.0;
    size_t ncells = 11 * 5 * 4;
    g.inside = calloc(ncells, 1);
    for (int k = 1; k <= 2; ++k)
        for (int j = 1; j <= 3; ++j)
            for (int i = 1; i <= 9; ++i) {
                int in = i <= 3 || i == 6 || i == 7 || (i == 9 && j == 1);
                g.inside[ohm_voxel_index(&g, i, j, k)] = (uint8_t)in;
                g.interior_cells += (size_t)in;
            }
    ohm_network net;
    ohm_error err;
    if (ohm_network_build(&net, &g, NULL, &err)) {
        CHECK_MSG(0, "%s", err.msg);
        free(g.inside);
        return;
    }
    const ohm_piece_runs *pr = &net.pieces;
    CHECK(net.npieces == 3);
    CHECK(pr->count == 2 * (3 * 2) + 2); /* A, B in each of 6 rows, C in 2 */
    size_t bad_piece = 0, bad_find = 0, joinable = 0;
    int64_t run = 0;
    for (int64_t v = 0; v < net.n; ++v) {
        int64_t i = ohm_network_cell(&net, v) % 11;
        int32_t expect = i <= 3 ? 0 : i <= 7 ? 1 : 2; /* numbered by their smallest unknown */
        bad_piece += ohm_piece_runs_next(pr, &run, v) != expect;
        int64_t r = ohm_piece_runs_find(pr, v);
        bad_find += !(pr->start[r] <= v && v < pr->start[r + 1]);
    }
    for (int64_t r = 0; r + 1 < pr->count; ++r) joinable += pr->piece[r] == pr->piece[r + 1];
    CHECK_MSG(bad_piece == 0, "%zu unknowns in the wrong piece", bad_piece);
    CHECK_MSG(bad_find == 0, "%zu unknowns' runs found wrong", bad_find);
    CHECK_MSG(joinable == 0, "%zu neighbouring runs could be one", joinable);
    CHECK(pr->start[0] == 0 && pr->start[pr->count] == net.n);
    /* absorption in A and B only: with robin every piece leaks (the sums
     * per piece are the rows' own), with neumann C is singular */
    ohm_coeff *sa = malloc((size_t)net.n * sizeof *sa);
    run = 0;
    for (int64_t v = 0; v < net.n; ++v) sa[v] = ohm_piece_runs_next(pr, &run, v) == 2 ? 0.0f : 0.01f;
    ohm_channel_medium med = {0};
    med.sigma_a = sa, med.sigma_s0 = 1.0, med.eta = 1.3;
    ohm_stencil st = {0};
    CHECK(ohm_network_stencil(&st, NULL, NULL, &net, &med, OHM_BOUNDARY_ROBIN, &err) == 0);
    double sink[3] = {0}, diag[3] = {0}, expect_sink[3] = {0};
    run = 0;
    for (int64_t v = 0; v < net.n && st.sink; ++v) expect_sink[ohm_piece_runs_next(pr, &run, v)] += st.sink[v];
    if (st.sink) ohm_stencil_piece_sums(&st, pr->start, pr->piece, pr->count, sink, diag);
    for (int p = 0; p < 3; ++p) {
        CHECK_REL(sink[p], expect_sink[p], 1e-14);
        CHECK(diag[p] > sink[p] && sink[p] > 0);
    }
    ohm_stencil_free(&st);
    ohm_stencil singular = {0};
    CHECK(ohm_network_stencil(&singular, NULL, NULL, &net, &med, OHM_BOUNDARY_NEUMANN, &err) != 0);
    CHECK_MSG(strstr(err.msg, "cell (9,1,1)") != NULL, "%s", err.msg);
    ohm_stencil_free(&singular);
    free(sa);
    ohm_network_free(&net);
    free(g.inside);
}

int main(void)
{
    ohm_mesh m;
    ohm_error err;
    if (ohm_mesh_read(&m, "samples/spot.obj", &err)) {
        CHECK_MSG(0, "%s", err.msg);
        return check_summary();
    }
    ohm_mesh_scale(&m, 30.0);
    ohm_voxel_grid g;
    ohm_voxelize_params vp = {0};
    vp.dim = 20;
    if (ohm_voxelize(&g, NULL, &m, &vp, &quiet, &err)) {
        CHECK_MSG(0, "%s", err.msg);
        ohm_mesh_free(&m);
        return check_summary();
    }
    /* an inhomogeneous medium: coefficients varying cell by cell */
    size_t n = g.interior_cells;
    ohm_coeff *sa = malloc(n * sizeof *sa), *ss = malloc(n * sizeof *ss);
    for (size_t u = 0; u < n; ++u) {
        sa[u] = (ohm_coeff)(0.001 + 0.01 * (double)(u % 7));
        ss[u] = (ohm_coeff)(0.5 + 0.3 * (double)(u % 11));
    }
    check_matrix(&g, OHM_BOUNDARY_ROBIN, sa, ss, 1.3);
    check_matrix(&g, OHM_BOUNDARY_DIRICHLET, sa, ss, 1.3);
    check_matrix(&g, OHM_BOUNDARY_NEUMANN, sa, ss, 1.0);
    refill(&g, sa, ss);
    channel_sharing(&g);
    unknown_cells(&g);
    pieces_by_runs();
    free(sa);
    free(ss);
    ohm_voxel_grid_free(&g);
    ohm_mesh_free(&m);
    return check_summary();
}
