/* export_ply.c — see export_ply.h. */
#include "outputs/export_ply.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/output.h"

static const char *const channel_suffix[3] = {"_r", "_g", "_b"};

/* Weighted exitance around point p: cells within `radius` voxels (radius <= 0:
 * the nearest boundary cell).  Returns the number of cells used. */
static int gather(double *acc, const double p[3], const ohm_voxel_grid *g, const ohm_solution *sol,
                  const uint8_t *bnd, double *const exitance[], double radius)
{
    const double h = g->h;
    double q[3];
    int32_t lo[3], hi[3];
    for (int a = 0; a < 3; ++a) q[a] = (p[a] - g->origin[a]) / h;
    int channels = sol->channels, used = 0;
    for (int c = 0; c < channels; ++c) acc[c] = 0;

    if (radius > 0) {
        double wsum = 0;
        for (int a = 0; a < 3; ++a) {
            double l = floor(q[a] - radius), u = ceil(q[a] + radius);
            lo[a] = (int32_t)fmax(0, l);
            hi[a] = (int32_t)fmin(g->dims[a] - 1, u);
        }
        for (int32_t k = lo[2]; k <= hi[2]; ++k)
            for (int32_t j = lo[1]; j <= hi[1]; ++j)
                for (int32_t i = lo[0]; i <= hi[0]; ++i) {
                    int64_t u = ohm_network_unknown(&sol->net, ohm_voxel_index(g, i, j, k));
                    if (u < 0 || !bnd[u]) continue;
                    double dx = i - q[0], dy = j - q[1], dz = k - q[2];
                    double d = sqrt(dx * dx + dy * dy + dz * dz);
                    if (d > radius) continue;
                    double w = 1.0 / fmax(d, 1e-3);
                    for (int c = 0; c < channels; ++c)
                        acc[c] += w * exitance[c][u];
                    wsum += w;
                    ++used;
                }
        if (used)
            for (int c = 0; c < channels; ++c) acc[c] /= wsum;
        return used;
    }

    /* Nearest: search growing cubes until the best found is provably nearest. */
    int32_t maxdim = g->dims[0];
    if (g->dims[1] > maxdim) maxdim = g->dims[1];
    if (g->dims[2] > maxdim) maxdim = g->dims[2];
    for (int32_t R = 2;; R *= 2) {
        double best = INFINITY;
        int64_t bu = -1;
        for (int a = 0; a < 3; ++a) {
            double c0 = floor(q[a] + 0.5);
            lo[a] = (int32_t)fmax(0, c0 - R);
            hi[a] = (int32_t)fmin(g->dims[a] - 1, c0 + R);
        }
        for (int32_t k = lo[2]; k <= hi[2]; ++k)
            for (int32_t j = lo[1]; j <= hi[1]; ++j)
                for (int32_t i = lo[0]; i <= hi[0]; ++i) {
                    int64_t u = ohm_network_unknown(&sol->net, ohm_voxel_index(g, i, j, k));
                    if (u < 0 || !bnd[u]) continue;
                    double dx = i - q[0], dy = j - q[1], dz = k - q[2];
                    double d = dx * dx + dy * dy + dz * dz;
                    if (d < best) best = d, bu = u;
                }
        if (bu >= 0 && (sqrt(best) <= R - 1 || R > 2 * maxdim)) {
            for (int c = 0; c < channels; ++c)
                acc[c] = exitance[c][bu];
            return 1;
        }
        if (R > 2 * maxdim) return 0;
    }
}

int ohm_vertex_exitance(float **out, const ohm_mesh *mesh, const ohm_voxel_grid *grid, const ohm_solution *sol,
                        int frame, ohm_error *err)
{
    *out = NULL;
    if (frame < 0 || frame >= sol->frames)
        return ohm_fail(err, OHM_ERR_INVALID, "frame %d out of range: the solution has %d frame(s)", frame + 1,
                        sol->frames);
    if (!sol->net.unknowns.bits || sol->n <= 0)
        return ohm_fail(err, OHM_ERR_INVALID, "the solution has no interior cells");
    int channels = sol->channels;
    uint8_t *bnd = calloc((size_t)sol->n, 1);
    float *v = malloc((mesh->nverts ? mesh->nverts : 1) * (size_t)channels * sizeof *v);
    double *exitance[OHM_MAX_CHANNELS] = {NULL}; /* per unknown, this frame */
    int no_exitance = 0;
    for (int c = 0; c < channels; ++c) {
        exitance[c] = malloc((size_t)sol->n * sizeof *exitance[c]);
        if (exitance[c]) ohm_solution_exitance_frame(exitance[c], sol, c, frame);
        else no_exitance = 1;
    }
    if (!bnd || !v || no_exitance) {
        free(bnd);
        free(v);
        for (int c = 0; c < channels; ++c) free(exitance[c]);
        return ohm_fail(err, OHM_ERR_NOMEM, "out of memory for %zu vertices", mesh->nverts);
    }
    for (int64_t f = 0; f < sol->net.nfaces; ++f) bnd[sol->net.face_unknown[f]] = 1;
    for (size_t i = 0; i < mesh->nverts; ++i) {
        double acc[OHM_MAX_CHANNELS];
        const double *p = mesh->verts + 3 * i;
        if (!gather(acc, p, grid, sol, bnd, exitance, 1.5)) {
            if (!gather(acc, p, grid, sol, bnd, exitance, 0))
                for (int c = 0; c < channels; ++c) acc[c] = 0;
        }
        for (int c = 0; c < channels; ++c) v[i * (size_t)channels + (size_t)c] = (float)acc[c];
    }
    free(bnd);
    for (int c = 0; c < channels; ++c) free(exitance[c]);
    *out = v;
    return OHM_OK;
}

