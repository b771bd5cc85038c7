/* check.h — the few macros ohm's C tests use.  A failed CHECK prints where and
 * why and counts; the test's main returns check_summary(), which prints
 * "N passed, N failed" and is non-zero when anything failed. */
#ifndef OHM_CHECK_H
#define OHM_CHECK_H

#include <math.h>
#include <stdio.h>

static int check_passed_, check_failed_;

#define CHECK(cond)                                                                \
    do {                                                                           \
        if (cond) {                                                                \
            ++check_passed_;                                                       \
        } else {                                                                   \
            ++check_failed_;                                                       \
            fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond); \
        }                                                                          \
    } while (0)

#define CHECK_MSG(cond, ...)                                                       \
    do {                                                                           \
        if (cond) {                                                                \
            ++check_passed_;                                                       \
        } else {                                                                   \
            ++check_failed_;                                                       \
            fprintf(stderr, "%s:%d: CHECK failed: %s: ", __FILE__, __LINE__, #cond); \
            fprintf(stderr, __VA_ARGS__);                                          \
            fputc('\n', stderr);                                                   \
        }                                                                          \
    } while (0)

/* |a - b| <= rel * |b| */
#define CHECK_REL(a, b, rel)                                                       \
    CHECK_MSG(fabs((double)(a) - (double)(b)) <= (rel) * fabs((double)(b)),       \
              "%s = %.9g, %s = %.9g, relative difference %.3g > %.3g", #a,         \
              (double)(a), #b, (double)(b),                                        \
              fabs((double)(a) - (double)(b)) / fabs((double)(b)), (double)(rel))

static inline int check_summary(void)
{
    printf("%d passed, %d failed\n", check_passed_, check_failed_);
    return check_failed_ ? 1 : 0;
}

#endif
