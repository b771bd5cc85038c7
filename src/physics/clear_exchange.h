/* clear_exchange.h — transport across clear regions coupled to diffusion in
 * the rest: the radiosity–diffusion model (Firbank, Arridge, Schweiger &
 * Delpy, Phys. Med. Biol. 41:767, 1996; Arridge et al., Med. Phys. 27:252,
 * 2000) in the form of Oppenheim's radiation network, linear in the sources
 * and symmetric positive definite (docs/transport.md, "Transport across clear
 * regions: radiosity–diffusion", derives every conductance below).
 *
 * Given a mask of clear unknowns (cells where light flies straight: diffusion
 * is no model there), the network's matrix is changed so that:
 *   - no link joins two clear cells (no D = infinity left in the operator);
 *   - a clear cell with a face on the region's wall — a face to a diffusive
 *     cell, or a boundary face of the object — is a node whose unknown is the
 *     fluence of the clear medium at its wall faces; each wall face links the
 *     diffusive cell to it through half a cell of diffusion in series with
 *     the partial-current condition at the index step (wall conductance);
 *   - nodes exchange light by the view factors between their faces through
 *     the clear cells (a 3-D DDA for visibility, mirror planes unfolded):
 *     conductance (1/2) a_p F_pq, symmetric by reciprocity, the view factors
 *     renormalised symmetrically so that every face's sum to 1 (what distance
 *     culling and the voxel staircase lose goes to the faces kept, never to
 *     absorption); absorption on the way (exp(-sigma_a r)) is a ground;
 *   - a clear cell with no wall face is no node: its row is the identity, the
 *     sources deposited in it are moved to its nearest node
 *     (ohm_clear_exchange_move_sources) and its fluence is that node's after
 *     the solve (ohm_clear_exchange_fill), for the outputs only.
 * Conservation stays exact: every added link is a conductance between two
 * unknowns, and every sink is booked in ga (absorbed) or gb (out). */
#ifndef OHM_CLEAR_EXCHANGE_H
#define OHM_CLEAR_EXCHANGE_H

#include <stddef.h>
#include <stdint.h>

#include <cholmod.h>

#include "base/log.h"
#include "base/ohm_error.h"
#include "physics/network.h"
#include "physics/stencil_form.h"

typedef struct ohm_clear_exchange_params {
    /* face pairs farther apart than this (mm) are not linked; 0: every
     * visible pair.  The renormalisation gives what they would have carried
     * to the pairs kept. */
    double max_distance;
    /* progress of the pairs' search (its longest step: the pairs grow with
     * the wall's area within reach) and its cancel flag; NULL: none */
    const ohm_log *log;
} ohm_clear_exchange_params;

/* The geometry of the coupling (medium independent): built once per
 * network and mask, valued per channel medium by ohm_clear_exchange_apply. */
typedef struct ohm_clear_exchange {
    const ohm_network *net;   /* not owned */
    const uint8_t *clear;     /* n, not owned: 1 = clear unknown */
    int64_t nclear;           /* clear unknowns */
    int64_t nnodes;           /* clear unknowns with a wall face: nodes */
    int64_t *node_unknown;    /* nnodes, increasing */
    int64_t nwall;            /* faces between a diffusive unknown and a node */
    int64_t *wall_diffusive;  /* nwall: the diffusive unknown */
    int64_t *wall_node;       /* nwall: the clear unknown (a node) */
    int64_t nescape;          /* boundary faces of nodes (net's face indices) */
    int64_t *escape_face;
    int64_t npairs;           /* node pairs linked by exchange */
    /* the pairs, 20 B each (10^8 at a head's clear regions at 1 mm): 32-bit
     * unknowns (fewer than the grid's cells, which the voxelizer keeps below
     * 2^31: checked by build), the distance in a float (it only sets the
     * absorption on the way, exp(-sigma_a r)) */
    int32_t *pair_u, *pair_v; /* npairs: unknowns, u < v */
    double *pair_w;           /* npairs: sum of a_p F_pq over their faces (mm^2), renormalised */
    float *pair_r;            /* npairs: its F-weighted mean distance (mm) */
    double *self_w, *self_r;  /* nnodes: a node's faces with each other and with their mirror images */
    int64_t nfill;            /* clear unknowns that are no node */
    int64_t *fill_unknown, *fill_from; /* nfill: the unknown, its nearest node's unknown */
    /* what it took, for the log and the stats */
    int64_t faces;            /* wall + escape faces */
    int64_t rays;             /* visibility rays traced */
    double renorm_min, renorm_max; /* the renormalisation's range of row factors */
    double seconds;           /* set-up time */
} ohm_clear_exchange;

/* The coupling's geometry for the network's unknowns with clear[v] set (n
 * entries, kept by pointer: it must outlive ce).  A mask with no clear cell
 * gives an empty coupling (nclear 0), which apply leaves the network as it is.
 * Fails (one line) on a depth band, on mirror planes on both sides of an
 * axis, and out of memory. */
int ohm_clear_exchange_build(ohm_clear_exchange *ce, const ohm_network *net, const uint8_t *clear,
                             const ohm_clear_exchange_params *params, ohm_error *err);
void ohm_clear_exchange_free(ohm_clear_exchange *ce);

/* The network's matrix A (ohm_network_assemble's, for this medium) made the
 * coupled one: *A replaced by a new matrix (the old freed), ga[n] and
 * gb[nfaces] (both required) rewritten where the coupling changes them.  The
 * pattern depends on the geometry only, so every medium's coupled matrix has
 * the same (a symbolic analysis is shared).  Empty coupling: nothing changes,
 * bit for bit.  Needs optical coefficients (not resistance=); boundary: the
 * assembly's (an escape face's conductance replaces robin's only). */
int ohm_clear_exchange_apply(cholmod_sparse **A, double *ga, double *gb, const ohm_clear_exchange *ce,
                             const ohm_channel_medium *med, ohm_boundary boundary, cholmod_common *cc,
                             ohm_error *err);

/* The same coupled operator in the network's stencil form (*st: the
 * network's, ohm_network_stencil's, for this medium, with ga and gb):
 * links touching clear cells become the walls' conductances or none, the
 * clear cells' sinks the coupling's, and the node pairs the stencil's links
 * beyond the grid (stencil_form.h's extra rows).  A multigrid reads it as
 * it reads any network's stencil.  Empty coupling: nothing changes. */
int ohm_clear_exchange_stencil(ohm_stencil *st, double *ga, double *gb, const ohm_clear_exchange *ce,
                               const ohm_channel_medium *med, ohm_boundary boundary, ohm_error *err);

/* The wall conductance of a face between diffusive unknown v (index eta_v,
 * diffusion coefficient D) and clear cell of index eta_c, in the network's
 * scaled unknowns (network.h): s_v h^2 / (h/(2D) + 2 (A(m) - m^2)), m =
 * eta_v / eta_c, A(m) fresnel.h's boundary constant of the step. */
double ohm_clear_wall_conductance(double h, double D, double s_v, double eta_v, double eta_c);

/* Sources of ncols columns (n each) in clear cells that are no node moved
 * to their nearest node, so that they are solved for and booked there. */
void ohm_clear_exchange_move_sources(const ohm_clear_exchange *ce, double *b, size_t ncols);

/* The fluence of those cells after the solve: their nearest node's. */
void ohm_clear_exchange_fill(const ohm_clear_exchange *ce, double *x, size_t ncols);

#endif
