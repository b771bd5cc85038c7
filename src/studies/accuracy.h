/* accuracy.h — `ohm accuracy`: the speed/accuracy trade of a scene, measured
 * (issue 7): a resolution series per material against a finer reference and
 * its Richardson extrapolation, both solvers timed, depth bands against the
 * full solve, and the half-space scene against its exact solution.  Prints
 * figures; asserts nothing (tests/cli_accuracy.sh does, on a small run). */
#ifndef OHM_ACCURACY_H
#define OHM_ACCURACY_H

#include <stddef.h>

#include "physics/light.h"
#include "base/log.h"
#include "physics/material.h"
#include "input/mesh.h"
#include "base/ohm_error.h"
#include "solvers/solve.h"
#include "grid/voxelize.h"

/* The error measure: each boundary face's power (exitance x h^2, frame 0)
 * split trilinearly among the 8 nodes around its centre on a world lattice
 * fixed by the mesh's box (OHM_EXITANCE_NBINS nodes along its longest side),
 * so grids of any resolution compare node by node; the error is
 * sum |P - P_ref| / sum P_ref over nodes and channels. */
enum { OHM_EXITANCE_NBINS = 12 };
typedef struct ohm_exitance_lattice {
    double lo[3], step;
    int n[3];
    size_t nodes;
} ohm_exitance_lattice;
void ohm_exitance_lattice_for(ohm_exitance_lattice *L, const ohm_mesh *mesh);
/* 3 x nodes values (R, G, B; a grey solution fills all three), or NULL. */
double *ohm_exitance_binned(const ohm_exitance_lattice *L, const ohm_solution *sol, const ohm_voxel_grid *g);

/* -voxelize error=: solve the scene (CG, no band) at dim 16 and 32, turn
 * their binned-exitance difference into a Richardson estimate of the error at
 * 32 and extrapolate to the coarsest dim predicted to meet the target (the
 * orders used are the cautious ends of those measured: accuracy.c). */
typedef struct ohm_resolution_pick {
    int dim;                /* chosen cells along the longest side */
    double predicted;       /* predicted error there               */
    int probe_dims[2];
    double probe_error;     /* estimated error at probe_dims[1]    */
    double t_probe;         /* seconds spent probing               */
} ohm_resolution_pick;
int ohm_pick_resolution(ohm_resolution_pick *out, const ohm_mesh *mesh, const ohm_material *mat,
                        const ohm_light *lights, size_t nlights, double target, const ohm_log *log, ohm_error *err);

/* argc/argv: the words after `accuracy`.  Returns the exit code: 0 done, 1 a
 * step failed, 2 bad usage. */
int ohm_accuracy_main(int argc, char **argv);

#endif
