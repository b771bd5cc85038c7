/* studies/block_medium.c — see block_medium.h. */
#include "studies/block_medium.h"

#include <math.h>
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

static const char *const family_names[OHM_FAMILY_COUNT] = {"blocks2", "blocks4", "blocks9", "blocks16",
                                                           "gradient", "shells", "checker", "clear"};

const char *ohm_family_medium_name(ohm_family_medium which)
{
    return (unsigned)which < OHM_FAMILY_COUNT ? family_names[which] : NULL;
}

int ohm_family_medium_of(const char *name)
{
    for (int q = 0; q < OHM_FAMILY_COUNT; ++q)
        if (strcmp(name, family_names[q]) == 0) return q;
    return -1;
}

/* Random 8^3 blocks of `levels` levels, as ohm_block_medium_grid draws its
 * two (the same seed and draws: level levels-1 where it draws 1e6), moved
 * by SHIFT cells so that their faces cut the hierarchy's blocks at every
 * level (block_medium.h). */
static int imax(int a, int b) { return a > b ? a : b; }

static void family_blocks(int nx, int levels, int spread_sigma_a, ohm_coeff *ss, ohm_coeff *sa)
{
    enum { BLOCK = 8, SHIFT = 3 };
    int nb = (nx + SHIFT + BLOCK - 1) / BLOCK;
    uint64_t seed = 12;
    int64_t nblocks = (int64_t)nb * nb * nb;
    for (int64_t q = 0; q < nblocks; ++q) {
        int level = levels - 1 - (int)(ohm_lcg(&seed) * levels);
        double t = (double)level / (levels - 1);
        double s = pow(10.0, 6.0 * t), a = spread_sigma_a ? 1e-3 * pow(10.0, 3.0 * t) : 1e-3;
        int bi = (int)(q % nb), bj = (int)(q / nb % nb), bk = (int)(q / nb / nb);
        for (int k = imax(bk * BLOCK - SHIFT, 0); k < nx && k < (bk + 1) * BLOCK - SHIFT; ++k)
            for (int j = imax(bj * BLOCK - SHIFT, 0); j < nx && j < (bj + 1) * BLOCK - SHIFT; ++j)
                for (int i = imax(bi * BLOCK - SHIFT, 0); i < nx && i < (bi + 1) * BLOCK - SHIFT; ++i) {
                    int64_t v = i + (int64_t)nx * (j + (int64_t)nx * k);
                    ss[v] = (ohm_coeff)s;
                    sa[v] = (ohm_coeff)a;
                }
    }
}

/* Distance of cell (i, j, k)'s centre from the grid's centre, in cells. */
static double family_radius(int nx, int i, int j, int k)
{
    double c = 0.5 * (nx - 1), x = i - c, y = j - c, z = k - c;
    return sqrt(x * x + y * y + z * z);
}

/* In the shell r in [r0, r0 + thick): a shell one cell thick or more cannot
 * be crossed by a face step, which changes r by at most 1. */
static int in_shell(double r, double r0, double thick)
{
    return r >= r0 && r < r0 + thick;
}

static void family_cell(ohm_family_medium which, int nx, int i, int j, int k, ohm_coeff *s, ohm_coeff *a)
{
    double r = family_radius(nx, i, j, k);
    switch (which) {
    case OHM_FAMILY_GRADIENT:
        *s = (ohm_coeff)pow(10.0, 6.0 * (i + j + k) / (3.0 * (nx - 1)));
        *a = 1e-3f;
        return;
    case OHM_FAMILY_SHELLS: {
        int hard = in_shell(r, 0.45 * nx, 1) || in_shell(r, 0.35 * nx, 2) || in_shell(r, 0.25 * nx, 1);
        *s = hard ? 1e6f : 1.0f;
        *a = 1e-2f;
        return;
    }
    case OHM_FAMILY_CHECKER:
        *s = (i + j + k) & 1 ? 1e6f : 1.0f;
        *a = 1e-3f;
        return;
    case OHM_FAMILY_CLEAR: {
        int clear = in_shell(r, 0.4 * nx, 2) || r < 0.1 * nx;
        *s = clear ? 1e-3f : 1.0f;
        *a = clear ? 1e-4f : 1e-2f;
        return;
    }
    default: *s = 1.0f, *a = 1e-3f; return;
    }
}

int ohm_family_medium_grid(ohm_voxel_grid *g, int nx, ohm_family_medium which, ohm_coeff **ss, ohm_coeff **sa)
{
    *ss = *sa = NULL;
    if ((unsigned)which >= OHM_FAMILY_COUNT || nx < 2 || ohm_cube_grid(g, nx, 1.0)) return -1;
    size_t cells = (size_t)nx * nx * nx;
    memset(g->inside, 1, cells);
    ohm_grid_count_inside(g);
    *ss = malloc(cells * sizeof **ss);
    *sa = malloc(cells * sizeof **sa);
    if (!*ss || !*sa) {
        free(*ss), free(*sa);
        *ss = *sa = NULL;
        ohm_voxel_grid_free(g);
        return -1;
    }
    static const int levels[] = {2, 4, 9, 16};
    if (which <= OHM_FAMILY_BLOCKS16) {
        family_blocks(nx, levels[which], which == OHM_FAMILY_BLOCKS9, *ss, *sa);
        return 0;
    }
    int64_t v = 0;
    for (int k = 0; k < nx; ++k)
        for (int j = 0; j < nx; ++j)
            for (int i = 0; i < nx; ++i, ++v) family_cell(which, nx, i, j, k, &(*ss)[v], &(*sa)[v]);
    return 0;
}
