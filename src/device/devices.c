/* devices.c — see devices.h. */
#include "device/devices.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/log.h"

/* an OpenCL call's failure as ohm's error */
static int cl_fail(ohm_error *err, cl_int status, const char *what)
{
    char buf[24];
    int code = status == CL_OUT_OF_RESOURCES || status == CL_MEM_OBJECT_ALLOCATION_FAILURE ||
                       status == CL_OUT_OF_HOST_MEMORY
                   ? OHM_ERR_NOMEM
                   : OHM_ERR_INTERNAL;
    return ohm_fail(err, code, "OpenCL: %s: %s", what, ohm_cl_status(status, buf));
}

/* a device's text property, cut to `size` (the runtime refuses a buffer
 * shorter than the whole text) */
static void device_text(const ohm_cl *cl, cl_device_id d, cl_device_info what, char *out, size_t size)
{
    out[0] = '\0';
    size_t need = 0;
    if (cl->GetDeviceInfo(d, what, 0, NULL, &need) != CL_SUCCESS || need == 0) return;
    char *whole = malloc(need + 1);
    if (!whole) return;
    if (cl->GetDeviceInfo(d, what, need, whole, NULL) == CL_SUCCESS) {
        whole[need] = '\0';
        snprintf(out, size, "%s", whole);
    }
    free(whole);
}

static int has_fp64(const ohm_cl *cl, cl_device_id d, const char *extensions)
{
    cl_device_fp_config config = 0;
    if (cl->GetDeviceInfo(d, CL_DEVICE_DOUBLE_FP_CONFIG, sizeof config, &config, NULL) == CL_SUCCESS && config)
        return 1;
    return strstr(extensions, "cl_khr_fp64") != NULL;
}

static void describe(ohm_device *dev, const ohm_cl *cl)
{
    cl_device_type type = 0;
    cl_uint units = 0;
    cl_ulong global = 0, alloc = 0;
    cl->GetDeviceInfo(dev->device_id, CL_DEVICE_TYPE, sizeof type, &type, NULL);
    cl->GetDeviceInfo(dev->device_id, CL_DEVICE_MAX_COMPUTE_UNITS, sizeof units, &units, NULL);
    cl->GetDeviceInfo(dev->device_id, CL_DEVICE_GLOBAL_MEM_SIZE, sizeof global, &global, NULL);
    cl->GetDeviceInfo(dev->device_id, CL_DEVICE_MAX_MEM_ALLOC_SIZE, sizeof alloc, &alloc, NULL);
    dev->is_gpu = (type & (CL_DEVICE_TYPE_GPU | CL_DEVICE_TYPE_ACCELERATOR)) != 0;
    dev->compute_units = (int)units;
    dev->global_bytes = (double)global;
    dev->max_alloc_bytes = (double)alloc;
    char extensions[8192];
    device_text(cl, dev->device_id, CL_DEVICE_EXTENSIONS, extensions, sizeof extensions);
    dev->fp64 = has_fp64(cl, dev->device_id, extensions);
    dev->atomics64 = strstr(extensions, "cl_khr_int64_base_atomics") != NULL;
#ifdef OHM_TEST_HOOKS
    /* test hook (tests/cli_devices.sh; builds for the suite only): a device
     * this small, so that the out-of-device-memory refusal runs */
    const char *cap = getenv("OHM_TEST_DEVICE_MEMORY_MB");
    if (cap && atof(cap) > 0) dev->global_bytes = dev->max_alloc_bytes = atof(cap) * (1 << 20);
    /* ... and devices without double precision or 64-bit atomics, so that
     * those refusals run (test_mc_device, cli_devices.sh) */
    const char *lacks = getenv("OHM_TEST_DEVICE_LACKS");
    if (lacks && strstr(lacks, "fp64")) dev->fp64 = 0;
    if (lacks && strstr(lacks, "atomics64")) dev->atomics64 = 0;
#endif
    device_text(cl, dev->device_id, CL_DEVICE_NAME, dev->name, sizeof dev->name);
    device_text(cl, dev->device_id, CL_DEVICE_VERSION, dev->version, sizeof dev->version);
    if (cl->GetPlatformInfo(dev->platform_id, CL_PLATFORM_NAME, sizeof dev->platform, dev->platform, NULL) !=
        CL_SUCCESS)
        dev->platform[0] = '\0';
    dev->platform[sizeof dev->platform - 1] = '\0';
}

