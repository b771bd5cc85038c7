/* test_lights.c — light arriving where it should:
 *  - shadows: a directional light's captured power equals its irradiance times
 *    the voxel object's projected area (its shadow on a plane behind it),
 *    measured here by an independent ray march, for a convex and a concave
 *    object; without shadow rays the concave one captures more;
 *  - spot and area lights on a flat face against analytic values;
 *  - an orbit: one factorization, every frame equal to a fresh single-light
 *    solve, and to a kept solver's relight (no factorization after its first);
 *  - the deposit below a face: its total is alpha' (1 - e^-tau), its mean depth
 *    mu / sigma_t' exactly on grids of 1/4 to 3/2 transport mean free paths and
 *    for oblique rays (lumped at cell centres it was 8% too deep at
 *    one), and mu is Snell's refracted cosine. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "physics/light.h"
#include "studies/scene.h"
#include "solvers/solve.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

static const ohm_log quiet = {.verbosity = 0};

static int load_voxelize(ohm_mesh *m, ohm_voxel_grid *g, ohm_voxelize_report *rep, const char *path, double size,
                         int dim)
{
    ohm_error err;
    ohm_error_clear(&err);
    if (ohm_mesh_read(m, path, &err)) {
        CHECK_MSG(0, "%s", err.msg);
        return -1;
    }
    double lo[3], hi[3];
    ohm_mesh_bounds(m, lo, hi);
    ohm_mesh_scale(m, size / fmax(hi[0] - lo[0], fmax(hi[1] - lo[1], hi[2] - lo[2])));
    ohm_voxelize_params p = {0};
    p.dim = dim;
    if (ohm_voxelize(g, rep, m, &p, &quiet, &err)) {
        CHECK_MSG(0, "%s", err.msg);
        ohm_mesh_free(m);
        return -1;
    }
    return 0;
}

static int inside_at(const ohm_voxel_grid *g, const double x[3])
{
    int32_t c[3];
    for (int a = 0; a < 3; ++a) {
        double q = (x[a] - g->origin[a]) / g->h + 0.5;
        if (q < 0 || q >= g->dims[a]) return 0;
        c[a] = (int32_t)floor(q);
    }
    return g->inside[ohm_voxel_index(g, c[0], c[1], c[2])];
}

/* Area of the voxel object's shadow on a plane perpendicular to l: a grid of
 * parallel rays (spacing h/4) marched in steps of h/16 (an independent, brute
 * force check of what the lit faces must add up to). */
static double projected_area(const ohm_voxel_grid *g, const double l[3])
{
    double u[3], v[3], up[3] = {0, 0, 1};
    if (fabs(l[2]) > 0.9) up[0] = 1, up[2] = 0;
    u[0] = up[1] * l[2] - up[2] * l[1], u[1] = up[2] * l[0] - up[0] * l[2], u[2] = up[0] * l[1] - up[1] * l[0];
    double nu = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    for (int a = 0; a < 3; ++a) u[a] /= nu;
    v[0] = l[1] * u[2] - l[2] * u[1], v[1] = l[2] * u[0] - l[0] * u[2], v[2] = l[0] * u[1] - l[1] * u[0];
    double centre[3], R = 0;
    for (int a = 0; a < 3; ++a) {
        centre[a] = g->origin[a] + 0.5 * (g->dims[a] - 1) * g->h;
        R += 0.25 * g->dims[a] * g->dims[a] * g->h * g->h;
    }
    R = sqrt(R);
    double ds = g->h / 4, dt = g->h / 16;
    int n = (int)ceil(2 * R / ds), steps = (int)ceil(2 * R / dt);
    size_t hit = 0;
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            double s = -R + (i + 0.5) * ds, t = -R + (j + 0.5) * ds;
            for (int k = 0; k < steps; ++k) {
                double w = -R + (k + 0.5) * dt, x[3];
                for (int a = 0; a < 3; ++a) x[a] = centre[a] + s * u[a] + t * v[a] + w * l[a];
                if (inside_at(g, x)) {
                    ++hit;
                    break;
                }
            }
        }
    return (double)hit * ds * ds;
}

