#include "base/memory.h"

#include <math.h>
#include <stdio.h>
#include <stdint.h>
#include <string.h>

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
#include <malloc.h>

/* SuperLU_DIST, which PETSc brings into every process that loads libohm,
 * turns off glibc's mmap for large blocks and its trimming in a load-time
 * constructor (mallopt(M_MMAP_MAX, 0), mallopt(M_TRIM_THRESHOLD, -1)):
 * then no freed array goes back to the system, and a solve's peak carries
 * the holes its earlier steps left (on the 216^3 block medium 60 MB more
 * resident).  libohm's own constructor runs after its dependencies' and
 * puts glibc's defaults back: blocks of 128 KiB and more mapped and
 * returned when freed, free memory above 128 KiB at the heap's top trimmed. */
__attribute__((constructor)) static void restore_malloc_defaults(void)
{
    mallopt(M_MMAP_MAX, 65536);
    mallopt(M_TRIM_THRESHOLD, 128 * 1024);
    mallopt(M_MMAP_THRESHOLD, 128 * 1024);
}
#endif
