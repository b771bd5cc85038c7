/* voxelize.h — stage 2: which cells of a regular grid lie inside a mesh.
 *
 * Inside/outside comes from the generalized winding number (Jacobson et al.
 * 2013, "Robust inside-outside segmentation using generalized winding
 * numbers"), evaluated with a BVH and a first-order far-field (dipole)
 * expansion (Barill et al. 2018, "Fast winding numbers for soups and clouds").
 * Unlike a ray-parity or OpenVDB meshToVolume sign, it degrades gracefully on
 * holes, open rims and overlapping pieces: a cell is inside when w > 1/2.
 * A mesh wound inside-out (negative enclosed volume) is read with the opposite
 * sign rather than coming out empty.
 *
 * The grid is dense over the mesh's bounding box plus a margin of
 * band_voxels + 1 cells; index (i,j,k) >= 0, x fastest, cell centre at
 * origin + (i,j,k) * h (world mm, OpenVDB's convention).  The grid owns its
 * arrays; ohm_voxel_grid_free releases them (NULL or zeroed is fine). */
#ifndef OHM_VOXELIZE_H
#define OHM_VOXELIZE_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>

#include "grid/cell_index.h"
#include "base/log.h"
#include "input/mesh.h"
#include "base/ohm_error.h"

typedef struct ohm_voxel_grid {
    int32_t dims[3];        /* cells per axis, margin included                */
    double h;               /* voxel size (mm)                                */
    double origin[3];       /* world centre of cell (0,0,0) (mm)              */
    uint8_t *inside;        /* dims[0]*dims[1]*dims[2]: 1 = interior cell     */
    ohm_cell_index near;    /* the narrow band: the cells within band of the
                               surface (cell_index.h); empty for a grid made
                               cell by cell, which has no surface            */
    float *near_dist;       /* near.count: their unsigned distance to the
                               surface (mm), in cell order: a dense field was
                               4 B per grid cell, 17-23 B per interior cell  */
    double band;            /* narrow-band half width (mm)                    */
    size_t interior_cells;  /* how many inside[] are 1                        */
} ohm_voxel_grid;

typedef struct ohm_voxelize_params {
    int dim;          /* cells along the bounding box's longest axis, or 0     */
    double voxel;     /* voxel size in mm (used when dim == 0)                 */
    int band_voxels;  /* narrow-band half width in voxels; 0 means 3           */
    double max_cells; /* refuse a dense grid larger than this; 0 means 2^31    */
    double max_memory;/* bytes the grid may take; 0: what the machine has      */
    /* Fit the bounding box into fit[0] x fit[1] x fit[2] cells (all three > 0;
     * all zero = unused, and then dim/voxel decide).  Voxels stay cubic: the
     * largest count goes to the longest axis, the next to the next, and
     * h = max over axes of extent / count, so every axis fits — the paper's
     * "cube of cells around the model" at its grid sizes (8x8x4 ... 64x64x32).
     * Takes precedence over dim and voxel; the margin is added as usual. */
    int fit[3];
} ohm_voxelize_params;

/* What the voxelizer found and did, for the log and the stats. */
typedef struct ohm_voxelize_report {
    int flipped;               /* mesh was inside-out, read reversed          */
    double signed_volume;      /* divergence-theorem volume of the mesh (mm^3) */
    size_t winding_exact;      /* cells whose winding number was evaluated    */
    size_t winding_filled;     /* cells decided from a block's corners        */
    size_t ambiguous;          /* cells with 0.4 < |w| < 0.6 (holes)          */
} ohm_voxelize_report;

int ohm_voxelize(ohm_voxel_grid *out, ohm_voxelize_report *report, const ohm_mesh *mesh,
                 const ohm_voxelize_params *params, const ohm_log *log, ohm_error *err);

void ohm_voxel_grid_free(ohm_voxel_grid *g);

/* An object from a scalar field instead of a mesh (a CT's iso-surface): the
 * cells whose centre lies in the field's domain and whose value there is
 * >= threshold, on a grid laid out over the world box [lo, hi] like
 * ohm_voxelize's (dim / voxel / fit, margin).  The distance band is the
 * first-order estimate of the signed distance to that intersection,
 * max((T - f) / |grad f|, domain distance) (central differences at h), so
 * the surface level set and the smooth normals follow the iso-surface
 * between cell centres and the domain's faces where they cut it. */
typedef struct ohm_field {
    double (*value)(void *user, const double world[3]);
    /* signed distance, mm, from a point to where the field is defined
     * (negative inside); no cell outside is in the object.  NULL: the field
     * is defined everywhere. */
    double (*domain)(void *user, const double world[3]);
    void *user;
} ohm_field;
int ohm_voxelize_field(ohm_voxel_grid *out, const ohm_field *field, const double lo[3], const double hi[3],
                       double threshold, const ohm_voxelize_params *params, const ohm_log *log, ohm_error *err);

static inline size_t ohm_voxel_index(const ohm_voxel_grid *g, int32_t i, int32_t j, int32_t k)
{
    return (size_t)i + (size_t)g->dims[0] * ((size_t)j + (size_t)g->dims[1] * (size_t)k);
}

/* Unsigned distance from dense cell c's centre to the surface (mm): exact
 * within the band, +INFINITY beyond it; NaN when the grid has no band. */
static inline double ohm_voxel_dist(const ohm_voxel_grid *g, size_t c)
{
    if (!g->near.bits) return NAN;
    int64_t b = ohm_cell_index_of(&g->near, c);
    return b < 0 ? INFINITY : g->near_dist[b];
}

/* The inverse: (i,j,k) of a dense cell index. */
static inline void ohm_voxel_coords(const ohm_voxel_grid *g, int64_t cell, int32_t ijk[3])
{
    size_t c = (size_t)cell, nx = (size_t)g->dims[0], ny = (size_t)g->dims[1];
    ijk[0] = (int32_t)(c % nx);
    ijk[1] = (int32_t)((c / nx) % ny);
    ijk[2] = (int32_t)(c / (nx * ny));
}

/* Generalized winding number of the mesh at point q (exact, O(triangles)).
 * Used by tests to check the fast evaluation. */
double ohm_winding_number_exact(const ohm_mesh *mesh, const double q[3]);

#endif