static double incident(const ohm_voxel_grid *g, const ohm_mesh *m, int flipped, const ohm_light *lights, size_t nl,
                       ohm_shadows shadows)
{
    ohm_material mat = {0};
    mat.kind = OHM_MATERIAL_OPTICAL;
    mat.channels = 1;
    mat.sigma_a[0] = 0.01;
    mat.sigma_s[0] = 1;
    mat.eta = 1.3;
    ohm_solve_params p = {0};
    p.num.ordering = "amd";
    p.src.shadows = shadows;
    p.src.mesh = m;
    p.src.orientation = flipped ? -1 : 1;
    ohm_solution sol;
    ohm_error err;
    if (ohm_solve(&sol, g, &mat, lights, nl, &p, &quiet, &err)) {
        CHECK_MSG(0, "%s", err.msg);
        return NAN;
    }
    double P = sol.power_incident;
    CHECK(ohm_solution_conservation_error(&sol) < 1e-10);
    ohm_solution_free(&sol);
    return P;
}

static void shadow_area(const char *path, int concave /* documentation only */)
{
    ohm_mesh m;
    ohm_voxel_grid g;
    ohm_voxelize_report rep;
    if (load_voxelize(&m, &g, &rep, path, 40.0, 40)) return;
    ohm_light l = {0};
    l.type = OHM_LIGHT_DIRECTIONAL;
    double d[3] = {0.3, -0.8, -0.52}, len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int a = 0; a < 3; ++a) l.dir[a] = d[a] / len;
    l.intensity[0] = 1.0; /* W/mm^2: captured power = projected area */
    l.channels = 1;
    double to_light[3] = {-l.dir[0], -l.dir[1], -l.dir[2]};
    double area = projected_area(&g, to_light);
    double pm = incident(&g, &m, rep.flipped, &l, 1, OHM_SHADOWS_MESH);
    double pg = incident(&g, &m, rep.flipped, &l, 1, OHM_SHADOWS_GRID);
    double pn = incident(&g, &m, rep.flipped, &l, 1, OHM_SHADOWS_NONE);
    printf("%-20s projected area %.2f mm^2; captured: mesh shadows %.2f (%+.2f%%), grid %.2f (%+.2f%%), none %.2f "
           "(%+.2f%%)\n",
           path, area, pm, 100 * (pm / area - 1), pg, 100 * (pg / area - 1), pn, 100 * (pn / area - 1));
    CHECK_REL(pm, area, 0.03);
    CHECK_REL(pg, area, 0.03);
    /* without shadow rays every face turned to the light counts: far too much,
     * even for a convex object, whose voxel staircase shades itself */
    CHECK_MSG(pn > 1.2 * area, "without shadows the sum should be larger: %g vs %g", pn, area);
    (void)concave;
    ohm_voxel_grid_free(&g);
    ohm_mesh_free(&m);
}

