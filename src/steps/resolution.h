/* resolution.h — -voxelize error=: the coarsest grid predicted to meet an
 * error target in the surface exitance (docs/accuracy.md), and how far
 * diffusion itself is from transport in this scene (docs/transport.md,
 * "Which model: -solve model=").
 *
 * The grid: solves the scene (CG, no band) at dim 16 and 32 with the
 * accuracy study's probe (outputs/exitance_probe.h), turns their
 * binned-exitance difference into a Richardson estimate of the error at 32
 * and extrapolates to the coarsest dim predicted to meet the target (the
 * orders used are the cautious ends of those measured: resolution.c).  The
 * error is the one `ohm accuracy` measures.
 *
 * The model: both probe grids traced as transport too (Monte Carlo), binned
 * alike.  Diffusion's difference from transport on the same grid is its
 * model error plus what its finite volumes miss, which falls with the grid
 * (as marble's does: docs/transport.md) while the model error stays (as
 * ketchup's does); the part that stays, less the tracer's noise, is a lower
 * bound on diffusion's model error: what no finer grid removes.  -solve
 * model=auto takes transport where that bound exceeds the target. */
#ifndef OHM_RESOLUTION_H
#define OHM_RESOLUTION_H

#include <stddef.h>
#include <stdint.h>

#include "base/log.h"
#include "base/ohm_error.h"
#include "input/mesh.h"
#include "physics/light.h"
#include "physics/material.h"

typedef struct ohm_resolution_pick {
    int dim;                /* chosen cells along the longest side */
    double predicted;       /* predicted error there               */
    int probe_dims[2];
    double probe_error;     /* estimated error at probe_dims[1]    */
    double t_probe;         /* seconds spent probing (both probes) */
    /* the model probe (photons > 0): diffusion against transport on each
     * probe grid, binned as above */
    int64_t photons;        /* traced per grid (0: not probed)     */
    double model_diff;      /* at probe_dims[1]: sum |P_diffusion - P_transport| / sum P_transport */
    double mc_noise;        /* the tracer's noise in the estimate, as a part       */
    double model_error;     /* the part of the difference that does not fall with
                               the grid, less the noise, at least 0: a lower bound
                               on diffusion's model error                         */
    double t_model;         /* seconds the tracing took                           */
} ohm_resolution_pick;

/* Pick the grid for `target`; with photons > 0 also measure diffusion's
 * model error with that many photons. */
int ohm_pick_resolution(ohm_resolution_pick *out, const ohm_mesh *mesh, const ohm_material *mat,
                        const ohm_light *lights, size_t nlights, double target, int64_t photons, const ohm_log *log,
                        ohm_error *err);

/* Photons per grid for the model probe of `mat` at `target`: 0 (no probe)
 * unless a channel's albedo is below 0.9 (resolution.c says why), else
 * enough that the tracer's binned noise is about half the target, within
 * 2e4 .. 1e6. */
int64_t ohm_model_probe_photons(const ohm_material *mat, double target);

#endif
