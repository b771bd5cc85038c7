/* test_device.c — the OpenCL device layer (src/device/, docs/design.md §6) on the
 * machine's own devices: PoCL's CPU device in CI (pocl-opencl-icd, which
 * scripts/install-deps.sh installs), a GPU where there is one.
 *  - the runtime loads, lists at least one device, and a device with double
 *    precision can be picked by kind and by number;
 *  - on each device a triad kernel runs and every element is checked;
 *  - a kernel that does not compile is one error with the compiler's words;
 *  - asking for what is not there (opencl:N out of range, a GPU where there
 *    is none, a word that is no device) is one error naming the devices;
 *  - a runtime that is not there (OHM_OPENCL_LIBRARY pointing nowhere) is
 *    one error that says what to install.
 * Without any OpenCL runtime or device the test prints SKIP and passes,
 * unless CI=true or OHM_REQUIRE_OPENCL is set (as for Blender). */
#define _POSIX_C_SOURCE 200809L
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "opencl_test.h"

/* device= as a run reads it: the text parsed once (request.h), then picked */
static int pick_text(int *picked, const ohm_device *list, int n, const char *text, ohm_error *err)
{
    ohm_device_request req;
    int rc = ohm_device_request_parse(&req, text, err);
    if (rc) {
        *picked = -1;
        return rc;
    }
    return ohm_device_pick(picked, list, n, &req, err);
}

static void test_picks(const ohm_device *list, int n)
{
    ohm_error err;
    int picked = 7;
    ohm_error_clear(&err);
    CHECK(pick_text(&picked, list, n, "host", &err) == OHM_OK && picked == -1);
    int gpus = 0, cpu = -1;
    for (int i = 0; i < n; ++i) {
        gpus += list[i].is_gpu && list[i].fp64;
        if (!list[i].is_gpu && cpu < 0) cpu = i;
    }
    CHECK(pick_text(&picked, list, n, "auto", &err) == OHM_OK);
    CHECK_MSG(gpus ? picked >= 0 && list[picked].is_gpu : picked == -1, "auto picked %d with %d GPUs", picked, gpus);
    if (!gpus) {
        ohm_error_clear(&err);
        CHECK(pick_text(&picked, list, n, "gpu", &err) == OHM_ERR_INVALID);
        CHECK_MSG(strstr(err.msg, "no GPU") && strstr(err.msg, "opencl:0"), "%s", err.msg);
    }
    if (cpu >= 0 && list[cpu].fp64) {
        CHECK(pick_text(&picked, list, n, "cpu", &err) == OHM_OK && picked == cpu);
        char spec[32];
        snprintf(spec, sizeof spec, "opencl:%d", cpu);
        CHECK(pick_text(&picked, list, n, spec, &err) == OHM_OK && picked == cpu);
    }
    ohm_error_clear(&err);
    CHECK(pick_text(&picked, list, n, "opencl:99", &err) == OHM_ERR_INVALID);
    CHECK_MSG(strstr(err.msg, "opencl:99") && strstr(err.msg, "opencl:0 ("), "%s", err.msg);
    ohm_error_clear(&err);
    CHECK(pick_text(&picked, list, n, "opencl:x", &err) == OHM_ERR_USAGE);
    ohm_error_clear(&err);
    CHECK(pick_text(&picked, list, n, "fast", &err) == OHM_ERR_USAGE);
    CHECK_MSG(strstr(err.msg, "expected host, gpu, cpu, opencl:N or auto"), "%s", err.msg);
}

static void test_kernels(const ohm_cl *cl, const ohm_device *d)
{
    ohm_device_queue q;
    ohm_error err;
    ohm_error_clear(&err);
    int rc = ohm_device_queue_open(&q, cl, d, &err);
    CHECK_MSG(rc == OHM_OK, "%s: %s", d->name, err.msg);
    if (rc) return;
    double bw = 0;
    rc = ohm_device_triad(&bw, &q, (size_t)1 << 20, 2, &err); /* every element checked */
    CHECK_MSG(rc == OHM_OK && bw > 0, "%s: triad: %s", d->name, err.msg);
    printf("opencl:%d %s: triad %.1f GB/s\n", d->index, d->name, 1e-9 * bw);
    cl_program program = NULL;
    ohm_error_clear(&err);
    rc = ohm_device_build(&program, &q, "__kernel void broken(__global float *a) { a[0] = undeclared; }", "",
                          &err);
    CHECK(rc == OHM_ERR_INTERNAL && program == NULL);
    CHECK_MSG(strstr(err.msg, "failed to build") && strstr(err.msg, "undeclared"), "%s", err.msg);
    ohm_device_queue_close(&q);
}

int main(void)
{
    ohm_error err;
    ohm_error_clear(&err);

    /* no runtime where one is named that is not there */
    const char *saved = getenv("OHM_OPENCL_LIBRARY");
    setenv("OHM_OPENCL_LIBRARY", "/nonexistent/libOpenCL.so.1", 1);
    ohm_cl missing;
    CHECK(ohm_cl_open(&missing, &err) == OHM_ERR_INVALID && missing.library == NULL);
    CHECK_MSG(strstr(err.msg, "no OpenCL runtime") && strstr(err.msg, "pocl-opencl-icd"), "%s", err.msg);
    if (saved) setenv("OHM_OPENCL_LIBRARY", saved, 1);
    else unsetenv("OHM_OPENCL_LIBRARY");

    ohm_cl cl;
    ohm_error_clear(&err);
    ohm_device *list = NULL;
    int n = 0;
    int rc = ohm_cl_open(&cl, &err);
    if (!rc) rc = ohm_device_list(&list, &n, &cl, &err);
    if (rc || n == 0) {
        if (!rc) ohm_cl_close(&cl);
        if (opencl_required()) {
            CHECK_MSG(0, "no OpenCL device (%s), but CI=true or OHM_REQUIRE_OPENCL is set", rc ? err.msg : "none");
            return check_summary();
        }
        printf("SKIP: no OpenCL device (%s)\n", rc ? err.msg : "the runtime lists none");
        return 0;
    }
    int fp64 = 0;
    for (int i = 0; i < n; ++i) {
        printf("opencl:%d %s [%s] %s %s %.1f GiB\n", i, list[i].name, list[i].platform,
               list[i].is_gpu ? "GPU" : "CPU", list[i].fp64 ? "fp64" : "no fp64", list[i].global_bytes / (1 << 30));
        CHECK(list[i].index == i && list[i].name[0] && list[i].global_bytes > 0 && list[i].compute_units > 0);
        fp64 += list[i].fp64;
        test_kernels(&cl, &list[i]);
    }
    CHECK_MSG(fp64 > 0, "no device with double precision");
    test_picks(list, n);
    free(list);
    ohm_cl_close(&cl);
    return check_summary();
}
