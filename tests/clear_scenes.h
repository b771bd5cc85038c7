/* clear_scenes.h — scenes with clear regions for test_clear_exchange.c and
 * bench_clear.c: quarter boxes lit by a pencil beam at the corner x = y = 0
 * (symmetry planes through the beam's axis, as the transport study's,
 * docs/transport.md), a medium per cell, and the clear mask from it (sigma_s'
 * below CLEAR_SS: the radiosity–diffusion coupling, physics/clear_exchange.h),
 * solved by diffusion (with or without the coupling) or by ohm's Monte Carlo
 * tracer, which flies straight through such cells. */
#ifndef OHM_TESTS_CLEAR_SCENES_H
#define OHM_TESTS_CLEAR_SCENES_H

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "physics/network.h"
#include "solvers/solve.h"
#include "studies/block_error.h"
#include "studies/scene.h"

static const double CLEAR_SS = 0.1; /* 1/mm: a cell of less reduced scattering is clear */

typedef struct clear_scene {
    int nx, ny, nz;
    double h, eta, g;
    /* the medium at a cell centre (mm, beam entering at x = y = z = 0, z
     * down into the box) */
    void (*medium)(const struct clear_scene *sc, double x, double y, double z, double *sa, double *ss);
    double sphere_c, sphere_r; /* the void scene's sphere */
    double reach;              /* the coupling's distance cut (mm), 0: none */
    ohm_voxel_grid grid;
    size_t n;
    ohm_coeff *sa, *ss;
    double *eta_v; /* per cell when the medium gives the clear cells their own index, else NULL */
    double clear_eta; /* > 0: the clear cells' index */
    uint8_t *clear;
} clear_scene;

/* The transport study's cube with a clear void: sigma_a 0.005, sigma_s'
 * 0.99 /mm, a sphere of sigma_a 1e-4, sigma_s' 0.01 on the axis. */
static void void_medium(const clear_scene *sc, double x, double y, double z, double *sa, double *ss)
{
    double dz = z - sc->sphere_c;
    int in = x * x + y * y + dz * dz < sc->sphere_r * sc->sphere_r;
    *sa = in ? 0.0001 : 0.005;
    *ss = in ? 0.01 : 0.99;
}

/* The three-layer head slab: 10 mm scalp and skull, 2 mm CSF, brain. */
static void head_medium(const clear_scene *sc, double x, double y, double z, double *sa, double *ss)
{
    (void)sc, (void)x, (void)y;
    if (z < 10.0) *sa = 0.019, *ss = 0.86;
    else if (z < 12.0) *sa = 0.0004, *ss = 0.001;
    else *sa = 0.02, *ss = 1.0;
}

/* A clear layer of index 1.0 (an air gap) 6-8 mm deep in tissue of sigma_a
 * 0.01, sigma_s' 1.0 /mm (the scene's clear_eta 1.0 gives it its index). */
static void gap_medium(const clear_scene *sc, double x, double y, double z, double *sa, double *ss)
{
    (void)sc, (void)x, (void)y;
    int gap = z > 6.0 && z < 8.0;
    *sa = gap ? 0.0 : 0.01;
    *ss = gap ? 0.001 : 1.0;
}

/* Cell (i, j, k) of the box's centre in the beam's frame (ohm_scene_box:
 * inside cells 1-based, beam at the world origin entering z = 0 going +z;
 * the box's z grows away from the lit face). */
static void clear_scene_centre(const clear_scene *sc, int i, int j, int k, double c[3])
{
    c[0] = (i - 0.5) * sc->h;
    c[1] = (j - 0.5) * sc->h;
    c[2] = (k - 0.5) * sc->h;
}

static int clear_scene_make(clear_scene *sc, ohm_error *err)
{
    int rc = ohm_scene_box(&sc->grid, sc->nx, sc->ny, sc->nz, sc->h, err);
    if (rc) return rc;
    sc->n = sc->grid.interior_cells;
    sc->sa = malloc(sc->n * sizeof *sc->sa);
    sc->ss = malloc(sc->n * sizeof *sc->ss);
    sc->clear = malloc(sc->n);
    sc->eta_v = sc->clear_eta > 0 ? malloc(sc->n * sizeof *sc->eta_v) : NULL;
    if (!sc->sa || !sc->ss || !sc->clear || (sc->clear_eta > 0 && !sc->eta_v))
        return ohm_fail(err, OHM_ERR_NOMEM, "clear scene: out of memory");
    size_t u = 0;
    const ohm_voxel_grid *g = &sc->grid;
    for (int k = 0; k < g->dims[2]; ++k)
        for (int j = 0; j < g->dims[1]; ++j)
            for (int i = 0; i < g->dims[0]; ++i) {
                if (!g->inside[ohm_voxel_index(g, i, j, k)]) continue;
                double c[3], sa, ss;
                clear_scene_centre(sc, i, j, k, c);
                sc->medium(sc, c[0], c[1], c[2], &sa, &ss);
                sc->sa[u] = (ohm_coeff)sa;
                sc->ss[u] = (ohm_coeff)ss;
                sc->clear[u] = ss < CLEAR_SS;
                if (sc->eta_v) sc->eta_v[u] = sc->clear[u] ? sc->clear_eta : sc->eta;
                ++u;
            }
    return OHM_OK;
}

