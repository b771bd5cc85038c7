#include "base/stats.h"

#include <math.h>
#include <string.h>

static ohm_stat *slot(ohm_stats *s, const char *key)
{
    for (size_t i = 0; i < s->n; ++i)
        if (strcmp(s->items[i].key, key) == 0) return &s->items[i];
    if (s->n == OHM_STATS_MAX) return NULL; /* full: drop, never overflow */
    ohm_stat *st = &s->items[s->n++];
    memset(st, 0, sizeof *st);
    snprintf(st->key, sizeof st->key, "%s", key);
    return st;
}

void ohm_stats_set(ohm_stats *s, const char *key, double value)
{
    ohm_stat *st = slot(s, key);
    if (!st) return;
    st->is_string = 0;
    st->is_integer = 0;
    st->num = value;
}

void ohm_stats_set_int(ohm_stats *s, const char *key, long long value)
{
    ohm_stat *st = slot(s, key);
    if (!st) return;
    st->is_string = 0;
    st->is_integer = 1;
    st->num = (double)value;
}

void ohm_stats_add(ohm_stats *s, const char *key, double value)
{
    ohm_stat *st = slot(s, key);
    if (!st) return;
    st->is_string = 0;
    st->num += value;
}

void ohm_stats_set_str(ohm_stats *s, const char *key, const char *value)
{
    ohm_stat *st = slot(s, key);
    if (!st) return;
    st->is_string = 1;
    snprintf(st->str, sizeof st->str, "%s", value ? value : "");
}

const ohm_stat *ohm_stats_find(const ohm_stats *s, const char *key)
{
    for (size_t i = 0; i < s->n; ++i)
        if (strcmp(s->items[i].key, key) == 0) return &s->items[i];
    return NULL;
}

static void json_string(FILE *f, const char *str)
{
    fputc('"', f);
    for (const unsigned char *p = (const unsigned char *)str; *p; ++p) {
        if (*p == '"' || *p == '\\') fprintf(f, "\\%c", *p);
        else if (*p < 0x20) fprintf(f, "\\u%04x", *p);
        else fputc(*p, f); /* UTF-8 passes through; file names may be any bytes */
    }
    fputc('"', f);
}

int ohm_stats_write_json(const ohm_stats *s, FILE *f)
{
    fputs("{\n", f);
    for (size_t i = 0; i < s->n; ++i) {
        const ohm_stat *st = &s->items[i];
        fputs("  ", f);
        json_string(f, st->key);
        fputs(": ", f);
        if (st->is_string) json_string(f, st->str);
        else if (!isfinite(st->num)) fputs("null", f);
        else if (st->is_integer) fprintf(f, "%.0f", st->num);
        else fprintf(f, "%.17g", st->num); /* round-trips */
        fputs(i + 1 < s->n ? ",\n" : "\n", f);
    }
    fputs("}\n", f);
    return ferror(f) ? -1 : 0;
}
