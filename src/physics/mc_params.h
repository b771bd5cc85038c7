/* physics/mc_params.h — what a Monte Carlo trace is asked (ohm_mc_params)
 * and what it answers (ohm_mc_result), in its OHM_MC_BATCHES batches: the
 * types that the tracer on the host's threads (mc.h), the tracer on an
 * OpenCL device (mc_device.h) and their shared tallies (mc_tally.h) all
 * speak, so that none of their headers includes another's.  The method:
 * mc.h. */
#ifndef OHM_PHYSICS_MC_PARAMS_H
#define OHM_PHYSICS_MC_PARAMS_H

#include <stdint.h>

#include "base/log.h"
#include "device/request.h"

enum { OHM_MC_BATCHES = 16 };

typedef struct ohm_mc_params {
    int64_t photons; /* per frame and channel, rounded up to a multiple of 16; 0: 10^6 */
    uint64_t seed;
    int threads;     /* 0: every core the process may use */
    double max_path; /* mm; 0: none.  A time gate (path = time x c / n): weight still
                        travelling after this path length is counted as gated, neither
                        absorbed nor out, as time-resolved codes do at their window's end
                        (MCX's cube60 benchmark: 5 ns) */
    int total_fluence; /* 0: the fluence of scattered light only, what diffusion's
                          phi is (its source is the first scattering); 1: the
                          unscattered beam's too, what transport codes report */
    double max_memory;  /* bytes the tallies may take; 0: what the machine has */
    int handoff;        /* > 0: the hybrid of transport and diffusion (solve.h,
                           hybrid=): a photon ends after `handoff` reduced
                           scatterings (each scattering counts 1 - g of its
                           cell: ceil(handoff / (1 - g)) scatterings in one
                           medium, when its direction is forgotten, g^k ~
                           e^-handoff), and its weight becomes an
                           isotropic diffusion source there, shared between
                           the nearest cell centres so that its place is kept
                           (ohm_mc_result.handoff) */
    const ohm_log *log; /* progress; NULL: quiet */
    ohm_device_request device; /* zero (host): the host's threads; else an
                                  OpenCL device (mc_device.h), opened for
                                  this trace */
    struct ohm_mc_device *kept; /* a device kept open by the caller
                                   (mc_device.h), which traces instead of
                                   `device`; NULL: none */
} ohm_mc_params;

/* One channel and frame.  Arrays are the caller's: fluence, fluence_se,
 * exitance_se n = net->n entries, face_exitance net->nfaces. */
typedef struct ohm_mc_result {
    double *fluence, *fluence_se;     /* W/mm^2, and its standard error        */
    double *face_exitance;            /* W/mm^2 leaving through each face      */
    double *exitance_se;              /* standard error of each cell's exitance
                                         (the mean of its faces', solve.h)     */
    double power_in, power_absorbed, power_out; /* W                           */
    double power_gated;               /* W still travelling at max_path        */
    double *handoff;                  /* n, params->handoff > 0: W handed to
                                         diffusion per cell (else unused)      */
    double power_handoff;             /* their sum                             */
    double power_absorbed_se, power_out_se; /* their standard errors (W)       */
    int64_t photons;                  /* traced                                */
    int64_t truncated;                /* photons stopped after 10^8 events     */
    int64_t events;                   /* path segments (cell crossings and
                                         scatterings), for the speed figures   */
    double seconds;
    int threads;                      /* host threads, or the device's compute units */
    char device[96];                  /* the OpenCL device it ran on; "": the host */
} ohm_mc_result;

#endif
