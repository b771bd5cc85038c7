/* physics/mc_trace.h — a Monte Carlo trace (the method: mc.h), on the
 * host's threads (mc.h) or on an OpenCL device (mc_device.h), as its
 * params say: the one entry point the solve, the studies and the tests
 * call.  The choice between the two is made here, above both tracers, so
 * that neither calls the other. */
#ifndef OHM_PHYSICS_MC_TRACE_H
#define OHM_PHYSICS_MC_TRACE_H

#include <stddef.h>

#include "base/ohm_error.h"
#include "physics/light.h"
#include "physics/mc_params.h"
#include "physics/network.h"

/* Trace the entries' power of channel `channel` through medium med: on
 * params->kept when the caller keeps a device open, else on the device
 * params->device names (none, or the host: the host's threads).  res's
 * arrays are the caller's; they are zeroed here. */
int ohm_mc_trace(ohm_mc_result *res, const ohm_network *net, const ohm_channel_medium *med,
                 const ohm_light_entry *entries, size_t nentries, int channel, const ohm_mc_params *params,
                 ohm_error *err);

#endif
