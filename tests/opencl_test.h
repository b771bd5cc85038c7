/* opencl_test.h — what the tests that run on an OpenCL device share
 * (test_device.c, test_mg_device.c, test_mg_scenes.c, test_mc_device.c):
 * whether a missing device is a failure (CI=true or OHM_REQUIRE_OPENCL set,
 * as for Blender) or a SKIP, and the first device with double precision. */
#ifndef OHM_TESTS_OPENCL_TEST_H
#define OHM_TESTS_OPENCL_TEST_H

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "device/devices.h"

static inline int opencl_required(void)
{
    const char *ci = getenv("CI"), *req = getenv("OHM_REQUIRE_OPENCL");
    return (ci && strcmp(ci, "true") == 0) || (req && *req && strcmp(req, "0") != 0);
}

/* "opencl:N" into spec for the first device with double precision; -1 when
 * there is none (or no runtime) */
static inline int first_fp64_device(char spec[32])
{
    ohm_cl cl;
    ohm_error err;
    ohm_error_clear(&err);
    if (ohm_cl_open(&cl, &err)) return -1;
    ohm_device *list = NULL;
    int n = 0, found = -1;
    if (!ohm_device_list(&list, &n, &cl, &err))
        for (int i = 0; i < n && found < 0; ++i)
            if (list[i].fp64) found = i;
    free(list);
    ohm_cl_close(&cl);
    if (found >= 0) snprintf(spec, 32, "opencl:%d", found);
    return found;
}

/* The device a test runs on: "opencl:N" into spec and 1, or 0 after
 * printing SKIP — or after a failed check when CI=true or
 * OHM_REQUIRE_OPENCL asks for a device. */
static inline int device_for_test(char spec[32])
{
    if (first_fp64_device(spec) >= 0) {
        printf("device %s\n", spec);
        return 1;
    }
    if (opencl_required())
        CHECK_MSG(0, "no OpenCL device with double precision, but CI=true or OHM_REQUIRE_OPENCL is set");
    else
        printf("SKIP: no OpenCL device with double precision\n");
    return 0;
}

#endif
