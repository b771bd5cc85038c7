/* cell_index.h — a subset of a dense grid's cells, numbered in cell order.
 *
 * A bit per grid cell says whether cell c belongs; a running count per 64
 * cells gives its number among the members with one popcount.  That is 0.25
 * B per grid cell where a table of numbers costs 8: on the samples a grid
 * has 4–6 cells per interior cell, so a table was 34–45 B per interior cell,
 * more than the matrix (docs/serial-stages.md).  The network numbers its
 * unknowns with one; the voxel grid keeps its narrow band's distances by one. */
#ifndef OHM_CELL_INDEX_H
#define OHM_CELL_INDEX_H

#include <stddef.h>
#include <stdint.h>

typedef struct ohm_cell_index {
    uint64_t *bits;  /* (ncells + 63) / 64 words: bit c set when c is a member */
    int64_t *rank;   /* same count: members in the words before this one      */
    int64_t count;   /* members                                               */
    int64_t nwords;  /* words of bits and rank                                 */
} ohm_cell_index;

/* An empty set over ncells cells; 0 or -1 (out of memory, ix left empty). */
int ohm_cell_index_alloc(ohm_cell_index *ix, size_t ncells);

/* Add cell c (before ohm_cell_index_finish). */
static inline void ohm_cell_index_add(ohm_cell_index *ix, size_t c)
{
    ix->bits[c >> 6] |= (uint64_t)1 << (c & 63);
}

/* The running counts, once every member is added. */
void ohm_cell_index_finish(ohm_cell_index *ix, size_t ncells);

/* Set bits of x.  Written out (Hacker's Delight, 2nd ed., fig. 5-2) because
 * the compiler's builtin becomes a libgcc call on the x86-64 baseline, which
 * has no popcnt instruction: the network's build and assembly ran 10-15%
 * slower with it (tests/bench_serial, warm memory, 10^6 cells). */
static inline int64_t ohm_popcount64(uint64_t x)
{
    x = x - ((x >> 1) & 0x5555555555555555u);
    x = (x & 0x3333333333333333u) + ((x >> 2) & 0x3333333333333333u);
    x = (x + (x >> 4)) & 0x0f0f0f0f0f0f0f0fu;
    return (int64_t)((x * 0x0101010101010101u) >> 56);
}

/* How many members come before cell c (any cell, past the last too). */
static inline int64_t ohm_cell_index_rank(const ohm_cell_index *ix, size_t c)
{
    if ((int64_t)(c >> 6) >= ix->nwords) return ix->count;
    return ix->rank[c >> 6] + ohm_popcount64(ix->bits[c >> 6] & (((uint64_t)1 << (c & 63)) - 1));
}

/* The number of cell c among the members (0-based, in cell order), or -1. */
static inline int64_t ohm_cell_index_of(const ohm_cell_index *ix, size_t c)
{
    if (!(ix->bits[c >> 6] & ((uint64_t)1 << (c & 63)))) return -1;
    return ohm_cell_index_rank(ix, c);
}

/* The cell of member k (0 <= k < count): the inverse of ohm_cell_index_of,
 * by a binary search of the running counts, then the word's bits — for a
 * member now and then; to visit members in order, a cursor (below). */
int64_t ohm_cell_index_cell(const ohm_cell_index *ix, int64_t k);

/* Members in cell order from member k on: ohm_cell_cursor_next gives the
 * next one's cell, at a word's bits a step (no more of them than there are
 * members from k). */
typedef struct ohm_cell_cursor {
    const uint64_t *bits;
    int64_t word;  /* the word being read */
    uint64_t left; /* its members not yet given */
} ohm_cell_cursor;

ohm_cell_cursor ohm_cell_index_cursor(const ohm_cell_index *ix, int64_t k);

static inline int64_t ohm_cell_cursor_next(ohm_cell_cursor *cur)
{
    while (!cur->left) cur->left = cur->bits[++cur->word];
    int64_t c = cur->word * 64 + __builtin_ctzll(cur->left); /* an inline bsf, no library call */
    cur->left &= cur->left - 1;
    return c;
}

/* Accepts NULL and an empty set. */
void ohm_cell_index_free(ohm_cell_index *ix);

#endif
