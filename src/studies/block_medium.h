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

#endif
