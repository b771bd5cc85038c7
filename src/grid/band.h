/* band.h — stage: model only the depth light reaches.
 *
 * Diffuse light entering a surface decays like e^(-sigma_tr z) with depth z
 * (docs/design.md §3), so cells deeper than k / sigma_tr below every surface
 * carry ~e^-k of the fluence there and nothing that leaves the object.  The
 * depth band keeps only the interior cells within that depth as unknowns; the
 * faces between the band and the dropped core get a closure (network.c): the
 * core is treated as an absorbing half-space, whose exact flux for the
 * decaying solution is J = D sigma_tr phi. */
#ifndef OHM_BAND_H
#define OHM_BAND_H

#include <stdint.h>

#include "base/ohm_error.h"
#include "grid/voxelize.h"

/* Depth of every cell below the object's surface (mm): the Euclidean distance
 * from its centre to the nearest cell outside the object, less half a cell
 * (so a cell with an outside face neighbour has depth h/2); 0 outside.
 * Exact Euclidean distance transform (Felzenszwalb & Huttenlocher 2012,
 * "Distance transforms of sampled functions"), O(cells). */
int ohm_cell_depth(float **depth, const ohm_voxel_grid *g, ohm_error *err);

/* active[c] = inside and depth <= max_depth; *kept = how many. */
int ohm_depth_band(uint8_t **active, int64_t *kept, const ohm_voxel_grid *g, double max_depth, ohm_error *err);

#endif
