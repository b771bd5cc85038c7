/* api/api.h — what the public API's files share (include/ohm.h): the
 * context and scene behind the opaque handles, and the per-thread last
 * error every exported call sets when it fails. */
#ifndef OHM_API_INTERNAL_H
#define OHM_API_INTERNAL_H

#include "ohm.h"

#include <pthread.h>

#include "base/ohm_error.h"
#include "steps/state.h"

struct ohm_context {
    ohm_log log;            /* verbosity and the caller's callbacks; log.cancel
                               points at `cancel`                             */
    atomic_int cancel;      /* ohm_context_cancel's request for the calls
                               running; cleared as the next call begins      */
    /* the latest progress report, kept for ohm_context_progress when the
     * context polls (ohm_context_poll_progress); any thread reads it */
    pthread_mutex_t progress_lock;
    char progress_what[64];
    double progress_fraction;
};

struct ohm_scene {
    ohm_context *ctx;
    ohm_state state;        /* the chain's state: mesh, grid, material, lights, solver */
};

/* Record err as this thread's last error and return its code (OHM_OK: the
 * last error is left as it was). */
int ohm_api_return(int rc, const ohm_error *err);

/* Record a message as this thread's last error and return code. */
int ohm_api_fail(int code, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* OHM_OK when a caller's sized struct (ohm.h's ABI rule) holds at least
 * the fields of the struct's first version, its first end_of_first bytes;
 * else OHM_ERR_USAGE, naming fn and the struct's *_INIT. */
int ohm_api_sized_ok(size_t size, size_t end_of_first, const char *fn, const char *init);

/* The scene's log follows its context's (set before every step). */
void ohm_api_sync_log(ohm_scene *scene);

/* A call that runs steps on the scene begins: a cancellation requested
 * before it (aimed at an earlier call, or made while none ran) is dropped,
 * and the scene's log follows its context's. */
void ohm_api_scene_begin(ohm_scene *scene);

#endif
