/* bench_device.c — solver=mg on an OpenCL device against the host (issue
 * 37, item 5): on the scale study's block medium (blocks of 8^3 cells,
 * sigma_s' 1 or 1e6 at random, sigma_a 0.001 /mm, robin boundary) at each
 * N^3, the hierarchy built once, then one light's solve to 1e-10 from zero
 * on the host's cores and on the device (the hierarchy copied there first,
 * timed apart), the device's answer against the host's, and the device's
 * triad.  Prints one Markdown row per N; asserts nothing (the suite's tests
 * check the answers: test_mg_device, test_mg_scenes).
 *
 * Not a ctest: tests/CMakeLists.txt builds it as bench_device,
 * scripts/gpu-bench.sh runs it and writes docs/gpu.md.
 *
 *   bench_device DEVICE N...   DEVICE: gpu, cpu, opencl:K or auto
 *   bench_device devices       what `ohm devices` prints
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

int main(int argc, char **argv)
{
    if (argc == 2 && strcmp(argv[1], "devices") == 0) return ohm_devices_main(0, NULL);
    if (argc < 3) {
        fprintf(stderr, "usage: bench_device DEVICE N... (DEVICE: gpu, cpu, opencl:K, auto; block medium on N^3 "
                        "cells), or bench_device devices\n");
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
