/* validate.c — built-in scenes with exact answers (validate.h). */
#include "studies/validate.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "solvers/solve.h"
#include "studies/reference.h"
#include "studies/scene.h"

/* ---- rows ---------------------------------------------------------------- */

ohm_check_row *ohm_validation_add(ohm_validation *v, const char *name, const char *reference, double measured,
                              double expected, double error, double tolerance)
{
    if (v->n == OHM_VALIDATION_MAX_ROWS) return NULL;
    ohm_check_row *r = &v->rows[v->n++];
    memset(r, 0, sizeof *r);
    snprintf(r->name, sizeof r->name, "%s", name);
    snprintf(r->reference, sizeof r->reference, "%s", reference);
    r->measured = measured;
    r->expected = expected;
    r->error = error;
    r->tolerance = tolerance;
    r->pass = tolerance < 0 ? 1 : (error <= tolerance); /* NaN fails */
    return r;
}

static double rel(double a, double b) { return fabs(a - b) / fabs(b); }

int ohm_validation_print(FILE *f, const ohm_validation *v)
{
    int failed = 0;
    fprintf(f, "%-46s %-34s %12s %12s %10s %9s  %s\n", "check", "reference", "measured", "expected", "error",
            "tolerance", "result");
    for (int i = 0; i < v->n; ++i) {
        const ohm_check_row *r = &v->rows[i];
        char tol[16];
        if (r->tolerance < 0) snprintf(tol, sizeof tol, "%9s", "report");
        else snprintf(tol, sizeof tol, "%9.2g", r->tolerance);
        fprintf(f, "%-46s %-34s %12.6g %12.6g %10.3g %s  %s\n", r->name, r->reference, r->measured, r->expected,
                r->error, tol, r->tolerance < 0 ? "-" : (r->pass ? "pass" : "FAIL"));
        if (!r->pass) ++failed;
    }
    fprintf(f, "%d passed, %d failed\n", v->n - failed, failed);
    return failed;
}

/* ---- scenes ---------------------------------------------------------------- */

int ohm_scene_box(ohm_voxel_grid *g, int nx, int ny, int nz, double h, ohm_error *err)
{
    memset(g, 0, sizeof *g);
    g->dims[0] = nx + 2;
    g->dims[1] = ny + 2;
    g->dims[2] = nz + 2;
    g->h = h;
    g->band = h;
    for (int a = 0; a < 3; ++a) g->origin[a] = -0.5 * h;
    size_t n = (size_t)g->dims[0] * g->dims[1] * g->dims[2];
    g->inside = calloc(n, 1);
    if (!g->inside) return ohm_fail(err, OHM_ERR_NOMEM, "validate: out of memory");
    for (int k = 1; k <= nz; ++k)
        for (int j = 1; j <= ny; ++j)
            for (int i = 1; i <= nx; ++i) g->inside[ohm_voxel_index(g, i, j, k)] = 1;
    g->interior_cells = (size_t)nx * ny * nz;
    return OHM_OK;
}

/* The validation media's index, and the A their Robin solves use (the
 * default, exact Fresnel moments): the references take it. */
#define VALIDATION_ETA 1.3
static double validation_A(void) { return ohm_boundary_A(VALIDATION_ETA, OHM_FRESNEL_EXACT); }

ohm_light ohm_scene_directional(const double dir[3])
{
    ohm_light l;
    memset(&l, 0, sizeof l);
    l.type = OHM_LIGHT_DIRECTIONAL;
    memcpy(l.dir, dir, sizeof l.dir);
    l.intensity[0] = 1.0;
    l.channels = 1;
    return l;
}

ohm_light ohm_scene_pencil(const double pos[3], const double dir[3])
{
    ohm_light l = ohm_scene_directional(dir);
    l.type = OHM_LIGHT_PENCIL;
    memcpy(l.pos, pos, sizeof l.pos);
    return l;
}

ohm_material ohm_scene_grey(double sigma_a, double sigma_s)
{
    ohm_material m;
    memset(&m, 0, sizeof m);
    m.kind = OHM_MATERIAL_OPTICAL;
    m.channels = 1;
    m.sigma_a[0] = sigma_a;
    m.sigma_s[0] = sigma_s;
    m.eta = VALIDATION_ETA;
    snprintf(m.name, sizeof m.name, "validation");
    return m;
}

static int64_t unknown_at(const ohm_solution *s, int i, int j, int k)
{
    return ohm_network_unknown(&s->net, ohm_voxel_index(s->net.grid, i, j, k));
}

/* Trilinear interpolation of the fluence between cell centres. */
static double fluence_at(const ohm_solution *s, const double x[3])
{
    const ohm_voxel_grid *g = s->net.grid;
    int i0[3];
    double t[3];
    for (int a = 0; a < 3; ++a) {
        double q = (x[a] - g->origin[a]) / g->h;
        i0[a] = (int)floor(q);
        t[a] = q - i0[a];
    }
    double sum = 0;
    for (int c = 0; c < 8; ++c) {
        int i = i0[0] + (c & 1), j = i0[1] + ((c >> 1) & 1), k = i0[2] + ((c >> 2) & 1);
        double w = ((c & 1) ? t[0] : 1 - t[0]) * (((c >> 1) & 1) ? t[1] : 1 - t[1]) * (((c >> 2) & 1) ? t[2] : 1 - t[2]);
        int64_t u = unknown_at(s, i, j, k);
        if (u < 0) return NAN;
        sum += w * s->fluence[0][u];
    }
    return sum;
}

/* ---- infinite medium: octant with three mirror planes ---------------------- */

