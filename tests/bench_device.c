/* bench_device.c — solver=mg on an OpenCL device against the host (issue
 * 37, item 5): on the scale study's block medium (blocks of 8^3 cells,
 * sigma_s' 1 or 1e6 at random, sigma_a 0.001 /mm, robin boundary) at each
 * N^3, the hierarchy built once, then one light's solve to 1e-10 from zero
 * on the host's cores and on the device (the hierarchy copied there first,
 * timed apart), the device's answer against the host's, and the device's
 * triad.  Prints one Markdown row per N; asserts nothing (the suite's tests
 * check the answers: test_mg_device, test_mg_scenes).
 *
 * With `mc`: the Monte Carlo tracer on MCX's cube60 (60^3 cells of 1 mm,
 * sigma_a 0.005, sigma_s 1 /mm, g 0.01, a pencil beam at (29, 29) mm, no
 * reflection, a 5 ns gate: MCX's 17.69708%), PHOTONS on the device and
 * HOST_PHOTONS on the host's cores: photons per millisecond and the
 * absorbed fraction with its standard error, on each.
 *
 * Not a ctest: tests/CMakeLists.txt builds it as bench_device,
 * scripts/gpu-bench.sh runs it and writes docs/gpu.md.
 *
 *   bench_device DEVICE N...                        DEVICE: gpu, cpu, opencl:K or auto
 *   bench_device DEVICE mc PHOTONS [HOST_PHOTONS]   cube60 (HOST_PHOTONS: PHOTONS / 100, >= 10^5)
 *   bench_device devices                            what `ohm devices` prints
 *
 * Built twice: bench_device (with the tests) and ohm-gpu-bench, the same
 * program from only the sources it uses, which needs nothing but libc and
 * libm (libOpenCL.so.1 is loaded at run time) and so can be copied to a
 * GPU machine without ohm's packages (scripts/gpu-pack.sh). */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/log.h"
#include "blocks.h"
#include "device/devices.h"
#include "physics/mc.h"
#include "solvers/grid_order.h"
#include "solvers/mg.h"
#include "solvers/mg_device.h"
#include "studies/devices.h"

static int bench(const char *spec, int nx)
{
    ohm_voxel_grid g;
    ohm_coeff *ss = NULL;
    if (make_blocks(&g, nx, &ss, 8)) return 1;
    ohm_error err;
    ohm_error_clear(&err);
    ohm_channel_medium med;
    block_medium(&med, ss, 0.001);
    ohm_network net;
    ohm_stencil st = {0};
    ohm_mg *mg = NULL;
    ohm_mg_device *dev = NULL;
    double *b = NULL, *xh = NULL, *xd = NULL;
    int rc = 1;
    if (ohm_network_build(&net, &g, NULL, &err)) goto out_grid;
    if (ohm_network_stencil(&st, NULL, NULL, &net, &med, OHM_BOUNDARY_ROBIN, &err)) goto out;
    int64_t n = net.n, its_h = 0, its_d = 0;
    double relres = 0;
    b = malloc((size_t)n * sizeof *b), xh = calloc((size_t)n, sizeof *xh), xd = calloc((size_t)n, sizeof *xd);
    if (!b || !xh || !xd) goto out;
    uint64_t seed = 3;
    for (int64_t v = 0; v < n; ++v) b[v] = lcg(&seed);
    ohm_grid_layout layout = ohm_grid_layout_of(&net);
    double t0 = ohm_now();
    if (ohm_mg_setup(&mg, &st, &layout, 0, &err)) goto out;
    double t_setup = ohm_now() - t0;
    t0 = ohm_now();
    if (ohm_mg_device_open(&dev, mg, spec, NULL, &err)) goto out;
    double t_copy = ohm_now() - t0;
    if (!dev) {
        snprintf(err.msg, sizeof err.msg, "device=%s: no device (the host would run it)", spec);
        goto out;
    }
    t0 = ohm_now();
    if (ohm_mg_solve(mg, xh, b, 1e-10, 500, NULL, &its_h, &relres, &err)) goto out;
    double t_host = ohm_now() - t0;
    t0 = ohm_now();
    if (ohm_mg_device_solve(dev, xd, b, 1e-10, 500, NULL, &its_d, &relres, &err)) goto out;
    double t_dev = ohm_now() - t0;
    double diff = 0, peak = 0;
    for (int64_t v = 0; v < n; ++v) {
        diff = fmax(diff, fabs(xd[v] - xh[v]));
        peak = fmax(peak, fabs(xh[v]));
    }
    printf("| %d^3 | %.3g | %.2f | %.2f (%lld its) | %s | %.2f | %.0f | %.2f (%lld its) | %.2f | %.1e |\n", nx,
           (double)n, t_setup, t_host, (long long)its_h, ohm_mg_device_name(dev), t_copy,
           ohm_mg_device_bytes(dev) / (1 << 20), t_dev, (long long)its_d, t_host / t_dev, diff / peak);
    fflush(stdout);
    rc = 0;
out:
    if (rc) fprintf(stderr, "bench_device: %d^3: %s\n", nx, err.msg);
    ohm_mg_device_free(dev);
    ohm_mg_free(mg);
    ohm_stencil_free(&st);
    ohm_network_free(&net);
out_grid:
    free(b), free(xh), free(xd);
    ohm_voxel_grid_free(&g);
    free(ss);
    return rc;
}

/* MCX's cube60 (validate_transport.c's row, fangq/mcx src/mcx_bench.c)
 * traced on `spec` (NULL: the host's cores): one table row. */
