/* madvise's MADV_HUGEPAGE is outside POSIX; glibc shows it with _DEFAULT_SOURCE */
#define _DEFAULT_SOURCE
#include "base/memory.h"

#include <math.h>
#include <stdio.h>
#include <stdint.h>
#include <string.h>
#if defined(__linux__)
#include <sys/mman.h>
#endif

double ohm_memory_available(void)
{
    double avail = 0;
    FILE *f = fopen("/proc/meminfo", "r");
    if (f) {
        char line[256];
        while (fgets(line, sizeof line, f)) {
            double kb;
            if (sscanf(line, "MemAvailable: %lf kB", &kb) == 1) {
                avail = kb * 1024.0;
                break;
            }
        }
        fclose(f);
    }
    /* a container's limit, when lower */
    f = fopen("/sys/fs/cgroup/memory.max", "r");
    if (f) {
        double lim;
        if (fscanf(f, "%lf", &lim) == 1 && lim > 0 && (avail == 0 || lim < avail)) avail = lim;
        fclose(f);
    }
    return avail;
}

double ohm_memory_limit(double user_bytes)
{
    if (user_bytes > 0) return user_bytes;
    double a = ohm_memory_available();
    return a > 0 ? a : INFINITY;
}

const char *ohm_format_bytes(double bytes, char *buf, int len)
{
    if (bytes >= 1024.0 * 1024 * 1024) snprintf(buf, (size_t)len, "%.1f GiB", bytes / (1024.0 * 1024 * 1024));
    else if (bytes >= 1024.0 * 1024) snprintf(buf, (size_t)len, "%.1f MiB", bytes / (1024.0 * 1024));
    else snprintf(buf, (size_t)len, "%.0f KiB", bytes / 1024.0);
    return buf;
}

void ohm_memory_advise_huge(void *p, size_t bytes)
{
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    const uintptr_t huge = (uintptr_t)2 << 20; /* x86-64's PMD page */
    if (!p || bytes < 4 * huge) return;
    uintptr_t lo = ((uintptr_t)p + huge - 1) & ~(huge - 1), hi = ((uintptr_t)p + bytes) & ~(huge - 1);
    if (hi > lo) (void)madvise((void *)lo, hi - lo, MADV_HUGEPAGE); /* a hint: failure changes nothing */
#else
    (void)p;
    (void)bytes;
#endif
}

