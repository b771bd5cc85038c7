/* export_ply.h — the input mesh with the solved exitance at each vertex, as a
 * binary little-endian PLY (-export ply=, docs/outputs.md).
 *
 * Each vertex gets the inverse-distance-weighted mean of the exitance of the
 * boundary cells (cells with at least one boundary face) whose centres lie
 * within 1.5 voxels of it, or of the nearest boundary cell when none does.
 * Properties: x y z (float, mm), exitance (grey) or exitance_r/_g/_b (float,
 * W/mm^2), and red green blue (uchar): sRGB of exitance * exposure, clamped.
 * The exposure used is written as "comment ohm exposure E". */
#ifndef OHM_EXPORT_PLY_H
#define OHM_EXPORT_PLY_H

#include "input/mesh.h"
#include "base/ohm_error.h"
#include "base/output.h"
#include "solvers/solve.h"
#include "grid/voxelize.h"

/* Per-vertex exitance of frame `frame` (0-based): out[v * channels + c].
 * The caller frees *out. */
int ohm_vertex_exitance(float **out, const ohm_mesh *mesh, const ohm_voxel_grid *grid, const ohm_solution *sol,
                        int frame, ohm_error *err);

/* exposure <= 0: automatic (the 99th percentile of the vertex exitance maps to
 * 1.0).  *exposure_used (may be NULL) receives the exposure written. */
int ohm_export_ply(const char *path, const ohm_mesh *mesh, const ohm_voxel_grid *grid, const ohm_solution *sol,
                   int frame, double exposure, double *exposure_used, ohm_output_batch *batch, ohm_error *err);

#endif
