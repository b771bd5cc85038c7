/* solvers/grid_order.c — geometric nested dissection of a grid's unknowns
 * (grid_order.h). */
#include "solvers/grid_order.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* Blocks of at most this many cells are numbered as they come (grid
 * order); below it a separator saves nothing. */
enum { LEAF_CELLS = 8 };

/* No side of a chosen plane may keep more than this share of the cells. */
static const double MAX_SIDE = 0.55;

typedef struct order_work {
    int32_t *coord[3];  /* n each: the unknowns' cell coordinates            */
    int64_t *scratch;   /* n: partition buffer                               */
    int64_t *histogram; /* 3 max dim + 1: cells per plane across a direction */
    int64_t *perm;      /* the output                                        */
} order_work;

/* Separator planes d . (i, j, k) = p with every entry of d in {-1, 0, 1}:
 * a step to a face neighbour changes d . x by at most 1, so the plane's
 * cells separate its two sides.  The three axes, the six face diagonals and
 * the four body diagonals: through a cube's centre the body-diagonal plane
 * holds about 0.75 k^2 cells against an axis plane's k^2 — graph
 * partitioners find such cuts, and the fill follows the separators. */
static const int8_t DIRECTIONS[13][3] = {{1, 0, 0},  {0, 1, 0},  {0, 0, 1},  {1, 1, 0},  {1, -1, 0},
                                         {1, 0, 1},  {1, 0, -1}, {0, 1, 1},  {0, 1, -1}, {1, 1, 1},
                                         {1, 1, -1}, {1, -1, 1}, {-1, 1, 1}};

typedef struct split {
    int direction;
    int32_t plane;
    int64_t separator; /* cells on the plane; -1: none chosen */
    double score;      /* separator / (cells below x cells above): smaller is better */
} split;

static inline int32_t project(const order_work *w, int direction, int64_t u)
{
    const int8_t *d = DIRECTIONS[direction];
    return d[0] * w->coord[0][u] + d[1] * w->coord[1][u] + d[2] * w->coord[2][u];
}

/* The best plane across one direction for the cells list[0..count): the
 * smallest separator for the balance it leaves (separator / (below x
 * above), a ratio cut) among planes leaving each side at most MAX_SIDE of
 * the cells; *best is replaced when this direction does better. */
static void best_plane(split *best, const order_work *w, const int64_t *list, int64_t count, int direction)
{
    int32_t lo = project(w, direction, list[0]), hi = lo;
    for (int64_t q = 1; q < count; ++q) {
        int32_t v = project(w, direction, list[q]);
        if (v < lo) lo = v;
        if (v > hi) hi = v;
    }
    if (hi - lo < 2) return; /* no plane strictly inside */
    int64_t *h = w->histogram;
    memset(h, 0, (size_t)(hi - lo + 1) * sizeof *h);
    for (int64_t q = 0; q < count; ++q) ++h[project(w, direction, list[q]) - lo];
    const int64_t cap = (int64_t)(MAX_SIDE * (double)count);
    int64_t below = h[0];
    for (int32_t p = lo + 1; p < hi; ++p) {
        int64_t on = h[p - lo], above = count - below - on;
        double score = (double)on / ((double)(below + 1) * (double)(above + 1));
        if (below <= cap && above <= cap && (best->separator < 0 || score < best->score))
            *best = (split){direction, p, on, score};
        below += on;
    }
}

/* Number list[0..count) into perm[pos .. pos + count): both sides of the
 * best plane, recursively, then the plane.  The list is reordered in place
 * (left, right, separator); recursion depth is O(log count) because each
 * side keeps at most MAX_SIDE of the cells.  A block no plane splits within
 * that balance (a few cells, or a thin sliver) is numbered as it comes. */
