/* device/request.c — see request.h. */
#include "device/request.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const char *ohm_device_request_expected(const char *text)
{
    ohm_device_request r;
    return ohm_device_request_parse(&r, text, NULL) ? "expected host, gpu, cpu, opencl:N or auto" : NULL;
}

int ohm_device_request_parse(ohm_device_request *out, const char *text, ohm_error *err)
{
    static const struct {
        const char *name;
        ohm_device_kind kind;
    } kinds[] = {{"host", OHM_DEVICE_HOST}, {"auto", OHM_DEVICE_AUTO}, {"gpu", OHM_DEVICE_GPU}, {"cpu", OHM_DEVICE_CPU}};
    memset(out, 0, sizeof *out);
    for (size_t i = 0; text && i < sizeof kinds / sizeof *kinds; ++i)
        if (strcmp(text, kinds[i].name) == 0) {
            out->kind = kinds[i].kind;
            return OHM_OK;
        }
    if (text && strncmp(text, "opencl:", 7) == 0) {
        char *end = NULL;
        long k = strtol(text + 7, &end, 10);
        if (end != text + 7 && !*end && k >= 0 && k < 1000000) {
            out->kind = OHM_DEVICE_INDEX;
            out->index = (int)k;
            return OHM_OK;
        }
    }
    return ohm_fail(err, OHM_ERR_USAGE, "device=%s: expected host, gpu, cpu, opencl:N or auto", text ? text : "");
}

const char *ohm_device_request_name(const ohm_device_request *r, char *buf, size_t size)
{
    static const char *const names[] = {"host", "auto", "gpu", "cpu"};
    if (r && r->kind == OHM_DEVICE_INDEX) snprintf(buf, size, "opencl:%d", r->index);
    else snprintf(buf, size, "%s", names[r ? r->kind : OHM_DEVICE_HOST]);
    return buf;
}
