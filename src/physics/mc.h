/* mc.h — a Monte Carlo photon-transport reference on the voxel object
 * (docs/design.md §5; docs/transport.md), traced on the host's threads; its
 * entry point, which picks the host or an OpenCL device (mc_device.h), is
 * ohm_mc_trace (mc_trace.h).
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
#include "physics/mc_params.h"
#include "physics/network.h"
#include "base/ohm_error.h"

/* The host's threads a trace uses: params->threads, else every core the
 * process may use, at most one per batch. */
int ohm_mc_host_threads(const ohm_mc_params *params);

/* Trace on the host's threads into res (its arrays zeroed by the caller),
 * P the entries' power in `channel`, per_batch photons in each of the
 * OHM_MC_BATCHES batches: ohm_mc_trace's work when no device traces it
 * (mc_trace.h).  Tallies beyond the memory limit: an error that says so. */
int ohm_mc_host_run(ohm_mc_result *res, const ohm_network *net, const ohm_channel_medium *med,
                    const ohm_light_entry *entries, size_t nentries, int channel, double P, int64_t per_batch,
                    const ohm_mc_params *params, ohm_error *err);

#endif
