/* exitance_probe.h — a scene's surface exitance at a given resolution, in a
 * form that compares across resolutions: the mesh voxelized at dim and solved
 * with fixed parameters, its exitance binned on a lattice fixed by the mesh.
 * Shared by the resolution picker behind -voxelize error= (steps/resolution.h)
 * and the accuracy study (studies/accuracy.h), so that the error the picker
 * predicts is the error the study measures.  Every function here allocates
 * what it returns; the caller frees it (free, ohm_solution_free,
 * ohm_voxel_grid_free). */
#ifndef OHM_EXITANCE_PROBE_H
#define OHM_EXITANCE_PROBE_H

#include <stddef.h>
#include <stdint.h>

#include "base/ohm_error.h"
#include "grid/voxelize.h"
#include "input/mesh.h"
#include "physics/light.h"
#include "physics/material.h"
#include "solvers/solve.h"

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
/* sum |a - b| over n values. */
double ohm_exitance_l1_diff(const double *a, const double *b, size_t n);
/* The noise of a Monte Carlo solution's binned exitance P (ohm_exitance_binned
 * of mc) as a part of sum |P|, from the tracer's standard errors. */
double ohm_exitance_binned_noise(const ohm_exitance_lattice *L, const ohm_solution *mc, const ohm_voxel_grid *g,
                                 const double *P);

/* The probe's solve on grid g (Robin, METIS, exponential deposit, mesh
 * shadows, nothing logged): solver direct, cg or mc (then photons per
 * solve, seed 1); band: the depth band's k, 0 for none. */
int ohm_probe_solve(ohm_solution *sol, const ohm_voxel_grid *g, int flipped, const ohm_mesh *mesh,
                    const ohm_material *mat, const ohm_light *lights, size_t nlights, ohm_solver_kind solver, double band,
                    int64_t photons, ohm_error *err);

/* Voxelize the mesh at dim and solve it (ohm_probe_solve, "cg" or "direct").
 * *t_voxelize gets the voxelization's seconds, *flipped the mesh's
 * orientation.  On success the caller frees *g and *sol. */
int ohm_probe_voxelize_and_solve(ohm_voxel_grid *g, ohm_solution *sol, double *t_voxelize, int *flipped,
                                 const ohm_mesh *mesh, const ohm_material *mat, const ohm_light *lights,
                                 size_t nlights, int dim, int use_cg, double band, ohm_error *err);

#endif
