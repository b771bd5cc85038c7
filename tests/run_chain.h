/* run_chain.h — run pipeline lines through the action chain, as `ohm run`
 * does, for tests of what a whole step decides (include check.h first; the
 * functions are static inline). */
#ifndef OHM_TESTS_RUN_CHAIN_H
#define OHM_TESTS_RUN_CHAIN_H

#include <stdio.h>
#include <string.h>

#include "steps/pipeline.h"
#include "steps/state.h"

/* Run `lines` (actions one per line, no header) on a fresh, quiet state s,
 * which the caller frees whatever the result; a failure is a failed check. */
static inline int run_lines(ohm_state *s, const char *lines)
{
    char text[8192];
    snprintf(text, sizeof text, "ohm-pipeline 1\n%s", lines);
    ohm_state_init(s);
    s->log.verbosity = 0;
    ohm_error err;
    ohm_error_clear(&err);
    ohm_chain c;
    memset(&c, 0, sizeof c);
    int rc = ohm_chain_parse_text(&c, text, strlen(text), "test", &err);
    if (!rc) rc = ohm_chain_run(&c, s, &err);
    ohm_chain_free(&c);
    CHECK_MSG(rc == 0, "%s: %s", lines, err.msg);
    return rc;
}

/* The interior cells of the object the lines make; -1 when they fail. */
static inline long long object_cells(const char *lines)
{
    ohm_state s;
    int rc = run_lines(&s, lines);
    long long cells = rc ? -1 : (long long)s.grid.interior_cells;
    ohm_state_free(&s);
    return cells;
}

#endif
