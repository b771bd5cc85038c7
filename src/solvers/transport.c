/* solvers/transport.c — Monte Carlo transport in a solve (transport.h, mc_trace.h): solver=mc,
 * every frame's light entries traced per channel instead of diffusion; and
 * the hybrid's transport part (mc.handoff), the photons traced to their
 * handoff, whose weight becomes diffusion's source.  The hybrid's arrays
 * belong to the batch's work (batch.c). */
#include "solvers/solver_impl.h"
#include "solvers/transport.h"

#include "physics/mc_device.h"
#include "physics/mc_trace.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The light arriving and entering in channel c, booked from a frame's entries. */
static void book_entries(double *incident, double *entered, const ohm_light_entries *in, int c)
{
    for (size_t k = 0; k < in->count; ++k) {
        *incident += in->entry[k].incident[c];
        *entered += in->entry[k].power[c];
    }
}

/* Trace a frame's entries in channel c through med (mc.h) into r, with the
 * solve's fluence choice and memory cap; the tracer's counts are booked. */
static int trace_entries(ohm_solution *sol, ohm_mc_result *r, const ohm_channel_medium *med,
                         const ohm_light_entries *in, int c, const ohm_solve_params *params, ohm_mc_device *device,
                         ohm_error *err)
{
    ohm_mc_params mp = params->mc;
    mp.total_fluence = params->src.total_fluence;
    mp.max_memory = params->num.max_memory;
    mp.kept = device; /* kept open across the solve's traces (mc_device.h) */
    int rc = ohm_mc_trace(r, &sol->net, med, in->entry, in->count, c, &mp, err);
    if (rc) return rc;
    sol->mc_photons += r->photons;
    sol->mc_events += r->events;
    sol->mc_truncated += r->truncated;
    if (r->threads > sol->mc_threads) sol->mc_threads = r->threads;
    if (r->device[0] && !sol->device[0]) snprintf(sol->device, sizeof sol->device, "%s", r->device);
    return OHM_OK;
}

int ohm_hybrid_alloc(hybrid_part *h, size_t n, size_t nf, size_t batch, ohm_error *err)
{
    memset(h, 0, sizeof *h);
    h->fluence = malloc(n * batch * sizeof(double));
    h->face = malloc(nf * batch * sizeof(double));
    h->fluence_se = malloc(n * sizeof(double));
    h->exit_se = malloc(n * sizeof(double));
    h->power = malloc(3 * batch * sizeof(double));
    if (!h->fluence || !h->face || !h->fluence_se || !h->exit_se || !h->power)
        return ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory for the hybrid's transport part");
    return OHM_OK;
}

void ohm_hybrid_free(hybrid_part *h)
{
    free(h->fluence), free(h->face), free(h->fluence_se), free(h->exit_se), free(h->power);
    ohm_mc_device_free(h->device);
    h->device = NULL;
}

/* Column j of B (zeroed first) gets frame f0 + j's handed-off weight in
 * channel c: the frame's light entries traced to their handoff (mc.h); the
 * photons' own fluence, exitance and power go to h for ohm_hybrid_add. */
int ohm_hybrid_sources(ohm_solution *sol, channel_tally *t, double *B, hybrid_part *h, size_t f0, size_t nb, int c,
                       const ohm_channel_medium *med, const ohm_material *mat, const ohm_light *lights,
                       size_t nlights, const ohm_solve_params *params, const ohm_occluder *occ, ohm_error *err)
{
    const ohm_network *net = &sol->net;
    size_t n = (size_t)net->n, nf = (size_t)(net->nfaces ? net->nfaces : 1);
    ohm_light_entries in = {0};
    int rc = OHM_OK;
    if (!h->device_opened) { /* the photons' device, once for the solve */
        h->device_opened = 1;
        rc = ohm_mc_device_open(&h->device, &params->mc.device, params->mc.photons, params->mc.log, err);
    }
    for (size_t j = 0; j < nb && !rc; ++j) {
        rc = ohm_frame_entries(&in, net, lights, nlights, f0 + j, sol->channels, mat->eta, med->eta_v, occ, err);
        if (rc) break;
        book_entries(&t->power_incident, &t->power_entered, &in, c);
        ohm_mc_result r = {.fluence = h->fluence + j * n,
                           .fluence_se = h->fluence_se,
                           .face_exitance = h->face + j * nf,
                           .exitance_se = h->exit_se,
                           .handoff = B + j * n};
        rc = trace_entries(sol, &r, med, &in, c, params, h->device, err);
        if (rc) break;
        h->power[3 * j] = r.power_in;
        h->power[3 * j + 1] = r.power_absorbed;
        h->power[3 * j + 2] = r.power_out;
    }
    ohm_light_entries_free(&in);
    return rc;
}

