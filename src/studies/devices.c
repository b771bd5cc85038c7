/* devices.c — see devices.h. */
#include "studies/devices.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "device/devices.h"
#include "studies/subcommand.h"

/* the triad's size: large enough to leave a GPU's caches (48 MB) */
static const size_t TRIAD_FLOATS = (size_t)1 << 22;
static const int TRIAD_REPEATS = 5;

static void usage(FILE *f)
{
    fprintf(f, "usage: ohm devices\n"
               "  Lists the OpenCL devices (device=opencl:N in -solve), their memory and double precision,\n"
               "  and measures each one's memory bandwidth with a triad kernel whose every result is checked.\n"
               "  The runtime is libOpenCL.so.1 (OHM_OPENCL_LIBRARY names another); the drivers are found\n"
               "  through /etc/OpenCL/vendors (OCL_ICD_VENDORS names another folder).\n");
}

static int list_devices(const ohm_cl *cl, ohm_error *err)
{
    ohm_device *list = NULL;
    int n = 0;
    int rc = ohm_device_list(&list, &n, cl, err);
    if (rc) return rc;
    if (n == 0)
        rc = ohm_fail(err, OHM_ERR_INVALID,
                      "the OpenCL runtime %s found no device: install a driver (pocl-opencl-icd for the CPU, or "
                      "the GPU vendor's OpenCL ICD) or point OCL_ICD_VENDORS at a folder with its .icd file",
                      cl->path);
    int failed = 0;
    for (int i = 0; !rc && i < n; ++i) {
        const ohm_device *d = &list[i];
        printf("opencl:%d  %s  [%s]  %s, %s%s, %d compute units, %.1f GiB (one buffer up to %.1f GiB), %s\n", i,
               d->name, d->platform, d->is_gpu ? "GPU" : "CPU", d->fp64 ? "fp64" : "no fp64",
               d->atomics64 ? "" : ", no 64-bit atomics (solver=mc cannot run there)", d->compute_units,
               d->global_bytes / (1 << 30), d->max_alloc_bytes / (1 << 30), d->version);
        ohm_device_queue q;
        ohm_error derr;
        ohm_error_clear(&derr);
        double bw = 0;
        int drc = ohm_device_queue_open(&q, cl, d, &derr);
        if (!drc) {
            drc = ohm_device_triad(&bw, &q, TRIAD_FLOATS, TRIAD_REPEATS, &derr);
            ohm_device_queue_close(&q);
        }
        if (drc) {
            printf("           kernel test: FAILED: %s\n", derr.msg);
            failed = 1;
        } else {
            printf("           kernel test: ok, triad %.1f GB/s\n", 1e-9 * bw);
        }
    }
    free(list);
    if (!rc && failed) rc = ohm_fail(err, OHM_ERR_NUMERIC, "a device failed its kernel test (above)");
    return rc;
}

int ohm_devices_main(int argc, char **argv)
{
    ohm_error err;
    ohm_error_clear(&err);
    if (ohm_subcommand_wants_help(argc, argv)) {
        usage(stdout);
        return 0;
    }
    if (argc > 0) {
        fprintf(stderr, "ohm: error: devices: unexpected '%s' (see 'ohm devices help')\n", argv[0]);
        return 2;
    }
    ohm_cl cl;
    int rc = ohm_cl_open(&cl, &err);
    if (!rc) {
        rc = list_devices(&cl, &err);
        ohm_cl_close(&cl);
    }
    return ohm_subcommand_exit(rc, &err, "devices");
}
