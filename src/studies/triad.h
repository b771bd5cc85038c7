/* studies/triad.h — the memory bandwidth these threads can stream: STREAM's
 * triad a = b + s c (McCalpin, "Memory bandwidth and machine balance in
 * current high performance computers", IEEE TCCA Newsletter, 1995), on
 * arrays far beyond the caches, each thread first touching its own part.
 * Bytes are counted as STREAM counts them, 3 x 8 per element (the
 * write-allocate read of a is not).  `ohm bench` and tests/bench_mg.c set
 * their solves against it. */
#ifndef OHM_STUDIES_TRIAD_H
#define OHM_STUDIES_TRIAD_H

#include "base/ohm_error.h"

/* The best of `repeats` triads over total_bytes of three arrays on
 * `threads` threads, in bytes per second. */
int ohm_triad(int threads, double total_bytes, int repeats, double *bytes_per_second, ohm_error *err);

#endif
