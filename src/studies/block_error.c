/* studies/block_error.c — block-averaged fluence against Monte Carlo
 * (block_error.h). */
#include "studies/block_error.h"

#include <math.h>

/* One block's sums: diffusion's, the Monte Carlo's and its variance; 0 when
 * keep refuses one of its cells. */
static int block_sums(const ohm_solution *d, const ohm_solution *mc, const int lo[3], int b, ohm_block_keep keep,
                      const void *user, double *sd, double *sm, double *var)
{
    const ohm_voxel_grid *g = d->net.grid;
    *sd = *sm = *var = 0;
    for (int k = lo[2]; k < lo[2] + b; ++k)
        for (int j = lo[1]; j < lo[1] + b; ++j)
            for (int i = lo[0]; i < lo[0] + b; ++i) {
                int64_t v = ohm_network_unknown(&d->net, ohm_voxel_index(g, i, j, k));
                if (!keep(user, i, j, k, v)) return 0;
                *sd += d->fluence[0][v];
                *sm += mc->fluence[0][v];
                *var += mc->fluence_se[0][v] * mc->fluence_se[0][v];
            }
    return 1;
}

ohm_block_error ohm_block_error_of(const ohm_solution *d, const ohm_solution *mc, const int dims[3], int b,
                                   double max_noise, ohm_block_keep keep, const void *user)
{
    ohm_block_error e = {0, 0, 0, 0, 0};
    double sum_abs = 0, sum2 = 0, sum = 0, noise2 = 0;
    if (b < 1) b = 1;
    for (int k0 = 1; k0 + b - 1 <= dims[2]; k0 += b)
        for (int j0 = 1; j0 + b - 1 <= dims[1]; j0 += b)
            for (int i0 = 1; i0 + b - 1 <= dims[0]; i0 += b) {
                const int lo[3] = {i0, j0, k0};
                double sd, sm, var;
                if (!block_sums(d, mc, lo, b, keep, user, &sd, &sm, &var)) continue;
                if (!(sm > 0) || !(sqrt(var) < max_noise * sm)) continue;
                double r = sd / sm - 1.0;
                sum_abs += fabs(r);
                sum2 += r * r;
                sum += r;
                noise2 += var / (sm * sm);
                e.blocks++;
            }
    if (e.blocks) {
        e.mean_abs = sum_abs / (double)e.blocks;
        e.rms = sqrt(sum2 / (double)e.blocks);
        e.bias = sum / (double)e.blocks;
        e.mc_noise = sqrt(noise2 / (double)e.blocks);
    } else {
        e.mean_abs = e.rms = e.bias = e.mc_noise = NAN;
    }
    return e;
}
