#include "base/log.h"

#include <stdarg.h>
#include <time.h>

static FILE *log_stream(const ohm_log *log) { return (log && log->stream) ? log->stream : stderr; }

static void log_emit(const ohm_log *log, int level, const char *fmt, va_list ap)
{
    if (log && log->message) {
        char text[2048];
        vsnprintf(text, sizeof text, fmt, ap);
        log->message(log->user, level, text);
        return;
    }
    FILE *f = log_stream(log);
    fputs(level == OHM_LOG_WARNING ? "ohm: warning: " : "ohm: ", f);
    vfprintf(f, fmt, ap);
    fputc('\n', f);
}

void ohm_log_info(const ohm_log *log, const char *fmt, ...)
{
    if (log && log->verbosity < 1) return;
    va_list ap;
    va_start(ap, fmt);
    log_emit(log, OHM_LOG_INFO, fmt, ap);
    va_end(ap);
}

void ohm_log_warn(const ohm_log *log, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    log_emit(log, OHM_LOG_WARNING, fmt, ap);
    va_end(ap);
}

double ohm_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

void ohm_progress_begin(ohm_progress *p, const ohm_log *log, const char *what)
{
    p->log = log;
    p->what = what;
    p->t_begin = p->t_last = ohm_now();
    p->printed = 0;
}

/* A step's fraction on the bar its log's span gives it. */
static double spanned(const ohm_log *log, double fraction)
{
    const ohm_progress_span *s = log ? log->span : NULL;
    return s && s->hi > s->lo ? s->lo + fraction * (s->hi - s->lo) : fraction;
}

int ohm_progress_update(ohm_progress *p, double fraction)
{
    if (!p) return 0;
    fraction = spanned(p->log, fraction);
    if (p->log && p->log->progress) {
        p->log->progress(p->log->progress_user, p->what, fraction);
        return ohm_log_cancelled(p->log);
    }
    if (p->log && p->log->verbosity < 1) return ohm_log_cancelled(p->log);
    double t = ohm_now();
    if (t - p->t_begin < 1.0 || t - p->t_last < 1.0) return ohm_log_cancelled(p->log);
    p->t_last = t;
    p->printed = 1;
    fprintf(log_stream(p->log), "ohm: %s: %3.0f%% (%.1f s)\n", p->what, 100.0 * fraction, t - p->t_begin);
    return ohm_log_cancelled(p->log);
}

int ohm_fail_cancelled(ohm_error *err, const char *step)
{
    return ohm_fail(err, OHM_ERR_CANCELLED, "%s: cancelled", step);
}

void ohm_progress_end(ohm_progress *p)
{
    if (p && p->log && p->log->progress) {
        p->log->progress(p->log->progress_user, p->what, spanned(p->log, 1.0));
        return;
    }
    if (!p || !p->printed) return;
    fprintf(log_stream(p->log), "ohm: %s: done (%.1f s)\n", p->what, ohm_now() - p->t_begin);
}