static void clear_scene_free(clear_scene *sc)
{
    ohm_voxel_grid_free(&sc->grid);
    free(sc->sa), free(sc->ss), free(sc->clear), free(sc->eta_v);
}

/* Diffusion (mc NULL; clear: the mask, or NULL for diffusion everywhere)
 * or Monte Carlo transport (mc given), with the transport study's
 * defaults: the hybrid for the beam (its 10 first reduced scatterings as
 * transport, from another stream than the reference's). */
static int clear_scene_solve_with(ohm_solution *sol, const clear_scene *sc, const uint8_t *clear,
                                  const ohm_mc_params *mc, int64_t hybrid_photons, ohm_solver_kind kind, ohm_error *err)
{
    ohm_material m = ohm_scene_grey(0.005, 0.99);
    m.eta = sc->eta;
    m.g = sc->g;
    ohm_light beam = ohm_scene_pencil((const double[3]){0, 0, -1.0}, (const double[3]){0, 0, 1.0});
    ohm_mirrors mirror = {{1, 1, -1}, {-1, -1, -1}};
    ohm_solve_params p;
    memset(&p, 0, sizeof p);
    p.op.mirrors = &mirror;
    p.op.clear_cells = clear;
    p.op.clear_reach = sc->reach;
    p.num.solver = mc ? OHM_SOLVER_MC : kind;
    p.num.cg_tol = 1e-12;
    if (mc) p.mc = *mc;
    else if (hybrid_photons > 0) {
        p.mc.photons = hybrid_photons;
        p.mc.seed = 1000004;
        p.mc.handoff = 10;
    }
    p.media.sigma_a[0] = sc->sa;
    p.media.sigma_s[0] = sc->ss;
    p.media.eta_v = sc->eta_v;
    return ohm_solve(sol, &sc->grid, &m, &beam, 1, &p, NULL, err);
}

static int clear_scene_solve(ohm_solution *sol, const clear_scene *sc, const uint8_t *clear, const ohm_mc_params *mc,
                             int64_t hybrid_photons, ohm_error *err)
{
    return clear_scene_solve_with(sol, sc, clear, mc, hybrid_photons, OHM_SOLVER_DIRECT, err);
}

/* The bulk fluence's error against Monte Carlo as the transport study
 * measures it (validate_transport.c): 3 mm blocks every cell of which is
 * more than 2 mfp from the source and every face (skip_clear: and no clear
 * cell; 2: and none within 2 mfp of the void scene's sphere), where the Monte Carlo block mean is precise to 1%: mean |err|, bias. */
typedef struct clear_bulk_cells {
    const clear_scene *sc;
    int skip_clear;
} clear_bulk_cells;

static int clear_bulk_keep(const void *user, int i, int j, int k, int64_t v)
{
    const clear_bulk_cells *c = user;
    const clear_scene *sc = c->sc;
    const double h = sc->h, near = 2.0 / (0.005 + 0.99);
    double p[3];
    clear_scene_centre(sc, i, j, k, p);
    double to_face = fmin(fmin(sc->nx * h - p[0], sc->ny * h - p[1]), fmin(p[2], sc->nz * h - p[2]));
    double dz = p[2] - sc->sphere_c;
    double to_void = fabs(sqrt(p[0] * p[0] + p[1] * p[1] + dz * dz) - sc->sphere_r);
    return sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]) > near && to_face > near &&
           !(c->skip_clear && sc->clear[v]) && !(c->skip_clear > 1 && to_void <= near);
}

static ohm_block_error clear_scene_bulk(const clear_scene *sc, const ohm_solution *d, const ohm_solution *mc,
                                        int skip_clear)
{
    const clear_bulk_cells cells = {sc, skip_clear};
    const int dims[3] = {sc->nx, sc->ny, sc->nz};
    return ohm_block_error_of(d, mc, dims, (int)lround(3.0 / sc->h), 0.01, clear_bulk_keep, &cells);
}

#endif