/* The corner cell of the octant holds 1/8 of the source: in the mirrored full
 * domain, a 2x2x2-cell source of power P centred on the origin. */
static int src_corner(void *user, double *b, size_t ncols, const ohm_network *net, int c)
{
    (void)ncols;
    (void)net;
    (void)c;
    b[0] = *(const double *)user / 8.0;
    return 0;
}

static const double INF_SA = 0.3, INF_SS = 1.0; /* sigma_tr = 1.08/mm: walls far in few cells */
static const double INF_L = 6.0;                 /* octant edge, mm (walls: phi = 0)           */

static int infinite_run(ohm_solution *sol, ohm_voxel_grid *g, double h, const ohm_log *log, ohm_error *err)
{
    int n = (int)lround(INF_L / h);
    int rc = ohm_scene_box(g, n, n, n, h, err);
    if (rc) return rc;
    ohm_material m = ohm_scene_grey(INF_SA, INF_SS);
    static double P = 1.0;
    ohm_mirrors mirror = {{1, 1, 1}, {-1, -1, -1}};
    ohm_solve_params p;
    memset(&p, 0, sizeof p);
    p.op.boundary = OHM_BOUNDARY_DIRICHLET;
    p.num.ordering = "metis";
    p.op.mirrors = &mirror;
    p.src.custom_source = src_corner;
    p.src.custom_user = &P;
    rc = ohm_solve(sol, g, &m, NULL, 1, &p, log, err);
    if (rc) ohm_voxel_grid_free(g);
    return rc;
}

int ohm_validate_infinite(ohm_validation *v, const ohm_log *log, ohm_error *err)
{
    /* A fixed physical point at r = 1.5 mm on the diagonal, three grids. */
    const double hs[3] = {0.4, 0.2, 0.1};
    const double x[3] = {1.5 / sqrt(3.0), 1.5 / sqrt(3.0), 1.5 / sqrt(3.0)};
    const double exact = ohm_ref_infinite(1.0, INF_SA, INF_SS, 1.5);
    double e[3];
    for (int s = 0; s < 3; ++s) {
        ohm_voxel_grid g;
        ohm_solution sol;
        int rc = infinite_run(&sol, &g, hs[s], log, err);
        if (rc) return rc;
        double phi = fluence_at(&sol, x);
        e[s] = rel(phi, exact);
        char name[80];
        snprintf(name, sizeof name, "infinite medium phi(1.5 mm), h=%.2g", hs[s]);
        ohm_validation_add(v, name, "P e^-str r/(4 pi D r)", phi, exact, e[s], -1);
        snprintf(name, sizeof name, "infinite medium conservation, h=%.2g", hs[s]);
        ohm_validation_add(v, name, "in = absorbed + out", sol.power_absorbed + sol.power_out, sol.power_in,
                ohm_solution_conservation_error(&sol), 1e-10);
        if (s == 2) {
            /* every cell with 5h <= r <= 3 mm on the finest grid */
            double worst = 0, at = 0;
            ohm_cell_cursor cells = ohm_network_cells(&sol.net, 0);
            for (int64_t u = 0; u < sol.n; ++u) {
                int32_t c[3];
                ohm_voxel_coords(&g, ohm_cell_cursor_next(&cells), c);
                double px = (c[0] - 0.5) * g.h, py = (c[1] - 0.5) * g.h, pz = (c[2] - 0.5) * g.h;
                double r = sqrt(px * px + py * py + pz * pz);
                if (r < 5 * g.h || r > 3.0) continue;
                double er = rel(sol.fluence[0][u], ohm_ref_infinite(1.0, INF_SA, INF_SS, r));
                if (er > worst) worst = er, at = r;
            }
            snprintf(name, sizeof name, "infinite medium, worst over 5h<=r<=3mm (r=%.2f)", at);
            ohm_validation_add(v, name, "P e^-str r/(4 pi D r)", worst, 0, worst, 0.02);
        }
        ohm_solution_free(&sol);
        ohm_voxel_grid_free(&g);
    }
    double order = log2(e[1] / e[2]);
    ohm_check_row *r = ohm_validation_add(v, "infinite medium convergence order in h", "1.7 .. 2.3", order, 2.0,
                               fabs(order - 2.0), 0.3);
    (void)r;
    return OHM_OK;
}

/* ---- semi-infinite medium, Robin boundary, pencil beam ----------------------- */

static const double HS_SA = 0.05, HS_SS = 0.95; /* 1/sigma_t' = 1 mm, 1/sigma_tr = 2.58 mm */

typedef struct beam_source {
    double P;       /* power in the full (mirrored) domain */
    double z0;      /* depth of the point source           */
    int columns;    /* 4: quarter domain, 1 x 1 corner column */
} beam_source;

/* Power P at depth z0 below the z = 0 face of column (i, j) (1-based, the
 * surface layer is k = 1): split linearly between the two cell centres around
 * z0, the deposit=point rule of light.c. */
static int deposit_at_depth(double *b, const ohm_network *net, int i, int j, double z0, double P)
{
    const ohm_voxel_grid *g = net->grid;
    double s = z0 / g->h - 0.5;
    int m = s <= 0 ? 0 : (int)floor(s);
    double frac = s <= 0 ? 0 : s - m;
    int64_t u0 = ohm_network_unknown(net, ohm_voxel_index(g, i, j, 1 + m));
    int64_t u1 = ohm_network_unknown(net, ohm_voxel_index(g, i, j, 2 + m));
    if (u0 < 0 || u1 < 0) return -1;
    b[u0] += P * (1 - frac);
    b[u1] += P * frac;
    return 0;
}

