/* block_medium.h — the scale study's block medium (scripts/scale.sh,
 * docs/scale.md, docs/multigrid.md, docs/gpu.md): nx^3 cells of 1 mm in blocks of
 * block^3, each sigma_s' 1 or 1e6 at random (p = 1/2: both phases
 * percolate, a maze of conductances 1e6 apart; a checkerboard's blocks
 * touch only at edges and are no test).  What the benchmarks (`ohm bench
 * device=`, bench_mg, ohm-gpu-bench) and the multigrid's tests solve. */
#ifndef OHM_STUDIES_BLOCK_MEDIUM_H
#define OHM_STUDIES_BLOCK_MEDIUM_H

#include <stdint.h>

#include "grid/voxelize.h"
#include "physics/network.h"

/* A deterministic uniform number in [0, 1) (a 64-bit LCG, Knuth's MMIX
 * constants), for reproducible media and right-hand sides. */
static inline double ohm_lcg(uint64_t *s)
{
    *s = *s * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(*s >> 11) / 9007199254740992.0;
}

/* An empty d^3 grid of cells h (inside all 0); 0, or -1 out of memory. */
int ohm_cube_grid(ohm_voxel_grid *g, int d, double h);

/* g->interior_cells from g->inside. */
void ohm_grid_count_inside(ohm_voxel_grid *g);

/* The block medium on a full nx^3 grid: *ss (malloc'd) sigma_s' per cell
 * in cell order; 0, or -1 out of memory. */
int ohm_block_medium_grid(ohm_voxel_grid *g, int nx, ohm_coeff **ss, int block);

/* A medium of per-cell sigma_s' ss (1 /mm where NULL), sigma_a (1/mm), index 1.4. */
void ohm_block_medium(ohm_channel_medium *med, const ohm_coeff *ss, double sigma_a);

/* The held-in family of media that multigrid's iterations are measured on
 * (docs/multigrid.md, "Any medium"): full nx^3 grids of 1 mm cells, sigma_a
 * 0.001 /mm unless said otherwise, made deterministically (ohm_lcg):
 *  - BLOCKS2/4/9/16: random 8^3 blocks whose sigma_s' takes 2, 4, 9 or 16
 *    levels spread evenly in the logarithm over 1 .. 1e6, each level equally
 *    likely; BLOCKS9's sigma_a rises with its level over 1e-3 .. 1 (a
 *    transfer function through random densities: 1e3 in sigma_a).  The
 *    blocks are ohm_block_medium_grid's draws moved by 3 cells along each
 *    axis (their faces between cells 8m + 2 and 8m + 3): a face then cuts
 *    a 2x2x2 block of mg's hierarchy at every level, as a medium made
 *    without the hierarchy in mind does (block_medium's own faces fall
 *    between 8-cell blocks, which the first three levels never straddle);
 *  - GRADIENT: sigma_s' 10^(6 t), t = (i + j + k) / (3 (nx - 1)): smooth,
 *    1e6 from corner to corner;
 *  - SHELLS: three concentric spherical shells of sigma_s' 1e6, one, two and
 *    one cells thick at every size (a skull's thin hard layers), in a soft
 *    interior of sigma_s' 1 (sigma_a 0.01);
 *  - CHECKER: sigma_s' 1 and 1e6 alternating cell by cell in all three axes;
 *  - CLEAR: tissue (sigma_s' 1, sigma_a 0.01) holding a 2 mm shell and a
 *    ventricle-like ball of clear fluid (sigma_s' 1e-3, sigma_a 1e-4), as a
 *    head's CSF. */
typedef enum ohm_family_medium {
    OHM_FAMILY_BLOCKS2,
    OHM_FAMILY_BLOCKS4,
    OHM_FAMILY_BLOCKS9,
    OHM_FAMILY_BLOCKS16,
    OHM_FAMILY_GRADIENT,
    OHM_FAMILY_SHELLS,
    OHM_FAMILY_CHECKER,
    OHM_FAMILY_CLEAR,
    OHM_FAMILY_COUNT
} ohm_family_medium;

/* The medium's name ("blocks9", "shells", ...), or NULL out of range. */
const char *ohm_family_medium_name(ohm_family_medium which);

/* ohm_family_medium_name's inverse; -1 for an unknown name. */
int ohm_family_medium_of(const char *name);

/* Medium `which` on a full nx^3 grid: *ss and *sa (malloc'd) sigma_s' and
 * sigma_a per cell in cell order; 0, or -1 out of memory. */
int ohm_family_medium_grid(ohm_voxel_grid *g, int nx, ohm_family_medium which, ohm_coeff **ss, ohm_coeff **sa);

#endif
