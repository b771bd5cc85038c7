/* suggest.h — "did you mean" for every unknown name a user types (an action,
 * an option, a subcommand): the nearest candidate by edit distance
 * (case-insensitive), or a candidate the word is a prefix of. */
#ifndef OHM_SUGGEST_H
#define OHM_SUGGEST_H

#include <stddef.h>

/* Nearest candidate to `word`, or NULL if none is close. */
const char *ohm_suggest(const char *word, const char *const *candidates, size_t n);

#endif
