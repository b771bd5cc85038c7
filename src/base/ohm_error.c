#include "base/ohm_error.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

int ohm_fail(ohm_error *err, int code, const char *fmt, ...)
{
    if (err) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err->msg, sizeof err->msg, fmt, ap);
        va_end(ap);
        /* Keep it one line: a message is shown as "ohm: <msg>". */
        for (char *p = err->msg; *p; ++p)
            if (*p == '\n' || *p == '\r') *p = ' ';
        err->code = code;
    }
    return code;
}

void ohm_error_clear(ohm_error *err)
{
    if (err) {
        err->code = 0;
        err->msg[0] = '\0';
    }
}

int ohm_error_name(ohm_error *err, int code, const char *name)
{
    if (!err || code == 0 || !name || strstr(err->msg, name)) return code;
    char why[OHM_ERROR_MSG_MAX];
    snprintf(why, sizeof why, "%s", err->msg);
    return ohm_fail(err, code, "%s: %s", name, why);
}
