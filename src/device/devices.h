/* devices.h — the OpenCL devices this machine has, and the one a run asks
 * for: device=gpu|cpu|opencl:N|auto (docs/devices.md), read once into an
 * ohm_device_request.
 *
 * Devices are numbered across platforms in the order the runtime lists
 * them (opencl:0, opencl:1, ...), as `ohm devices` prints them.  A device
 * runs ohm's solver only with double precision (the outer iteration is
 * fp64: cl_khr_fp64, or CL_DEVICE_DOUBLE_FP_CONFIG set). */
#ifndef OHM_DEVICE_DEVICES_H
#define OHM_DEVICE_DEVICES_H

#include "device/opencl.h"
#include "device/request.h"

typedef struct ohm_device {
    int index; /* opencl:N */
    cl_platform_id platform_id;
    cl_device_id device_id;
    char platform[96], name[96], version[64];
    int is_gpu;           /* CL_DEVICE_TYPE_GPU (or an accelerator)  */
    int fp64;             /* double precision                        */
    int atomics64;        /* cl_khr_int64_base_atomics: the tracer's tallies */
    int compute_units;
    double global_bytes;  /* CL_DEVICE_GLOBAL_MEM_SIZE               */
    double max_alloc_bytes; /* CL_DEVICE_MAX_MEM_ALLOC_SIZE: one buffer */
} ohm_device;

/* Every device of every platform: *out (free()), *count.  A runtime with
 * no platform gives 0 devices and OHM_OK. */
int ohm_device_list(ohm_device **out, int *count, const ohm_cl *cl, ohm_error *err);

/* The device `req` names among list[0..n): gpu the first GPU, cpu the
 * first CPU device, opencl:N that one, auto the first GPU, else none
 * (*picked -1 and OHM_OK: the caller runs on the host).  A device that
 * cannot be had (none of that kind, N out of range, no fp64) is an error
 * that says which devices there are. */
int ohm_device_pick(int *picked, const ohm_device *list, int n, const ohm_device_request *req, ohm_error *err);

/* A device in use: its context and queue. */
typedef struct ohm_device_queue {
    const ohm_cl *cl;
    const ohm_device *device;
    cl_context context;
    cl_command_queue queue;
} ohm_device_queue;

int ohm_device_queue_open(ohm_device_queue *q, const ohm_cl *cl, const ohm_device *device, ohm_error *err);
void ohm_device_queue_close(ohm_device_queue *q);

/* `source` built for the queue's device into *program; a failed build is
 * OHM_ERR_INTERNAL with the compiler's first lines. */
int ohm_device_build(cl_program *program, const ohm_device_queue *q, const char *source, const char *options,
                     ohm_error *err);

/* The device's memory bandwidth, measured: a single-precision triad
 * a = b + s c over `count` floats (12 bytes per element), run `repeats`
 * times after one warm-up; every element checked against the host's
 * arithmetic.  *bytes_per_second the best run's; OHM_ERR_NUMERIC when a
 * result differs. */
int ohm_device_triad(double *bytes_per_second, const ohm_device_queue *q, size_t count, int repeats,
                     ohm_error *err);

#endif
