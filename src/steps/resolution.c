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

/* The scene at dim, solved with CG, its exitance binned on Lat into *P. */
static int probe_at(double **P, const ohm_exitance_lattice *Lat, const ohm_mesh *mesh, const ohm_material *mat,
                    const ohm_light *lights, size_t nlights, int dim, ohm_error *err)
{
    ohm_voxel_grid g;
    ohm_solution sol;
    double t;
    int flipped;
    int rc = ohm_probe_voxelize_and_solve(&g, &sol, &t, &flipped, mesh, mat, lights, nlights, dim, 1, 0, err);
    if (rc) return rc;
    *P = ohm_exitance_binned(Lat, &sol, &g);
    if (!*P) rc = ohm_fail(err, OHM_ERR_NOMEM, "voxelize error=: out of memory");
    ohm_solution_free(&sol);
    ohm_voxel_grid_free(&g);
    return rc;
}

int ohm_pick_resolution(ohm_resolution_pick *out, const ohm_mesh *mesh, const ohm_material *mat,
                        const ohm_light *lights, size_t nlights, double target, const ohm_log *log, ohm_error *err)
{
    memset(out, 0, sizeof *out);
    ohm_exitance_lattice Lat;
    ohm_exitance_lattice_for(&Lat, mesh);
    double *P0 = NULL, *P1 = NULL;
    double t0 = ohm_now();
    int rc = probe_at(&P0, &Lat, mesh, mat, lights, nlights, PICK_PROBE, err);
    if (!rc) rc = probe_at(&P1, &Lat, mesh, mat, lights, nlights, 2 * PICK_PROBE, err);
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
    out->t_probe = ohm_now() - t0;
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
    return OHM_OK;
}
