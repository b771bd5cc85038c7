/* base/options.c — see options.h. */
#include "base/options.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/suggest.h"

int ohm_opt_parse_real(const char *s, double *out)
{
    if (!*s || isspace((unsigned char)*s)) return -1;
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (*end || errno == ERANGE || !isfinite(v)) return -1;
    *out = v;
    return 0;
}

int ohm_opt_parse_int(const char *s, long long *out)
{
    if (!*s || isspace((unsigned char)*s)) return -1;
    char *end;
    errno = 0;
    long long v = strtoll(s, &end, 10);
    if (*end || errno == ERANGE) return -1;
    *out = v;
    return 0;
}

int ohm_opt_parse_vec3(const char *s, double out[3])
{
    char buf[256];
    if (strlen(s) >= sizeof buf) return -1;
    strcpy(buf, s);
    char *p = buf;
    for (int i = 0; i < 3; ++i) {
        char *comma = strchr(p, ',');
        if (i < 2 && !comma) return -1;
        if (i == 2 && comma) return -1;
        if (comma) *comma = '\0';
        if (ohm_opt_parse_real(p, &out[i])) return -1;
        p = comma ? comma + 1 : p;
    }
    return 0;
}

int ohm_opt_parse_real13(const char *s, double out[3])
{
    if (!strchr(s, ',')) {
        if (ohm_opt_parse_real(s, &out[0])) return 0;
        out[1] = out[2] = out[0];
        return 1;
    }
    return ohm_opt_parse_vec3(s, out) ? 0 : 3;
}

static int enum_has(const char *choices, const char *v)
{
    size_t lv = strlen(v);
    for (const char *p = choices; *p;) {
        const char *bar = strchr(p, '|');
        size_t l = bar ? (size_t)(bar - p) : strlen(p);
        if (l == lv && strncmp(p, v, l) == 0) return 1;
        if (!bar) break;
        p = bar + 1;
    }
    return 0;
}

int ohm_opt_check(const ohm_opt_spec *o, const char *v, const char *prefix, ohm_error *err)
{
    int has_range = o->min != o->max;
    switch (o->type) {
    case OHM_OPT_INT: {
        long long x;
        if (ohm_opt_parse_int(v, &x) || (has_range && (x < o->min || x > o->max))) {
            if (has_range)
                return ohm_fail(err, OHM_ERR_USAGE, "%s %s=%s: expected a whole number from %.0f to %.0f", prefix,
                                o->name, v, o->min, o->max);
            return ohm_fail(err, OHM_ERR_USAGE, "%s %s=%s: expected a whole number", prefix, o->name, v);
        }
        return OHM_OK;
    }
    case OHM_OPT_REAL: {
        double x;
        if (ohm_opt_parse_real(v, &x) || (has_range && (x < o->min || x > o->max))) {
            if (has_range)
                return ohm_fail(err, OHM_ERR_USAGE, "%s %s=%s: expected a number from %g to %g", prefix, o->name, v,
                                o->min, o->max);
            return ohm_fail(err, OHM_ERR_USAGE, "%s %s=%s: expected a finite number", prefix, o->name, v);
        }
        return OHM_OK;
    }
    case OHM_OPT_VEC3: {
        double x[3];
        if (ohm_opt_parse_vec3(v, x))
            return ohm_fail(err, OHM_ERR_USAGE, "%s %s=%s: expected three numbers x,y,z", prefix, o->name, v);
        return OHM_OK;
    }
    case OHM_OPT_REAL13: {
        double x[3];
        int k = ohm_opt_parse_real13(v, x);
        int bad = k == 0;
        for (int i = 0; i < k && !bad; ++i) bad = has_range && (x[i] < o->min || x[i] > o->max);
        if (bad) {
            if (has_range)
                return ohm_fail(err, OHM_ERR_USAGE, "%s %s=%s: expected one number (grey) or three (r,g,b), each "
                                "from %g to %g", prefix, o->name, v, o->min, o->max);
            return ohm_fail(err, OHM_ERR_USAGE, "%s %s=%s: expected one number (grey) or three (r,g,b)", prefix,
                            o->name, v);
        }
        return OHM_OK;
    }
    case OHM_OPT_ENUM:
        if (!enum_has(o->choices, v))
            return ohm_fail(err, OHM_ERR_USAGE, "%s %s=%s: expected one of %s", prefix, o->name, v, o->choices);
        return OHM_OK;
    case OHM_OPT_STRING:
    case OHM_OPT_DEVICE: /* (its words: device/request.h, a later stage, whose users check them) */
        if (!*v) return ohm_fail(err, OHM_ERR_USAGE, "%s %s=: the value is empty", prefix, o->name);
        return OHM_OK;
    }
    return OHM_OK;
}

