/* solvers/clear.c — the clear regions of a solve (physics/clear_regions.h)
 * found in its media after the network is built, named in the log, and
 * treated: clear=effective gives diffusion's operator an effective sigma_s'
 * there, clear=radiosity couples their walls by view factors
 * (physics/clear_exchange.h) (docs/transport.md, "Clear regions"). */
#include "solvers/solver_impl.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Regions named one by one in the log; the rest are summed in one line. */
enum { LOGGED_REGIONS = 5 };

/* Whether channel c has a medium of its own to look at: the material's
 * channels, and any other whose coefficients are given per cell. */
static int channel_present(const ohm_solver *s, int c)
{
    if (c < s->mat.channels) return 1;
    ohm_channel_medium med;
    ohm_medium_for(&med, &s->mat, &s->params, c);
    return ohm_medium_varies(&med);
}

static void log_regions(const ohm_solver *s)
{
    const ohm_clear_regions *r = &s->sol.clear;
    if (r->count == 0) {
        ohm_log_info(s->log,
                     "clear regions (clear=%s): none (%lld cells with 1/sigma_t' above the %.4g mm cell, in no region "
                     "with sigma_t' x mean chord 4V/S < %g)",
                     ohm_clear_mode_name(s->params.op.clear), (long long)r->candidate_cells, s->grid->h,
                     OHM_CLEAR_OPTICAL_THICKNESS);
        return;
    }
    ohm_log_info(s->log,
                 "clear regions (clear=%s): %d, %lld cells, %.4g mm^3, where 1/sigma_t' exceeds the %.4g mm cell "
                 "and sigma_t' x mean chord 4V/S < %g (%lld candidate cells)",
                 ohm_clear_mode_name(s->params.op.clear), r->count, (long long)r->clear_cells, r->clear_volume_mm3,
                 s->grid->h, OHM_CLEAR_OPTICAL_THICKNESS, (long long)r->candidate_cells);
    for (int32_t k = 0; k < r->count && k < LOGGED_REGIONS; ++k) {
        const ohm_clear_region *g = &r->region[k];
        ohm_log_info(s->log,
                     "clear region %d: %lld cells, %.4g mm^3, thickness %.4g mm, sigma_t' %.4g /mm, optical "
                     "thickness %.3g, %.0f%% of its faces on the surface: %s%s",
                     (int)k, (long long)g->cells, g->volume_mm3, g->thickness_mm, g->sigma_t, g->optical_thickness,
                     g->exposed_faces ? 100.0 * (double)g->surface_faces / (double)g->exposed_faces : 0.0,
                     ohm_clear_mode_name(g->action),
                     g->action == OHM_CLEAR_EFFECTIVE   ? " (diffusion with sigma_t' = 1/thickness there)"
                     : g->action == OHM_CLEAR_RADIOSITY ? " (its walls exchange light by view factors)"
                     : g->action != OHM_CLEAR_OFF       ? ""
                     : s->params.op.clear == OHM_CLEAR_AUTO
                         ? " (diffusion as given: mostly the object's surface layer, which no treatment here models; "
                           "solver=mc does)"
                         : " (diffusion as given: expect errors around it)");
    }
    if (r->count > LOGGED_REGIONS) {
        int64_t cells = 0, treated = 0;
        double volume = 0;
        for (int32_t k = LOGGED_REGIONS; k < r->count; ++k) {
            cells += r->region[k].cells, volume += r->region[k].volume_mm3;
            treated += r->region[k].action != OHM_CLEAR_OFF;
        }
        ohm_log_info(s->log, "clear regions: and %d more, %lld cells, %.4g mm^3: %lld of them %s, the rest off",
                     (int)(r->count - LOGGED_REGIONS), (long long)cells, volume, (long long)treated,
                     ohm_clear_mode_name(s->sol.clear_action));
    }
}

/* Channel c's sigma_s' per unknown with each clear region's effective value
 * (clear_regions.h: sigma_t' = 1/L, the cell's own sigma_s' where larger). */
static ohm_coeff *effective_sigma_s(const ohm_solver *s, int c)
{
    const ohm_solution *sol = &s->sol;
    ohm_channel_medium med;
    ohm_medium_for(&med, &s->mat, &s->params, c);
    ohm_coeff *ss = malloc((size_t)sol->n * sizeof *ss);
    if (!ss) return NULL;
    for (int64_t v = 0; v < sol->n; ++v) {
        double sa, sv;
        ohm_medium_coefficients(&med, v, &sa, &sv);
        int32_t k = sol->clear.region_of_cell[v];
        if (k >= 0 && sol->clear.region[k].action == OHM_CLEAR_EFFECTIVE)
            sv = fmax(sv, ohm_clear_effective_sigma_t(sol->clear.region[k].thickness_mm) - sa);
        ss[v] = (ohm_coeff)sv;
    }
    return ss;
}

