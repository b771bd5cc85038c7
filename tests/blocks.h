/* blocks.h — the block medium's stencil for the multigrid's tests and
 * benchmarks (test_mg.c, test_mg_device.c, bench_mg.c); the grid, the
 * medium and the random numbers are studies/block_medium.h's. */
#ifndef OHM_TESTS_BLOCKS_H
#define OHM_TESTS_BLOCKS_H

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "grid/voxelize.h"
#include "physics/network.h"
#include "studies/block_medium.h"

/* The network of g and its stencil for ohm_block_medium(ss, sigma_a) under the
 * robin boundary; 0, or -1 with err set. */
static inline int block_stencil(ohm_network *net, ohm_stencil *st, const ohm_voxel_grid *g, const ohm_coeff *ss,
                                double sigma_a, ohm_error *err)
{
    ohm_channel_medium med;
    ohm_block_medium(&med, ss, sigma_a);
    memset(st, 0, sizeof *st);
    if (ohm_network_build(net, g, NULL, err)) return -1;
    return ohm_network_stencil(st, NULL, NULL, net, &med, OHM_BOUNDARY_ROBIN, err) ? -1 : 0;
}

#endif
