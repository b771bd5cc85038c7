/* log.h — messages and progress on stderr (data goes to stdout or files),
 * or to the caller's callbacks (the public API's context: include/ohm.h).
 *
 * A run owns one ohm_log (no global logger).  Progress lines appear only for a
 * step that has already taken more than a second, at most once a second, so
 * short runs stay quiet and long ones show they are alive; a progress
 * callback is told every update (it decides how often to redraw). */
#ifndef OHM_LOG_H
#define OHM_LOG_H

#include <stdio.h>

#include "ohm/common.h" /* OHM_LOG_WARNING, OHM_LOG_INFO */

typedef struct ohm_log {
    FILE *stream;    /* where messages go; NULL = stderr                  */
    int verbosity;   /* 0 errors and warnings only, 1 normal, 2 verbose    */
    /* When set, messages go here instead (one line, no "ohm: " prefix and
     * no newline), and progress: what, the fraction done in [0, 1] (1 at
     * the end). */
    void (*message)(void *user, int level, const char *text);
    void (*progress)(void *user, const char *what, double fraction);
    void *user, *progress_user; /* passed to message and to progress */
} ohm_log;

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
void ohm_progress_update(ohm_progress *p, double fraction);
void ohm_progress_end(ohm_progress *p);

#endif