static int cube60(const char *spec, int64_t photons)
{
    enum { N = 60 };
    ohm_voxel_grid g;
    ohm_network net;
    ohm_error err;
    ohm_error_clear(&err);
    if (grid_alloc(&g, N + 2, 1.0)) return 1;
    g.band = g.h;
    for (int a = 0; a < 3; ++a) g.origin[a] = -0.5 * g.h;
    for (int k = 1; k <= N; ++k)
        for (int j = 1; j <= N; ++j)
            for (int i = 1; i <= N; ++i) g.inside[ohm_voxel_index(&g, i, j, k)] = 1;
    count_inside(&g);
    int rc = ohm_network_build(&net, &g, NULL, &err);
    size_t n = (size_t)net.n, nf = (size_t)net.nfaces;
    double *phi = calloc(n, 8), *phi_se = calloc(n, 8), *face = calloc(nf, 8), *exit_se = calloc(n, 8);
    if (!rc && (!phi || !phi_se || !face || !exit_se)) rc = ohm_fail(&err, OHM_ERR_NOMEM, "out of memory");
    /* the beam enters the top face at x = y = 29 mm: voxel coordinate
     * 29 / h + 0.5 = 29.5 -> cell 30 (the padding is cell 0) */
    ohm_light_entry e;
    memset(&e, 0, sizeof e);
    if (!rc) {
        int64_t v = ohm_network_unknown(&net, ohm_voxel_index(&g, 30, 30, N));
        e.face = ohm_network_face(&net, v, 5);
        e.incident[0] = e.power[0] = 1.0;
        e.dir[2] = -1.0;
        e.point[0] = e.point[1] = 29.0;
        e.point[2] = N * g.h;
        e.mu = 1.0;
        e.at_point = 1;
        if (e.face < 0) rc = ohm_fail(&err, OHM_ERR_INTERNAL, "cube60: no top face at the beam");
    }
    ohm_channel_medium med;
    memset(&med, 0, sizeof med);
    med.sigma_a0 = 0.005;
    med.sigma_s0 = 1.0 * (1 - 0.01);
    med.g = 0.01;
    med.eta = 1.0;
    ohm_mc_result r = {.fluence = phi, .fluence_se = phi_se, .face_exitance = face, .exitance_se = exit_se};
    ohm_mc_params p = {.photons = photons, .seed = 1, .max_path = 5.0 * 299.792458 / 1.37, .device = spec};
    if (!rc) rc = ohm_mc_trace(&r, &net, &med, &e, 1, 0, &p, &err);
    if (!rc) {
        char where[128];
        if (r.device[0]) snprintf(where, sizeof where, "%s", r.device);
        else snprintf(where, sizeof where, "host, %d threads", r.threads);
        printf("| %s | %.3g | %.2f | %.0f | %.4f%% ± %.4f%% | %+.1f |\n", where, (double)r.photons, r.seconds,
               1e-3 * (double)r.photons / r.seconds, 100 * r.power_absorbed / r.power_in,
               100 * r.power_absorbed_se / r.power_in,
               (r.power_absorbed / r.power_in - 0.1769708) / (r.power_absorbed_se / r.power_in));
        fflush(stdout);
    } else {
        fprintf(stderr, "bench_device: cube60 on %s: %s\n", spec ? spec : "the host", err.msg);
    }
    free(phi), free(phi_se), free(face), free(exit_se);
    if (net.n) ohm_network_free(&net);
    ohm_voxel_grid_free(&g);
    return rc ? 1 : 0;
}

static int mc_main(const char *spec, int argc, char **argv)
{
    double photons = argc > 0 ? atof(argv[0]) : 1e6;
    double host = argc > 1 ? atof(argv[1]) : fmax(1e5, photons / 100);
    if (!(photons >= 16 && photons <= 1e12 && host >= 16 && host <= 1e12)) {
        fprintf(stderr, "bench_device: mc PHOTONS [HOST_PHOTONS]: counts in 16..1e12\n");
        return 2;
    }
    printf("| where | photons | seconds (with the set-up) | photons/ms | absorbed (MCX: 17.69708%%) | "
           "(ours - MCX) / se |\n");
    printf("|---|---:|---:|---:|---:|---:|\n");
    int rc = cube60(spec, (int64_t)photons);
    rc |= cube60(NULL, (int64_t)host);
    return rc;
}

int main(int argc, char **argv)
{
    if (argc >= 3 && strcmp(argv[2], "mc") == 0) return mc_main(argv[1], argc - 3, argv + 3);
    if (argc == 2 && strcmp(argv[1], "devices") == 0) return ohm_devices_main(0, NULL);
    if (argc < 3) {
        fprintf(stderr, "usage: bench_device DEVICE N... (DEVICE: gpu, cpu, opencl:K, auto; block medium on N^3 "
                        "cells), bench_device DEVICE mc PHOTONS [HOST_PHOTONS] (cube60), or bench_device devices\n");
        return 2;
    }
    printf("| grid | cells | set-up on the host (s) | host solve (s) | device | copy to the device (s) | device "
           "memory (MiB) | device solve (s) | host / device | largest difference / peak |\n");
    printf("|---|---:|---:|---:|---|---:|---:|---:|---:|---:|\n");
    int rc = 0;
    for (int i = 2; i < argc; ++i) {
        int nx = atoi(argv[i]);
        if (nx < 8 || nx > 2000) {
            fprintf(stderr, "bench_device: %s: not a grid size in 8..2000\n", argv[i]);
            return 2;
        }
        rc |= bench(argv[1], nx);
    }
    return rc;
}
