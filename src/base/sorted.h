/* base/sorted.h — a search in an ascending array of 64-bit values, the one
 * the runs and running counts share (the stencil's runs, the pieces' runs,
 * the cell index's counts per word). */
#ifndef OHM_BASE_SORTED_H
#define OHM_BASE_SORTED_H

#include <stdint.h>

/* The last i in 0 .. n-1 with a[i] <= key, for a[] ascending and a[0] <=
 * key (n <= 0: 0): a bisection. */
static inline int64_t ohm_sorted_last_at_most(const int64_t *a, int64_t n, int64_t key)
{
    int64_t lo = 0, hi = n - 1;
    while (lo < hi) {
        int64_t mid = lo + (hi - lo + 1) / 2;
        if (a[mid] <= key) lo = mid;
        else hi = mid - 1;
    }
    return lo;
}

#endif
