/* physics/stencil.h — the network's matrix in its 7-point stencil form:
 * the form (ohm_stencil: stencil_form.h) and its runs, and its operations:
 * A x, A's diagonal and norm, the residual's norms and the pieces' sums, on the
 * stencil's runs (every solver that works matrix-free reads the network
 * through these).  The network fills it (ohm_network_stencil, network.h)
 * from the same row function as the matrix's assembly, so the two are one
 * matrix. */
#ifndef OHM_PHYSICS_STENCIL_H
#define OHM_PHYSICS_STENCIL_H

#include <stdint.h>

#include "base/ohm_error.h"
#include "physics/stencil_form.h"

/* The bytes st holds. */
double ohm_stencil_bytes(const ohm_stencil *st);

/* st's runs from per-unknown offsets off[v] (-y, +y, -z, +z; st->n of
 * them), replacing any it has: for a stencil built cell by cell (a coarse
 * level's).  OHM_ERR_NOMEM. */
int ohm_stencil_set_runs(ohm_stencil *st, const int32_t (*off)[4], ohm_error *err);

void ohm_stencil_free(ohm_stencil *st); /* NULL or zeroed is fine */

/* Drop st's links beyond the grid (stencil_form.h), if any. */
void ohm_stencil_drop_extra(ohm_stencil *st);

/* A stencil's runs as they are found, in increasing unknowns: a new run
 * where the offsets change (a builder's, one per thread's share of the
 * rows). */
typedef struct ohm_stencil_runs {
    int64_t n, cap;
    int64_t *start;
    int32_t (*off)[4];
    int failed; /* out of memory */
} ohm_stencil_runs;

/* Unknown v's offsets (-y, +y, -z, +z), v after every unknown pushed. */
void ohm_stencil_runs_push(ohm_stencil_runs *rl, int64_t v, const int32_t off[4]);
void ohm_stencil_runs_free(ohm_stencil_runs *rl);

/* st's runs: the lists of consecutive stretches of its unknowns, in order,
 * joined (a run cut only by where one list ends and the next begins is one
 * run), replacing any it has.  OHM_ERR_NOMEM. */
int ohm_stencil_adopt_runs(ohm_stencil *st, const ohm_stencil_runs *lists, int count, ohm_error *err);

/* y = A x for the stencil's matrix, on up to `threads` cores. */
void ohm_stencil_apply(const ohm_stencil *st, const double *x, double *y, int threads);

/* ||b - A x||_inf, ||x||_inf and ||b||_inf in one pass, row by row, with
 * no vector of its own (threads <= 0: every usable core). */
void ohm_stencil_residual_norms(const ohm_stencil *st, const double *b, const double *x, int threads, double *nr,
                                double *nx, double *nb);

/* Add each piece's sum of the sinks and of A's diagonal into sink[p],
 * diag[p]: the pieces as runs of unknowns (network.h's ohm_piece_runs:
 * run r is start[r] .. start[r + 1] - 1, in piece[r]; count 0: one piece). */
void ohm_stencil_piece_sums(const ohm_stencil *st, const int64_t *start, const int32_t *piece, int64_t count,
                            double *sink, double *diag);

/* ||A||_inf of the stencil's matrix: its largest row sum of |a|. */
double ohm_stencil_norm_inf(const ohm_stencil *st);

/* A's diagonal entry in row v (its run found by bisection). */
double ohm_stencil_diag(const ohm_stencil *st, int64_t v);

#endif
