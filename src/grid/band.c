/* band.c — the depth band (band.h). */
#include "grid/band.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* One line of the squared distance transform: d[q] = min_p (q - p)^2 + f[p]
 * (Felzenszwalb & Huttenlocher, the lower envelope of parabolas).  v, z are
 * scratch of n and n + 1 entries. */
static void edt_line(const double *f, double *d, int64_t n, int64_t *v, double *z)
{
    int64_t k = 0;
    v[0] = 0;
    z[0] = -INFINITY;
    z[1] = INFINITY;
    for (int64_t q = 1; q < n; ++q) {
        if (isinf(f[q])) continue;
        for (;;) {
            if (isinf(f[v[k]])) { /* only an infinite parabola so far: replace it */
                v[k] = q;
                z[k] = -INFINITY;
                z[k + 1] = INFINITY;
                break;
            }
            double s = ((f[q] + (double)q * q) - (f[v[k]] + (double)v[k] * v[k])) / (2.0 * (double)(q - v[k]));
            if (s <= z[k] && k > 0) {
                --k;
                continue;
            }
            if (s <= z[k]) { /* k == 0 */
                v[0] = q;
                z[0] = -INFINITY;
                z[1] = INFINITY;
                break;
            }
            ++k;
            v[k] = q;
            z[k] = s;
            z[k + 1] = INFINITY;
            break;
        }
    }
    k = 0;
    for (int64_t q = 0; q < n; ++q) {
        while (z[k + 1] < (double)q) ++k;
        double dq = (double)(q - v[k]);
        d[q] = isinf(f[v[k]]) ? INFINITY : dq * dq + f[v[k]];
    }
}

int ohm_cell_depth(float **out, const ohm_voxel_grid *g, ohm_error *err)
{
    *out = NULL;
    int64_t nx = g->dims[0], ny = g->dims[1], nz = g->dims[2];
    size_t cells = (size_t)nx * (size_t)ny * (size_t)nz;
    int64_t longest = nx > ny ? (nx > nz ? nx : nz) : (ny > nz ? ny : nz);
    double *sq = malloc(cells * sizeof *sq);
    double *f = malloc((size_t)longest * sizeof *f), *d = malloc((size_t)longest * sizeof *d);
    double *z = malloc((size_t)(longest + 1) * sizeof *z);
    int64_t *v = malloc((size_t)longest * sizeof *v);
    float *depth = malloc(cells * sizeof *depth);
    if (!sq || !f || !d || !z || !v || !depth) {
        free(sq), free(f), free(d), free(z), free(v), free(depth);
        return ohm_fail(err, OHM_ERR_NOMEM, "band: out of memory for the depth of %zu cells", cells);
    }
    for (size_t c = 0; c < cells; ++c) sq[c] = g->inside[c] ? INFINITY : 0.0;
    /* separable: x lines, then y, then z, each on the previous result */
    const int64_t len[3] = {nx, ny, nz};
    const size_t stride[3] = {1, (size_t)nx, (size_t)nx * (size_t)ny};
    for (int a = 0; a < 3; ++a) {
        int b = (a + 1) % 3, e = (a + 2) % 3;
        for (int64_t jb = 0; jb < len[b]; ++jb)
            for (int64_t je = 0; je < len[e]; ++je) {
                size_t base = (size_t)jb * stride[b] + (size_t)je * stride[e];
                for (int64_t q = 0; q < len[a]; ++q) f[q] = sq[base + (size_t)q * stride[a]];
                edt_line(f, d, len[a], v, z);
                for (int64_t q = 0; q < len[a]; ++q) sq[base + (size_t)q * stride[a]] = d[q];
            }
    }
    for (size_t c = 0; c < cells; ++c)
        depth[c] = g->inside[c] ? (float)((sqrt(sq[c]) - 0.5) * g->h) : 0.0f;
    free(sq), free(f), free(d), free(z), free(v);
    *out = depth;
    return OHM_OK;
}

int ohm_depth_band(uint8_t **active, int64_t *kept, const ohm_voxel_grid *g, double max_depth, ohm_error *err)
{
    *active = NULL;
    *kept = 0;
    float *depth = NULL;
    int rc = ohm_cell_depth(&depth, g, err);
    if (rc) return rc;
    size_t cells = (size_t)g->dims[0] * (size_t)g->dims[1] * (size_t)g->dims[2];
    uint8_t *a = malloc(cells ? cells : 1);
    if (!a) {
        free(depth);
        return ohm_fail(err, OHM_ERR_NOMEM, "band: out of memory");
    }
    int64_t k = 0;
    for (size_t c = 0; c < cells; ++c) {
        a[c] = g->inside[c] && depth[c] <= max_depth;
        k += a[c];
    }
    free(depth);
    *active = a;
    *kept = k;
    return OHM_OK;
}