/* The beam's corner column of the quarter domain. */
static int src_beam(void *user, double *b, size_t ncols, const ohm_network *net, int c)
{
    (void)ncols;
    (void)c;
    const beam_source *bs = user;
    return deposit_at_depth(b, net, 1, 1, bs->z0, bs->P / bs->columns);
}

static int halfspace_run(ohm_solution *sol, ohm_voxel_grid *g, double h, double L, double depth, ohm_boundary bnd,
                         beam_source *bs, const ohm_log *log, ohm_error *err)
{
    int nl = (int)lround(L / h), nd = (int)lround(depth / h);
    int rc = ohm_scene_box(g, nl, nl, nd, h, err);
    if (rc) return rc;
    ohm_material m = ohm_scene_grey(HS_SA, HS_SS);
    ohm_mirrors mirror = {{1, 1, -1}, {-1, -1, -1}}; /* the beam's axis is the corner line x = y = 0 */
    ohm_solve_params p;
    memset(&p, 0, sizeof p);
    p.op.boundary = bnd;
    p.num.ordering = "metis";
    p.op.mirrors = &mirror;
    p.src.custom_source = src_beam;
    p.src.custom_user = bs;
    rc = ohm_solve(sol, g, &m, NULL, 1, &p, log, err);
    if (rc) ohm_voxel_grid_free(g);
    return rc;
}

int ohm_validate_halfspace(ohm_validation *v, const ohm_log *log, ohm_error *err)
{
    /* h = 0.25 mm = z0/4; lateral walls 16 mm and floor 12 mm away: their
     * images are > 16 mm from every compared point, e^{-sigma_tr 16} ~ 2e-3. */
    const double h = 0.25, z0 = 1.0 / (HS_SA + HS_SS);
    const double rmin = 1.0 / (HS_SA + HS_SS), rmax = 3.0 / sqrt(3.0 * HS_SA * (HS_SA + HS_SS));
    beam_source bs = {1.0, z0, 4};
    ohm_voxel_grid g;
    ohm_solution sol;
    int rc = halfspace_run(&sol, &g, h, 16.0, 12.0, OHM_BOUNDARY_ROBIN, &bs, log, err);
    if (rc) return rc;
    double worst = 0, worst_r = 0, worst_dip = 0, worst_dip_r = 0;
    for (int64_t f = 0; f < sol.net.nfaces; ++f) {
        if (sol.net.face_dir[f] != 4) continue; /* the surface z = 0, outward -z */
        int32_t c[3];
        ohm_voxel_coords(&g, sol.net.face_cell[f], c);
        double x = (c[0] - 0.5) * h, y = (c[1] - 0.5) * h, r = sqrt(x * x + y * y);
        if (r < rmin || r > rmax) continue;
        double J = sol.face_exitance[0][f];
        double Jref = ohm_ref_halfspace_exitance(r, z0, HS_SA, HS_SS, validation_A());
        double e = rel(J, Jref);
        if (e > worst) worst = e, worst_r = r;
        /* the dipole's R_d is per unit incident power; our source is the
         * scattered power, albedo times that */
        double Jdip = ohm_ref_dipole_Rd(r, HS_SA, HS_SS, validation_A()) * (HS_SA + HS_SS) / HS_SS;
        double ed = rel(J, Jdip);
        if (ed > worst_dip) worst_dip = ed, worst_dip_r = r;
    }
    char name[80];
    snprintf(name, sizeof name, "half-space J(r), worst over 1/st'..3/str (r=%.2f)", worst_r);
    ohm_validation_add(v, name, "exact Robin half-space", worst, 0, worst, 0.02);
    snprintf(name, sizeof name, "half-space J(r) vs dipole, worst (r=%.2f)", worst_dip_r);
    ohm_validation_add(v, name, "Jensen 2001 dipole (loose)", worst_dip, 0, worst_dip, -1);
    /* what leaves through the surface z = 0 (the floor and far walls are the
     * box's, not the half-space's) */
    double surface_out = 0;
    for (int64_t f = 0; f < sol.net.nfaces; ++f)
        if (sol.net.face_dir[f] == 4) surface_out += sol.face_exitance[0][f] * h * h;
    double escape = surface_out / sol.power_in;
    double escape_ref = ohm_ref_halfspace_escape(z0, HS_SA, HS_SS, validation_A());
    ohm_validation_add(v, "half-space escaped fraction of the source", "1-D closed form", escape, escape_ref,
            rel(escape, escape_ref), 0.02);
    double dip_total = ohm_ref_dipole_Rd_total(HS_SA, HS_SS, validation_A()) * (HS_SA + HS_SS) / HS_SS;
    ohm_validation_add(v, "half-space escaped fraction vs dipole Rd", "Jensen 2001 total Rd (loose)", escape, dip_total,
            rel(escape, dip_total), -1);
    ohm_validation_add(v, "half-space: constant-mode corrections", "none needed", (double)sol.mode_corrections, 0,
            (double)sol.mode_corrections, 0);
    ohm_validation_add(v, "half-space conservation", "in = absorbed + out", sol.power_absorbed + sol.power_out, sol.power_in,
            ohm_solution_conservation_error(&sol), 1e-10);
    ohm_validation_add(v, "half-space scaled backward error", "< 1e-12", sol.residual, 0, sol.residual, 1e-12);
    ohm_solution_free(&sol);
    ohm_voxel_grid_free(&g);
    return OHM_OK;
}

