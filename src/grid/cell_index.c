/* cell_index.c — a subset of a grid's cells by bit and running count (cell_index.h). */
#include "grid/cell_index.h"

#include <stdlib.h>
#include <string.h>

#include "base/sorted.h"

int ohm_cell_index_alloc(ohm_cell_index *ix, size_t ncells)
{
    size_t nwords = (ncells + 63) / 64;
    if (nwords == 0) nwords = 1;
    ix->bits = calloc(nwords, sizeof *ix->bits);
    ix->rank = malloc(nwords * sizeof *ix->rank);
    ix->count = 0;
    ix->nwords = (int64_t)nwords;
    if (ix->bits && ix->rank) return 0;
    ohm_cell_index_free(ix);
    return -1;
}

void ohm_cell_index_finish(ohm_cell_index *ix, size_t ncells)
{
    int64_t before = 0;
    for (size_t w = 0; w < (ncells + 63) / 64; ++w) {
        ix->rank[w] = before;
        before += ohm_popcount64(ix->bits[w]);
    }
    ix->count = before;
}

/* The word holding member k: the last whose running count is <= k. */
static int64_t word_of(const ohm_cell_index *ix, int64_t k) { return ohm_sorted_last_at_most(ix->rank, ix->nwords, k); }

/* word with its lowest `skip` set bits cleared */
static uint64_t drop_lowest(uint64_t word, int64_t skip)
{
    for (int64_t i = 0; i < skip; ++i) word &= word - 1;
    return word;
}

int64_t ohm_cell_index_cell(const ohm_cell_index *ix, int64_t k)
{
    int64_t w = word_of(ix, k);
    return w * 64 + __builtin_ctzll(drop_lowest(ix->bits[w], k - ix->rank[w]));
}

ohm_cell_cursor ohm_cell_index_cursor(const ohm_cell_index *ix, int64_t k)
{
    if (k >= ix->count) return (ohm_cell_cursor){ix->bits, 0, 0};
    int64_t w = word_of(ix, k);
    return (ohm_cell_cursor){ix->bits, w, drop_lowest(ix->bits[w], k - ix->rank[w])};
}

void ohm_cell_index_free(ohm_cell_index *ix)
{
    if (!ix) return;
    free(ix->bits);
    free(ix->rank);
    memset(ix, 0, sizeof *ix);
}
