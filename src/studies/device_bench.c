/* studies/device_bench.c — see device_bench.h. */
#include "studies/device_bench.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "base/log.h"
#include "physics/mc_trace.h"
#include "solvers/grid_order.h"
#include "solvers/mg.h"
#include "solvers/mg_device.h"
#include "studies/block_medium.h"

void ohm_device_bench_mg_header(FILE *out)
{
    fprintf(out, "| grid | cells | set-up on the host (s) | host solve (s) | device | copy to the device (s) | device "
                 "memory (MiB) | device solve (s) | host / device | largest difference / peak |\n");
    fprintf(out, "|---|---:|---:|---:|---|---:|---:|---:|---:|---:|\n");
}

int ohm_device_bench_mg(FILE *out, const ohm_device_request *req, int nx, ohm_error *err)
{
    char spec[32];
    ohm_device_request_name(req, spec, sizeof spec);
    ohm_voxel_grid g;
    ohm_coeff *ss = NULL;
    if (ohm_block_medium_grid(&g, nx, &ss, 8)) return ohm_fail(err, OHM_ERR_NOMEM, "bench: out of memory for %d^3", nx);
    ohm_channel_medium med;
    ohm_block_medium(&med, ss, 0.001);
    ohm_network net;
    memset(&net, 0, sizeof net);
    ohm_stencil st = {0};
    ohm_mg *mg = NULL;
    ohm_mg_device *dev = NULL;
    double *b = NULL, *xh = NULL, *xd = NULL;
    int rc = ohm_network_build(&net, &g, NULL, err);
    if (!rc) rc = ohm_network_stencil(&st, NULL, NULL, &net, &med, OHM_BOUNDARY_ROBIN, err);
    int64_t n = net.n, its_h = 0, its_d = 0;
    double relres = 0, t_setup = 0, t_copy = 0, t_host = 0, t_dev = 0;
    if (!rc) {
        b = malloc((size_t)n * sizeof *b), xh = calloc((size_t)n, sizeof *xh), xd = calloc((size_t)n, sizeof *xd);
        if (!b || !xh || !xd) rc = ohm_fail(err, OHM_ERR_NOMEM, "bench: out of memory for %d^3", nx);
    }
    if (!rc) {
        uint64_t seed = 3;
        for (int64_t v = 0; v < n; ++v) b[v] = ohm_lcg(&seed);
        ohm_grid_layout layout = ohm_grid_layout_of(&net);
        double t0 = ohm_now();
        rc = ohm_mg_setup(&mg, &st, &layout, 0, err);
        t_setup = ohm_now() - t0;
    }
    if (!rc) {
        double t0 = ohm_now();
        rc = ohm_mg_device_open(&dev, mg, req, NULL, err);
        t_copy = ohm_now() - t0;
        if (!rc && !dev) rc = ohm_fail(err, OHM_ERR_INVALID, "device=%s: no device (the host would run it)", spec);
    }
    if (!rc) {
        double t0 = ohm_now();
        rc = ohm_mg_solve(mg, xh, b, 1e-10, 500, NULL, &its_h, &relres, err);
        t_host = ohm_now() - t0;
    }
    if (!rc) {
        double t0 = ohm_now();
        rc = ohm_mg_device_solve(dev, xd, b, 1e-10, 500, NULL, &its_d, &relres, err);
        t_dev = ohm_now() - t0;
    }
    if (!rc) {
        double diff = 0, peak = 0;
        for (int64_t v = 0; v < n; ++v) {
            diff = fmax(diff, fabs(xd[v] - xh[v]));
            peak = fmax(peak, fabs(xh[v]));
        }
        fprintf(out, "| %d^3 | %.3g | %.2f | %.2f (%lld its) | %s | %.2f | %.0f | %.2f (%lld its) | %.2f | %.1e |\n",
                nx, (double)n, t_setup, t_host, (long long)its_h, ohm_mg_device_name(dev), t_copy,
                ohm_mg_device_bytes(dev) / (1 << 20), t_dev, (long long)its_d, t_host / t_dev, diff / peak);
        fflush(out);
    }
    ohm_mg_device_free(dev);
    ohm_mg_free(mg);
    ohm_stencil_free(&st);
    if (net.n) ohm_network_free(&net);
    free(b), free(xh), free(xd);
    ohm_voxel_grid_free(&g);
    free(ss);
    return rc;
}