int ohm_device_list(ohm_device **out, int *count, const ohm_cl *cl, ohm_error *err)
{
    *out = NULL;
    *count = 0;
    cl_uint nplatforms = 0;
    cl_int st = cl->GetPlatformIDs(0, NULL, &nplatforms);
    if (st == CL_PLATFORM_NOT_FOUND_KHR || nplatforms == 0) return OHM_OK; /* a loader without drivers */
    if (st != CL_SUCCESS) return cl_fail(err, st, "listing the platforms");
    cl_platform_id *platforms = calloc(nplatforms, sizeof *platforms);
    if (!platforms) return ohm_fail(err, OHM_ERR_NOMEM, "out of memory listing OpenCL platforms");
    int rc = OHM_OK;
    ohm_device *list = NULL;
    int n = 0;
    st = cl->GetPlatformIDs(nplatforms, platforms, NULL);
    if (st != CL_SUCCESS) rc = cl_fail(err, st, "listing the platforms");
    for (cl_uint p = 0; !rc && p < nplatforms; ++p) {
        cl_uint ndev = 0;
        st = cl->GetDeviceIDs(platforms[p], CL_DEVICE_TYPE_ALL, 0, NULL, &ndev);
        if (st == CL_DEVICE_NOT_FOUND || ndev == 0) continue;
        if (st != CL_SUCCESS) {
            rc = cl_fail(err, st, "listing a platform's devices");
            break;
        }
        cl_device_id ids[64];
        if (ndev > 64) ndev = 64;
        st = cl->GetDeviceIDs(platforms[p], CL_DEVICE_TYPE_ALL, ndev, ids, NULL);
        if (st != CL_SUCCESS) {
            rc = cl_fail(err, st, "listing a platform's devices");
            break;
        }
        ohm_device *grown = realloc(list, (size_t)(n + (int)ndev) * sizeof *grown);
        if (!grown) {
            rc = ohm_fail(err, OHM_ERR_NOMEM, "out of memory listing OpenCL devices");
            break;
        }
        list = grown;
        for (cl_uint d = 0; d < ndev; ++d, ++n) {
            memset(&list[n], 0, sizeof list[n]);
            list[n].index = n;
            list[n].platform_id = platforms[p];
            list[n].device_id = ids[d];
            describe(&list[n], cl);
        }
    }
    free(platforms);
    if (rc) {
        free(list);
        return rc;
    }
    *out = list;
    *count = n;
    return OHM_OK;
}

/* "opencl:0 (NVIDIA H200, GPU, fp64), opencl:1 (...)" or "none" */
static void device_names(char *buf, size_t size, const ohm_device *list, int n)
{
    snprintf(buf, size, "%s", n ? "" : "none");
    for (int i = 0; i < n; ++i) {
        size_t used = strlen(buf);
        snprintf(buf + used, size - used, "%sopencl:%d (%s, %s%s)", i ? ", " : "", i, list[i].name,
                 list[i].is_gpu ? "GPU" : "CPU", list[i].fp64 ? ", fp64" : ", no fp64");
    }
}