int ohm_halfspace_accuracy(ohm_halfspace_result *out, double h, int use_cg, const ohm_log *log, ohm_error *err)
{
    memset(out, 0, sizeof *out);
    const double z0 = 1.0 / (HS_SA + HS_SS);
    const double rmin = 1.0 / (HS_SA + HS_SS), rmax = 3.0 / sqrt(3.0 * HS_SA * (HS_SA + HS_SS));
    beam_source bs = {1.0, z0, 4};
    ohm_voxel_grid g;
    ohm_solution sol;
    int nl = (int)lround(16.0 / h), nd = (int)lround(12.0 / h);
    int rc = ohm_scene_box(&g, nl, nl, nd, h, err);
    if (rc) return rc;
    ohm_material m = ohm_scene_grey(HS_SA, HS_SS);
    ohm_mirrors mirror = {{1, 1, -1}, {-1, -1, -1}};
    ohm_solve_params p;
    memset(&p, 0, sizeof p);
    p.op.boundary = OHM_BOUNDARY_ROBIN;
    p.num.ordering = "metis";
    p.num.solver = use_cg ? OHM_SOLVER_CG : OHM_SOLVER_DIRECT;
    p.op.mirrors = &mirror;
    p.src.custom_source = src_beam;
    p.src.custom_user = &bs;
    double t0 = ohm_now();
    rc = ohm_solve(&sol, &g, &m, NULL, 1, &p, log, err);
    out->seconds = ohm_now() - t0;
    if (rc) {
        ohm_voxel_grid_free(&g);
        return rc;
    }
    double sum_e = 0, sum_ref = 0;
    for (int64_t f = 0; f < sol.net.nfaces; ++f) {
        if (sol.net.face_dir[f] != 4) continue;
        int32_t c[3];
        ohm_voxel_coords(&g, sol.net.face_cell[f], c);
        double x = (c[0] - 0.5) * h, y = (c[1] - 0.5) * h, r = sqrt(x * x + y * y);
        if (r < rmin || r > rmax) continue;
        double J = sol.face_exitance[0][f], Jref = ohm_ref_halfspace_exitance(r, z0, HS_SA, HS_SS, validation_A());
        out->worst = fmax(out->worst, rel(J, Jref));
        sum_e += fabs(J - Jref);
        sum_ref += fabs(Jref);
    }
    out->mean = sum_ref > 0 ? sum_e / sum_ref : 0;
    out->cells = sol.n;
    out->nnz_L = sol.nnz_L;
    ohm_solution_free(&sol);
    ohm_voxel_grid_free(&g);
    return OHM_OK;
}

/* ---- Neumann (the paper's) against Robin ------------------------------------ */

int ohm_validate_boundaries(ohm_validation *v, const ohm_log *log, ohm_error *err)
{
    const double h = 0.5, z0 = 1.0 / (HS_SA + HS_SS);
    beam_source bs = {1.0, z0, 4};
    ohm_voxel_grid gr, gn;
    ohm_solution robin, neumann;
    int rc = halfspace_run(&robin, &gr, h, 16.0, 12.0, OHM_BOUNDARY_ROBIN, &bs, log, err);
    if (rc) return rc;
    rc = halfspace_run(&neumann, &gn, h, 16.0, 12.0, OHM_BOUNDARY_NEUMANN, &bs, log, err);
    if (rc) {
        ohm_solution_free(&robin);
        ohm_voxel_grid_free(&gr);
        return rc;
    }
    ohm_validation_add(v, "neumann: power out", "exactly 0", neumann.power_out, 0, fabs(neumann.power_out), 0);
    ohm_validation_add(v, "neumann: absorbed / in", "1", neumann.power_absorbed / neumann.power_in, 1,
            ohm_solution_conservation_error(&neumann), 1e-10);
    ohm_validation_add(v, "robin: escaped fraction (neumann: 0)", "report", robin.power_out / robin.power_in, 0,
            robin.power_out / robin.power_in, -1);
    /* how much too bright the paper's boundary makes the surface, 5 mm out */
    int i5 = 1 + (int)lround(5.0 / h - 0.5);
    int64_t ur = unknown_at(&robin, i5, 1, 1), un = unknown_at(&neumann, i5, 1, 1);
    double ratio = neumann.fluence[0][un] / robin.fluence[0][ur];
    ohm_validation_add(v, "neumann/robin surface fluence at r=5 mm", "report (paper: too bright)", ratio, 1, ratio, -1);
    ohm_solution_free(&robin);
    ohm_solution_free(&neumann);
    ohm_voxel_grid_free(&gr);
    ohm_voxel_grid_free(&gn);
    return OHM_OK;
}

/* ---- singular and ill-conditioned systems ------------------------------------ */


/* Box of n^3 cells of 1 mm; the top half (k > n/2) gets (sa_top, ss_top). */
static int run_two_layer(ohm_solution *sol, int n, double sa_bot, double ss_bot, double sa_top, double ss_top,
                         ohm_boundary bnd, const ohm_log *log, ohm_error *err)
{
    ohm_voxel_grid g;
    int rc = ohm_scene_box(&g, n, n, n, 1.0, err);
    if (rc) return rc;
    size_t cells = (size_t)n * n * n;
    ohm_coeff *sa = malloc(cells * sizeof *sa), *ss = malloc(cells * sizeof *ss);
    if (!sa || !ss) {
        free(sa);
        free(ss);
        ohm_voxel_grid_free(&g);
        return ohm_fail(err, OHM_ERR_NOMEM, "validate: out of memory");
    }
    /* unknowns are the inside cells in x-fastest order */
    for (size_t u = 0; u < cells; ++u) {
        int k = (int)(u / ((size_t)n * n)) + 1;
        int top = k > n / 2;
        sa[u] = (ohm_coeff)(top ? sa_top : sa_bot);
        ss[u] = (ohm_coeff)(top ? ss_top : ss_bot);
    }
    ohm_material m = ohm_scene_grey(sa_bot, ss_bot);
    ohm_light l = ohm_scene_directional((const double[3]){0, 0, 1.0}); /* from below, onto z = 0 */
    ohm_solve_params p;
    memset(&p, 0, sizeof p);
    p.op.boundary = bnd;
    p.num.ordering = "metis";
    p.media.sigma_a[0] = sa;
    p.media.sigma_s[0] = ss;
    rc = ohm_solve(sol, &g, &m, &l, 1, &p, log, err);
    /* the solution keeps a pointer to the grid: detach before freeing it */
    sol->net.grid = NULL;
    free(sa);
    free(ss);
    ohm_voxel_grid_free(&g);
    return rc;
}

