/* resolution.h — -voxelize error=: the coarsest grid predicted to meet an
 * error target in the surface exitance (docs/accuracy.md).  Solves the scene (CG, no
 * band) at dim 16 and 32 with the accuracy study's probe
 * (outputs/exitance_probe.h), turns their binned-exitance difference into a
 * Richardson estimate of the error at 32 and extrapolates to the coarsest dim
 * predicted to meet the target (the orders used are the cautious ends of those
 * measured: resolution.c).  The error is the one `ohm accuracy` measures. */
#ifndef OHM_RESOLUTION_H
#define OHM_RESOLUTION_H

#include <stddef.h>

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
    double t_probe;         /* seconds spent probing               */
} ohm_resolution_pick;
int ohm_pick_resolution(ohm_resolution_pick *out, const ohm_mesh *mesh, const ohm_material *mat,
                        const ohm_light *lights, size_t nlights, double target, const ohm_log *log, ohm_error *err);

#endif
