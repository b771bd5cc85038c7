/* test_mg_device.c — solver=mg on an OpenCL device (mg_device.h, docs/devices.md)
 * against the same hierarchy on the host (mg.h), on PoCL's CPU device in
 * CI, or the first device with double precision:
 *  - the block medium (10^6 contrasts in blocks of 5^3, a 40^3 box, several
 *    levels and the K-cycle), a point-like source and a uniform one: every
 *    cell within 1e-6 of the host's solution (relative to the largest), the
 *    power sunk equal to the power in to 1e-10 (what the books check);
 *  - a hollow, irregular object (a sphere shell with a hole: several
 *    coarse-level shapes, cells on the boundary);
 *  - the warm start: solving again from the answer takes no iteration, as
 *    on the host (a kept solver relighting);
 *  - device=opencl:99, a device that is not there, is one error naming
 *    the devices; device=host gives no device.
 * Without OpenCL it prints SKIP, unless CI=true or OHM_REQUIRE_OPENCL. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "blocks.h"
#include "check.h"
#include "opencl_test.h"
#include "solvers/mg.h"
#include "solvers/mg_device.h"

/* device= as a run reads it: the text parsed once (device/request.h) */
static ohm_device_request req_of(const char *text)
{
    ohm_device_request r = {OHM_DEVICE_HOST, 0};
    ohm_error err;
    if (ohm_device_request_parse(&r, text, &err)) {
        fprintf(stderr, "test_mg_device: %s\n", err.msg);
        exit(1);
    }
    return r;
}

/* The host's and the device's solutions of st for b: the largest cell
 * difference over the largest value, and the power balance on the device. */
static void compare(const char *what, const ohm_stencil *st, const ohm_grid_layout *layout, const double *b,
                    const char *spec)
{
    ohm_error err;
    ohm_error_clear(&err);
    int64_t n = st->n, its_host = 0, its_dev = 0, again = -1;
    double *xh = calloc((size_t)n, 8), *xd = calloc((size_t)n, 8), rh = 0, rd = 0;
    ohm_mg *mg = NULL;
    ohm_mg_device *dev = NULL;
    const ohm_device_request req = req_of(spec);
    CHECK_MSG(ohm_mg_setup(&mg, st, layout, 2, &err) == 0, "%s", err.msg);
    CHECK_MSG(mg && ohm_mg_device_open(&dev, mg, &req, NULL, &err) == 0 && dev, "%s: %s", what, err.msg);
    if (!mg || !dev) goto done;
    CHECK_MSG(ohm_mg_solve(mg, xh, b, 1e-10, 500, NULL, &its_host, &rh, &err) == 0, "%s", err.msg);
    CHECK_MSG(ohm_mg_device_solve(dev, xd, b, 1e-10, 500, NULL, &its_dev, &rd, &err) == 0, "%s: %s", what, err.msg);
    double diff = 0, peak = 0, in = 0, sunk = 0;
    for (int64_t v = 0; v < n; ++v) {
        diff = fmax(diff, fabs(xd[v] - xh[v]));
        peak = fmax(peak, fabs(xh[v]));
        in += b[v];
        sunk += st->sink[v] * xd[v];
    }
    printf("%s: %lld cells, host %lld iterations, device %lld; largest difference %.3g of the peak; power in %.6g, "
           "sunk on the device %.12g\n",
           what, (long long)n, (long long)its_host, (long long)its_dev, diff / peak, in, sunk);
    CHECK_MSG(diff <= 1e-6 * peak, "%s: device and host differ by %.3g of the peak", what, diff / peak);
    CHECK_MSG(fabs(sunk - in) <= 1e-10 * in, "%s: %.15g W in, %.15g W sunk", what, in, sunk);
    CHECK_MSG(its_dev > 0 && labs((long)(its_dev - its_host)) <= 2, "%s: %lld iterations on the device, %lld on the host",
              what, (long long)its_dev, (long long)its_host);
    /* a relight from the answer: nothing left to do */
    CHECK(ohm_mg_device_solve(dev, xd, b, 1e-10, 500, NULL, &again, &rd, &err) == 0 && again == 0);
done:
    ohm_mg_device_free(dev);
    ohm_mg_free(mg);
    free(xh), free(xd);
}

