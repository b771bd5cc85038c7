/* studies/block_medium.c — see block_medium.h. */
#include "studies/block_medium.h"

#include <stdlib.h>
#include <string.h>

int ohm_cube_grid(ohm_voxel_grid *g, int d, double h)
{
    memset(g, 0, sizeof *g);
    g->dims[0] = g->dims[1] = g->dims[2] = d;
    g->h = h;
    g->inside = calloc((size_t)d * d * d, 1);
    return g->inside ? 0 : -1;
}

void ohm_grid_count_inside(ohm_voxel_grid *g)
{
    size_t cells = (size_t)g->dims[0] * g->dims[1] * g->dims[2];
    g->interior_cells = 0;
    for (size_t c = 0; c < cells; ++c) g->interior_cells += g->inside[c];
}

int ohm_block_medium_grid(ohm_voxel_grid *g, int nx, ohm_coeff **ss, int block)
{
    if (ohm_cube_grid(g, nx, 1.0)) return -1;
    memset(g->inside, 1, (size_t)nx * nx * nx);
    ohm_grid_count_inside(g);
    int nb = (nx + block - 1) / block;
    uint8_t *hard = malloc((size_t)nb * nb * nb);
    *ss = malloc((size_t)nx * nx * nx * sizeof **ss);
    if (!*ss || !hard) {
        free(hard);
        free(*ss);
        *ss = NULL;
        ohm_voxel_grid_free(g);
        return -1;
    }
    uint64_t seed = 12;
    for (int q = 0; q < nb * nb * nb; ++q) hard[q] = ohm_lcg(&seed) < 0.5;
    int64_t v = 0;
    for (int k = 0; k < nx; ++k)
        for (int j = 0; j < nx; ++j)
            for (int i = 0; i < nx; ++i)
                (*ss)[v++] = hard[i / block + nb * (j / block + nb * (k / block))] ? 1e6f : 1.0f;
    free(hard);
    return 0;
}

void ohm_block_medium(ohm_channel_medium *med, const ohm_coeff *ss, double sigma_a)
{
    memset(med, 0, sizeof *med);
    med->sigma_a0 = sigma_a;
    med->sigma_s0 = 1.0;
    med->sigma_s = ss;
    med->eta = 1.4;
}
