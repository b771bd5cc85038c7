/* sched_getaffinity and CPU_COUNT are GNU extensions */
#define _GNU_SOURCE
#include "base/parallel.h"

#include <dirent.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
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

/* The tasks runnable on the machine now (the fourth field of
 * /proc/loadavg, "running/total"); -1 when unreadable. */
static int runnable_tasks(void)
{
    FILE *f = fopen("/proc/loadavg", "r");
    if (!f) return -1;
    double l1, l5, l15;
    int running = 0, total = 0;
    int got = fscanf(f, "%lf %lf %lf %d/%d", &l1, &l5, &l15, &running, &total);
    fclose(f);
    return got == 5 ? running : -1;
}

/* This process's threads that are runnable now (state R in
 * /proc/self/task/N/stat): this one, and a BLAS's that still spin after
 * its last call; -1 when unreadable. */
static int own_runnable_threads(void)
{
    DIR *d = opendir("/proc/self/task");
    if (!d) return -1;
    int count = 0;
    for (struct dirent *e; (e = readdir(d));) {
        if (e->d_name[0] == '.') continue;
        char path[64], line[512];
        snprintf(path, sizeof path, "/proc/self/task/%.20s/stat", e->d_name);
        FILE *f = fopen(path, "r");
        if (!f) continue;
        size_t len = fread(line, 1, sizeof line - 1, f);
        fclose(f);
        line[len] = 0;
        const char *end = strrchr(line, ')'); /* the name may hold spaces */
        if (end && end[1] == ' ' && end[2] == 'R') ++count;
    }
    closedir(d);
    return count;
}

int ohm_idle_cores(double sample_seconds)
{
    int usable = ohm_usable_cores();
    long online = sysconf(_SC_NPROCESSORS_ONLN);
    /* the fewest runnable over a few looks, this process's own threads not
     * counted: a process that keeps a core busy is runnable at each, a
     * kernel thread's moment is not */
    enum { LOOKS = 5 };
    int fewest = 0;
    for (int k = 0; k < LOOKS; ++k) {
        int all = runnable_tasks(), own = own_runnable_threads();
        if (all < 0 || own < 0) return usable;
        int others = all - own > 0 ? all - own : 0;
        if (k == 0 || others < fewest) fewest = others;
        if (k + 1 < LOOKS) {
            double dt = sample_seconds / (LOOKS - 1);
            struct timespec pause = {(time_t)dt, (long)(1e9 * (dt - (double)(time_t)dt))};
            nanosleep(&pause, NULL);
        }
    }
    long idle = online - fewest;
    return idle < 1 ? 1 : idle > usable ? usable : (int)idle;
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