static void blocks(const char *spec)
{
    ohm_voxel_grid g;
    ohm_coeff *ss = NULL;
    CHECK(ohm_block_medium_grid(&g, 40, &ss, 5) == 0);
    ohm_error err;
    ohm_error_clear(&err);
    ohm_network net;
    ohm_stencil st;
    CHECK(block_stencil(&net, &st, &g, ss, 0.01, &err) == 0);
    int64_t n = net.n;
    ohm_grid_layout layout = ohm_grid_layout_of(&net);
    double *b = calloc((size_t)n, 8);
    for (int64_t v = 0; v < n; ++v) b[v] = 1.0 / (double)n;
    compare("block medium, uniform source", &st, &layout, b, spec);
    memset(b, 0, (size_t)n * 8);
    b[n / 2 + 7] = 1.0; /* one cell inside */
    compare("block medium, one cell lit", &st, &layout, b, spec);
    free(b);
    ohm_stencil_free(&st);
    ohm_network_free(&net);
    ohm_voxel_grid_free(&g);
    free(ss);
}

/* a spherical shell (radius 9-14 cells) with a hole through it */
static void shell(const char *spec)
{
    ohm_voxel_grid g;
    CHECK(ohm_cube_grid(&g, 30, 0.5) == 0);
    for (int k = 0; k < 30; ++k)
        for (int j = 0; j < 30; ++j)
            for (int i = 0; i < 30; ++i) {
                double x = i - 14.5, y = j - 14.5, z = k - 14.5, r = sqrt(x * x + y * y + z * z);
                int hole = fabs(x) < 3 && fabs(y) < 3 && z > 0;
                g.inside[i + 30 * (j + 30 * k)] = r >= 9 && r <= 14 && !hole;
            }
    ohm_grid_count_inside(&g);
    ohm_error err;
    ohm_error_clear(&err);
    ohm_network net;
    ohm_stencil st;
    CHECK(block_stencil(&net, &st, &g, NULL, 0.02, &err) == 0);
    int64_t n = net.n;
    ohm_grid_layout layout = ohm_grid_layout_of(&net);
    double *b = calloc((size_t)n, 8);
    for (int64_t v = 0; v < n; v += 97) b[v] = 1.0;
    compare("hollow shell with a hole", &st, &layout, b, spec);
    free(b);
    ohm_stencil_free(&st);
    ohm_network_free(&net);
    ohm_voxel_grid_free(&g);
}

static void refusals(void)
{
    ohm_voxel_grid g;
    CHECK(ohm_cube_grid(&g, 12, 1.0) == 0);
    memset(g.inside, 1, 12 * 12 * 12);
    ohm_grid_count_inside(&g);
    ohm_error err;
    ohm_error_clear(&err);
    ohm_network net;
    ohm_stencil st;
    CHECK(block_stencil(&net, &st, &g, NULL, 0.01, &err) == 0);
    ohm_grid_layout layout = ohm_grid_layout_of(&net);
    ohm_mg *mg = NULL;
    CHECK(ohm_mg_setup(&mg, &st, &layout, 1, &err) == 0);
    ohm_mg_device *dev = (ohm_mg_device *)&err; /* must be set to NULL */
    CHECK(ohm_mg_device_open(&dev, mg, &(const ohm_device_request){OHM_DEVICE_HOST, 0}, NULL, &err) == 0 && dev == NULL);
    ohm_error_clear(&err);
    CHECK(ohm_mg_device_open(&dev, mg, &(const ohm_device_request){OHM_DEVICE_INDEX, 99}, NULL, &err) == OHM_ERR_INVALID && dev == NULL);
    CHECK_MSG(strstr(err.msg, "opencl:99") && strstr(err.msg, "opencl:0 ("), "%s", err.msg);
    ohm_mg_free(mg);
    ohm_stencil_free(&st);
    ohm_network_free(&net);
    ohm_voxel_grid_free(&g);
}

int main(void)
{
    char spec[32];
    if (!device_for_test(spec)) return check_summary();
    blocks(spec);
    shell(spec);
    refusals();
    return check_summary();
}
