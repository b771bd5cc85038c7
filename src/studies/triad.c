/* studies/triad.c — STREAM's triad on this machine's threads (triad.h). */
#include "studies/triad.h"

#include <math.h>
#include <pthread.h>
#include <stdlib.h>

#include "base/log.h"

typedef struct triad_task {
    double *a, *b, *c;
    size_t lo, hi;
    int init;              /* first touch: each thread owns its pages */
} triad_task;

static void *triad_worker(void *arg)
{
    triad_task *t = arg;
    double *restrict a = t->a, *restrict b = t->b, *restrict c = t->c;
    if (t->init) {
        for (size_t i = t->lo; i < t->hi; ++i) {
            a[i] = 0.0;
            b[i] = 1.0;
            c[i] = 2.0;
        }
        return NULL;
    }
    const double s = 3.0;
    for (size_t i = t->lo; i < t->hi; ++i) a[i] = b[i] + s * c[i];
    return NULL;
}

/* Run every task, task 0 on this thread; a task that gets no thread runs
 * here too (slower, but still right). */
static void run_tasks(triad_task *tasks, pthread_t *th, int nt)
{
    int started = 1;
    while (started < nt && pthread_create(&th[started], NULL, triad_worker, &tasks[started]) == 0) ++started;
    for (int i = started; i < nt; ++i) triad_worker(&tasks[i]);
    triad_worker(&tasks[0]);
    for (int i = 1; i < started; ++i) pthread_join(th[i], NULL);
}

int ohm_triad(int threads, double total_bytes, int repeats, double *bytes_per_second, ohm_error *err)
{
    int nt = threads > 0 ? threads : 1;
    size_t n = (size_t)(total_bytes / (3 * sizeof(double)));
    double *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b), *c = malloc(n * sizeof *c);
    triad_task *tasks = calloc((size_t)nt, sizeof *tasks);
    pthread_t *th = calloc((size_t)nt, sizeof *th);
    if (!a || !b || !c || !tasks || !th) {
        free(a), free(b), free(c), free(tasks), free(th);
        return ohm_fail(err, OHM_ERR_NOMEM, "bench: out of memory for the %.0f MB bandwidth test",
                        total_bytes / 1e6);
    }
    for (int i = 0; i < nt; ++i)
        tasks[i] = (triad_task){a, b, c, n * (size_t)i / (size_t)nt, n * (size_t)(i + 1) / (size_t)nt, 1};
    run_tasks(tasks, th, nt);
    for (int i = 0; i < nt; ++i) tasks[i].init = 0;
    double best = INFINITY;
    for (int r = 0; r < repeats; ++r) {
        double t0 = ohm_now();
        run_tasks(tasks, th, nt);
        best = fmin(best, ohm_now() - t0);
    }
    int sane = a[0] == 7.0 && a[n - 1] == 7.0; /* and the stores are used */
    free(a), free(b), free(c), free(tasks), free(th);
    if (!sane || !(best > 0)) return ohm_fail(err, OHM_ERR_INTERNAL, "bench: the bandwidth test went wrong");
    *bytes_per_second = 3.0 * sizeof(double) * (double)n / best;
    return OHM_OK;
}