/* After ohm_book_power: the hybrid's transport part added to frames f0..f0+nb of
 * channel c (X their fluence).  ohm_book_power counted the handed-off weight as
 * in; the photons' absorption and escape before it complete in = entered. */
void ohm_hybrid_add(ohm_solution *sol, channel_tally *t, double *X, const hybrid_part *h, size_t f0, size_t nb,
                    int c)
{
    const ohm_network *net = &sol->net;
    size_t n = (size_t)net->n, nf = (size_t)(net->nfaces ? net->nfaces : 1);
    for (size_t j = 0; j < nb; ++j) {
        for (size_t v = 0; v < n; ++v) X[j * n + v] += h->fluence[j * n + v];
        double *fx = sol->face_exitance[c] + (f0 + j) * nf;
        for (int64_t f = 0; f < net->nfaces; ++f) fx[f] += h->face[j * nf + (size_t)f];
        double absorbed = h->power[3 * j + 1], out = h->power[3 * j + 2];
        t->power_in += absorbed + out;
        t->power_absorbed += absorbed;
        t->power_out += out;
    }
}

/* solver=mc refuses what only diffusion has: resistances, the boundary
 * models other than the physical one, a depth band, scenes' own sources. */
static int mc_applies(const ohm_solution *sol, const ohm_material *mat, const ohm_solve_params *p, ohm_error *err)
{
    if (mat->kind == OHM_MATERIAL_RESISTANCE || p->media.resistance_v)
        return ohm_fail(err, OHM_ERR_USAGE, "solve: solver=mc traces light through sigma_a and sigma_s', not resistances");
    if (p->op.boundary != OHM_BOUNDARY_ROBIN)
        return ohm_fail(err, OHM_ERR_USAGE,
                        "solve: solver=mc traces the Fresnel boundary itself: boundary=%s is a diffusion model, leave "
                        "it out",
                        ohm_boundary_name(p->op.boundary));
    if (sol->band_active)
        return ohm_fail(err, OHM_ERR_USAGE, "solve: solver=mc traces every cell: leave depth_band= out");
    if (p->src.custom_source)
        return ohm_fail(err, OHM_ERR_INTERNAL, "solve: solver=mc needs lights, not a scene's own source vector");
    if (p->mc.handoff > 0)
        return ohm_fail(err, OHM_ERR_USAGE,
                        "solve: solver=mc traces every scattering: hybrid= hands photons to diffusion, use it with "
                        "a diffusion solver (direct, cg, amg, auto)");
    return OHM_OK;
}

/* Channel c of a frame may take channel e's transport when both media and
 * every entry's power are the same (grey lights on a grey material). */
static int same_transport(const ohm_material *mat, const ohm_media_params *p, const ohm_light_entries *in, int c, int e)
{
    if (!ohm_same_medium(mat, p, c, e)) return 0;
    for (size_t k = 0; k < in->count; ++k)
        if (in->entry[k].power[c] != in->entry[k].power[e]) return 0;
    return 1;
}

/* Monte Carlo transport instead of diffusion (mc.h): every frame's light
 * entries traced per channel; the same solution arrays, plus standard errors. */
