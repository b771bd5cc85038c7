/* physics/stencil_form.h — the network's matrix in its 7-point stencil
 * form (ohm_stencil) and the lookup of an unknown's run: the type that the
 * stencil's operations (stencil.h) and the loop over its rows
 * (stencil_rows.h, which stencil.c is written with) both speak, so that
 * neither header includes the other. */
#ifndef OHM_PHYSICS_STENCIL_FORM_H
#define OHM_PHYSICS_STENCIL_FORM_H

#include <stdint.h>

#include "base/sorted.h"

/* The network's matrix as a 7-point stencil over its unknowns, what a
 * matrix-free solver reads instead of the assembled A (28 B per unknown and
 * a few per run, against CHOLMOD's 24 per entry, four entries per
 * unknown): row v is
 *   sink[v] x_v + sum_w g_vw (x_v - x_w)
 * over v's face neighbours w.  Each link's conductance is stored once, by
 * its lower unknown, in gx, gy or gz by its axis, and is > 0 exactly where
 * the link is (0 where there is none).  Unknowns are numbered in cell
 * order, so a +x neighbour is always v + 1 and needs no index; the y and
 * z neighbours' offsets (w - v) are the same along most of a row of cells,
 * so they are stored per run: a run is a longest stretch of consecutive
 * unknowns whose four offsets are equal (the rows of a box's plane between
 * its first and last are one run; an object's ragged edge cuts a row into a
 * few).  A solver's rows then read
 * their neighbours at fixed distances, as a box's would, and vectorise.
 * The values are ohm_network_assemble's, by the same code: A = the
 * stencil's matrix, up to the order its diagonal is summed in. */
typedef struct ohm_stencil {
    int64_t n;
    int64_t nruns;
    int64_t *run_start;    /* nruns + 1: run r is unknowns run_start[r] ..
                              run_start[r + 1] - 1                         */
    int32_t (*run_off)[4]; /* run r's -y, +y, -z, +z neighbour minus v; 0: none */
    float *gx, *gy, *gz;   /* conductance of v's +x, +y, +z link; 0: none  */
    double *sink;          /* ground + boundary (+ closure) conductance, scaled
                              as the diagonal (network.h: s_v with eta_v)   */
    /* Links beyond the grid (NULL: none), as rows: v's are xcol[k], xg[k]
     * for k in xstart[v] .. xstart[v + 1] - 1, each link in both its rows
     * with the same float; row v gains sum g (x_v - x_w).  What the clear
     * regions' coupling adds (physics/clear_exchange.h).  Columns in 32
     * bits: the unknowns are fewer than the grid's cells, which the
     * voxelizer keeps below 2^31 (checked where they are made); at 10^8
     * links (a head's clear regions at 1 mm) that is 0.4 GB less, and a
     * third less to read in every pass. */
    int64_t *xstart;
    int32_t *xcol;
    float *xg;
} ohm_stencil;

/* The run holding unknown v, from *cursor (a run at or before v's; 0 to
 * start): O(1) for unknowns visited in increasing order. */
static inline int64_t ohm_stencil_run(const ohm_stencil *st, int64_t v, int64_t *cursor)
{
    int64_t r = *cursor;
    while (st->run_start[r + 1] <= v) ++r;
    return *cursor = r;
}

/* The run holding unknown v, by bisection. */
static inline int64_t ohm_stencil_run_of(const ohm_stencil *st, int64_t v)
{
    return ohm_sorted_last_at_most(st->run_start, st->nruns, v);
}

#endif
