/* resolution.c — -voxelize error=: the coarsest grid predicted to meet an
 * error target (resolution.h). */
#include "steps/resolution.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "outputs/exitance_probe.h"

/* Orders of the binned-exitance error in h measured on spot at 12.5..200 mm
 * with marble, skin1 and ketchup (docs/accuracy.md): 1.3..1.6 between dim 16
 * and 32 (not yet asymptotic), 1.5..1.75 from 32 to 64.  The probe pair's
 * difference is turned into the error at 32 with the lower order (which
 * over-estimates it) and extrapolated with 1.5: both choices err on the side
 * of a finer grid. */
static const double PICK_PROBE_ORDER = 1.3;
static const double PICK_ORDER = 1.5;
static const int PICK_PROBE = 16;

/* The model probe runs for a material with a channel of albedo below this:
 * above it the transport study found diffusion within 1-2% of transport
 * away from sources (docs/transport.md), and tracing a high albedo's long
 * paths is what would cost (marble: 16 s at 3e5 photons on the cow). */
static const double MODEL_PROBE_ALBEDO = 0.9;
/* The tracer's binned noise is about this / sqrt(photons) on the 12-node
 * lattice (measured: 0.019 to 0.031 at 3.1e5 photons, cow and spot, ketchup
 * to marble); the probe asks for half the target. */
static const double MC_BINNED_NOISE = 14.0;

/* Diffusion against transport on one probe grid: a part of transport's
 * binned exitance, and the tracer's noise in it. */
typedef struct model_probe {
    double diff, noise, seconds;
} model_probe;

/* The scene at dim, solved with CG, its exitance binned on Lat into *P;
 * with photons > 0 the same grid traced as transport too, into *m. */
static int probe_at(double **P, model_probe *m, const ohm_exitance_lattice *Lat, const ohm_mesh *mesh,
                    const ohm_material *mat, const ohm_light *lights, size_t nlights, int dim, int64_t photons,
                    ohm_error *err)
{
    ohm_voxel_grid g;
    ohm_solution sol;
    double t;
    int flipped;
    int rc = ohm_probe_voxelize_and_solve(&g, &sol, &t, &flipped, mesh, mat, lights, nlights, dim, 1, 0, err);
    if (rc) return rc;
    *P = ohm_exitance_binned(Lat, &sol, &g);
    ohm_solution_free(&sol);
    if (!*P) rc = ohm_fail(err, OHM_ERR_NOMEM, "voxelize error=: out of memory");
    if (!rc && photons > 0) {
        double t0 = ohm_now();
        rc = ohm_probe_solve(&sol, &g, flipped, mesh, mat, lights, nlights, OHM_SOLVER_MC, 0, photons, err);
        int traced = !rc;
        double *T = traced ? ohm_exitance_binned(Lat, &sol, &g) : NULL;
        if (traced && !T) rc = ohm_fail(err, OHM_ERR_NOMEM, "voxelize error=: out of memory");
        if (T) {
            size_t len = Lat->nodes * 3;
            double sum = 0;
            for (size_t i = 0; i < len; ++i) sum += fabs(T[i]);
            m->diff = sum > 0 ? ohm_exitance_l1_diff(*P, T, len) / sum : 0;
            m->noise = ohm_exitance_binned_noise(Lat, &sol, &g, T);
            m->seconds = ohm_now() - t0;
        }
        free(T);
        if (traced) ohm_solution_free(&sol);
    }
    ohm_voxel_grid_free(&g);
    return rc;
}

int64_t ohm_model_probe_photons(const ohm_material *mat, double target)
{
    double lowest = 1.0;
    for (int c = 0; c < mat->channels; ++c) lowest = fmin(lowest, ohm_material_albedo(mat, c));
    if (mat->kind != OHM_MATERIAL_OPTICAL || lowest >= MODEL_PROBE_ALBEDO) return 0;
    double n = pow(2.0 * MC_BINNED_NOISE / target, 2.0);
    return (int64_t)(n < 2e4 ? 2e4 : n > 1e6 ? 1e6 : n);
}