int ohm_device_pick(int *picked, const ohm_device *list, int n, const ohm_device_request *req, ohm_error *err)
{
    *picked = -1;
    char names[512], spec[32];
    device_names(names, sizeof names, list, n);
    ohm_device_request_name(req, spec, sizeof spec);
    int want = -1;
    switch (req->kind) {
    case OHM_DEVICE_HOST: return OHM_OK;
    case OHM_DEVICE_AUTO:
    case OHM_DEVICE_GPU:
        for (int i = 0; i < n && want < 0; ++i)
            if (list[i].is_gpu && list[i].fp64) want = i;
        if (want < 0 && req->kind == OHM_DEVICE_AUTO) return OHM_OK; /* the host */
        if (want < 0)
            return ohm_fail(err, OHM_ERR_INVALID, "device=gpu: no GPU with double precision among the OpenCL devices: %s",
                            names);
        break;
    case OHM_DEVICE_CPU:
        for (int i = 0; i < n && want < 0; ++i)
            if (!list[i].is_gpu) want = i;
        if (want < 0) return ohm_fail(err, OHM_ERR_INVALID, "device=cpu: no OpenCL CPU device among: %s", names);
        break;
    case OHM_DEVICE_INDEX:
        if (req->index < 0 || req->index >= n)
            return ohm_fail(err, OHM_ERR_INVALID, "device=%s: there are %d OpenCL device(s): %s", spec, n, names);
        want = req->index;
        break;
    }
    if (!list[want].fp64)
        return ohm_fail(err, OHM_ERR_INVALID,
                        "device=%s: %s has no double precision (cl_khr_fp64), which ohm's solver needs", spec,
                        list[want].name);
    *picked = want;
    return OHM_OK;
}

int ohm_device_queue_open(ohm_device_queue *q, const ohm_cl *cl, const ohm_device *device, ohm_error *err)
{
    memset(q, 0, sizeof *q);
    q->cl = cl;
    q->device = device;
    cl_int st = CL_SUCCESS;
    cl_context_properties props[] = {CL_CONTEXT_PLATFORM, (cl_context_properties)device->platform_id, 0};
    q->context = cl->CreateContext(props, 1, &device->device_id, NULL, NULL, &st);
    if (!q->context) return cl_fail(err, st, device->name);
    q->queue = cl->CreateCommandQueue(q->context, device->device_id, 0, &st);
    if (!q->queue) {
        int rc = cl_fail(err, st, device->name);
        ohm_device_queue_close(q);
        return rc;
    }
    return OHM_OK;
}

void ohm_device_queue_close(ohm_device_queue *q)
{
    if (q->queue) q->cl->ReleaseCommandQueue(q->queue);
    if (q->context) q->cl->ReleaseContext(q->context);
    q->queue = NULL;
    q->context = NULL;
}

int ohm_device_build(cl_program *program, const ohm_device_queue *q, const char *source, const char *options,
                     ohm_error *err)
{
    const ohm_cl *cl = q->cl;
    cl_int st = CL_SUCCESS;
    *program = cl->CreateProgramWithSource(q->context, 1, &source, NULL, &st);
    if (!*program) return cl_fail(err, st, "creating a program");
    st = cl->BuildProgram(*program, 1, &q->device->device_id, options, NULL, NULL);
    if (st == CL_SUCCESS) return OHM_OK;
    /* the compiler's log, its first words on one line (the runtime refuses
     * a buffer shorter than the whole log) */
    char log[320] = "";
    size_t need = 0;
    char *whole = NULL;
    if (cl->GetProgramBuildInfo(*program, q->device->device_id, CL_PROGRAM_BUILD_LOG, 0, NULL, &need) ==
            CL_SUCCESS &&
        need > 0 && (whole = malloc(need + 1)) &&
        cl->GetProgramBuildInfo(*program, q->device->device_id, CL_PROGRAM_BUILD_LOG, need, whole, NULL) ==
            CL_SUCCESS) {
        whole[need] = '\0';
        const char *start = whole;
        while (*start == '\n' || *start == ' ') ++start;
        snprintf(log, sizeof log, "%s", start);
    }
    free(whole);
    for (char *c = log; *c; ++c)
        if (*c == '\n') *c = ' ';
    cl->ReleaseProgram(*program);
    *program = NULL;
    char buf[24];
    return ohm_fail(err, OHM_ERR_INTERNAL, "OpenCL: a kernel failed to build for %s (%s): %s", q->device->name,
                    ohm_cl_status(st, buf), log[0] ? log : "(the compiler left no log)");
}

static const char *triad_source =
    "__kernel void triad(__global float *a, __global const float *b, __global const float *c, float s,\n"
    "                    ulong n)\n"
    "{\n"
    "    size_t i = get_global_id(0);\n"
    "    if (i < n) a[i] = b[i] + s * c[i];\n"
    "}\n";

