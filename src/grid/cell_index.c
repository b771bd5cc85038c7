/* cell_index.c — a subset of a grid's cells by bit and running count (cell_index.h). */
#include "grid/cell_index.h"

#include <stdlib.h>
#include <string.h>

int ohm_cell_index_alloc(ohm_cell_index *ix, size_t ncells)
{
    size_t nwords = (ncells + 63) / 64;
    if (nwords == 0) nwords = 1;
    ix->bits = calloc(nwords, sizeof *ix->bits);
    ix->rank = malloc(nwords * sizeof *ix->rank);
    ix->count = 0;
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

void ohm_cell_index_free(ohm_cell_index *ix)
{
    if (!ix) return;
    free(ix->bits);
    free(ix->rank);
    memset(ix, 0, sizeof *ix);
}
