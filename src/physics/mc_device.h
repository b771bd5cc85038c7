/* mc_device.h — the Monte Carlo tracer (mc.h) on an OpenCL device (issue
 * 37): solver=mc, `ohm validate transport|mc` and the hybrid's traced
 * photons with device=gpu|cpu|opencl:N|auto.  The same physics as the
 * host's tracer (kernels: mc_device.cl), the same batches, estimators and
 * standard errors (mc_tally.h); photon k's random numbers come from a
 * counter-based generator keyed by the seed, so a run is repeated by the
 * same seed on the same device, whatever its launches.  The scene is
 * copied to the device for each call (its cells' unknowns, faces, media
 * and the entries); the tallies are double, added atomically. */
#ifndef OHM_PHYSICS_MC_DEVICE_H
#define OHM_PHYSICS_MC_DEVICE_H

#include "physics/mc.h"

/* Trace on the device params->device names into res (its arrays zeroed by
 * the caller), P the entries' power in `channel`, per_batch photons in each
 * of the OHM_MC_BATCHES batches.  *ran 0 and OHM_OK when that is the host
 * (host, or auto without a GPU): the caller traces.  No runtime, no such
 * device, a device without double precision or 64-bit atomics, too little
 * device memory, a kernel that does not build: an error that says which. */
int ohm_mc_device_trace(int *ran, ohm_mc_result *res, const ohm_network *net, const ohm_channel_medium *med,
                        const ohm_light_entry *entries, size_t nentries, int channel, double P, int64_t per_batch,
                        const ohm_mc_params *params, ohm_error *err);

#endif