/* A flat slab, 40 x 40 x 2 mm, its top face at z = 2 (voxel 0.5 mm). */
static int make_slab(ohm_mesh *m, ohm_voxel_grid *g)
{
    double v[8][3];
    for (int c = 0; c < 8; ++c) {
        v[c][0] = -20 + 40.0 * (c & 1);
        v[c][1] = -20 + 40.0 * ((c >> 1) & 1);
        v[c][2] = 2.0 * ((c >> 2) & 1);
    }
    static const int64_t f[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                                     {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
    memset(m, 0, sizeof *m);
    m->nverts = 8;
    m->ntris = 12;
    m->verts = malloc(sizeof v);
    m->tris = malloc(sizeof f);
    memcpy(m->verts, v, sizeof v);
    memcpy(m->tris, f, sizeof f);
    ohm_voxelize_params p = {0};
    p.voxel = 0.5;
    ohm_error err;
    if (ohm_voxelize(g, NULL, m, &p, &quiet, &err)) {
        CHECK_MSG(0, "%s", err.msg);
        return -1;
    }
    return 0;
}

/* Irradiance on a plane from a coaxial, parallel Lambertian disk of radius R
 * and radiance L at height d, at distance rho from the axis (closed form). */
static double disk_irradiance(double L, double R, double d, double rho)
{
    double a = d * d + rho * rho + R * R;
    return 0.5 * M_PI * L * (1.0 - (d * d + rho * rho - R * R) / sqrt(a * a - 4 * R * R * rho * rho));
}

static void spot_and_area(void)
{
    ohm_mesh m;
    ohm_voxel_grid g;
    if (make_slab(&m, &g)) return;
    /* spot, 30 mm above the centre, half-angle 20 degrees: the cone's whole
     * footprint (radius 10.9 mm) lies on the face, so the power arriving is
     * I times the cone's solid angle, 2 pi (1 - cos 20deg) */
    ohm_light spot = {0};
    spot.type = OHM_LIGHT_SPOT;
    spot.pos[2] = 32;
    spot.dir[2] = -1;
    spot.intensity[0] = 1;
    spot.channels = 1;
    spot.angle = 20;
    double expect = 2 * M_PI * (1 - cos(20 * M_PI / 180));
    double got = incident(&g, &m, 0, &spot, 1, OHM_SHADOWS_MESH);
    printf("spot: %.6f W arriving, analytic %.6f (%+.3f%%)\n", got, expect, 100 * (got / expect - 1));
    CHECK_REL(got, expect, 0.02);
    /* a soft edge only lowers it */
    spot.falloff = 10;
    double soft = incident(&g, &m, 0, &spot, 1, OHM_SHADOWS_MESH);
    CHECK(soft < got && soft > 0.5 * got);

    /* area: a disk of radius 5 mm, 10 mm above the face, emitting 1 W down;
     * the power on the 40 x 40 mm face integrates the closed-form irradiance */
    ohm_light area = {0};
    area.type = OHM_LIGHT_AREA;
    area.pos[2] = 12;
    area.dir[2] = -1;
    area.intensity[0] = 1;
    area.channels = 1;
    area.disk = 1;
    area.width = 10;
    area.samples = 1024;
    double R = 5, d = 10, L = 1.0 / (M_PI * M_PI * R * R), sum = 0;
    const int q = 800;
    for (int j = 0; j < q; ++j)
        for (int i = 0; i < q; ++i) {
            double x = -20 + (i + 0.5) * 40.0 / q, y = -20 + (j + 0.5) * 40.0 / q;
            sum += disk_irradiance(L, R, d, sqrt(x * x + y * y));
        }
    expect = sum * (40.0 / q) * (40.0 / q);
    got = incident(&g, &m, 0, &area, 1, OHM_SHADOWS_MESH);
    printf("area disk: %.6f W arriving, analytic %.6f (%+.3f%%)\n", got, expect, 100 * (got / expect - 1));
    CHECK_REL(got, expect, 0.02);
    /* and a rectangle emitter sees the same total when the face catches it all
     * but its grazing tail: just check it is a plausible fraction of 1 W */
    area.disk = 0;
    area.width = area.height = 8;
    got = incident(&g, &m, 0, &area, 1, OHM_SHADOWS_MESH);
    CHECK(got > 0.7 && got < 1.0);
    ohm_voxel_grid_free(&g);
    ohm_mesh_free(&m);
}

/* A kept solver relit one light at a time (solve.h, keep = 1): the 3
 * channels' factors are made once, by the first solve, and never again;
 * every relit frame equals the orbit's to round-off and conserves power. */
static void relight(const ohm_solution *all, const ohm_voxel_grid *g, const ohm_material *mat,
                    const ohm_light *lights, const ohm_solve_params *p)
{
    ohm_solver *s = NULL;
    ohm_error err;
    if (ohm_solver_create(&s, g, mat, p, 1, &quiet, &err)) {
        CHECK_MSG(0, "%s", err.msg);
        return;
    }
    for (int k = 0; k < 16; k += 3) {
        ohm_light one = lights[k];
        one.frame = 0;
        if (ohm_solver_solve(s, &one, 1, &err)) {
            CHECK_MSG(0, "%s", err.msg);
            break;
        }
        const ohm_solution *sol = ohm_solver_solution(s);
        CHECK_MSG(sol->factors == 3, "relight %d: %d factorizations in all, expected the first solve's 3", k,
                  sol->factors);
        CHECK(sol->frames == 1 && sol->solves == 3);
        CHECK_MSG(ohm_solution_conservation_error(sol) < 1e-12, "relight %d: conservation error %g", k,
                  ohm_solution_conservation_error(sol));
        for (int c = 0; c < 3; ++c) {
            double worst = 0, scale = 0;
            const double *a = all->fluence[c] + (size_t)k * (size_t)all->n, *b = sol->fluence[c];
            for (int64_t v = 0; v < all->n; ++v) {
                worst = fmax(worst, fabs(a[v] - b[v]));
                scale = fmax(scale, fabs(b[v]));
            }
            CHECK_MSG(worst <= 1e-12 * scale, "relight %d channel %d differs by %g of %g", k, c, worst, scale);
        }
    }
    ohm_solver_free(s);
}

/* 16 orbit frames: one factorization; each frame equals a fresh solve. */
static void orbit_reuse(void)
{
    ohm_mesh m;
    ohm_voxel_grid g;
    ohm_voxelize_report rep;
    if (load_voxelize(&m, &g, &rep, "samples/cow.obj", 40.0, 20)) return;
    ohm_material mat = {0};
    if (ohm_material_preset(&mat, "skin1", NULL)) return;
    ohm_light lights[16];
    for (int k = 0; k < 16; ++k) {
        memset(&lights[k], 0, sizeof lights[k]);
        lights[k].type = OHM_LIGHT_POINT;
        double a = 2 * M_PI * k / 16;
        lights[k].pos[0] = 60 * cos(a);
        lights[k].pos[1] = 20;
        lights[k].pos[2] = 60 * sin(a);
        lights[k].intensity[0] = 1000;
        lights[k].channels = 1;
        lights[k].frame = k + 1;
    }
    ohm_solve_params p = {0};
    p.num.ordering = "metis";
    p.src.shadows = OHM_SHADOWS_MESH;
    p.src.mesh = &m;
    p.src.orientation = 1;
    p.num.max_rhs_bytes = 5.0 * sizeof(double) * 2 * (double)g.interior_cells; /* batches of 5 frames */
    ohm_solution all;
    ohm_error err;
    if (ohm_solve(&all, &g, &mat, lights, 16, &p, &quiet, &err)) {
        CHECK_MSG(0, "%s", err.msg);
        return;
    }
    CHECK_MSG(all.factors == 3, "%d factorizations for 3 distinct channels", all.factors);
    CHECK(all.frames == 16 && all.solves == 16 * 3);
    p.num.max_rhs_bytes = 0;
    for (int k = 0; k < 16; k += 5) {
        ohm_light one = lights[k];
        one.frame = 0;
        ohm_solution fresh;
        if (ohm_solve(&fresh, &g, &mat, &one, 1, &p, &quiet, &err)) {
            CHECK_MSG(0, "%s", err.msg);
            continue;
        }
        for (int c = 0; c < 3; ++c) {
            double worst = 0, scale = 0;
            const double *a = all.fluence[c] + (size_t)k * (size_t)all.n, *b = fresh.fluence[c];
            for (int64_t v = 0; v < all.n; ++v) {
                worst = fmax(worst, fabs(a[v] - b[v]));
                scale = fmax(scale, fabs(b[v]));
            }
            CHECK_MSG(worst <= 1e-10 * scale, "frame %d channel %d differs by %g of %g", k + 1, c, worst, scale);
        }
        ohm_solution_free(&fresh);
    }
    relight(&all, &g, &mat, lights, &p);
    ohm_solution_free(&all);
    ohm_voxel_grid_free(&g);
    ohm_mesh_free(&m);
}

/* Mean depth and total of the exponential deposit of 1 W through the top face
 * of a 3 x 3 x nz column of cells h, along a ray of cosine mu. */
static void deposit_moment(double h, double mu, double *mean_depth, double *total)
{
    ohm_voxel_grid g;
    ohm_network net;
    ohm_error err = {0};
    const int nz = 200;
    CHECK(ohm_scene_box(&g, 3, 3, nz, h, &err) == 0);
    CHECK(ohm_network_build(&net, &g, NULL, &err) == 0);
    int64_t top = ohm_network_unknown(&net, ohm_voxel_index(&g, 2, 2, nz)), f = -1;
    for (int64_t q = 0; q < net.nfaces; ++q)
        if (net.face_unknown[q] == top && net.face_dir[q] == 5) f = q;
    CHECK(f >= 0);
    ohm_channel_medium med;
    memset(&med, 0, sizeof med);
    med.sigma_a0 = 0.05;
    med.sigma_s0 = 0.95; /* sigma_t' = 1 /mm, albedo 0.95 */
    med.eta = 1.3;
    double *b = calloc((size_t)net.n, sizeof *b);
    double put = ohm_source_deposit_face(b, &net, f, 1.0, mu, &med, OHM_DEPOSIT_EXPONENTIAL);
    double sum = 0, moment = 0;
    for (int k = 1; k <= nz; ++k) {
        double w = b[ohm_network_unknown(&net, ohm_voxel_index(&g, 2, 2, k))];
        CHECK(w >= 0);
        sum += w;
        moment += w * (nz - k + 0.5) * h; /* depth of the cell's centre below the face */
    }
    CHECK_REL(sum, put, 1e-13);
    *mean_depth = moment / sum;
    *total = sum;
    free(b);
    ohm_network_free(&net);
    ohm_voxel_grid_free(&g);
}

static void deposit_moments(void)
{
    const double hs[] = {0.25, 0.5, 1.0, 1.5}, mus[] = {1.0, 0.75};
    for (size_t i = 0; i < sizeof hs / sizeof hs[0]; ++i)
        for (size_t j = 0; j < sizeof mus / sizeof mus[0]; ++j) {
            if (hs[i] / mus[j] > 1.8) continue; /* the first cell's clamp acts beyond (light.c) */
            double depth, total;
            deposit_moment(hs[i], mus[j], &depth, &total);
            CHECK_REL(depth, mus[j] / 1.0, 1e-9);
            CHECK_REL(total, 0.95, 1e-12); /* alpha' (1 - e^-tau), tau > 40 */
        }
    /* Snell: a directional light at 60 degrees onto the top face enters at
     * cos_t = sqrt(1 - sin^2 60 / eta^2) */
    ohm_voxel_grid g;
    ohm_network net;
    ohm_error err = {0};
    CHECK(ohm_scene_box(&g, 5, 5, 5, 1.0, &err) == 0);
    CHECK(ohm_network_build(&net, &g, NULL, &err) == 0);
    ohm_light l;
    memset(&l, 0, sizeof l);
    l.type = OHM_LIGHT_DIRECTIONAL;
    l.dir[0] = sin(M_PI / 3), l.dir[2] = -cos(M_PI / 3);
    l.intensity[0] = 1.0;
    l.channels = 1;
    size_t nf = (size_t)net.nfaces;
    double *en = calloc(nf, sizeof *en), *emu = calloc(nf, sizeof *emu), ar = 0;
    CHECK(ohm_light_face_powers(&en, &emu, &ar, 1, &net, &l, 1.3, NULL, NULL, &err) == 0);
    int64_t top = ohm_network_unknown(&net, ohm_voxel_index(&g, 3, 3, 5));
    int seen = 0;
    for (size_t f = 0; f < nf; ++f)
        if (net.face_unknown[f] == top && net.face_dir[f] == 5) {
            CHECK_REL(emu[f] / en[f], sqrt(1.0 - 0.75 / (1.3 * 1.3)), 1e-12);
            ++seen;
        }
    CHECK(seen == 1);
    /* the power arriving, summed over the faces: the 25 top faces at cos 60,
     * the 25 on -x at cos 30, none else (h = 1) */
    CHECK_REL(ar, 25.0 * (cos(M_PI / 3) + sin(M_PI / 3)), 1e-12);
    free(en), free(emu);
    ohm_network_free(&net);
    ohm_voxel_grid_free(&g);
}

int main(void)
{
    deposit_moments();
    shadow_area("samples/larger_sphere.off", 0);
    shadow_area("samples/cow.obj", 1);
    spot_and_area();
    orbit_reuse();
    return check_summary();
}