void ohm_device_bench_mc_header(FILE *out)
{
    fprintf(out, "| where | photons | seconds (with the set-up) | photons/ms | absorbed (MCX: 17.69708%%) | "
                 "(ours - MCX) / se |\n");
    fprintf(out, "|---|---:|---:|---:|---:|---:|\n");
}

/* cube60's one light entry: a pencil beam entering the top face at
 * x = y = 29 mm, voxel coordinate 29 / h + 0.5 = 29.5 -> cell 30 (the
 * padding is cell 0), as validate_transport.c's row has it through
 * ohm_light_entries_add. */
static int cube60_entry(ohm_light_entry *e, const ohm_network *net, const ohm_voxel_grid *g, int n, ohm_error *err)
{
    memset(e, 0, sizeof *e);
    int64_t v = ohm_network_unknown(net, ohm_voxel_index(g, 30, 30, n));
    e->face = v >= 0 ? ohm_network_face(net, v, 5) : -1;
    e->incident[0] = e->power[0] = 1.0;
    e->dir[2] = -1.0;
    e->point[0] = e->point[1] = 29.0;
    e->point[2] = n * g->h;
    e->mu = 1.0;
    e->at_point = 1;
    return e->face < 0 ? ohm_fail(err, OHM_ERR_INTERNAL, "cube60: no top face at the beam") : OHM_OK;
}

int ohm_device_bench_cube60(FILE *out, const ohm_device_request *req, int64_t photons, uint64_t seed, ohm_error *err)
{
    enum { N = 60 };
    ohm_voxel_grid g;
    if (ohm_cube_grid(&g, N + 2, 1.0)) return ohm_fail(err, OHM_ERR_NOMEM, "bench: out of memory for cube60");
    g.band = g.h;
    for (int a = 0; a < 3; ++a) g.origin[a] = -0.5 * g.h;
    for (int k = 1; k <= N; ++k)
        for (int j = 1; j <= N; ++j)
            for (int i = 1; i <= N; ++i) g.inside[ohm_voxel_index(&g, i, j, k)] = 1;
    ohm_grid_count_inside(&g);
    ohm_network net;
    memset(&net, 0, sizeof net);
    int rc = ohm_network_build(&net, &g, NULL, err);
    size_t n = (size_t)net.n, nf = (size_t)net.nfaces;
    double *phi = calloc(n, 8), *phi_se = calloc(n, 8), *face = calloc(nf, 8), *exit_se = calloc(n, 8);
    if (!rc && (!phi || !phi_se || !face || !exit_se)) rc = ohm_fail(err, OHM_ERR_NOMEM, "bench: out of memory");
    ohm_light_entry e;
    if (!rc) rc = cube60_entry(&e, &net, &g, N, err);
    ohm_channel_medium med;
    memset(&med, 0, sizeof med);
    med.sigma_a0 = 0.005;
    med.sigma_s0 = 1.0 * (1 - 0.01);
    med.g = 0.01;
    med.eta = 1.0;
    ohm_mc_result r = {.fluence = phi, .fluence_se = phi_se, .face_exitance = face, .exitance_se = exit_se};
    ohm_mc_params p = {.photons = photons, .seed = seed, .max_path = 5.0 * 299.792458 / 1.37};
    if (req) p.device = *req;
    if (!rc) rc = ohm_mc_trace(&r, &net, &med, &e, 1, 0, &p, err);
    if (!rc) {
        char where[128];
        if (r.device[0]) snprintf(where, sizeof where, "%s", r.device);
        else snprintf(where, sizeof where, "host, %d threads", r.threads);
        double a = r.power_absorbed / r.power_in, se = r.power_absorbed_se / r.power_in;
        fprintf(out, "| %s | %.3g | %.2f | %.0f | %.4f%% ± %.4f%% | %+.1f |\n", where, (double)r.photons, r.seconds,
                1e-3 * (double)r.photons / r.seconds, 100 * a, 100 * se, (a - 0.1769708) / se);
        fflush(out);
    }
    free(phi), free(phi_se), free(face), free(exit_se);
    if (net.n) ohm_network_free(&net);
    ohm_voxel_grid_free(&g);
    return rc;
}
