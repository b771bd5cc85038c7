/* api/context.c — version, the per-thread last error, the context. */
#include "api/api.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ohm_version.h"

/* Per thread, as libgit2's git_error_last: two threads never see each
 * other's messages, and no call needs a context to report that it could not
 * make one. */
static _Thread_local ohm_error last_error;

const char *ohm_version(int *major, int *minor, int *patch)
{
    if (major) *major = OHM_VERSION_MAJOR;
    if (minor) *minor = OHM_VERSION_MINOR;
    if (patch) *patch = OHM_VERSION_PATCH;
    return OHM_VERSION;
}

const char *ohm_error_last(void)
{
    return last_error.msg;
}

int ohm_error_last_code(void)
{
    return last_error.code;
}

int ohm_api_return(int rc, const ohm_error *err)
{
    if (rc == OHM_OK) return rc;
    last_error.code = rc;
    snprintf(last_error.msg, sizeof last_error.msg, "%s", err && err->msg[0] ? err->msg : "failed");
    return rc;
}

int ohm_api_fail(int code, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    last_error.code = code;
    vsnprintf(last_error.msg, sizeof last_error.msg, fmt, ap);
    va_end(ap);
    return code;
}

int ohm_api_sized_ok(size_t size, size_t end_of_first, const char *fn, const char *init)
{
    if (size < end_of_first)
        return ohm_api_fail(OHM_ERR_USAGE, "%s: out->size is %zu, less than the %zu bytes of the struct's first "
                            "version: set it with %s", fn, size, end_of_first, init);
    return OHM_OK;
}

int ohm_context_new(ohm_context **out)
{
    if (!out) return ohm_api_fail(OHM_ERR_USAGE, "ohm_context_new: out is NULL");
    *out = calloc(1, sizeof **out);
    if (!*out) return ohm_api_fail(OHM_ERR_NOMEM, "ohm_context_new: out of memory");
    (*out)->log.verbosity = 1;
    atomic_init(&(*out)->cancel, 0);
    pthread_mutex_init(&(*out)->progress_lock, NULL);
    (*out)->log.cancel = &(*out)->cancel;
    return OHM_OK;
}

void ohm_context_cancel(ohm_context *ctx)
{
    /* a lock-free store: async-signal-safe (the CLI calls it from SIGINT) */
    if (ctx) atomic_store(&ctx->cancel, 1);
}

void ohm_context_free(ohm_context *ctx)
{
    if (!ctx) return;
    pthread_mutex_destroy(&ctx->progress_lock);
    free(ctx);
}

void ohm_context_set_verbosity(ohm_context *ctx, int verbosity)
{
    if (ctx) ctx->log.verbosity = verbosity < 0 ? 0 : verbosity > 2 ? 2 : verbosity;
}

void ohm_context_set_log(ohm_context *ctx, ohm_log_callback fn, void *user)
{
    if (!ctx) return;
    ctx->log.message = fn;
    ctx->log.user = user;
}

void ohm_context_set_progress(ohm_context *ctx, ohm_progress_callback fn, void *user)
{
    if (!ctx) return;
    ctx->log.progress = fn;
    ctx->log.progress_user = user;
}

/* The progress callback of a polling context: the report kept, nothing
 * called, nothing printed. */
static void keep_progress(void *user, const char *what, double fraction)
{
    ohm_context *ctx = user;
    pthread_mutex_lock(&ctx->progress_lock);
    snprintf(ctx->progress_what, sizeof ctx->progress_what, "%s", what ? what : "");
    ctx->progress_fraction = fraction;
    pthread_mutex_unlock(&ctx->progress_lock);
}

void ohm_context_poll_progress(ohm_context *ctx)
{
    if (!ctx) return;
    keep_progress(ctx, "", 0.0);
    ctx->log.progress = keep_progress;
    ctx->log.progress_user = ctx;
}

int ohm_context_progress(ohm_context *ctx, char *what, size_t size, double *fraction)
{
    if (!ctx) return ohm_api_fail(OHM_ERR_USAGE, "ohm_context_progress: ctx is NULL");
    pthread_mutex_lock(&ctx->progress_lock);
    if (what && size) snprintf(what, size, "%s", ctx->progress_what);
    if (fraction) *fraction = ctx->progress_fraction;
    pthread_mutex_unlock(&ctx->progress_lock);
    return OHM_OK;
}
