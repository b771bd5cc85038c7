/* sched_getaffinity and CPU_COUNT are GNU extensions */
#define _GNU_SOURCE
#include "base/parallel.h"

#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include <unistd.h>
#if defined(__linux__)
#include <sched.h>
#endif

int ohm_usable_cores(void)
{
#if defined(__linux__)
    cpu_set_t set;
    if (sched_getaffinity(0, sizeof set, &set) == 0) {
        int n = CPU_COUNT(&set);
        if (n > 0) return n;
    }
#endif
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n > 0 ? (int)n : 1;
}

/* The machine's busy and idle ticks so far (the "cpu" line of /proc/stat:
 * idle and iowait are idle); 0 when it cannot be read. */
static int cpu_ticks(double *busy, double *idle)
{
    FILE *f = fopen("/proc/stat", "r");
    if (!f) return 0;
    unsigned long long v[8] = {0};
    int got = fscanf(f, "cpu %llu %llu %llu %llu %llu %llu %llu %llu", &v[0], &v[1], &v[2], &v[3], &v[4], &v[5],
                     &v[6], &v[7]);
    fclose(f);
    if (got < 5) return 0;
    *idle = (double)(v[3] + v[4]);
    *busy = (double)(v[0] + v[1] + v[2] + v[5] + v[6] + v[7]);
    return 1;
}

int ohm_idle_cores(double sample_seconds)
{
    int usable = ohm_usable_cores();
    long online = sysconf(_SC_NPROCESSORS_ONLN);
    double b0, i0, b1, i1;
    if (online < 1 || !cpu_ticks(&b0, &i0)) return usable;
    struct timespec pause = {(time_t)sample_seconds, (long)(1e9 * (sample_seconds - (double)(time_t)sample_seconds))};
    nanosleep(&pause, NULL);
    if (!cpu_ticks(&b1, &i1) || b1 + i1 <= b0 + i0) return usable;
    int idle = (int)lround((double)online * (i1 - i0) / ((b1 + i1) - (b0 + i0)));
    return idle < 1 ? 1 : idle > usable ? usable : idle;
}

typedef struct shared_loop {
    _Atomic int64_t next;
    int64_t count;
    void (*job)(void *user, int64_t i);
    void *user;
} shared_loop;

static void *run_loop(void *arg)
{
    shared_loop *loop = arg;
    for (int64_t i; (i = atomic_fetch_add(&loop->next, 1)) < loop->count;) loop->job(loop->user, i);
    return NULL;
}

enum { PARALLEL_MAX_THREADS = 64 };

int ohm_parallel_for(int64_t count, int threads, void (*job)(void *user, int64_t i), void *user)
{
    if (count <= 0) return 0;
    if (threads > count) threads = (int)count;
    if (threads > PARALLEL_MAX_THREADS) threads = PARALLEL_MAX_THREADS;
    if (threads < 1) threads = 1;
    shared_loop loop = {.count = count, .job = job, .user = user};
    atomic_init(&loop.next, 0);
    pthread_t helper[PARALLEL_MAX_THREADS];
    int started = 0;
    while (started < threads - 1 && pthread_create(&helper[started], NULL, run_loop, &loop) == 0) ++started;
    run_loop(&loop);
    for (int k = 0; k < started; ++k) pthread_join(helper[k], NULL);
    return started + 1;
}
