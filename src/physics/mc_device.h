/* mc_device.h — the Monte Carlo tracer (mc.h) on an OpenCL device
 * (docs/devices.md): solver=mc, `ohm validate transport|mc` and the hybrid's traced
 * photons with device=gpu|cpu|opencl:N|auto.  The same physics as the
 * host's tracer (kernels: mc_device.cl), the same batches, estimators and
 * standard errors (mc_tally.h); photon k's random numbers come from a
 * counter-based generator keyed by the seed, so a run is repeated by the
 * same seed on the same device, whatever its launches.  The tallies are
 * double, added atomically. */
#ifndef OHM_PHYSICS_MC_DEVICE_H
#define OHM_PHYSICS_MC_DEVICE_H

#include <stddef.h>
#include <stdint.h>

#include "base/log.h"
#include "base/ohm_error.h"
#include "physics/light.h"
#include "physics/mc_params.h"
#include "physics/network.h"

typedef struct ohm_mc_device ohm_mc_device;

/* The device `req` names (gpu, cpu, opencl:N, auto; devices.h), open for
 * tracing `photons` per trace (0: mc_params.h's default, 10^6): *out NULL and
 * OHM_OK when that is the host
 * (host; auto without a GPU, or for fewer photons than pay for opening
 * one).  No runtime, no such device, a device without double
 * precision or 64-bit atomics: an error that says which.  A solve keeps one
 * open across its frames and channels (ohm_mc_params.kept), so the queue,
 * the built kernels, the network's layout and the tallies' buffers are
 * made once. */
int ohm_mc_device_open(ohm_mc_device **out, const ohm_device_request *req, int64_t photons, const ohm_log *log,
                       ohm_error *err);

/* Trace on d into res (its arrays zeroed by the caller), P the entries'
 * power in `channel`, per_batch photons in each of the OHM_MC_BATCHES
 * batches (ohm_mc_trace's work, mc_trace.h).  Too little device memory, a kernel
 * that does not build: an error that says which. */
int ohm_mc_device_run(ohm_mc_device *d, ohm_mc_result *res, const ohm_network *net, const ohm_channel_medium *med,
                      const ohm_light_entry *entries, size_t nentries, int channel, double P, int64_t per_batch,
                      const ohm_mc_params *params, ohm_error *err);

void ohm_mc_device_free(ohm_mc_device *d); /* NULL is fine */

#endif
