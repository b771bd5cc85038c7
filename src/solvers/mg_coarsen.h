/* solvers/mg_coarsen.h — one step of the multigrid's hierarchy (mg.h):
 * a level's unknowns grouped into the next level's, and the next level's
 * operator, the Galerkin product P^T A P of piecewise-constant
 * interpolation P.
 *
 * The groups follow the coefficients.  A coarse unknown is a part of a
 * 2x2x2 block of the level's grid: the block's unknowns joined by strong
 * links (a link is strong where its conductance is at least theta times
 * the largest link of either of its two unknowns: as AMG's strength of
 * connection, Ruge and Stueben 1987, made symmetric), so that a group
 * does not straddle a jump in the coefficients — a block cut by a jump
 * becomes two or more coarse unknowns where fixed blocks made one, at
 * every level, and the coarse operator keeps the jump where it is
 * (docs/multigrid.md, "Any medium").  Unknowns with no link at all (a
 * clear region's cells, whose light goes by links beyond the grid) join
 * one part per block, and so do parts of alike media in a block that no
 * weak link cuts (parts only because an object's edge or hole cuts the
 * block: whole blocks keep the level a stencil, mg.c).  Where strength would keep more than
 * OHM_MG_KEEP_MAX of the unknowns (a cell-scale checkerboard, where no
 * link is strong), the level falls back to whole blocks (every unknown of
 * a block in one group, connected or not), so that coarsening always
 * shrinks the level.
 *
 * Every coarse unknown keeps its block's place in the coarse grid (parts
 * of one block share it), and coarse unknowns are numbered by place, then
 * by their first fine unknown: so a coarse slab's fine unknowns are
 * consecutive, as the restriction's slabs need, and the next step
 * coarsens the coarse grid the same way.  The coarse operator is a sparse
 * matrix by rows (a coarse unknown's neighbours are parts of its block
 * and of the blocks beside it): each coarse link the sum of the fine links
 * between its two groups, summed in double in both of its rows (so that
 * it is one float twice), each coarse sink the sum of its group's sinks,
 * so that every level conserves power as the fine one does. */
#ifndef OHM_SOLVERS_MG_COARSEN_H
#define OHM_SOLVERS_MG_COARSEN_H

#include <stdint.h>

#include "base/ohm_error.h"
#include "grid/cell_index.h"
#include "physics/stencil_form.h"

/* A coarse level's operator by rows: row v is
 *   sink[v] x_v + sum_k g[k] (x_v - x_col[k])   (k in rp[v] .. rp[v + 1] - 1)
 * each link in both of its rows with the same value.
 *
 * Two forms.  The set-up's: row starts in 64 bits and sinks in double, from
 * which the next level's sums, the inverse diagonal and the coarsest
 * factor are taken.  The cycle's (ohm_mg_sparse_compact, once the whole
 * hierarchy is built): the sinks in floats, as the cycle's rows read them
 * anyway, and the starts in 32 bits where the links are fewer than 2^31;
 * 8 B a row fewer to hold and to stream on every pass. */
typedef struct ohm_mg_sparse {
    int64_t n;
    int64_t nnz;     /* links, counted in both rows */
    int64_t *rp;     /* n + 1; NULL once compacted to rp32 */
    int32_t *rp32;   /* n + 1, compacted (NULL: rp stays, nnz >= 2^31) */
    int32_t *col;    /* nnz: a coarse level has fewer unknowns than the grid's 2^31 */
    float *g;        /* > 0 */
    double *sink;    /* the set-up's; NULL once compacted */
    float *sink_f;   /* the cycle's, compacted */
} ohm_mg_sparse;

void ohm_mg_sparse_free(ohm_mg_sparse *sp); /* zeroed after; a zeroed one is fine */

/* sp in the cycle's form (above); -1: out of memory (sp as it was). */
int ohm_mg_sparse_compact(ohm_mg_sparse *sp);

/* Row v's first link, and its sink as a float, in either form. */
static inline int64_t ohm_mg_sparse_start(const ohm_mg_sparse *sp, int64_t v)
{
    return sp->rp32 ? sp->rp32[v] : sp->rp[v];
}
static inline float ohm_mg_sparse_sink(const ohm_mg_sparse *sp, int64_t v)
{
    return sp->sink_f ? sp->sink_f[v] : (float)sp->sink[v];
}

/* A level's operator as the coarsening reads it: the network's stencil
 * (the finest level; its links beyond the grid included) or a coarse
 * level's rows, one of the two NULL. */
typedef struct ohm_mg_operator {
    const ohm_stencil *st;
    const ohm_mg_sparse *sp;
} ohm_mg_operator;

/* Where a level's unknowns sit, in cell order, in a grid of dims: the
 * finest level's as its network's cell index, a coarse level's as an
 * array of cells (one per unknown, non-decreasing; parts share one). */
typedef struct ohm_mg_places {
    const ohm_cell_index *cells;
    const int64_t *cell;
    int64_t dims[3];
} ohm_mg_places;

/* theta of the strength test, and the fraction of a level's unknowns the
 * coarse level may keep before it falls back to whole blocks.  theta
 * measured on the held-in family (docs/multigrid.md): 0.25 as AMG's. */
#define OHM_MG_THETA 0.25
#define OHM_MG_KEEP_MAX 0.7

/* One step: level (n unknowns) into the coarse one. */
typedef struct ohm_mg_coarse {
    int32_t *agg;                /* n: the coarse unknown holding each        */
    int64_t nslabs;              /* the coarse grid's z extent                */
    int64_t *fine_at, *coarse_at; /* nslabs + 1: slab K's unknowns, both levels */
    int64_t nc;
    int64_t *cell;               /* nc: each coarse unknown's coarse cell     */
    int64_t cdims[3];
    ohm_mg_sparse sp;            /* the coarse operator                       */
    int whole_blocks;            /* strength kept too many: fixed blocks      */
} ohm_mg_coarse;

/* threads: cores it may use; its result is the same on any number. */
int ohm_mg_coarsen(const ohm_mg_operator *op, int64_t n, const ohm_mg_places *places, double theta, int threads,
                   ohm_mg_coarse *out, ohm_error *err);

/* A coarse level whose blocks all stayed whole (one unknown per coarse
 * cell) is a 7-point stencil on the coarse grid, whose loops vectorise and
 * stream 20 B a row against a sparse row's 16 and 8 a link: the same
 * operator as *st (physics/stencil_form.h, its arrays owned), *is_stencil
 * 1; else *is_stencil 0 and nothing made. */
int ohm_mg_sparse_as_stencil(const ohm_mg_sparse *sp, const int64_t *cell, const int64_t cdims[3], ohm_stencil *st,
                             int *is_stencil, ohm_error *err);

/* Frees what ohm_mg_coarsen allocated and the caller has not taken
 * (pointers the caller set to NULL are skipped). */
void ohm_mg_coarse_free(ohm_mg_coarse *c);

#endif
