/* export_vdb.h — write the voxel object as OpenVDB grids (docs/outputs.md).
 *
 *   surface  level set: narrow-band signed distance (mm), negative inside
 *   density  fog volume: 1 in every interior cell (Blender's Principled Volume
 *            reads "density" by default), 0 elsewhere
 * and after a solve, per channel (suffix _r _g _b, none for grey):
 *   fluence   fluence rate phi (W/mm^2) in every interior cell
 *   exitance  power leaving through a cell's boundary faces per unit area
 *             (W/mm^2), on the boundary cells only
 *
 * World units are millimetres; index (i,j,k) of ohm_voxel_grid is the VDB index,
 * so the transform is scale h and translation = the centre of cell (0,0,0). */
#ifndef OHM_EXPORT_VDB_H
#define OHM_EXPORT_VDB_H

#include "base/ohm_error.h"
#include "base/output.h"
#include "solvers/solve.h"
#include "grid/voxelize.h"

typedef struct ohm_vdb_provenance {
    const char *source;        /* the mesh file the object came from        */
    double mesh_scale_mm;      /* millimetres per mesh unit used by -read    */
    const char *material;      /* material description, or NULL            */
    const char *solve;         /* boundary / deposit / lights, or NULL      */
} ohm_vdb_provenance;

/* sol may be NULL (no solve yet); frame (0-based) picks the solution's frame. */
int ohm_export_vdb(const char *path, const ohm_voxel_grid *g, const ohm_solution *sol, int frame,
                   const ohm_vdb_provenance *prov, ohm_output_batch *batch, ohm_error *err);

#endif
