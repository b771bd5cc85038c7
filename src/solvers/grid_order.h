/* solvers/grid_order.h — a fill-reducing ordering made for voxel grids:
 * geometric nested dissection (George, "Nested dissection of a regular
 * finite element mesh", SIAM J. Numer. Anal. 10, 1973), issue 15 item 1.
 *
 * The network's unknowns are cells of a regular grid coupled only through
 * shared faces (the 7-point pattern), so one plane of cells across the
 * object is a vertex separator: cells on its two sides never share a face.
 * The ordering takes the plane, over the three axes, with the fewest cells
 * among those that leave neither side more than 55% of the cells (the
 * median plane when none does), numbers the two sides first, recursively,
 * and the plane last, down to blocks of a few cells numbered in grid order.
 * It never looks at the matrix, so it costs a few passes over the unknowns'
 * coordinates — milliseconds where METIS's graph partitioning takes a
 * large share of the whole analysis and factorization at 10^4-10^5 cells
 * (ohm bench) — and for grid graphs George's separators give fill of the
 * same order as graph partitioning's. */
#ifndef OHM_SOLVERS_GRID_ORDER_H
#define OHM_SOLVERS_GRID_ORDER_H

#include <stdint.h>

#include "base/ohm_error.h"

/* Where the unknowns sit: unknown u is dense grid cell cell[u] of a grid
 * of dims[0] x dims[1] x dims[2] cells, x fastest; piece[u] its connected
 * piece, 0 .. npieces-1 (NULL: one piece).  Pieces share no face, so each
 * is dissected on its own and none needs a separator from another: a scan
 * is often a shell and a core or a cloud of specks, which planes cut
 * needlessly. */
typedef struct ohm_grid_layout {
    const int64_t *cell;
    int64_t n;
    int64_t dims[3];
    const int64_t *piece;
    int64_t npieces;
} ohm_grid_layout;

/* perm[k] = the unknown eliminated k-th (n entries, CHOLMOD's Perm). */
int ohm_grid_order(int64_t *perm, const ohm_grid_layout *layout, ohm_error *err);

#endif