int ohm_device_triad(double *bytes_per_second, const ohm_device_queue *q, size_t count, int repeats,
                     ohm_error *err)
{
    const ohm_cl *cl = q->cl;
    *bytes_per_second = 0;
    float *host = malloc(3 * count * sizeof *host);
    if (!host) return ohm_fail(err, OHM_ERR_NOMEM, "out of memory for the triad's %zu floats", 3 * count);
    float *b = host + count, *c = host + 2 * count;
    for (size_t i = 0; i < count; ++i) {
        b[i] = (float)(i % 1000);
        c[i] = (float)(i % 7);
    }
    const float s = 3.0f;
    cl_program program = NULL;
    cl_kernel kernel = NULL;
    cl_mem mem[3] = {NULL, NULL, NULL};
    cl_int st = CL_SUCCESS;
    int rc = ohm_device_build(&program, q, triad_source, "", err);
    if (!rc) {
        kernel = cl->CreateKernel(program, "triad", &st);
        if (!kernel) rc = cl_fail(err, st, "the triad kernel");
    }
    for (int k = 0; !rc && k < 3; ++k) {
        mem[k] = cl->CreateBuffer(q->context, CL_MEM_READ_WRITE, count * sizeof(float), NULL, &st);
        if (!mem[k]) rc = cl_fail(err, st, "a buffer for the triad");
    }
    if (!rc) st = cl->EnqueueWriteBuffer(q->queue, mem[1], CL_TRUE, 0, count * sizeof(float), b, 0, NULL, NULL);
    if (!rc && st == CL_SUCCESS)
        st = cl->EnqueueWriteBuffer(q->queue, mem[2], CL_TRUE, 0, count * sizeof(float), c, 0, NULL, NULL);
    if (!rc && st != CL_SUCCESS) rc = cl_fail(err, st, "writing the triad's input");
    cl_ulong n64 = count;
    if (!rc) {
        cl->SetKernelArg(kernel, 0, sizeof(cl_mem), &mem[0]);
        cl->SetKernelArg(kernel, 1, sizeof(cl_mem), &mem[1]);
        cl->SetKernelArg(kernel, 2, sizeof(cl_mem), &mem[2]);
        cl->SetKernelArg(kernel, 3, sizeof s, &s);
        st = cl->SetKernelArg(kernel, 4, sizeof n64, &n64);
        if (st != CL_SUCCESS) rc = cl_fail(err, st, "the triad's arguments");
    }
    double best = 0;
    for (int r = 0; !rc && r <= repeats; ++r) { /* r == 0: the warm-up */
        double t0 = ohm_now();
        st = cl->EnqueueNDRangeKernel(q->queue, kernel, 1, NULL, &count, NULL, 0, NULL, NULL);
        if (st == CL_SUCCESS) st = cl->Finish(q->queue);
        if (st != CL_SUCCESS) rc = cl_fail(err, st, "running the triad");
        double t = ohm_now() - t0;
        if (r > 0 && t > 0 && 12.0 * (double)count / t > best) best = 12.0 * (double)count / t;
    }
    if (!rc) {
        st = cl->EnqueueReadBuffer(q->queue, mem[0], CL_TRUE, 0, count * sizeof(float), host, 0, NULL, NULL);
        if (st != CL_SUCCESS) rc = cl_fail(err, st, "reading the triad's result");
    }
    /* small integers: exact in float, with or without a fused multiply-add */
    for (size_t i = 0; !rc && i < count; ++i)
        if (host[i] != b[i] + s * c[i])
            rc = ohm_fail(err, OHM_ERR_NUMERIC, "OpenCL: %s computed the triad wrong at element %zu: %g, not %g",
                          q->device->name, i, (double)host[i], (double)(b[i] + s * c[i]));
    for (int k = 0; k < 3; ++k)
        if (mem[k]) cl->ReleaseMemObject(mem[k]);
    if (kernel) cl->ReleaseKernel(kernel);
    if (program) cl->ReleaseProgram(program);
    free(host);
    if (!rc) *bytes_per_second = best;
    return rc;
}