int ohm_validate_extremes(ohm_validation *v, const ohm_log *log, ohm_error *err)
{
    ohm_solution sol;
    ohm_error e2;
    /* sigma_a = 0 with Neumann: singular, refused with the physical cause */
    ohm_error_clear(&e2);
    int rc = run_two_layer(&sol, 8, 0.0, 1.0, 0.0, 1.0, OHM_BOUNDARY_NEUMANN, log, &e2);
    int refused = rc == OHM_ERR_NUMERIC && strstr(e2.msg, "sigma_a = 0") && strstr(e2.msg, "neither leave nor be absorbed");
    ohm_validation_add(v, "sigma_a=0, neumann: refused as singular", "clear error, no solve", refused, 1, !refused, 0);
    if (!rc) ohm_solution_free(&sol);

    /* sigma_a = 0 with Robin: light leaves through the boundary, fine */
    rc = run_two_layer(&sol, 8, 0.0, 1.0, 0.0, 1.0, OHM_BOUNDARY_ROBIN, log, err);
    if (rc) return rc;
    ohm_validation_add(v, "sigma_a=0, robin: backward error", "< 1e-12", sol.residual, 0, sol.residual, 1e-12);
    ohm_validation_add(v, "sigma_a=0, robin: all deposited power leaves", "out = in", sol.power_out, sol.power_in,
            ohm_solution_conservation_error(&sol), 1e-10);
    ohm_solution_free(&sol);

    /* conductance contrasts of 1e6 and 1e12 across one face */
    const double contrast[2] = {1e6, 1e12};
    for (int i = 0; i < 2; ++i) {
        rc = run_two_layer(&sol, 16, 0.01, 1.0, 0.01, contrast[i], OHM_BOUNDARY_ROBIN, log, err);
        if (rc) return rc;
        char name[80];
        snprintf(name, sizeof name, "contrast %.0e in sigma_s': backward error", contrast[i]);
        ohm_validation_add(v, name, "< 1e-12", sol.residual, 0, sol.residual, 1e-12);
        snprintf(name, sizeof name, "contrast %.0e in sigma_s': conservation", contrast[i]);
        ohm_validation_add(v, name, "in = absorbed + out", sol.power_absorbed + sol.power_out, sol.power_in,
                ohm_solution_conservation_error(&sol), 1e-10);
        ohm_solution_free(&sol);
    }

    /* sigma_a = 1e-9 with Neumann: nearly singular, still backward stable */
    rc = run_two_layer(&sol, 16, 1e-9, 1.0, 1e-9, 1.0, OHM_BOUNDARY_NEUMANN, log, err);
    if (rc) return rc;
    ohm_validation_add(v, "sigma_a=1e-9, neumann: backward error", "< 1e-12", sol.residual, 0, sol.residual, 1e-12);
    ohm_validation_add(v, "sigma_a=1e-9, neumann: conservation", "in = absorbed", sol.power_absorbed, sol.power_in,
            ohm_solution_conservation_error(&sol), 1e-10);
    ohm_validation_add(v, "sigma_a=1e-9, neumann: constant-mode shift", "report (relative to phi)", sol.mode_shift, 0,
            sol.mode_shift, -1);
    ohm_solution_free(&sol);
    return OHM_OK;
}

int ohm_validate_layered(ohm_validation *v, const ohm_log *log, ohm_error *err)
{
    /* an inhomogeneous scene: two different media, lit from below */
    ohm_solution sol;
    int rc = run_two_layer(&sol, 20, 0.02, 1.5, 0.2, 0.5, OHM_BOUNDARY_ROBIN, log, err);
    if (rc) return rc;
    ohm_validation_add(v, "two layers: conservation", "in = absorbed + out", sol.power_absorbed + sol.power_out, sol.power_in,
            ohm_solution_conservation_error(&sol), 1e-10);
    ohm_validation_add(v, "two layers: constant-mode corrections", "none needed", (double)sol.mode_corrections, 0,
            (double)sol.mode_corrections, 0);
    ohm_solution_free(&sol);
    return OHM_OK;
}

/* ---- a refractive index per cell: two layers against the 1-D solution -------- */

/* Layer 0 (lit, top) and layer 1 of ohm_ref_two_layer, 2 mm each. */
static const ohm_ref_layer IDX_LAYERS[2] = {{0.02, 1.0, 1.3, 2.0}, {0.1, 2.0, 1.6, 2.0}};

/* A 1-D column of cells of size h (mirrors on both sides of x and y) through
 * the two layers, lit from above at normal incidence; with_eta = 1: each
 * layer's own index per cell; 2: layer 0's index per cell in both; 0: no
 * per-cell index (layer 0's for both, as the material's).  *err_max: the largest
 * |phi - phi_1D| / phi_1D at the cell centres. */
