/* bench_device.c — ohm on an OpenCL device against the host's cores
 * (docs/gpu.md): the tables of studies/device_bench.h — solver=mg on
 * the scale study's block medium at each N^3, and with `mc` the Monte
 * Carlo tracer on MCX's cube60 (PHOTONS on the device, HOST_PHOTONS on the
 * host's cores).  Asserts nothing (the suite's tests check the answers:
 * test_mg_device, test_mg_scenes, test_mc_device).
 *
 * Not a ctest: tests/CMakeLists.txt builds it as bench_device,
 * scripts/gpu-bench.sh runs it and writes docs/gpu.md; `ohm bench
 * device=` prints the same tables.
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

#include "studies/device_bench.h"
#include "studies/devices.h"

static int mc_main(const char *spec, const ohm_device_request *req, int argc, char **argv)
{
    double photons = argc > 0 ? atof(argv[0]) : 1e6;
    double host = argc > 1 ? atof(argv[1]) : fmax(1e5, photons / 100);
    if (!(photons >= 16 && photons <= 1e12 && host >= 16 && host <= 1e12)) {
        fprintf(stderr, "bench_device: mc PHOTONS [HOST_PHOTONS]: counts in 16..1e12\n");
        return 2;
    }
    ohm_device_bench_mc_header(stdout);
    int rc = 0;
    for (int side = 0; side < 2; ++side) {
        ohm_error err;
        ohm_error_clear(&err);
        if (ohm_device_bench_cube60(stdout, side ? NULL : req, (int64_t)(side ? host : photons), 1, &err)) {
            fprintf(stderr, "bench_device: cube60 on %s: %s\n", side ? "the host" : spec, err.msg);
            rc = 1;
        }
    }
    return rc;
}

int main(int argc, char **argv)
{
    if (argc == 2 && strcmp(argv[1], "devices") == 0) return ohm_devices_main(0, NULL);
    ohm_device_request req;
    ohm_error perr;
    if (argc >= 3 && ohm_device_request_parse(&req, argv[1], &perr)) {
        fprintf(stderr, "bench_device: %s\n", perr.msg);
        return 2;
    }
    if (argc >= 3 && strcmp(argv[2], "mc") == 0) return mc_main(argv[1], &req, argc - 3, argv + 3);
    if (argc < 3) {
        fprintf(stderr, "usage: bench_device DEVICE N... (DEVICE: gpu, cpu, opencl:K, auto; block medium on N^3 "
                        "cells), bench_device DEVICE mc PHOTONS [HOST_PHOTONS] (cube60), or bench_device devices\n");
        return 2;
    }
    ohm_device_bench_mg_header(stdout);
    int rc = 0;
    for (int i = 2; i < argc; ++i) {
        int nx = atoi(argv[i]);
        if (nx < 8 || nx > 2000) {
            fprintf(stderr, "bench_device: %s: not a grid size in 8..2000\n", argv[i]);
            return 2;
        }
        ohm_error err;
        ohm_error_clear(&err);
        if (ohm_device_bench_mg(stdout, &req, nx, &err)) {
            fprintf(stderr, "bench_device: %d^3: %s\n", nx, err.msg);
            rc = 1;
        }
    }
    return rc;
}
