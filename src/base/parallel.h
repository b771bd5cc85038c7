/* parallel.h — how many cores a step may use, and a loop shared by threads.
 *
 * ohm keeps no thread pool (no hidden global state): a step that pays for
 * a second core starts its threads, shares the work and joins them before
 * it returns.  Creating and joining a thread costs ~20-50 us here, so the
 * callers only share loops of milliseconds or more. */
#ifndef OHM_PARALLEL_H
#define OHM_PARALLEL_H

#include <stdint.h>

/* Cores this process may run on (its CPU affinity, so `taskset` and
 * container cpusets count; else the cores online), at least 1: how many
 * threads a step may keep busy. */
int ohm_usable_cores(void);

/* Of the cores this process may use, how many the rest of the machine
 * leaves idle: the online cores less the runnable tasks that are not this
 * process's threads (the kernel's counts in /proc/loadavg and
 * /proc/self/task), the fewest over a few looks spread across
 * `sample_seconds`; at least 1; the usable cores where it cannot be read.
 * For a step whose threads wait for each other (the BLAS's): on a core
 * another process keeps busy such a thread is descheduled while its
 * partners spin. */
int ohm_idle_cores(double sample_seconds);

/* job(user, i) for every i in 0 .. count-1, on up to `threads` threads
 * (the caller's among them).  Each index is run whole by one thread; the
 * threads take the next index from a shared counter, so uneven jobs
 * balance.  Jobs must write disjoint memory (or their own slots of the
 * caller's arrays): the result is then the same on any number of threads.
 * A thread that cannot be created leaves its share to the others; returns
 * how many threads ran. */
int ohm_parallel_for(int64_t count, int threads, void (*job)(void *user, int64_t i), void *user);

#endif