static int cmp_float(const void *a, const void *b)
{
    float x = *(const float *)a, y = *(const float *)b;
    return (x > y) - (x < y);
}

static double srgb(double x)
{
    if (!(x > 0)) return 0;
    if (x >= 1) return 1;
    return x <= 0.0031308 ? 12.92 * x : 1.055 * pow(x, 1 / 2.4) - 0.055;
}

static void put_u32(unsigned char *b, uint32_t x)
{
    for (int i = 0; i < 4; ++i) b[i] = (unsigned char)(x >> (8 * i));
}

static void put_f32(unsigned char *b, float f)
{
    uint32_t x;
    memcpy(&x, &f, 4);
    put_u32(b, x);
}

int ohm_export_ply(const char *path, const ohm_mesh *mesh, const ohm_voxel_grid *grid, const ohm_solution *sol,
                   int frame, double exposure, double *exposure_used, ohm_output_batch *batch, ohm_error *err)
{
    if (mesh->nverts > (size_t)INT32_MAX)
        return ohm_fail(err, OHM_ERR_INVALID, "%s: %zu vertices are too many for PLY int indices", path,
                        mesh->nverts);
    float *ex;
    int rc = ohm_vertex_exitance(&ex, mesh, grid, sol, frame, err);
    if (rc) return rc;
    int channels = sol->channels;
    size_t m = mesh->nverts * (size_t)channels;

    if (!(exposure > 0)) {
        /* auto: the 99th percentile of the vertex exitance maps to 1 */
        float *sorted = malloc((m ? m : 1) * sizeof *sorted);
        if (!sorted) {
            free(ex);
            return ohm_fail(err, OHM_ERR_NOMEM, "out of memory for %zu vertices", mesh->nverts);
        }
        if (m) memcpy(sorted, ex, m * sizeof *sorted);
        qsort(sorted, m, sizeof *sorted, cmp_float);
        double p99 = m ? sorted[(size_t)floor(0.99 * (double)(m - 1))] : 0;
        if (!(p99 > 0) && m) p99 = sorted[m - 1];
        free(sorted);
        exposure = p99 > 0 ? 1.0 / p99 : 1.0;
    }
    if (exposure_used) *exposure_used = exposure;

    ohm_output out;
    rc = ohm_output_begin(&out, path, batch, err);
    if (rc) {
        free(ex);
        return rc;
    }
    FILE *f = out.stream;
    fprintf(f, "ply\nformat binary_little_endian 1.0\n");
    fprintf(f, "comment ohm exitance (W/mm^2) interpolated from boundary cells, frame %d, units mm\n", frame + 1);
    fprintf(f, "comment ohm exposure %.9g (colour = sRGB(clamp(exitance * exposure)))\n", exposure);
    fprintf(f, "element vertex %zu\nproperty float x\nproperty float y\nproperty float z\n", mesh->nverts);
    if (channels == 1) fprintf(f, "property float exitance\n");
    else
        for (int c = 0; c < channels; ++c) fprintf(f, "property float exitance%s\n", channel_suffix[c]);
    fprintf(f, "property uchar red\nproperty uchar green\nproperty uchar blue\n");
    fprintf(f, "element face %zu\nproperty list uchar int vertex_indices\nend_header\n", mesh->ntris);

    unsigned char rec[64];
    for (size_t i = 0; i < mesh->nverts; ++i) {
        size_t o = 0;
        for (int a = 0; a < 3; ++a, o += 4) put_f32(rec + o, (float)mesh->verts[3 * i + (size_t)a]);
        const float *e = ex + i * (size_t)channels;
        for (int c = 0; c < channels; ++c, o += 4) put_f32(rec + o, e[c]);
        for (int c = 0; c < 3; ++c) {
            double lin = (double)e[channels == 1 ? 0 : c] * exposure;
            rec[o++] = (unsigned char)lround(255.0 * srgb(lin));
        }
        fwrite(rec, 1, o, f);
    }
    for (size_t t = 0; t < mesh->ntris; ++t) {
        rec[0] = 3;
        for (int a = 0; a < 3; ++a) put_u32(rec + 1 + 4 * a, (uint32_t)mesh->tris[3 * t + (size_t)a]);
        fwrite(rec, 1, 13, f);
    }
    free(ex);
    if (ferror(f)) {
        ohm_output_abort(&out);
        return ohm_fail(err, OHM_ERR_IO, "cannot write '%s'", path);
    }
    return ohm_output_commit(&out, err);
}
