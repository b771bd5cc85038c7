/* options.h — key=value options checked against their declarations
 * (base/opt_spec.h: name, type, default, range, help) where the words come
 * in, for the pipeline's actions (steps/pipeline.h, which adds the
 * chain around them) and for the commands with options of their own
 * (`ohm bench`, `ohm accuracy`: studies/), so that one parser reads them
 * all and the help and the checks cannot drift apart. */
#ifndef OHM_BASE_OPTIONS_H
#define OHM_BASE_OPTIONS_H

#include <stddef.h>

#include "base/ohm_error.h"
#include "base/opt_spec.h"

enum { OHM_MAX_OPTS = 24 };

/* The values of one use of a table, by spec index (NULL: not given), each
 * checked against its spec. */
typedef struct ohm_opt_values {
    const ohm_opt_spec *specs; /* terminated by {0}                        */
    char *values[OHM_MAX_OPTS];
} ohm_opt_values;

/* Value v of option o, or OHM_ERR_USAGE "PREFIX NAME=V: expected ..."
 * (prefix: "argument 3: -voxelize", "bench:"). */
int ohm_opt_check(const ohm_opt_spec *o, const char *v, const char *prefix, ohm_error *err);

/* The spec of that name's index in specs, or -1. */
int ohm_opt_index(const ohm_opt_spec *specs, const char *name);

/* A further check of a value after ohm_opt_check's (OHM_OPT_DEVICE's
 * words, which a later stage knows), or NULL. */
typedef int (*ohm_opt_value_check)(const ohm_opt_spec *o, const char *v, const char *prefix, ohm_error *err);

/* One key=value word into out (whose specs are set): an unknown key (with
 * the nearest name), a word without '=', a value given twice or one its
 * spec refuses is OHM_ERR_USAGE.  Messages begin with prefix ("bench",
 * "argument 3: -voxelize") and end with see ("(see 'ohm help voxelize')"). */
int ohm_opt_word(ohm_opt_values *out, const char *word, const char *prefix, const char *see,
                 ohm_opt_value_check check, ohm_error *err);

/* key=value words into *out (zeroed first), for a command with options of
 * its own: `cmd` names it in the messages ("bench: unknown option 'frame';
 * did you mean 'frames'?"), which ohm_subcommand_usage_error's form
 * follows; a required option missing, a value given twice, a word without
 * '=' are errors too.  Free with ohm_opt_values_free. */
int ohm_opt_words(ohm_opt_values *out, const ohm_opt_spec *specs, const char *cmd, int argc, const char *const *argv,
                  ohm_error *err);
void ohm_opt_values_free(ohm_opt_values *v);

/* A value as given, else its default (NULL when it has none). */
const char *ohm_opt_text(const ohm_opt_values *v, const char *name);
/* Whether it was given. */
int ohm_opt_values_given(const ohm_opt_values *v, const char *name);

/* Texts already checked, as numbers: 0 on success (ohm_opt_check's rules
 * without the range). */
int ohm_opt_parse_real(const char *s, double *out);
int ohm_opt_parse_int(const char *s, long long *out);
int ohm_opt_parse_vec3(const char *s, double out[3]);
/* "x" (1, copied to all three) or "r,g,b" (3); 0 when it is neither */
int ohm_opt_parse_real13(const char *s, double out[3]);

#endif
