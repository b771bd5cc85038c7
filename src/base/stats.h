/* stats.h — the figures a run records, written as one JSON object (-stats).
 *
 * Stages record named numbers and strings as they go; times accumulate (a
 * stage run twice adds up).  Order of first recording is kept, so the JSON
 * reads in pipeline order. */
#ifndef OHM_STATS_H
#define OHM_STATS_H

#include <stdio.h>

#include "base/ohm_error.h"

enum { OHM_STATS_MAX = 128, OHM_STATS_KEY = 48, OHM_STATS_STR = 512 };

typedef struct ohm_stat {
    char key[OHM_STATS_KEY];
    int is_string;
    int is_integer;
    double num;
    char str[OHM_STATS_STR];
} ohm_stat;

typedef struct ohm_stats {
    ohm_stat items[OHM_STATS_MAX];
    size_t n;
} ohm_stats;

void ohm_stats_set(ohm_stats *s, const char *key, double value);
void ohm_stats_set_int(ohm_stats *s, const char *key, long long value);
void ohm_stats_add(ohm_stats *s, const char *key, double value); /* accumulate */
void ohm_stats_set_str(ohm_stats *s, const char *key, const char *value);
const ohm_stat *ohm_stats_find(const ohm_stats *s, const char *key);

/* One JSON object, keys in recording order, non-finite numbers as null. */
int ohm_stats_write_json(const ohm_stats *s, FILE *f);

#endif