static void dissect(order_work *w, int64_t *list, int64_t count, int64_t pos)
{
    split best = {0, 0, -1, 0};
    if (count > LEAF_CELLS)
        for (int d = 0; d < 13; ++d) best_plane(&best, w, list, count, d);
    if (best.separator < 0) {
        memcpy(w->perm + pos, list, (size_t)count * sizeof *list);
        return;
    }
    /* stable three-way partition through the scratch buffer */
    int64_t nl = 0, nr = 0, *tmp = w->scratch;
    for (int64_t q = 0; q < count; ++q) {
        int32_t v = project(w, best.direction, list[q]);
        nl += v < best.plane, nr += v > best.plane;
    }
    int64_t il = 0, ir = nl, is = nl + nr, ns = count - nl - nr;
    for (int64_t q = 0; q < count; ++q) {
        int32_t v = project(w, best.direction, list[q]);
        if (v < best.plane)
            tmp[il++] = list[q];
        else if (v > best.plane)
            tmp[ir++] = list[q];
        else
            tmp[is++] = list[q];
    }
    memcpy(list, tmp, (size_t)count * sizeof *list);
    dissect(w, list, nl, pos);
    dissect(w, list + nl, nr, pos + nl);
    memcpy(w->perm + pos + nl + nr, list + nl + nr, (size_t)ns * sizeof *list);
}

ohm_grid_layout ohm_grid_layout_of(const ohm_network *net)
{
    const int32_t *d = net->grid->dims;
    return (ohm_grid_layout){&net->unknowns, net->n, {d[0], d[1], d[2]}, &net->pieces, net->npieces};
}

int ohm_grid_order(int64_t *perm, const ohm_grid_layout *layout, ohm_error *err)
{
    const int64_t n = layout->n, nx = layout->dims[0], ny = layout->dims[1];
    int64_t maxdim = layout->dims[0];
    for (int a = 1; a < 3; ++a)
        if (layout->dims[a] > maxdim) maxdim = layout->dims[a];
    if (maxdim > INT32_MAX / 3) /* projections d . x must fit an int32_t */
        return ohm_fail(err, OHM_ERR_INVALID, "ordering=grid: a grid of %lld cells along an axis is too long",
                        (long long)maxdim);
    order_work w = {{NULL, NULL, NULL}, NULL, NULL, perm};
    int64_t *list = malloc((size_t)(n ? n : 1) * sizeof *list);
    int32_t *coords = malloc((size_t)(n ? n : 1) * 3 * sizeof *coords);
    w.scratch = malloc((size_t)(n ? n : 1) * sizeof *w.scratch);
    w.histogram = malloc((size_t)(3 * maxdim + 1) * sizeof *w.histogram); /* body diagonals span 3 x */
    if (!list || !coords || !w.scratch || !w.histogram) {
        free(list), free(coords), free(w.scratch), free(w.histogram);
        return ohm_fail(err, OHM_ERR_NOMEM, "ordering=grid: out of memory for %lld unknowns", (long long)n);
    }
    for (int a = 0; a < 3; ++a) w.coord[a] = coords + a * n;
    ohm_cell_cursor cells = ohm_cell_index_cursor(layout->cells, 0);
    for (int64_t u = 0; u < n; ++u) {
        int64_t cell = ohm_cell_cursor_next(&cells);
        w.coord[0][u] = (int32_t)(cell % nx);
        w.coord[1][u] = (int32_t)(cell / nx % ny);
        w.coord[2][u] = (int32_t)(cell / nx / ny);
        list[u] = u;
    }
    const ohm_piece_runs *pr = layout->pieces;
    if (pr && pr->count && layout->npieces > 1) {
        /* the pieces one after another (a counting sort, stable in cell order) */
        int64_t *start = calloc((size_t)layout->npieces + 1, sizeof *start);
        if (!start) {
            free(list), free(coords), free(w.scratch), free(w.histogram);
            return ohm_fail(err, OHM_ERR_NOMEM, "ordering=grid: out of memory for %lld pieces",
                            (long long)layout->npieces);
        }
        for (int64_t r = 0; r < pr->count; ++r) start[pr->piece[r] + 1] += pr->start[r + 1] - pr->start[r];
        for (int64_t p = 0; p < layout->npieces; ++p) start[p + 1] += start[p];
        int64_t *filled = w.scratch; /* per piece, npieces <= n */
        memset(filled, 0, (size_t)layout->npieces * sizeof *filled);
        for (int64_t r = 0; r < pr->count; ++r)
            for (int64_t u = pr->start[r]; u < pr->start[r + 1]; ++u)
                list[start[pr->piece[r]] + filled[pr->piece[r]]++] = u;
        for (int64_t p = 0; p < layout->npieces; ++p)
            dissect(&w, list + start[p], start[p + 1] - start[p], start[p]);
        free(start);
    } else if (n) {
        dissect(&w, list, n, 0);
    }
    free(list), free(coords), free(w.scratch), free(w.histogram);
    return OHM_OK;
}
