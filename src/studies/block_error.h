/* block_error.h — a diffusion fluence against a Monte Carlo one, in blocks
 * of b^3 cells (both fields summed over the block): per cell, a Monte Carlo
 * estimate precise to 1% would take ~10^8 photons, and diffusion varies on
 * the scale of 1/sigma_tr, not of a cell (docs/transport.md).  What
 * `ohm validate transport` and the clear-region tests and bench compare. */
#ifndef OHM_STUDIES_BLOCK_ERROR_H
#define OHM_STUDIES_BLOCK_ERROR_H

#include <stdint.h>

#include "solvers/solve.h"

typedef struct ohm_block_error {
    double mean_abs, rms, bias; /* of d / mc - 1 over the blocks kept */
    double mc_noise;            /* the Monte Carlo's rms relative standard error there */
    int64_t blocks;
} ohm_block_error;

/* Whether cell (i, j, k) (1-based, as ohm_voxel_index) whose unknown is v
 * may be in a compared block: a block counts only when all its cells may. */
typedef int (*ohm_block_keep)(const void *user, int i, int j, int k, int64_t v);

/* The blocks of b^3 cells tiling [1, dims] of d's grid (channel 0), each
 * kept when keep allows all its cells and the Monte Carlo's standard error
 * of its sum is below max_noise of the sum; NaNs when none is kept. */
ohm_block_error ohm_block_error_of(const ohm_solution *d, const ohm_solution *mc, const int dims[3], int b,
                                   double max_noise, ohm_block_keep keep, const void *user);

#endif
