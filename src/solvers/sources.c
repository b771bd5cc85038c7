/* solvers/sources.c — right-hand sides (solve.h): each batch's sources from
 * the lights (or a scene's own), a frame's light entries (light.h), the
 * per-face powers traced once for every channel, and the unscattered beam
 * added for fluence=total.  The face-power cache belongs to the run that
 * traced it (ohm_face_powers_free). */
#include "solvers/solver_impl.h"

#include <stdlib.h>
#include <string.h>

/* Column j of B (zeroed first) gets frame f0 + j's sources for channel c:
 * the cached per-face powers (traced once for every channel) or, for pencil
 * beams and when the cache did not fit, the lights themselves. */
int ohm_fill_sources(const ohm_solution *sol, channel_tally *t, double *B, size_t f0, size_t nb, int c,
                     const ohm_channel_medium *med,
                     const ohm_light *lights, size_t nlights, const ohm_source_params *src,
                     double *const *fp_enter, double *const *fp_enter_mu, double *const *fp_arrive,
                     const ohm_occluder *occ, ohm_error *err)
{
    const ohm_network *net = &sol->net;
    size_t n = (size_t)net->n, nf = (size_t)(net->nfaces ? net->nfaces : 1);
    memset(B, 0, n * nb * sizeof *B);
    if (src->custom_source) {
        if (src->custom_source(src->custom_user, B, nb, net, c))
            return ohm_fail(err, OHM_ERR_INVALID, "solve: the scene's source failed");
        return OHM_OK;
    }
    for (size_t j = 0; j < nb && fp_enter; ++j) {
        const double *en = fp_enter[c] + (f0 + j) * nf;
        ohm_source_deposit_faces(B + j * n, net, en, fp_enter_mu[c] + (f0 + j) * nf, med, src->deposit);
        t->power_incident += fp_arrive[c][f0 + j];
        for (int64_t f = 0; f < net->nfaces; ++f) t->power_entered += en[f];
    }
    for (size_t l = 0; l < nlights; ++l) {
        int lf = lights[l].frame;
        if (fp_enter && !ohm_light_at_a_point(&lights[l])) continue; /* traced already */
        for (size_t j = 0; j < nb; ++j) {
            if (lf != 0 && lf != (int)(f0 + j + 1)) continue;
            ohm_source_power pw = {0, 0, 0};
            int rc = ohm_source_add(B + j * n, &pw, net, &lights[l], c, med, src->deposit, occ, err);
            if (rc) return rc;
            t->power_incident += pw.incident;
            t->power_entered += pw.entered;
        }
    }
    return OHM_OK;
}

/* in = the entries (light.h) of every light of frame fr (0-based). */
int ohm_frame_entries(ohm_light_entries *in, const ohm_network *net, const ohm_light *lights, size_t nlights,
                      size_t fr, int channels, double eta, const double *eta_v, const ohm_occluder *occ,
                      ohm_error *err)
{
    in->count = 0;
    int rc = OHM_OK;
    for (size_t l = 0; l < nlights && !rc; ++l)
        if (ohm_light_in_frame(&lights[l], (int)fr))
            rc = ohm_light_entries_add(in, net, &lights[l], channels, eta, eta_v, occ, err);
    return rc;
}

/* fluence=total: frames f0..f0+nb of channel c (X) get the unscattered beam
 * of every light's entries (light.h). */
int ohm_add_unscattered(ohm_solution *sol, double *X, size_t f0, size_t nb, int c, const ohm_channel_medium *med,
                        const ohm_material *mat, const ohm_light *lights, size_t nlights, const ohm_occluder *occ,
                        ohm_error *err)
{
    ohm_light_entries in = {0};
    int rc = OHM_OK;
    for (size_t j = 0; j < nb && !rc; ++j) {
        rc = ohm_frame_entries(&in, &sol->net, lights, nlights, f0 + j, sol->channels, mat->eta, med->eta_v, occ, err);
        for (size_t k = 0; k < in.count && !rc; ++k)
            ohm_source_unscattered_face(X + j * (size_t)sol->n, &sol->net, in.entry[k].face, in.entry[k].power[c],
                                        in.entry[k].mu, med);
    }
    ohm_light_entries_free(&in);
    return rc;
}

void ohm_face_powers_free(face_powers *fp)
{
    for (int c = 0; c < OHM_MAX_CHANNELS; ++c) {
        free(fp->enter[c]);
        free(fp->enter_mu[c]);
        free(fp->arrive[c]);
    }
}

int ohm_face_powers_trace(face_powers *fp, ohm_solver *s, const ohm_light *lights, size_t nlights, double cap,
                          ohm_error *err)
{
    ohm_solution *sol = &s->sol;
    const ohm_solve_params *params = &s->params;
    const ohm_material *mat = &s->mat;
    size_t nf = (size_t)(sol->net.nfaces ? sol->net.nfaces : 1);
    int channels = sol->channels, frames = sol->frames;
    memset(fp, 0, sizeof *fp);
    const double face_cache_cap = cap > 256.0 * 1048576.0 ? cap : 256.0 * 1048576.0;
    if (2.0 * sizeof(double) * (double)nf * (double)frames * (double)channels > face_cache_cap) return OHM_OK;
    fp->cached = 1;
    for (int c = 0; c < channels && fp->cached; ++c) {
        fp->enter[c] = calloc(nf * (size_t)frames, sizeof(double));
        fp->arrive[c] = calloc((size_t)frames, sizeof(double));
        fp->enter_mu[c] = calloc(nf * (size_t)frames, sizeof(double));
        if (!fp->enter[c] || !fp->arrive[c] || !fp->enter_mu[c]) fp->cached = 0; /* trace per channel */
    }
    double t0 = ohm_now();
    double eta = mat->kind == OHM_MATERIAL_RESISTANCE ? 1.0 : mat->eta;
    const double *eta_v = mat->kind == OHM_MATERIAL_RESISTANCE ? NULL : params->media.eta_v;
    int rc = OHM_OK;
    for (int fr = 0; fr < frames && fp->cached && !rc; ++fr) {
        double *en[OHM_MAX_CHANNELS], *emu[OHM_MAX_CHANNELS], ar[OHM_MAX_CHANNELS] = {0};
        for (int c = 0; c < channels; ++c) {
            en[c] = fp->enter[c] + (size_t)fr * nf;
            emu[c] = fp->enter_mu[c] + (size_t)fr * nf;
        }
        for (size_t l = 0; l < nlights && !rc; ++l) {
            if (ohm_light_at_a_point(&lights[l])) continue;
            if (!ohm_light_in_frame(&lights[l], fr)) continue;
            rc = ohm_light_face_powers(en, emu, ar, channels, &sol->net, &lights[l], eta, eta_v, s->occ, err);
        }
        for (int c = 0; c < channels; ++c) fp->arrive[c][fr] = ar[c];
    }
    sol->t_source += ohm_now() - t0;
    return rc;
}
