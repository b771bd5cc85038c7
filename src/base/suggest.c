/* suggest.c — "did you mean": the nearest of a list of names to a word. */
#include "base/suggest.h"

#include <ctype.h>
#include <string.h>

static size_t edit_distance(const char *a, const char *b)
{
    size_t la = strlen(a), lb = strlen(b);
    if (la > 64 || lb > 64) return (size_t)-1;
    size_t row[65];
    for (size_t j = 0; j <= lb; ++j) row[j] = j;
    for (size_t i = 1; i <= la; ++i) {
        size_t diag = row[0];
        row[0] = i;
        for (size_t j = 1; j <= lb; ++j) {
            size_t up = row[j];
            size_t cost = tolower((unsigned char)a[i - 1]) == tolower((unsigned char)b[j - 1]) ? 0 : 1;
            size_t best = diag + cost;
            if (row[j] + 1 < best) best = row[j] + 1;
            if (row[j - 1] + 1 < best) best = row[j - 1] + 1;
            row[j] = best;
            diag = up;
        }
    }
    return row[lb];
}

const char *ohm_suggest(const char *word, const char *const *candidates, size_t n)
{
    const char *best = NULL;
    size_t best_d = (size_t)-1;
    for (size_t i = 0; i < n; ++i) {
        size_t d = edit_distance(word, candidates[i]);
        /* a prefix ("vox" for "voxelize") is a good guess too */
        if (strlen(word) >= 3 && strncmp(candidates[i], word, strlen(word)) == 0) d = 1;
        if (d < best_d) best_d = d, best = candidates[i];
    }
    size_t limit = strlen(word) / 3 + 1;
    if (limit < 2) limit = 2;
    return best_d <= limit ? best : NULL;
}
