/* solvers/grid_order.h — a fill-reducing ordering made for voxel grids:
 * geometric nested dissection (George, "Nested dissection of a regular
 * finite element mesh", SIAM J. Numer. Anal. 10, 1973); docs/ordering.md.
 *
 * The network's unknowns are cells of a regular grid coupled only through
 * shared faces (the 7-point pattern), so the cells of one plane
 * d . (i, j, k) = p, with d's entries in {-1, 0, 1}, separate its two sides:
 * a face step changes d . x by at most 1.  The ordering tries thirteen such
 * directions (the axes, the face diagonals and the body diagonals, whose
 * planes through a cube hold a quarter fewer cells than an axis plane),
 * takes the plane with the smallest separator for the balance it leaves (a
 * ratio cut) among those that leave neither side more than 55% of the
 * cells, numbers the two sides first, recursively, and the plane last, down
 * to blocks of a few cells numbered in grid order.  Connected pieces are
 * dissected one after another with no separator between them.  It never
 * looks at the matrix, so it costs a few passes over the unknowns'
 * coordinates: on the sample meshes the whole analysis takes a fifth of
 * METIS's time for fill within 0.89-1.09 of METIS's (docs/ordering.md);
 * thin shells and convoluted surfaces (the scans) fill 1.2-1.7x more, which
 * is why ordering=auto keeps METIS for density volumes. */
#ifndef OHM_SOLVERS_GRID_ORDER_H
#define OHM_SOLVERS_GRID_ORDER_H

#include <stdint.h>

#include "base/ohm_error.h"
#include "physics/network.h"

/* Where the unknowns sit: unknown u is the u-th member of cells (its
 * cell in a grid of dims[0] x dims[1] x dims[2] cells, x fastest, in cell
 * order: cell_index.h); pieces its connected
 * pieces, 0 .. npieces-1 (network.h's runs; none: one piece).  Pieces share no face, so each
 * is dissected on its own and none needs a separator from another: a scan
 * is often a shell and a core or a cloud of specks, which planes cut
 * needlessly. */
typedef struct ohm_grid_layout {
    const ohm_cell_index *cells;
    int64_t n;
    int64_t dims[3];
    const ohm_piece_runs *pieces;
    int64_t npieces;
} ohm_grid_layout;

/* The layout of a network's unknowns (its cells, its grid's dims, its
 * pieces); it points into the network. */
ohm_grid_layout ohm_grid_layout_of(const ohm_network *net);

/* perm[k] = the unknown eliminated k-th (n entries, CHOLMOD's Perm). */
int ohm_grid_order(int64_t *perm, const ohm_grid_layout *layout, ohm_error *err);

#endif