static int index_layers_run(ohm_solution *sol, double h, int with_eta, double *err_max, const ohm_log *log,
                            ohm_error *err)
{
    int n0 = (int)lround(IDX_LAYERS[0].thickness / h), n1 = (int)lround(IDX_LAYERS[1].thickness / h), N = n0 + n1;
    ohm_voxel_grid g;
    int rc = ohm_scene_box(&g, 1, 1, N, h, err);
    if (rc) return rc;
    ohm_coeff *sa = malloc((size_t)N * sizeof *sa), *ss = malloc((size_t)N * sizeof *ss);
    double *eta = malloc((size_t)N * sizeof *eta);
    if (!sa || !ss || !eta) {
        free(sa), free(ss), free(eta);
        ohm_voxel_grid_free(&g);
        return ohm_fail(err, OHM_ERR_NOMEM, "validate: out of memory");
    }
    for (int u = 0; u < N; ++u) { /* unknown u is cell k = u + 1; the top n0 cells are layer 0 */
        const ohm_ref_layer *l = &IDX_LAYERS[u >= n1 ? 0 : 1];
        sa[u] = (ohm_coeff)l->sigma_a;
        ss[u] = (ohm_coeff)l->sigma_s;
        eta[u] = with_eta == 1 ? l->eta : IDX_LAYERS[0].eta;
    }
    ohm_material m = ohm_scene_grey(IDX_LAYERS[0].sigma_a, IDX_LAYERS[0].sigma_s);
    m.eta = IDX_LAYERS[0].eta;
    ohm_light l = ohm_scene_directional((const double[3]){0, 0, -1.0});
    ohm_mirrors mirror = {{1, 1, -1}, {1, 1, -1}};
    ohm_solve_params p;
    memset(&p, 0, sizeof p);
    p.op.boundary = OHM_BOUNDARY_ROBIN;
    p.num.ordering = "amd";
    p.op.mirrors = &mirror;
    p.media.sigma_a[0] = sa;
    p.media.sigma_s[0] = ss;
    p.media.eta_v = with_eta ? eta : NULL;
    rc = ohm_solve(sol, &g, &m, &l, 1, &p, log, err);
    if (!rc) {
        ohm_ref_layer ref_layers[2] = {IDX_LAYERS[0], IDX_LAYERS[1]};
        if (with_eta != 1) ref_layers[1].eta = IDX_LAYERS[0].eta;
        ohm_ref_two_layer ref;
        double TI = 1.0 - ohm_fresnel_reflectance(IDX_LAYERS[0].eta, 1.0);
        if (ohm_ref_two_layer_init(&ref, ref_layers, TI)) {
            rc = ohm_fail(err, OHM_ERR_INTERNAL, "validate: the two-layer reference is singular");
        } else {
            *err_max = 0;
            for (int u = 0; u < N; ++u) {
                double x = (N - 1 - u + 0.5) * h, exact = ohm_ref_two_layer_phi(&ref, x);
                *err_max = fmax(*err_max, fabs(sol->fluence[0][u] - exact) / exact);
            }
        }
        if (rc) ohm_solution_free(sol);
    }
    if (!rc) sol->net.grid = NULL; /* the solution points at the grid: detach before freeing it */
    free(sa), free(ss), free(eta);
    ohm_voxel_grid_free(&g);
    return rc;
}

int ohm_validate_index_layers(ohm_validation *v, const ohm_log *log, ohm_error *err)
{
    static const double hs[] = {0.4, 0.2, 0.1, 0.05, 0.025};
    enum { NH = sizeof hs / sizeof hs[0] };
    double e[NH];
    char name[96];
    ohm_solution sol;
    for (int i = 0; i < NH; ++i) {
        int rc = index_layers_run(&sol, hs[i], 1, &e[i], log, err);
        if (rc) return rc;
        snprintf(name, sizeof name, "index layers 1.3|1.6: max |phi - exact|/exact, h=%g", hs[i]);
        ohm_validation_add(v, name, "1-D two-layer interface solution", e[i], 0, e[i], i == NH - 1 ? 0.01 : -1);
        if (i == NH - 1)
            ohm_validation_add(v, "index layers: conservation", "in = absorbed + out",
                               sol.power_absorbed + sol.power_out, sol.power_in,
                               ohm_solution_conservation_error(&sol), 1e-10);
        ohm_solution_free(&sol);
    }
    double order = log2(e[NH - 2] / e[NH - 1]);
    ohm_validation_add(v, "index layers convergence order in h", "1.7 .. 2.3", order, 2.0, fabs(order - 2.0), 0.3);
    /* a per-cell index that does not change gives what no per-cell index gives */
    ohm_solution plain;
    double e_plain, e_same;
    int rc = index_layers_run(&plain, 0.1, 0, &e_plain, log, err);
    if (rc) return rc;
    rc = index_layers_run(&sol, 0.1, 2, &e_same, log, err);
    if (rc) {
        ohm_solution_free(&plain);
        return rc;
    }
    double worst = 0;
    for (int64_t u = 0; u < sol.n; ++u)
        worst = fmax(worst, fabs(sol.fluence[0][u] - plain.fluence[0][u]) / plain.fluence[0][u]);
    /* equal to round-off but for A, read from the interfaces' table (fresnel.h: ~1e-12 at 1.3) */
    ohm_validation_add(v, "index layers: a uniform per-cell index = none", "equal to 1e-10", worst, 0, worst, 1e-10);
    ohm_solution_free(&plain);
    ohm_solution_free(&sol);
    return OHM_OK;
}

