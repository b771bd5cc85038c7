/* mc.h — a Monte Carlo photon-transport reference on the voxel object
 * (docs/design.md §5; docs/transport.md).
 *
 * Diffusion is a model of light transport; this traces the transport itself
 * through the same cells, media and light entries, so a user can measure the
 * model's error on their own scene.  Photons enter where ohm_light_entries_add
 * says (power after Fresnel, direction by Snell's law), fly free paths of the
 * scattering coefficient sigma_s = sigma_s' / (1 - g), scatter by
 * Henyey-Greenstein with anisotropy g, and lose weight continuously as
 * e^(-sigma_a s) (the "microscopic Beer-Lambert" weighting of MCX: Fang &
 * Boas 2009; g from the medium, ohm_channel_medium.g), so every path segment's absorption and fluence are exact
 * integrals, not point samples.  At a boundary face (into a cell that is not
 * part of the object) a photon is reflected specularly with the probability
 * of the exact unpolarised Fresnel reflectance at the face's own normal, and
 * otherwise leaves with all its weight (booked as that face's exitance); the
 * index is the cell's own (eta_v, or eta).  Where two cells' indices differ
 * the photon is reflected with the Fresnel probability of the interface
 * (relative index eta_here / eta_there) or refracted by Snell's law.
 * Splitting the weight instead (MCML's partial reflection) measured 4.7x
 * slower on a mismatched cube, the photon living on at ever smaller weight.  Symmetry
 * planes (validation scenes) reflect everything.  A photon whose weight has
 * fallen below 1e-6 of its start deposits the rest where it is: conservation
 * holds to round-off, at a bias below 1e-6 of the power.
 *
 * Estimators, per unit of power entering (the same units as the diffusion
 * solve): fluence phi_c = (sum over segments in c of w (1 - e^(-sigma_a s)) /
 * sigma_a) / h^3 (track length; by default only segments after a photon's
 * first scattering, see total_fluence), face exitance = escaped weight / h^2.  The
 * photons run in 16 equal batches; the standard error of every cell's
 * fluence and exitance is the spread of the batch means.  Batches are split
 * between threads statically and each batch has its own random stream
 * (xoshiro256+, seeded from seed and the batch number by splitmix64), so a
 * run is repeated bit for bit by the same seed and thread count. */
#ifndef OHM_MC_H
#define OHM_MC_H

#include <stdint.h>

#include "physics/light.h"
#include "base/log.h"
#include "physics/network.h"
#include "base/ohm_error.h"
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

/* Trace the entries' power of channel `channel` through medium med. */
int ohm_mc_trace(ohm_mc_result *res, const ohm_network *net, const ohm_channel_medium *med,
                 const ohm_light_entry *entries, size_t nentries, int channel, const ohm_mc_params *params,
                 ohm_error *err);

#endif
