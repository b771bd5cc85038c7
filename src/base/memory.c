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

