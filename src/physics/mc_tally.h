/* mc_tally.h — the Monte Carlo tracer's sums over its 16 batches (mc.h),
 * and the result written from them: one piece of code for the host's
 * threads (mc.c, a sums per thread, merged in thread order) and for the
 * device (mc_device.c, one sums filled batch by batch).  Private to
 * physics/mc*.c. */
#ifndef OHM_PHYSICS_MC_TALLY_H
#define OHM_PHYSICS_MC_TALLY_H

#include <stddef.h>
#include <stdint.h>

#include "physics/light.h"
#include "physics/mc_params.h"
#include "physics/network.h"

/* In voxel units of weight x length (fluence) and weight (faces, totals):
 * over the batches, sums and sums of squares of batch values. */
typedef struct ohm_mc_sums {
    double *phi_sum, *phi_sq;   /* n                                          */
    double *face_sum;           /* nfaces                                     */
    double *exit_sq;            /* n: squares of a cell's faces' batch mean   */
    double *handoff;            /* n when the hybrid hands off, else NULL     */
    double handed, absorbed, out, gated;
    double batch_absorbed, batch_out; /* at the batch's start, for:           */
    double absorbed_sq, out_sq;       /* sums of squares of batch totals      */
    int64_t truncated, events;
} ohm_mc_sums;

int ohm_mc_sums_alloc(ohm_mc_sums *s, const ohm_network *net, int handoff);
void ohm_mc_sums_free(ohm_mc_sums *s);

/* One batch's face tallies (nfaces) folded in; `face` is left as it was. */
void ohm_mc_fold_faces(ohm_mc_sums *s, const ohm_network *net, const double *face);
/* The batch's totals (what absorbed and out gained since the last call)
 * folded into their squares. */
void ohm_mc_fold_totals(ohm_mc_sums *s);

/* src's sums added into dst's. */
void ohm_mc_sums_merge(ohm_mc_sums *dst, const ohm_mc_sums *src, const ohm_network *net);

/* Means and standard errors per unit of power P into res: batches of
 * per_batch photons of weight P / per_batch each. */
void ohm_mc_write_result(ohm_mc_result *res, const ohm_mc_sums *s, const ohm_network *net, int64_t per_batch,
                         double P);

/* The entries' cumulative share of channel c's power P (the last exactly 1). */
void ohm_mc_entry_cdf(double *cdf, const ohm_light_entry *entries, size_t nentries, int channel, double P);

#endif