int ohm_opt_index(const ohm_opt_spec *specs, const char *name)
{
    for (int i = 0; specs[i].name; ++i)
        if (strcmp(specs[i].name, name) == 0) return i;
    return -1;
}

void ohm_opt_values_free(ohm_opt_values *v)
{
    for (int j = 0; j < OHM_MAX_OPTS; ++j) {
        free(v->values[j]);
        v->values[j] = NULL;
    }
}

int ohm_opt_word(ohm_opt_values *out, const char *word, const char *prefix, const char *see,
                 ohm_opt_value_check check, ohm_error *err)
{
    const char *eq = strchr(word, '=');
    char key[64];
    size_t klen = eq ? (size_t)(eq - word) : strlen(word);
    if (eq == word) return ohm_fail(err, OHM_ERR_USAGE, "%s: '%s' is not key=value %s", prefix, word, see);
    if (klen >= sizeof key)
        return ohm_fail(err, OHM_ERR_USAGE, "%s: option name '%.32s...' is too long %s", prefix, word, see);
    snprintf(key, sizeof key, "%.*s", (int)klen, word);
    int k = ohm_opt_index(out->specs, key);
    if (k < 0 && !eq) return ohm_fail(err, OHM_ERR_USAGE, "%s: '%s' is not key=value %s", prefix, word, see);
    if (k < 0) {
        const char *names[OHM_MAX_OPTS];
        size_t n = 0;
        for (int i = 0; out->specs[i].name && n < OHM_MAX_OPTS; ++i) names[n++] = out->specs[i].name;
        const char *s = ohm_suggest(key, names, n);
        if (s)
            return ohm_fail(err, OHM_ERR_USAGE, "%s: unknown option '%s'; did you mean '%s'? %s", prefix, key, s, see);
        return ohm_fail(err, OHM_ERR_USAGE, "%s: unknown option '%s' %s", prefix, key, see);
    }
    if (!eq) return ohm_fail(err, OHM_ERR_USAGE, "%s: option '%s' needs a value: %s=... %s", prefix, key, key, see);
    if (out->values[k]) return ohm_fail(err, OHM_ERR_USAGE, "%s: option '%s' is given twice %s", prefix, key, see);
    char at[320];
    snprintf(at, sizeof at, "%s:", prefix);
    int rc = ohm_opt_check(&out->specs[k], eq + 1, at, err);
    if (!rc && check) rc = check(&out->specs[k], eq + 1, at, err);
    if (rc) {
        char said[sizeof err->msg];
        snprintf(said, sizeof said, "%s", err->msg);
        return ohm_fail(err, rc, "%.*s %s", (int)(sizeof said - 40), said, see);
    }
    out->values[k] = strdup(eq + 1);
    return out->values[k] ? OHM_OK : ohm_fail(err, OHM_ERR_NOMEM, "%s: out of memory", prefix);
}

int ohm_opt_words(ohm_opt_values *out, const ohm_opt_spec *specs, const char *cmd, int argc, const char *const *argv,
                  ohm_error *err)
{
    memset(out, 0, sizeof *out);
    out->specs = specs;
    char see[64];
    snprintf(see, sizeof see, "(see 'ohm %s help')", cmd);
    int rc = OHM_OK;
    for (int i = 0; i < argc && !rc; ++i) rc = ohm_opt_word(out, argv[i], cmd, see, NULL, err);
    for (int i = 0; specs[i].name && !rc; ++i)
        if (specs[i].required && !out->values[i])
            rc = ohm_fail(err, OHM_ERR_USAGE, "%s: %s= is needed (%s) %s", cmd, specs[i].name, specs[i].doc, see);
    if (rc) ohm_opt_values_free(out);
    return rc;
}

const char *ohm_opt_text(const ohm_opt_values *v, const char *name)
{
    int i = ohm_opt_index(v->specs, name);
    if (i < 0) return NULL;
    return v->values[i] ? v->values[i] : v->specs[i].def;
}

int ohm_opt_values_given(const ohm_opt_values *v, const char *name)
{
    int i = ohm_opt_index(v->specs, name);
    return i >= 0 && v->values[i] != NULL;
}
