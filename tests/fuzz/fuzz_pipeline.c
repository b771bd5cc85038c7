/* fuzz_pipeline.c — libFuzzer harness for pipeline files (ohm_chain_parse_text)
 * and, built with -DARGS, for the command line (ohm_chain_parse_args: the
 * input split at NUL bytes into argv, so every option and number arrives as
 * the shell would pass it).  Run with scripts/fuzz.sh pipeline|args SECONDS.
 * Checks: no crash or UB
 * (sanitizers); a failure leaves the chain empty with a one-line message whose
 * code is the return value; a success has at least one action, each with a
 * known action, and every option it was given reads back as validated (finite
 * reals, integers and reals inside the spec's [min, max] when it has one). */
#include "steps/pipeline.h"
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
#ifdef ARGS
/* argv from the input: one argument per NUL-terminated run, each in its own
 * exact-size allocation (over-reads are caught); at most 64. */
static int parse(ohm_chain *c, const uint8_t *data, size_t size, ohm_error *e)
{
    enum { MAX_ARGS = 64 };
    char *argv[MAX_ARGS];
    int argc = 0;
    size_t start = 0;
    for (size_t i = 0; i <= size && argc < MAX_ARGS; ++i)
        if (i == size || data[i] == 0) {
            if (i == size && i == start && argc > 0) break;
            argv[argc] = malloc(i - start + 1);
            memcpy(argv[argc], data + start, i - start);
            argv[argc][i - start] = '\0';
            ++argc;
            start = i + 1;
        }
    int rc = ohm_chain_parse_args(c, argc, (const char *const *)argv, e);
    for (int k = 0; k < argc; ++k) free(argv[k]);
    return rc;
}
#else
static int parse(ohm_chain *c, const uint8_t *data, size_t size, ohm_error *e)
{
    char *copy = malloc(size ? size : 1); /* exact size, so over-reads are caught */
    if (size) memcpy(copy, data, size);
    int rc = ohm_chain_parse_text(c, size ? copy : NULL, size, "fuzz.ohm", e);
    free(copy);
    return rc;
}
#endif

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    ohm_chain c; ohm_error e;
    memset(&e, 0, sizeof e);
    int rc = parse(&c, data, size, &e);
    if (rc == 0) {
        if (c.n == 0 || !c.items) abort();
        for (size_t i = 0; i < c.n; ++i) {
            const ohm_invocation *inv = &c.items[i];
            if (!inv->action || ohm_action_find(inv->action->name) != inv->action) abort();
            if (!memchr(inv->where, 0, sizeof inv->where)) abort();
            for (int k = 0; k < OHM_MAX_OPTS && inv->action->opts[k].name; ++k) {
                const ohm_opt_spec *o = &inv->action->opts[k];
                if (!inv->values[k]) continue;
                if (!ohm_opt_given(inv, o->name)) abort();
                double v3[3];
                int ranged = o->min < o->max;
                switch (o->type) {
                case OHM_OPT_INT: {
                    long long v = ohm_opt_int(inv, o->name);
                    if (ranged && ((double)v < o->min || (double)v > o->max)) abort();
                    break;
                }
                case OHM_OPT_REAL: {
                    double v = ohm_opt_real(inv, o->name);
                    if (!isfinite(v) || (ranged && (v < o->min || v > o->max))) abort();
                    break;
                }
                case OHM_OPT_VEC3:
                    ohm_opt_vec3(inv, o->name, v3);
                    for (int j = 0; j < 3; ++j) if (!isfinite(v3[j])) abort();
                    break;
                case OHM_OPT_REAL13: {
                    int nv = ohm_opt_real13(inv, o->name, v3);
                    if (nv != 1 && nv != 3) abort();
                    for (int j = 0; j < 3; ++j)
                        if (!isfinite(v3[j]) || (ranged && (v3[j] < o->min || v3[j] > o->max))) abort();
                    break;
                }
                default:
                    (void)ohm_opt_str(inv, o->name);
                    break;
                }
            }
        }
        ohm_chain_free(&c);
    } else {
        if (c.items || c.n) abort();
        if (e.code != rc || !memchr(e.msg, 0, sizeof e.msg) || strchr(e.msg, '\n')) abort();
    }
    return 0;
}
