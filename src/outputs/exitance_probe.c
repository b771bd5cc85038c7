/* exitance_probe.c — see exitance_probe.h. */
#include "outputs/exitance_probe.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "base/log.h"

void ohm_exitance_lattice_for(ohm_exitance_lattice *L, const ohm_mesh *mesh)
{
    double lo[3], hi[3];
    ohm_mesh_bounds(mesh, lo, hi);
    double ext = fmax(hi[0] - lo[0], fmax(hi[1] - lo[1], hi[2] - lo[2]));
    L->step = ext / OHM_EXITANCE_NBINS;
    L->nodes = 1;
    for (int a = 0; a < 3; ++a) {
        L->lo[a] = lo[a] - L->step; /* one node of margin: faces lie half a cell outside */
        L->n[a] = (int)ceil((hi[a] - lo[a]) / L->step) + 3;
        L->nodes *= (size_t)L->n[a];
    }
}

/* P[c * nodes + node] += face powers of frame 0, trilinear. */
double *ohm_exitance_binned(const ohm_exitance_lattice *L, const ohm_solution *sol, const ohm_voxel_grid *g)
{
    size_t len = L->nodes * 3;
    double *P = calloc(len, sizeof *P);
    if (!P) return NULL;
    const double h = g->h;
    for (int64_t f = 0; f < sol->net.nfaces; ++f) {
        int32_t ijk[3];
        ohm_voxel_coords(g, sol->net.face_cell[f], ijk);
        int d = sol->net.face_dir[f];
        double t[3];
        int i0[3];
        for (int a = 0; a < 3; ++a) {
            double x = g->origin[a] + h * ijk[a] + 0.5 * h * ohm_face_offset[d][a];
            double u = (x - L->lo[a]) / L->step;
            i0[a] = (int)floor(u);
            if (i0[a] < 0) i0[a] = 0;
            if (i0[a] > L->n[a] - 2) i0[a] = L->n[a] - 2;
            t[a] = fmin(1.0, fmax(0.0, u - i0[a]));
        }
        for (int c = 0; c < 3; ++c) {
            int sc = sol->channels == 1 ? 0 : c;
            double p = ohm_solution_face_power(sol, sc, 0, f);
            for (int corner = 0; corner < 8; ++corner) {
                double w = 1;
                size_t idx = 0, stride = 1;
                for (int a = 0; a < 3; ++a) {
                    int bit = (corner >> a) & 1;
                    w *= bit ? t[a] : 1 - t[a];
                    idx += (size_t)(i0[a] + bit) * stride;
                    stride *= (size_t)L->n[a];
                }
                P[(size_t)c * L->nodes + idx] += w * p;
            }
        }
    }
    return P;
}

double ohm_exitance_l1_diff(const double *a, const double *b, size_t n)
{
    double s = 0;
    for (size_t i = 0; i < n; ++i) s += fabs(a[i] - b[i]);
    return s;
}

/* ohm_exitance_binned_noise (exitance_probe.h): each face's variance (its
 * cell's standard error squared) spread with the trilinear weights like its
 * power (not their squares: an upper estimate), the nodes' errors taken as
 * independent, and E|N(0, s)| = s sqrt(2/pi). */
double ohm_exitance_binned_noise(const ohm_exitance_lattice *L, const ohm_solution *mc, const ohm_voxel_grid *g,
                                 const double *P)
{
    ohm_solution var = *mc; /* the same faces, with se^2 h^2 per face as "exitance" */
    double *fx[OHM_MAX_CHANNELS] = {NULL};
    int ok = 1;
    for (int c = 0; c < mc->channels && ok; ++c) {
        fx[c] = malloc((size_t)(mc->net.nfaces ? mc->net.nfaces : 1) * sizeof(double));
        ok = fx[c] != NULL;
        for (int64_t f = 0; ok && f < mc->net.nfaces; ++f) {
            double se = mc->exitance_se[c][mc->net.face_unknown[f]];
            fx[c][f] = se * se * g->h * g->h; /* binned x h^2 below: se^2 h^4, a power's variance */
        }
        var.face_exitance[c] = fx[c];
    }
    double *V = ok ? ohm_exitance_binned(L, &var, g) : NULL;
    double noise = NAN;
    if (V) {
        double sum = 0, sp = 0;
        for (size_t i = 0; i < L->nodes * 3; ++i) {
            sum += sqrt(fmax(V[i], 0.0)) * sqrt(2.0 / 3.14159265358979323846);
            sp += fabs(P[i]);
        }
        noise = sp > 0 ? sum / sp : 0;
    }
    free(V);
    for (int c = 0; c < OHM_MAX_CHANNELS; ++c) free(fx[c]);
    return noise;
}

int ohm_probe_solve(ohm_solution *sol, const ohm_voxel_grid *g, int flipped, const ohm_mesh *mesh,
                    const ohm_material *mat, const ohm_light *lights, size_t nlights, ohm_solver_kind solver, double band,
                    int64_t photons, ohm_error *err)
{
    static const ohm_log quiet = {.verbosity = 0};
    ohm_solve_params p;
    memset(&p, 0, sizeof p);
    p.op.boundary = OHM_BOUNDARY_ROBIN;
    p.num.ordering = "metis";
    p.src.deposit = OHM_DEPOSIT_EXPONENTIAL;
    p.src.shadows = OHM_SHADOWS_MESH;
    p.src.mesh = mesh;
    p.src.orientation = flipped ? -1 : 1;
    p.num.solver = solver;
    p.op.band_k = band;
    p.mc.photons = photons;
    p.mc.seed = 1;
    return ohm_solve(sol, g, mat, lights, nlights, &p, &quiet, err);
}

int ohm_probe_voxelize_and_solve(ohm_voxel_grid *g, ohm_solution *sol, double *t_voxelize, int *flipped,
                                 const ohm_mesh *mesh, const ohm_material *mat, const ohm_light *lights,
                                 size_t nlights, int dim, int use_cg, double band, ohm_error *err)
{
    static const ohm_log quiet = {.verbosity = 0};
    ohm_voxelize_params vp;
    memset(&vp, 0, sizeof vp);
    vp.dim = dim;
    ohm_voxelize_report vr;
    double t0 = ohm_now();
    int rc = ohm_voxelize(g, &vr, mesh, &vp, &quiet, err);
    *t_voxelize = ohm_now() - t0;
    if (rc) return rc;
    *flipped = vr.flipped;
    rc = ohm_probe_solve(sol, g, vr.flipped, mesh, mat, lights, nlights, use_cg ? OHM_SOLVER_CG : OHM_SOLVER_DIRECT, band, 0, err);
    if (rc) ohm_voxel_grid_free(g);
    return rc;
}

