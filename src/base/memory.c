#include "base/memory.h"

#include <math.h>
#include <stdio.h>
#include <stdint.h>
#include <string.h>
#ifdef __GLIBC__
#include <malloc.h>
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

#ifdef __GLIBC__
/* SuperLU_DIST, which PETSc brings into every process that loads libohm,
 * turns off glibc's mmap for large blocks and its trimming in a load-time
 * constructor (mallopt(M_MMAP_MAX, 0), mallopt(M_TRIM_THRESHOLD, -1)):
 * then no freed array goes back to the system, and a solve's peak carries
 * the holes its earlier steps left (on the 216^3 nine-level block medium
 * 1 255 780 KiB resident against 1 158 248 with the settings below).
 * libohm's own constructor runs after its dependencies' and turns both
 * back on.  The threshold is 8 MiB, not glibc's starting 128 KiB (the
 * calls above also ended glibc's own moving threshold): arrays of a few
 * MiB, which a relight of 3e5 cells frees and takes again on every light,
 * stay in the heap instead of being mapped and faulted in anew each time
 * (4% of a relight at 128 KiB; none at 8 MiB); the large ones, which set
 * a solve's peak, are mapped and given back.  Freeing them costs a large
 * solve's set-up the faults of fresh pages (the 216^3 medium's 0.75 s
 * became 0.90 s) where it reused the holes before. */
__attribute__((constructor)) static void restore_malloc_defaults(void)
{
    mallopt(M_MMAP_MAX, 65536);
    mallopt(M_TRIM_THRESHOLD, 8 * 1024 * 1024);
    mallopt(M_MMAP_THRESHOLD, 8 * 1024 * 1024);
}
#endif
