/* session.h — one run's use of an OpenCL device (docs/design.md §6): the runtime
 * loaded, the device that device= names opened with a queue, and the
 * buffers and kernel launches of whoever runs there (mg_device.c,
 * mc_device.c), with their failures said once, in the run's terms.
 *
 * The caller owns the session (no process-wide state).  Launch failures
 * are kept in `status` until ohm_device_checked turns the first into an
 * error, so that a sequence of launches is checked once. */
#ifndef OHM_DEVICE_SESSION_H
#define OHM_DEVICE_SESSION_H

#include "base/log.h"
#include "device/devices.h"

typedef struct ohm_device_session {
    ohm_cl cl;
    ohm_device *devices;
    int ndevices;
    int picked;            /* opencl:N in use                        */
    ohm_device_queue q;
    const char *what;      /* "mg", "monte carlo": errors say "<what> on <device>: ..." */
    double bytes;          /* device memory its buffers take         */
    cl_int status;         /* the first failed launch since the last check */
} ohm_device_session;

/* Opens the device `req` names (devices.h: gpu, cpu, opencl:N, auto) into
 * *s (zeroed first).  *opened 0 and OHM_OK when req is NULL or the host, or
 * auto finds no GPU with double precision (then a log line says the work
 * stays on the host); otherwise the runtime, the device and its queue are
 * open, or an error says which of them is missing. */
int ohm_device_session_open(ohm_device_session *s, int *opened, const ohm_device_request *req, const char *what,
                            const ohm_log *log, ohm_error *err);
void ohm_device_session_close(ohm_device_session *s); /* zeroed is fine */

const ohm_device *ohm_device_session_device(const ohm_device_session *s);

/* An OpenCL failure as an error naming the run and the device:
 * OHM_ERR_NOMEM for the codes that mean memory, else OHM_ERR_INTERNAL. */
int ohm_device_failed(const ohm_device_session *s, ohm_error *err, cl_int status, const char *doing);

/* A buffer of `bytes` (counted in s->bytes), filled from host unless NULL;
 * an array larger than one buffer may be is refused, naming `advice` (what
 * the user can do). */
int ohm_device_buffer(ohm_device_session *s, cl_mem *mem, size_t bytes, const void *host, const char *advice,
                      ohm_error *err);
void ohm_device_release(ohm_device_session *s, cl_mem *mem); /* *mem NULL is fine; sets it NULL */

/* A blocking copy to (to_device) or from the device. */
int ohm_device_copy(ohm_device_session *s, cl_mem mem, void *host, size_t bytes, int to_device, ohm_error *err);

/* kernel k's argument i; a failure is kept in s->status */
void ohm_device_arg(ohm_device_session *s, cl_kernel k, cl_uint i, size_t size, const void *value);
/* k over `global` work-items in groups of `local`; a failure kept likewise */
void ohm_device_launch(ohm_device_session *s, cl_kernel k, size_t global, size_t local);

/* The launches' first failure since the last check, as an error; cleared. */
int ohm_device_checked(ohm_device_session *s, ohm_error *err);

/* The largest power of two up to `most` that the device runs in one
 * work-group. */
size_t ohm_device_group_size(const ohm_device_session *s, size_t most);

/* `source` built into *program with `options` (or, under OHM_TEST_HOOKS,
 * the environment's OHM_TEST_KERNEL_OPTIONS, so that a kernel that fails
 * to build is tested), and its kernels names[0..count) into kernels. */
int ohm_device_kernels(ohm_device_session *s, cl_program *program, cl_kernel *kernels, const char *const *names,
                       int count, const char *source, const char *options, ohm_error *err);

#endif
