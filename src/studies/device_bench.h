/* device_bench.h — ohm on an OpenCL device against the host's cores
 * (docs/gpu.md): the rows `ohm bench device=` adds, and what the
 * benchmark that travels (tests/bench_device.c as ohm-gpu-bench,
 * scripts/gpu-pack.sh) prints.  Markdown tables; each row measured in the
 * same run on both sides, the device's answer checked against the host's.
 *
 *  - mg: the block medium (block_medium.h, blocks of 8^3, sigma_a 0.001
 *    /mm, robin boundary) at nx^3: the hierarchy built once on the host,
 *    one light's solve to 1e-10 from zero on the host and on the device
 *    (the hierarchy copied there first, timed apart);
 *  - mc: MCX's cube60 (60^3 cells of 1 mm, sigma_a 0.005, sigma_s 1 /mm,
 *    g 0.01, a pencil beam at (29, 29) mm, no reflection, a 5 ns gate):
 *    photons/ms and the absorbed fraction against MCX's 17.69708%. */
#ifndef OHM_STUDIES_DEVICE_BENCH_H
#define OHM_STUDIES_DEVICE_BENCH_H

#include <stdint.h>
#include <stdio.h>

#include "base/ohm_error.h"
#include "device/request.h"

void ohm_device_bench_mg_header(FILE *out);
/* One row at nx^3 on the device `req` asks for (gpu, cpu, opencl:N, auto). */
int ohm_device_bench_mg(FILE *out, const ohm_device_request *req, int nx, ohm_error *err);

void ohm_device_bench_mc_header(FILE *out);
/* One row: cube60 with `photons` on the device `req` asks for, or on the
 * host's cores (req NULL), from seed `seed`. */
int ohm_device_bench_cube60(FILE *out, const ohm_device_request *req, int64_t photons, uint64_t seed, ohm_error *err);

#endif