/* clear=effective: each channel's array, shared by channels of one medium. */
static int apply_effective(ohm_solver *s, ohm_error *err)
{
    for (int c = 0; c < OHM_MAX_CHANNELS; ++c) {
        int e = 0;
        while (e < c && !ohm_same_medium(&s->mat, &s->params.media, c, e)) ++e;
        if (e < c) {
            s->clear_ss[c] = s->clear_ss[e];
            continue;
        }
        if (!(s->clear_owned[c] = effective_sigma_s(s, c)))
            return ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory for the clear regions' effective medium");
        s->clear_ss[c] = s->clear_owned[c];
    }
    return OHM_OK;
}

int ohm_solver_couple_clear(ohm_solver *s, const uint8_t *mask, double reach, ohm_error *err)
{
    ohm_solution *sol = &s->sol;
    ohm_clear_exchange_params cp = {.max_distance = reach, .log = s->log};
    int rc = ohm_clear_exchange_build(&s->exchange, &sol->net, mask, &cp, err);
    sol->clear_nodes = s->exchange.nnodes;
    sol->clear_pairs = s->exchange.npairs;
    sol->clear_reach_mm = reach;
    if (!rc)
        ohm_log_info(s->log,
                     "clear regions' coupling: %lld wall nodes, %lld wall faces, %lld node pairs within %.3g mm "
                     "(%lld rays), set up in %.2f s",
                     (long long)s->exchange.nnodes, (long long)s->exchange.faces, (long long)s->exchange.npairs,
                     cp.max_distance, (long long)s->exchange.rays, s->exchange.seconds);
    return rc;
}

/* clear=radiosity: the coupling of the regions so treated, face pairs within
 * the reach asked (clear_reach=), else that of the thickest (ohm_clear_reach). */
static int apply_radiosity(ohm_solver *s, ohm_error *err)
{
    ohm_solution *sol = &s->sol;
    if (!(s->clear_mask = calloc((size_t)(sol->n ? sol->n : 1), 1)))
        return ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory for the clear regions' mask");
    double thickest = 0;
    for (int64_t v = 0; v < sol->n; ++v) {
        int32_t k = sol->clear.region_of_cell[v];
        if (k < 0 || sol->clear.region[k].action != OHM_CLEAR_RADIOSITY) continue;
        s->clear_mask[v] = 1;
        thickest = fmax(thickest, sol->clear.region[k].thickness_mm);
    }
    double reach = s->params.op.clear_reach > 0 ? s->params.op.clear_reach : ohm_clear_reach(thickest);
    return ohm_solver_couple_clear(s, s->clear_mask, reach, err);
}

int ohm_solver_find_clear(ohm_solver *s, ohm_error *err)
{
    ohm_solution *sol = &s->sol;
    sol->clear_action = OHM_CLEAR_OFF;
    /* transport needs no treatment; resistances have no mean free path */
    if (s->params.op.clear == OHM_CLEAR_OFF || s->transport || s->mat.kind == OHM_MATERIAL_RESISTANCE) return OHM_OK;
    double t0 = ohm_now();
    ohm_channel_medium media[OHM_MAX_CHANNELS];
    int channels = 0;
    for (int c = 0; c < OHM_MAX_CHANNELS; ++c)
        if (channel_present(s, c)) ohm_medium_for(&media[channels++], &s->mat, &s->params, c);
    int rc = ohm_clear_regions_find(&sol->clear, &sol->net, media, channels, err);
    if (rc) return rc;
    for (int32_t k = 0; k < sol->clear.count; ++k) {
        ohm_clear_region *g = &sol->clear.region[k];
        g->action = ohm_clear_region_action(s->params.op.clear, g);
        if (g->action != OHM_CLEAR_OFF) sol->clear_action = g->action;
    }
    if (sol->clear_action == OHM_CLEAR_EFFECTIVE) rc = apply_effective(s, err);
    else if (sol->clear_action == OHM_CLEAR_RADIOSITY && s->exchange.nclear == 0) rc = apply_radiosity(s, err);
    sol->t_clear = ohm_now() - t0;
    if (!rc) log_regions(s);
    return rc;
}

void ohm_diffusion_medium(ohm_channel_medium *med, const ohm_solver *s, int c)
{
    ohm_medium_for(med, &s->mat, &s->params, c);
    if (s->clear_ss[c]) med->sigma_s = s->clear_ss[c];
}