int ohm_validate_all(ohm_validation *v, const ohm_log *log, ohm_error *err)
{
    int rc = ohm_validate_infinite(v, log, err);
    if (!rc) rc = ohm_validate_halfspace(v, log, err);
    if (!rc) rc = ohm_validate_boundaries(v, log, err);
    if (!rc) rc = ohm_validate_extremes(v, log, err);
    if (!rc) rc = ohm_validate_layered(v, log, err);
    if (!rc) rc = ohm_validate_index_layers(v, log, err);
    return rc;
}

/* ---- the paper's Figure 1 --------------------------------------------------------- */

enum { FIG1_N = 15, FIG1_STEP = 3 };
static const double FIG1_SA = 0.0041, FIG1_SS = 2.6, FIG1_V = 1.18, FIG1_R = 1000.0;

static int src_step(void *user, double *b, size_t ncols, const ohm_network *net, int c)
{
    (void)ncols;
    (void)c;
    double amps = *(const double *)user;
    const ohm_voxel_grid *g = net->grid;
    int lo = (FIG1_N - FIG1_STEP) / 2 + 1;
    for (int j = lo; j < lo + FIG1_STEP; ++j)
        for (int i = lo; i < lo + FIG1_STEP; ++i) b[ohm_network_unknown(net, ohm_voxel_index(g, i, j, 1))] = amps;
    return 0;
}

/* ohm's own model of the same experiment: a 15 x 15 x 10 mm block of milk at
 * h = 0.25 mm, Robin boundary, unit irradiance on the middle 3 x 3 mm square
 * entering at depth 1/sigma_t' (the dipole's source depth). */
typedef struct fig1_slab {
    double h, z0;
} fig1_slab;

static int src_lit_square(void *user, double *b, size_t ncols, const ohm_network *net, int c)
{
    (void)ncols;
    (void)c;
    const fig1_slab *fs = user;
    const ohm_voxel_grid *g = net->grid;
    double lo = (FIG1_N - FIG1_STEP) / 2.0, hi = lo + FIG1_STEP; /* mm */
    for (int j = 1; j < g->dims[1] - 1; ++j)
        for (int i = 1; i < g->dims[0] - 1; ++i) {
            double x = (i - 0.5) * fs->h, y = (j - 0.5) * fs->h;
            if (x < lo || x > hi || y < lo || y > hi) continue;
            /* unit irradiance on the cell's face */
            if (deposit_at_depth(b, net, i, j, fs->z0, fs->h * fs->h)) return -1;
        }
    return 0;
}

/* Width of a profile at half its peak, by linear interpolation (cells). */
static double half_width(const double *p, int n)
{
    double peak = 0;
    int at = 0;
    for (int i = 0; i < n; ++i)
        if (p[i] > peak) peak = p[i], at = i;
    double left = 0, right = n - 1;
    for (int i = at; i > 0; --i)
        if (p[i - 1] < 0.5 * peak) {
            left = i - 1 + (0.5 * peak - p[i - 1]) / (p[i] - p[i - 1]);
            break;
        }
    for (int i = at; i < n - 1; ++i)
        if (p[i + 1] < 0.5 * peak) {
            right = i + (p[i] - 0.5 * peak) / (p[i] - p[i + 1]);
            break;
        }
    return right - left;
}

