/* physics/mc_trace.c — a Monte Carlo trace: what it checks and zeroes, then
 * the host's threads or an OpenCL device (mc_trace.h). */
#include "physics/mc_trace.h"

#include <string.h>

#include "base/log.h"
#include "physics/mc.h"
#include "physics/mc_device.h"

int ohm_mc_trace(ohm_mc_result *res, const ohm_network *net, const ohm_channel_medium *med,
                 const ohm_light_entry *entries, size_t nentries, int channel, const ohm_mc_params *params,
                 ohm_error *err)
{
    double t0 = ohm_now();
    if (med->resistance_mode)
        return ohm_fail(err, OHM_ERR_USAGE, "solve: solver=mc needs optical coefficients, not resistances");
    if (!(med->g > -1.0 && med->g < 1.0))
        return ohm_fail(err, OHM_ERR_USAGE, "solve: g=%g: the anisotropy must lie in (-1, 1)", med->g);
    int64_t photons = params->photons > 0 ? params->photons : 1000000;
    int64_t per_batch = (photons + OHM_MC_BATCHES - 1) / OHM_MC_BATCHES;
    res->threads = ohm_mc_host_threads(params);
    double P = 0;
    for (size_t e = 0; e < nentries; ++e) P += entries[e].power[channel];
    size_t n = (size_t)net->n, nf = (size_t)(net->nfaces ? net->nfaces : 1);
    memset(res->fluence, 0, n * sizeof *res->fluence);
    memset(res->fluence_se, 0, n * sizeof *res->fluence_se);
    memset(res->exitance_se, 0, n * sizeof *res->exitance_se);
    memset(res->face_exitance, 0, nf * sizeof *res->face_exitance);
    res->power_in = res->power_absorbed = res->power_out = res->power_gated = res->power_handoff = 0;
    if (params->handoff > 0) memset(res->handoff, 0, n * sizeof *res->handoff);
    res->photons = res->truncated = res->events = 0;
    res->device[0] = '\0';
    if (!(P > 0)) { /* unlit in this channel: nothing to trace */
        res->seconds = ohm_now() - t0;
        return OHM_OK;
    }
    ohm_mc_device *dev = params->kept;
    int rc = dev ? OHM_OK : ohm_mc_device_open(&dev, &params->device, per_batch * OHM_MC_BATCHES, params->log, err);
    int on_device = dev != NULL;
    if (!rc && on_device)
        rc = ohm_mc_device_run(dev, res, net, med, entries, nentries, channel, P, per_batch, params, err);
    if (dev != params->kept) ohm_mc_device_free(dev);
    if (!rc && !on_device)
        rc = ohm_mc_host_run(res, net, med, entries, nentries, channel, P, per_batch, params, err);
    res->seconds = ohm_now() - t0;
    return rc;
}
