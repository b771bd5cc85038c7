/* mg_device.h — solver=mg on an OpenCL device: the hierarchy built on the
 * host (mg.h) is copied to the device once, and the whole solve runs there
 * — the outer flexible CG in double on the network's stencil, the K-cycle
 * in single precision, the coarsest level's dense factor — the same cycle
 * and iteration as the host's (mg_cycle.c) over the device's operations
 * (mg_ops.h; kernels: mg_device.cl).  The
 * host sends the right-hand side and the warm start and receives the
 * solution; a kept solver (keep=1, relighting) keeps its hierarchy on the
 * device between solves. */
#ifndef OHM_SOLVERS_MG_DEVICE_H
#define OHM_SOLVERS_MG_DEVICE_H

#include "device/request.h"
#include "solvers/mg.h"

typedef struct ohm_mg_device ohm_mg_device;

/* The device `req` names (device= of -solve: gpu, cpu, opencl:N, auto;
 * devices.h), with mg's hierarchy copied to it.  *out NULL and OHM_OK when
 * req is NULL or the host, or auto finds no GPU: the caller solves on the host.  No
 * runtime, no such device, no double precision, too little device memory,
 * a kernel that does not build: an error that says which. */
int ohm_mg_device_open(ohm_mg_device **out, const ohm_mg *mg, const ohm_device_request *req, const ohm_log *log,
                       ohm_error *err);

/* As ohm_mg_solve (mg.h), on the device. */
int ohm_mg_device_solve(ohm_mg_device *d, double *x, const double *b, double tol, int64_t max_iter,
                        const ohm_log *log, int64_t *iters, double *relres, ohm_error *err);

/* The device's name ("pthread-skylake-avx512-AMD EPYC ..."), and the bytes
 * its buffers take. */
const char *ohm_mg_device_name(const ohm_mg_device *d);
double ohm_mg_device_bytes(const ohm_mg_device *d);

void ohm_mg_device_free(ohm_mg_device *d); /* NULL is fine */

#endif