static int mc_solve(ohm_solution *sol, const ohm_material *mat, const ohm_light *lights, size_t nlights,
                    const ohm_solve_params *params, const ohm_occluder *occ, ohm_error *err)
{
    int rc = mc_applies(sol, mat, params, err);
    if (rc) return rc;
    const ohm_network *net = &sol->net;
    size_t n = (size_t)net->n, nf = (size_t)(net->nfaces ? net->nfaces : 1), frames = (size_t)sol->frames;
    for (int c = 0; c < sol->channels; ++c) {
        sol->fluence_se[c] = calloc(n * frames, sizeof(double));
        sol->exitance_se[c] = calloc(n * frames, sizeof(double));
        if (!sol->fluence_se[c] || !sol->exitance_se[c])
            return ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory for the standard errors");
    }
    snprintf(sol->solver, sizeof sol->solver, "mc");
    snprintf(sol->solver_reason, sizeof sol->solver_reason, "asked for");
    ohm_mc_device *device = NULL; /* device=: open for every frame and channel */
    rc = ohm_mc_device_open(&device, &params->mc.device, params->mc.photons, params->mc.log, err);
    if (rc) return rc;
    ohm_light_entries in = {0};
    for (size_t fr = 0; fr < frames && !rc; ++fr) {
        double t0 = ohm_now();
        rc = ohm_frame_entries(&in, net, lights, nlights, fr, sol->channels, mat->eta, params->media.eta_v, occ, err);
        sol->t_source += ohm_now() - t0;
        ohm_mc_result res[OHM_MAX_CHANNELS];
        for (int c = 0; c < sol->channels && !rc; ++c) {
            ohm_mc_result *r = &res[c];
            *r = (ohm_mc_result){.fluence = sol->fluence[c] + fr * n,
                                 .fluence_se = sol->fluence_se[c] + fr * n,
                                 .face_exitance = sol->face_exitance[c] + fr * nf,
                                 .exitance_se = sol->exitance_se[c] + fr * n};
            book_entries(&sol->power_incident, &sol->power_entered, &in, c);
            int e = 0;
            while (e < c && !same_transport(mat, &params->media, &in, c, e)) ++e;
            if (e < c) { /* the same photons would be traced again: take channel e's */
                memcpy(r->fluence, res[e].fluence, n * sizeof(double));
                memcpy(r->fluence_se, res[e].fluence_se, n * sizeof(double));
                memcpy(r->exitance_se, res[e].exitance_se, n * sizeof(double));
                memcpy(r->face_exitance, res[e].face_exitance, nf * sizeof(double));
                r->power_in = res[e].power_in;
                r->power_absorbed = res[e].power_absorbed;
                r->power_out = res[e].power_out;
            } else {
                ohm_channel_medium med;
                ohm_medium_for(&med, mat, params, c);
                rc = trace_entries(sol, r, &med, &in, c, params, device, err);
                if (rc) break;
                sol->t_solve += r->seconds;
                sol->solves += r->photons > 0;
            }
            sol->power_in += r->power_in;
            sol->power_absorbed += r->power_absorbed;
            sol->power_out += r->power_out;
            sol->power_in_channel[c] += r->power_in;
            sol->power_out_channel[c] += r->power_out;
        }
    }
    ohm_light_entries_free(&in);
    ohm_mc_device_free(device);
    return rc;
}

/* solver=mc (transport.h): the solver's lights traced into its solution. */
static int mc_transport(ohm_solver *s, const ohm_light *lights, size_t nlights, ohm_error *err)
{
    return mc_solve(&s->sol, &s->mat, lights, nlights, &s->params, s->occ, err);
}

/* mc: Monte Carlo transport instead of diffusion. */
const ohm_transport_ops ohm_transport_mc = {.name = "mc", .solve = mc_transport};

/* The hybrid (solve.h, mc.handoff) applies to optical media under the
 * Fresnel boundary, every cell kept. */
int ohm_hybrid_applies(const ohm_solver *s, ohm_error *err)
{
    const ohm_solve_params *params = &s->params;
    if (s->mat.kind == OHM_MATERIAL_RESISTANCE || params->media.resistance_v)
        return ohm_fail(err, OHM_ERR_USAGE,
                        "solve: hybrid= traces light through sigma_a and sigma_s', not resistances; use hybrid=0");
    if (params->op.boundary != OHM_BOUNDARY_ROBIN)
        return ohm_fail(err, OHM_ERR_USAGE,
                        "solve: hybrid= traces the Fresnel boundary itself: boundary=%s does not match it; use hybrid=0",
                        ohm_boundary_name(params->op.boundary));
    if (s->sol.band_active)
        return ohm_fail(err, OHM_ERR_USAGE, "solve: hybrid= traces photons through every cell: use hybrid=0 with depth_band=");
    return OHM_OK;
}
