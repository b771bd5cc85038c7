/* log.h — messages and progress on stderr (data goes to stdout or files),
 * or to the caller's callbacks (the public API's context: include/ohm.h).
 *
 * A run owns one ohm_log (no global logger).  Progress lines appear only for a
 * step that has already taken more than a second, at most once a second, so
 * short runs stay quiet and long ones show they are alive; a progress
 * callback is told every update (it decides how often to redraw). */
#ifndef OHM_LOG_H
#define OHM_LOG_H

#include <stdatomic.h>
#include <stdio.h>

#include "base/ohm_error.h" /* OHM_LOG_WARNING, OHM_LOG_INFO, OHM_ERR_CANCELLED */

/* One progress bar over several steps: while hi > lo, a step's fraction f
 * is shown as lo + f (hi - lo) (a solve's channels and batches of frames,
 * each an iterative solve of its own, fill one bar from 0 to 100%). */
typedef struct ohm_progress_span {
    double lo, hi;
} ohm_progress_span;

typedef struct ohm_log {
    FILE *stream;    /* where messages go; NULL = stderr                  */
    int verbosity;   /* 0 errors and warnings only, 1 normal, 2 verbose    */
    /* When set, messages go here instead (one line, no "ohm: " prefix and
     * no newline), and progress: what, the fraction done in [0, 1] (1 at
     * the end). */
    void (*message)(void *user, int level, const char *text);
    void (*progress)(void *user, const char *what, double fraction);
    void *user, *progress_user; /* passed to message and to progress */
    /* The run's cancellation request (the API context's, set by
     * ohm_context_cancel from any thread or a signal handler), or NULL:
     * never cancelled.  Long steps poll it, through ohm_progress_update or
     * ohm_log_cancelled, at least about every 0.1 s of work, and return
     * OHM_ERR_CANCELLED, having freed what they made. */
    const atomic_int *cancel;
    /* The share of one progress bar the steps now running fill, or NULL:
     * each step's own 0 to 100% (owned by whoever set it: a solver). */
    const ohm_progress_span *span;
} ohm_log;

/* 1 when the run has been asked to stop. */
static inline int ohm_log_cancelled(const ohm_log *log)
{
    return log && log->cancel && atomic_load_explicit(log->cancel, memory_order_relaxed);
}

/* OHM_ERR_CANCELLED with the message every cancelled step gives, naming the
 * step ("voxelize", "factorize", ...). */
int ohm_fail_cancelled(ohm_error *err, const char *step);

void ohm_log_info(const ohm_log *log, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
void ohm_log_warn(const ohm_log *log, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* Monotonic wall clock, seconds. */
double ohm_now(void);

typedef struct ohm_progress {
    const ohm_log *log;
    const char *what;
    double t_begin, t_last;
    int printed;
} ohm_progress;

void ohm_progress_begin(ohm_progress *p, const ohm_log *log, const char *what);
/* Report the fraction done; 1 when the run has been asked to stop (checked
 * after the progress callback, which may itself ask), else 0. */
int ohm_progress_update(ohm_progress *p, double fraction);
void ohm_progress_end(ohm_progress *p);

#endif
