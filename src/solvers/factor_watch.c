/* factor_watch.c — see factor_watch.h: dsyrk_, dgemm_, dpotrf_ and dtrsm_
 * are defined here, in front of the BLAS and LAPACK, so that CHOLMOD's
 * supernodal factorization reports progress and can be stopped. */
#define _GNU_SOURCE /* RTLD_NEXT */
#include "solvers/factor_watch.h"
#include "solvers/rebind.h"

#include <dlfcn.h>
#include <math.h>
#include <pthread.h>
#include <string.h>

/* the watch of the factorization running on this thread, or NULL */
static _Thread_local ohm_factor_watch *current;

/* The library's definition of `name`, the next one after this in the search
 * order; looked up once (a data pointer to a function pointer: POSIX's
 * dlsym guarantees it converts). */
static void *next_symbol(_Atomic(void *) *cache, const char *name)
{
    void *f = atomic_load(cache);
    if (!f) {
        f = dlsym(RTLD_NEXT, name);
        atomic_store(cache, f);
    }
    return f;
}
#define FORWARD(type, name) \
    static _Atomic(void *) cache_; \
    type real_; \
    *(void **)&real_ = next_symbol(&cache_, name)

/* 1 when the watched run is cancelled (the call must then do nothing);
 * else counts the call's flops and reports progress 20 times a second. */
static int watch_call(double flops)
{
    ohm_factor_watch *w = current;
    if (!w) return 0;
    if (w->cancelled || ohm_log_cancelled(w->progress.log)) {
        w->cancelled = 1;
        return 1;
    }
    w->done += flops;
    double t = ohm_now();
    if (t - w->t_reported >= 0.05) {
        w->t_reported = t;
        /* the callback may cancel: then this call is skipped too */
        if (ohm_progress_update(&w->progress, w->flops > 0 ? fmin(1.0, w->done / w->flops) : 0)) {
            w->cancelled = 1;
            return 1;
        }
    }
    return 0;
}

/* Each watched function is static, so that its address taken below is
 * this one's (an exported symbol's address resolves through the global
 * scope, to the host's LAPACK where the host links one), and exported under
 * LAPACK's name as an alias of it. */
#define EXPORT_AS(symbol, function) \
    __attribute__((visibility("default"), alias(#function))) __typeof__(function) symbol

typedef void (*dsyrk_fn)(const char *, const char *, const int *, const int *, const double *, const double *,
                         const int *, const double *, double *, const int *);
static void watched_dsyrk(const char *uplo, const char *trans, const int *n, const int *k, const double *alpha,
                          const double *a, const int *lda, const double *beta, double *c, const int *ldc)
{
    if (watch_call((double)*n * *n * *k)) return;
    FORWARD(dsyrk_fn, "dsyrk_");
    real_(uplo, trans, n, k, alpha, a, lda, beta, c, ldc);
}
EXPORT_AS(dsyrk_, watched_dsyrk);

typedef void (*dgemm_fn)(const char *, const char *, const int *, const int *, const int *, const double *,
                         const double *, const int *, const double *, const int *, const double *, double *,
                         const int *);
static void watched_dgemm(const char *ta, const char *tb, const int *m, const int *n, const int *k,
                          const double *alpha, const double *a, const int *lda, const double *b, const int *ldb,
                          const double *beta, double *c, const int *ldc)
{
    if (watch_call(2.0 * *m * *n * *k)) return;
    FORWARD(dgemm_fn, "dgemm_");
    real_(ta, tb, m, n, k, alpha, a, lda, b, ldb, beta, c, ldc);
}
EXPORT_AS(dgemm_, watched_dgemm);

typedef void (*dtrsm_fn)(const char *, const char *, const char *, const char *, const int *, const int *,
                         const double *, const double *, const int *, double *, const int *);
static void watched_dtrsm(const char *side, const char *uplo, const char *ta, const char *diag, const int *m,
                          const int *n, const double *alpha, const double *a, const int *lda, double *b,
                          const int *ldb)
{
    if (watch_call((double)*m * *n * *n)) return;
    FORWARD(dtrsm_fn, "dtrsm_");
    real_(side, uplo, ta, diag, m, n, alpha, a, lda, b, ldb);
}
EXPORT_AS(dtrsm_, watched_dtrsm);

typedef void (*dpotrf_fn)(const char *, const int *, double *, const int *, int *);
static void watched_dpotrf(const char *uplo, const int *n, double *a, const int *lda, int *info)
{
    if (watch_call((double)*n * *n * *n / 3.0)) {
        *info = 1; /* CHOLMOD stops here, as at a first pivot that is not positive */
        return;
    }
    FORWARD(dpotrf_fn, "dpotrf_");
    real_(uplo, n, a, lda, info);
}
EXPORT_AS(dpotrf_, watched_dpotrf);

/* CHOLMOD's calls bound to a LAPACK the host program loaded before libohm
 * (Blender links one) are pointed at ours, once per process (rebind.h);
 * where they already reach ours this changes nothing. */
static void rebind_cholmod(void)
{
    const ohm_rebind_target ours[] = {
        {"dsyrk_", (void (*)(void))watched_dsyrk},
        {"dgemm_", (void (*)(void))watched_dgemm},
        {"dtrsm_", (void (*)(void))watched_dtrsm},
        {"dpotrf_", (void (*)(void))watched_dpotrf},
    };
    ohm_rebind("libcholmod", ours, sizeof ours / sizeof *ours);
}

void ohm_factor_watch_begin(ohm_factor_watch *w, double flops, const ohm_log *log, const char *what)
{
    static pthread_once_t rebound = PTHREAD_ONCE_INIT;
    pthread_once(&rebound, rebind_cholmod);
    memset(w, 0, sizeof *w);
    ohm_progress_begin(&w->progress, log, what);
    w->flops = flops;
    w->t_reported = ohm_now();
    current = w;
}

void ohm_factor_watch_end(ohm_factor_watch *w)
{
    if (current == w) current = NULL;
    if (!w->cancelled) ohm_progress_end(&w->progress);
}