int ohm_paper_figure1(FILE *csv, ohm_validation *v, const ohm_log *log, ohm_error *err)
{
    const double h = 1.0;
    ohm_voxel_grid g;
    int rc = ohm_scene_box(&g, FIG1_N, FIG1_N, 1, h, err);
    if (rc) return rc;
    double amps = FIG1_V / FIG1_R;

    /* (a) the paper's network: every resistor 1 kOhm, Neumann boundary */
    ohm_material paper;
    memset(&paper, 0, sizeof paper);
    paper.kind = OHM_MATERIAL_RESISTANCE;
    paper.channels = 1;
    paper.resistance = FIG1_R;
    paper.ground = FIG1_R;
    paper.eta = 1.0;
    ohm_solve_params p;
    memset(&p, 0, sizeof p);
    p.op.boundary = OHM_BOUNDARY_NEUMANN;
    p.num.ordering = "amd";
    p.src.custom_source = src_step;
    p.src.custom_user = &amps;
    ohm_solution sa, sb;
    rc = ohm_solve(&sa, &g, &paper, NULL, 1, &p, log, err);
    if (rc) {
        ohm_voxel_grid_free(&g);
        return rc;
    }
    /* (b) the same grid with conductances from the milk coefficients */
    ohm_material milk = ohm_scene_grey(FIG1_SA, FIG1_SS);
    rc = ohm_solve(&sb, &g, &milk, NULL, 1, &p, log, err);
    if (rc) {
        ohm_solution_free(&sa);
        ohm_voxel_grid_free(&g);
        return rc;
    }
    /* (c) the dipole: exitance at x for unit irradiance on the lit square,
     * integrated over the square with 40 x 40 points per cell */
    int lo = (FIG1_N - FIG1_STEP) / 2; /* 0-based first lit column */
    double prof_a[FIG1_N], prof_b[FIG1_N], prof_c[FIG1_N];
    int mid = FIG1_N / 2 + 1;
    for (int i = 1; i <= FIG1_N; ++i) {
        prof_a[i - 1] = sa.fluence[0][unknown_at(&sa, i, mid, 1)]; /* node voltage, V */
        prof_b[i - 1] = sb.fluence[0][unknown_at(&sb, i, mid, 1)];
        double x = (i - 0.5) * h, y = (mid - 0.5) * h, sum = 0;
        const int q = 40;
        for (int sj = 0; sj < FIG1_STEP * q; ++sj)
            for (int si = 0; si < FIG1_STEP * q; ++si) {
                double sx = lo * h + (si + 0.5) * h / q, sy = lo * h + (sj + 0.5) * h / q;
                double r = sqrt((x - sx) * (x - sx) + (y - sy) * (y - sy));
                sum += ohm_ref_dipole_Rd(r, FIG1_SA, FIG1_SS, validation_A()) * (h / q) * (h / q);
            }
        prof_c[i - 1] = sum;
    }
    /* (d) ohm's 3-D model: exitance through z = 0, averaged over each 1 mm
     * cell of the middle row */
    double prof_d[FIG1_N];
    {
        fig1_slab fs = {0.25, 1.0 / (FIG1_SA + FIG1_SS)};
        ohm_voxel_grid g3;
        int n3 = (int)lround(FIG1_N / fs.h);
        rc = ohm_scene_box(&g3, n3, n3, (int)lround(10.0 / fs.h), fs.h, err);
        ohm_solution sd;
        ohm_solve_params p3;
        memset(&p3, 0, sizeof p3);
        p3.op.boundary = OHM_BOUNDARY_ROBIN;
        p3.num.ordering = "metis";
        p3.src.custom_source = src_lit_square;
        p3.src.custom_user = &fs;
        if (!rc) rc = ohm_solve(&sd, &g3, &milk, NULL, 1, &p3, log, err);
        if (rc) {
            ohm_voxel_grid_free(&g3);
            ohm_solution_free(&sa);
            ohm_solution_free(&sb);
            ohm_voxel_grid_free(&g);
            return rc;
        }
        double sum[FIG1_N] = {0};
        int cnt[FIG1_N] = {0};
        for (int64_t f = 0; f < sd.net.nfaces; ++f) {
            if (sd.net.face_dir[f] != 4) continue;
            int32_t c3[3];
            ohm_voxel_coords(&g3, sd.net.face_cell[f], c3);
            double x = (c3[0] - 0.5) * fs.h, y = (c3[1] - 0.5) * fs.h;
            if (y < mid - 1 || y > mid) continue; /* the middle 1 mm row */
            int bin = (int)floor(x);
            if (bin < 0 || bin >= FIG1_N) continue;
            sum[bin] += sd.face_exitance[0][f];
            cnt[bin]++;
        }
        for (int i = 0; i < FIG1_N; ++i) prof_d[i] = cnt[i] ? sum[i] / cnt[i] : NAN;
        if (v)
            ohm_validation_add(v, "figure 1: ohm 3-D block conservation", "in = absorbed + out", sd.power_absorbed + sd.power_out,
                    sd.power_in, ohm_solution_conservation_error(&sd), 1e-10);
        ohm_solution_free(&sd);
        ohm_voxel_grid_free(&g3);
    }
    double pa = 0, pb = 0, pc = 0, pd = 0;
    for (int i = 0; i < FIG1_N; ++i)
        pa = fmax(pa, prof_a[i]), pb = fmax(pb, prof_b[i]), pc = fmax(pc, prof_c[i]), pd = fmax(pd, prof_d[i]);
    if (csv) {
        fprintf(csv, "x_mm,paper_1kohm_V,milk_network_phi,dipole_exitance,ohm3d_exitance,paper_norm,milk_network_norm,"
                     "dipole_norm,ohm3d_norm\n");
        for (int i = 0; i < FIG1_N; ++i)
            fprintf(csv, "%.2f,%.9g,%.9g,%.9g,%.9g,%.6f,%.6f,%.6f,%.6f\n", (i + 0.5) * h, prof_a[i], prof_b[i],
                    prof_c[i], prof_d[i], prof_a[i] / pa, prof_b[i] / pb, prof_c[i] / pc, prof_d[i] / pd);
    }
    if (v) {
        double wa = half_width(prof_a, FIG1_N), wb = half_width(prof_b, FIG1_N), wc = half_width(prof_c, FIG1_N);
        ohm_validation_add(v, "figure 1: half-width, paper 1 kOhm network (mm)", "dipole half-width", wa * h, wc * h,
                rel(wa, wc), -1);
        ohm_validation_add(v, "figure 1: half-width, milk-derived network (mm)", "dipole half-width", wb * h, wc * h,
                rel(wb, wc), -1);
        double wd = half_width(prof_d, FIG1_N);
        ohm_validation_add(v, "figure 1: half-width, ohm 3-D robin block (mm)", "dipole half-width", wd * h, wc * h,
                rel(wd, wc), -1);
        ohm_validation_add(v, "figure 1: edge/peak, ohm 3-D robin block", "dipole edge/peak", prof_d[0] / pd, prof_c[0] / pc,
                rel(prof_d[0] / pd, prof_c[0] / pc), -1);
        ohm_validation_add(v, "figure 1: edge/peak, paper 1 kOhm network", "dipole edge/peak", prof_a[0] / pa, prof_c[0] / pc,
                rel(prof_a[0] / pa, prof_c[0] / pc), -1);
        ohm_validation_add(v, "figure 1: edge/peak, milk-derived network", "dipole edge/peak", prof_b[0] / pb, prof_c[0] / pc,
                rel(prof_b[0] / pb, prof_c[0] / pc), -1);
        ohm_validation_add(v, "figure 1: paper network conservation", "in = absorbed", sa.power_absorbed, sa.power_in,
                ohm_solution_conservation_error(&sa), 1e-10);
    }
    ohm_solution_free(&sa);
    ohm_solution_free(&sb);
    ohm_voxel_grid_free(&g);
    return OHM_OK;
}
