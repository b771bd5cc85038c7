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

/* A hint for a large array not yet written: back it with transparent huge
 * pages (Linux madvise MADV_HUGEPAGE; nothing elsewhere, or below 8 MiB).
 * The first write to a fresh 4 KiB page faults; on this project's machine
 * (a Firecracker VM) that costs ~12 us a page, 3 ns per byte — more than
 * computing what goes into it — and 2 MiB pages cut that to ~0.07-1.5 ns
 * per byte (measured, docs/serial-stages.md).  Memory use is unchanged. */
void ohm_memory_advise_huge(void *p, size_t bytes);

/* "12.3 GiB" style, into buf. */
const char *ohm_format_bytes(double bytes, char *buf, int len);

#endif
