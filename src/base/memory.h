/* memory.h — how much memory a step may use, asked before allocating.
 *
 * The limit is max_memory= when the user gives it, else what the machine
 * reports available (MemAvailable, or a lower cgroup limit).  Steps estimate
 * their need first (the voxel grid from its cell count, the factor from the
 * symbolic analysis, where nnz(L) is known before factorizing) and refuse
 * with both figures and a way out, instead of failing half way. */
#ifndef OHM_MEMORY_H
#define OHM_MEMORY_H

#include <stddef.h>

/* Bytes available now; 0 when unknown. */
double ohm_memory_available(void);

/* The limit for a step: user_bytes if > 0, else ohm_memory_available()
 * (unknown: +inf). */
double ohm_memory_limit(double user_bytes);

/* "12.3 GiB" style, into buf. */
const char *ohm_format_bytes(double bytes, char *buf, int len);

#endif