int ohm_pick_resolution(ohm_resolution_pick *out, const ohm_mesh *mesh, const ohm_material *mat,
                        const ohm_light *lights, size_t nlights, double target, int64_t photons, const ohm_log *log,
                        ohm_error *err)
{
    memset(out, 0, sizeof *out);
    ohm_exitance_lattice Lat;
    ohm_exitance_lattice_for(&Lat, mesh);
    double *P0 = NULL, *P1 = NULL;
    model_probe m0 = {0}, m1 = {0};
    double t0 = ohm_now();
    int rc = probe_at(&P0, &m0, &Lat, mesh, mat, lights, nlights, PICK_PROBE, photons, err);
    if (!rc) rc = probe_at(&P1, &m1, &Lat, mesh, mat, lights, nlights, 2 * PICK_PROBE, photons, err);
    if (rc) {
        free(P0);
        free(P1);
        return rc;
    }
    size_t len = Lat.nodes * 3;
    double sum = 0;
    for (size_t i = 0; i < len; ++i) sum += fabs(P1[i]);
    double change = sum > 0 ? ohm_exitance_l1_diff(P0, P1, len) / sum : 0;
    free(P0);
    free(P1);
    /* Richardson: e(h) = C h^p, so P(h) - P(h/2) = C h^p (1 - 2^-p) and the
     * error left at h/2 is that difference / (2^p - 1) */
    double e1 = change / (pow(2.0, PICK_PROBE_ORDER) - 1.0);
    out->probe_dims[0] = PICK_PROBE;
    out->probe_dims[1] = 2 * PICK_PROBE;
    out->probe_error = e1;
    out->t_model = m0.seconds + m1.seconds;
    out->t_probe = ohm_now() - t0 - out->t_model;
    double d = 2.0 * PICK_PROBE * pow(e1 / target, 1.0 / PICK_ORDER);
    int dim = (int)ceil(d);
    if (dim < 8) dim = 8;
    if (dim > 4096) dim = 4096;
    out->dim = dim;
    out->predicted = e1 * pow(2.0 * PICK_PROBE / dim, PICK_ORDER);
    ohm_log_info(log,
                 "voxelize error=%g: probes at dim %d and %d (%.2f s) differ by %.3g, so dim %d has about %.3g; "
                 "order %.1f predicts %.3g at dim %d",
                 target, PICK_PROBE, 2 * PICK_PROBE, out->t_probe, change, 2 * PICK_PROBE, e1, PICK_ORDER,
                 out->predicted, dim);
    if (photons > 0) {
        /* Diffusion against transport on the same grid, m(h), is its model
         * error M plus what its finite volumes miss, C h^p, which transport
         * on that grid does not share: m(2h) - m(h) = C h^p (2^p - 1), so
         * M = m(h) - (m(2h) - m(h)) / (2^p - 1), taken with the cautious
         * order (a lower bound), less the tracer's noise at both grids. */
        double falls = fmax(0.0, m0.diff - m1.diff) / (pow(2.0, PICK_PROBE_ORDER) - 1.0);
        out->photons = photons;
        out->model_diff = m1.diff;
        out->mc_noise = m1.noise + m0.noise / (pow(2.0, PICK_PROBE_ORDER) - 1.0);
        out->model_error = fmax(0.0, m1.diff - falls - out->mc_noise);
        ohm_log_info(log,
                     "voxelize error=%g: diffusion differs from transport (%.3g photons, %.2f s) by %.3g at dim %d "
                     "and %.3g at dim %d; less what falls with the grid and the tracer's noise %.3g, diffusion's "
                     "own error in this scene is at least %.3g",
                     target, (double)photons, out->t_model, m0.diff, PICK_PROBE, m1.diff, 2 * PICK_PROBE,
                     out->mc_noise, out->model_error);
    }
    return OHM_OK;
}
