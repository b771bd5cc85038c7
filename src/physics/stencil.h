/* physics/stencil.h — the network's matrix in its 7-point stencil form
 * (network.h's ohm_stencil, which ohm_network_stencil fills from the same
 * rows as the matrix's assembly), applied: A x, A's diagonal and norm, the
 * residual's norms and the pieces' books, on the stencil's runs (every
 * solver that works matrix-free reads the network through these). */
#ifndef OHM_PHYSICS_STENCIL_H
#define OHM_PHYSICS_STENCIL_H

#include <stdint.h>

#include "physics/network.h"

/* y = A x for the stencil's matrix, on up to `threads` cores. */
void ohm_stencil_apply(const ohm_stencil *st, const double *x, double *y, int threads);

/* ||b - A x||_inf, ||x||_inf and ||b||_inf in one pass, row by row, with
 * no vector of its own (threads <= 0: every usable core). */
void ohm_stencil_residual_norms(const ohm_stencil *st, const double *b, const double *x, int threads, double *nr,
                                double *nx, double *nb);

/* Add each piece's sum of the sinks and of A's diagonal into sink[p],
 * diag[p] (the unknowns' pieces, network.h). */
void ohm_stencil_piece_sums(const ohm_stencil *st, const ohm_piece_runs *pieces, double *sink, double *diag);

/* ||A||_inf of the stencil's matrix: its largest row sum of |a|. */
double ohm_stencil_norm_inf(const ohm_stencil *st);

/* A's diagonal entry in row v (its run found by bisection). */
double ohm_stencil_diag(const ohm_stencil *st, int64_t v);

#endif
