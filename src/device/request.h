/* request.h — the device a run asks for (device= of -solve, of `ohm
 * validate transport|mc` and of `ohm bench`), read once from its text where
 * the text comes in and passed on typed: the layers below ask its kind,
 * never compare names.  No OpenCL here: the solvers' and the tracer's
 * parameters carry a request without the runtime's headers (devices.h
 * finds the device it names). */
#ifndef OHM_DEVICE_REQUEST_H
#define OHM_DEVICE_REQUEST_H

#include <stddef.h>

#include "base/ohm_error.h"

/* Zeroed is the host. */
typedef enum ohm_device_kind {
    OHM_DEVICE_HOST = 0, /* this machine's cores                               */
    OHM_DEVICE_AUTO,     /* the first GPU with double precision when the work
                            pays for opening it, else the host                 */
    OHM_DEVICE_GPU,      /* the first GPU with double precision                */
    OHM_DEVICE_CPU,      /* the first OpenCL CPU device                        */
    OHM_DEVICE_INDEX     /* opencl:N, as `ohm devices` numbers them            */
} ohm_device_kind;

typedef struct ohm_device_request {
    ohm_device_kind kind;
    int index; /* OHM_DEVICE_INDEX: N */
} ohm_device_request;

/* "host", "auto", "gpu", "cpu" or "opencl:N" into *out; anything else is
 * OHM_ERR_USAGE saying what is expected (ohm_device_request_expected). */
int ohm_device_request_parse(ohm_device_request *out, const char *text, ohm_error *err);

/* NULL when text is a request, else what a request looks like (for an
 * option's message). */
const char *ohm_device_request_expected(const char *text);

/* The request as device= would name it ("opencl:2"), into buf. */
const char *ohm_device_request_name(const ohm_device_request *r, char *buf, size_t size);

#endif
