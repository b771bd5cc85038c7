/* device/session.c — see session.h. */
#include "device/session.h"

#include <stdlib.h>
#include <string.h>

int ohm_device_session_open(ohm_device_session *s, int *opened, const ohm_device_request *req, const char *what,
                            const ohm_log *log, ohm_error *err)
{
    memset(s, 0, sizeof *s);
    s->what = what;
    s->picked = -1;
    *opened = 0;
    if (!req || req->kind == OHM_DEVICE_HOST) return OHM_OK;
    int automatic = req->kind == OHM_DEVICE_AUTO;
    char spec[32];
    ohm_device_request_name(req, spec, sizeof spec);
    int rc = ohm_cl_open(&s->cl, err);
    if (!rc) rc = ohm_device_list(&s->devices, &s->ndevices, &s->cl, err);
    if (!rc && s->ndevices == 0 && !automatic)
        rc = ohm_fail(err, OHM_ERR_INVALID, "device=%s: the OpenCL runtime %s found no device (see 'ohm devices')",
                      spec, s->cl.path);
    if (!rc) rc = ohm_device_pick(&s->picked, s->devices, s->ndevices, req, err);
    if (rc || s->picked < 0) {
        ohm_device_session_close(s);
        if (!automatic) return rc;
        /* device=auto without a runtime or a GPU: the host */
        ohm_log_info(log, "%s: device=auto: no GPU with double precision, it runs on the host", what);
        ohm_error_clear(err);
        return OHM_OK;
    }
    rc = ohm_device_queue_open(&s->q, &s->cl, &s->devices[s->picked], err);
    if (rc) {
        ohm_device_session_close(s);
        return rc;
    }
    *opened = 1;
    return OHM_OK;
}

void ohm_device_session_close(ohm_device_session *s)
{
    if (s->q.context) ohm_device_queue_close(&s->q);
    free(s->devices);
    if (s->cl.library) ohm_cl_close(&s->cl);
    const char *what = s->what;
    memset(s, 0, sizeof *s);
    s->what = what;
    s->picked = -1;
}

const ohm_device *ohm_device_session_device(const ohm_device_session *s)
{
    return s->q.device;
}

int ohm_device_failed(const ohm_device_session *s, ohm_error *err, cl_int status, const char *doing)
{
    char buf[24];
    int code = status == CL_MEM_OBJECT_ALLOCATION_FAILURE || status == CL_OUT_OF_RESOURCES ||
                       status == CL_OUT_OF_HOST_MEMORY
                   ? OHM_ERR_NOMEM
                   : OHM_ERR_INTERNAL;
    return ohm_fail(err, code, "%s on %s: %s: %s", s->what, s->q.device ? s->q.device->name : "the device", doing,
                    ohm_cl_status(status, buf));
}

int ohm_device_buffer(ohm_device_session *s, cl_mem *mem, size_t bytes, const void *host, const char *advice,
                      ohm_error *err)
{
    const ohm_device *dev = s->q.device;
    if ((double)bytes > dev->max_alloc_bytes)
        return ohm_fail(err, OHM_ERR_NOMEM,
                        "%s on %s: one array of %.2f GiB is more than the device allows in one buffer (%.2f GiB); %s",
                        s->what, dev->name, (double)bytes / (1 << 30), dev->max_alloc_bytes / (1 << 30), advice);
    cl_int st = CL_SUCCESS;
    *mem = s->cl.CreateBuffer(s->q.context, CL_MEM_READ_WRITE, bytes ? bytes : 4, NULL, &st);
    if (!*mem) return ohm_device_failed(s, err, st, "allocating device memory");
    s->bytes += (double)bytes;
    return host && bytes ? ohm_device_copy(s, *mem, (void *)host, bytes, 1, err) : OHM_OK;
}

void ohm_device_release(ohm_device_session *s, cl_mem *mem)
{
    if (*mem) s->cl.ReleaseMemObject(*mem);
    *mem = NULL;
}

int ohm_device_copy(ohm_device_session *s, cl_mem mem, void *host, size_t bytes, int to_device, ohm_error *err)
{
    cl_int st = to_device ? s->cl.EnqueueWriteBuffer(s->q.queue, mem, CL_TRUE, 0, bytes, host, 0, NULL, NULL)
                          : s->cl.EnqueueReadBuffer(s->q.queue, mem, CL_TRUE, 0, bytes, host, 0, NULL, NULL);
    return st == CL_SUCCESS ? OHM_OK
                            : ohm_device_failed(s, err, st, to_device ? "copying to the device" : "copying back");
}

void ohm_device_arg(ohm_device_session *s, cl_kernel k, cl_uint i, size_t size, const void *value)
{
    cl_int st = s->cl.SetKernelArg(k, i, size, value);
    if (st != CL_SUCCESS && s->status == CL_SUCCESS) s->status = st;
}

void ohm_device_launch(ohm_device_session *s, cl_kernel k, size_t global, size_t local)
{
    cl_int st = s->cl.EnqueueNDRangeKernel(s->q.queue, k, 1, NULL, &global, &local, 0, NULL, NULL);
    if (st != CL_SUCCESS && s->status == CL_SUCCESS) s->status = st;
}

int ohm_device_checked(ohm_device_session *s, ohm_error *err)
{
    cl_int st = s->status;
    s->status = CL_SUCCESS;
    return st == CL_SUCCESS ? OHM_OK : ohm_device_failed(s, err, st, "a kernel failed");
}

size_t ohm_device_group_size(const ohm_device_session *s, size_t most)
{
    size_t max_wg = 0, wg = most;
    s->cl.GetDeviceInfo(s->q.device->device_id, CL_DEVICE_MAX_WORK_GROUP_SIZE, sizeof max_wg, &max_wg, NULL);
    while (wg > max_wg && wg > 1) wg /= 2;
    return wg;
}

int ohm_device_kernels(ohm_device_session *s, cl_program *program, cl_kernel *kernels, const char *const *names,
                       int count, const char *source, const char *options, ohm_error *err)
{
#ifdef OHM_TEST_HOOKS
    /* test hook (tests/cli_devices.sh, test_mc_device.c; builds for the suite only) */
    const char *test_options = getenv("OHM_TEST_KERNEL_OPTIONS");
    if (test_options) options = test_options;
#endif
    int rc = ohm_device_build(program, &s->q, source, options, err);
    for (int k = 0; !rc && k < count; ++k) {
        cl_int st = CL_SUCCESS;
        kernels[k] = s->cl.CreateKernel(*program, names[k], &st);
        if (!kernels[k]) rc = ohm_device_failed(s, err, st, names[k]);
    }
    return rc;
}
