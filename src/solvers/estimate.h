/* estimate.h — what a solve of a mesh's object will take, predicted before
 * anything is built: the whole process's peak memory with each solver, and
 * the solver solver=auto would take for a number of solves to come, with
 * its reason.  A caller refuses a setting that would not fit before it
 * starts (the Blender add-on's guard, through include/ohm.h's
 * ohm_scene_estimate) instead of carrying a model of its own.
 *
 * The memory model, fitted on 2026-12-05 to whole-process peaks of the
 * library's path (a kept solver, three channels, a point light) on a
 * sphere, Spot and the Stanford bunny from 1e5 to 1.7e7 cells; every
 * prediction was within 13% of the measured peak (docs/blender.md):
 *
 * - interior cells n = the mesh's enclosed volume / h^3, h = the longest
 *   extent / dim (exact for closed meshes, within a few percent for nearly
 *   closed ones);
 * - the voxel grid: 13 B per cell of its box (the voxelizer's own
 *   estimate), the box padded by the band of 3 cells and one more a side;
 * - mg: 410 B per interior cell (each channel's stencil and hierarchy kept
 *   for relighting); cg: 375 B; auto: 650 B (it holds the assembled matrix
 *   beside mg's stencil);
 * - direct: each distinct channel's Cholesky factor, 11 B per nonzero,
 *   nnz(L) = 2.19 n^1.4 c^0.94, and 150 B per cell for the rest.  n^1.4:
 *   the grid ordering's nested dissection (n^(4/3) in theory, 1.38-1.40
 *   measured).  c = (36 pi V^2 / S^3)^(1/3), the mesh's thickness 3V/S over
 *   a sphere's of the same volume (1 for a sphere, 0.42 for a knotted
 *   tube): a thin object's separators are its thin cross-sections.  Fitted
 *   to nnz(L) measured on eight meshes at 1e5-5e5 cells: within 0.82-1.19;
 * - amg: 74 B per cell plus 392 B per cell per channel (docs/scale-model.md);
 * - 95 MiB for the library and its callers.
 *
 * The times are solver=auto's own cost model (auto.c), with mg's column at
 * the ~500 ns per cell a column measured on the block medium
 * (docs/multigrid.md) in place of auto's timed probe. */
#ifndef OHM_SOLVERS_ESTIMATE_H
#define OHM_SOLVERS_ESTIMATE_H

#include "input/mesh.h"
#include "solvers/solve.h"

/* What the model needs of a mesh: its extents (mm), enclosed volume (mm^3)
 * and compactness (1 for a sphere, less for thin shapes). */
typedef struct ohm_shape {
    double extent[3];
    double volume;
    double compactness;
} ohm_shape;

void ohm_shape_of(ohm_shape *out, const ohm_mesh *mesh);

/* A prediction's error margin: the lowest prediction measured was 0.88 of
 * the peak (Spot, direct, docs/blender.md), so prediction x margin stays
 * above a peak. */
#define OHM_ESTIMATE_MARGIN 1.15

typedef struct ohm_solve_estimate {
    double interior_cells, box_cells;
    double bytes[OHM_SOLVER_MC + 1]; /* by ohm_solver_kind; mc's is not modelled (0) */
    ohm_solver_kind auto_choice;     /* what solver=auto would take           */
    char auto_reason[256];
} ohm_solve_estimate;

/* The prediction at `dim` cells across for `channels` distinct channel
 * materials and `solves` solves of each to come (relights; 1: one solve),
 * auto's choice among those whose bytes x margin fit `allowed` bytes. */
void ohm_estimate_solve(ohm_solve_estimate *out, const ohm_shape *shape, int dim, int channels, double solves,
                        double allowed);

/* The largest dim (<= 4096) whose prediction with `solver` times the margin
 * fits `allowed` bytes; 0 when none of at least 4 does. */
int ohm_estimate_largest_dim(const ohm_shape *shape, ohm_solver_kind solver, int channels, double allowed);

/* solver=auto's predicted seconds (auto.c): the factor's analysis, one
 * factorization per material and `columns` pairs of triangular solves; amg's
 * setups and columns (with PETSc's start when it has not started). */
double ohm_auto_direct_seconds(double n, int materials, double columns);
double ohm_auto_amg_seconds(double n, int materials, double columns);

#endif
