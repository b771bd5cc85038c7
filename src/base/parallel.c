/* sched_getaffinity and CPU_COUNT are GNU extensions */
#define _GNU_SOURCE
#include "base/parallel.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
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
