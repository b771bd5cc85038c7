/* blocks.h — grids for the multigrid's test and benchmark (test_mg.c,
 * bench_mg.c): a deterministic random number, an empty cubic grid, the
 * scale study's block medium, and a medium over it. */
#ifndef OHM_TESTS_BLOCKS_H
#define OHM_TESTS_BLOCKS_H

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "grid/voxelize.h"
#include "physics/network.h"

static double lcg(uint64_t *s) /* deterministic [0, 1) */
{
    *s = *s * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(*s >> 11) / 9007199254740992.0;
}

static int grid_alloc(ohm_voxel_grid *g, int d, double h)
{
    memset(g, 0, sizeof *g);
    g->dims[0] = g->dims[1] = g->dims[2] = d;
    g->h = h;
    g->inside = calloc((size_t)d * d * d, 1);
    return g->inside ? 0 : -1;
}

static void count_inside(ohm_voxel_grid *g)
{
    size_t cells = (size_t)g->dims[0] * g->dims[1] * g->dims[2];
    g->interior_cells = 0;
    for (size_t c = 0; c < cells; ++c) g->interior_cells += g->inside[c];
}

/* The scale study's block medium (scripts/scale.sh): nx^3 cells in blocks
 * of `block`^3, each sigma_s' 1 or 1e6 at random (p = 1/2: both phases
 * percolate, a maze of conductances 1e6 apart; a checkerboard's blocks
 * touch only at edges and are no test). */
static int make_blocks(ohm_voxel_grid *g, int nx, ohm_coeff **ss, int block)
{
    if (grid_alloc(g, nx, 1.0)) return -1;
    memset(g->inside, 1, (size_t)nx * nx * nx);
    count_inside(g);
    int nb = (nx + block - 1) / block;
    uint8_t *hard = malloc((size_t)nb * nb * nb);
    *ss = malloc((size_t)nx * nx * nx * sizeof **ss);
    if (!*ss || !hard) {
        free(hard);
        return -1;
    }
    uint64_t seed = 12;
    for (int q = 0; q < nb * nb * nb; ++q) hard[q] = lcg(&seed) < 0.5;
    int64_t v = 0;
    for (int k = 0; k < nx; ++k)
        for (int j = 0; j < nx; ++j)
            for (int i = 0; i < nx; ++i)
                (*ss)[v++] = hard[i / block + nb * (j / block + nb * (k / block))] ? 1e6f : 1.0f;
    free(hard);
    return 0;
}

/* A medium of per-cell sigma_s' ss (1 /mm where NULL), sigma_a (1/mm), index 1.4. */
static void block_medium(ohm_channel_medium *med, const ohm_coeff *ss, double sigma_a)
{
    memset(med, 0, sizeof *med);
    med->sigma_a0 = sigma_a;
    med->sigma_s0 = 1.0;
    med->sigma_s = ss;
    med->eta = 1.4;
}

/* The network of g and its stencil for block_medium(ss, sigma_a) under the
 * robin boundary; 0, or -1 with err set. */
static inline int block_stencil(ohm_network *net, ohm_stencil *st, const ohm_voxel_grid *g, const ohm_coeff *ss,
                                double sigma_a, ohm_error *err)
{
    ohm_channel_medium med;
    block_medium(&med, ss, sigma_a);
    memset(st, 0, sizeof *st);
    if (ohm_network_build(net, g, NULL, err)) return -1;
    return ohm_network_stencil(st, NULL, NULL, net, &med, OHM_BOUNDARY_ROBIN, err) ? -1 : 0;
}

#endif
