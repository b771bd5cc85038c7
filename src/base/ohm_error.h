/* ohm_error.h — status codes and the error record every ohm call fills.
 *
 * Convention (after libgit2/CHOLMOD): functions return int, 0 = OK, negative =
 * error; the caller passes an ohm_error it owns, the callee writes a one-line
 * message into it ("file:line: what is wrong, what was expected").  There is no
 * global "last error": the record travels with the call, so two threads or two
 * runs never see each other's messages.  This header is plain C and is also
 * included by the C++ wrappers. */
#ifndef OHM_ERROR_H
#define OHM_ERROR_H

#include <stddef.h>

#include "ohm/common.h" /* the status codes */

#ifdef __cplusplus
extern "C" {
#endif

#define OHM_ERROR_MSG_MAX 1024

typedef struct ohm_error {
    int code;                      /* last status, 0 when none             */
    char msg[OHM_ERROR_MSG_MAX];   /* one line, no trailing newline        */
} ohm_error;

/* Record an error (printf-style) and return `code`, so callers can write
 * `return ohm_fail(err, OHM_ERR_PARSE, "%s:%zu: ...", path, line);`.
 * A NULL err is allowed (the message is dropped). */
int ohm_fail(ohm_error *err, int code, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* Clear the record. */
void ohm_error_clear(ohm_error *err);

/* Make a failure name the file it came from: when code is an error and the
 * message does not already hold `name`, it becomes "name: message" (a
 * library's exception text, "OpenVDB: ArithmeticError: ...", then says where).
 * Returns code. */
int ohm_error_name(ohm_error *err, int code, const char *name);

#ifdef __cplusplus
}
#endif
#endif
