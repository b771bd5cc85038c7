/* physics/mc_tally.c — see mc_tally.h. */
#include "physics/mc_tally.h"

#include <math.h>
#include <stdlib.h>

int ohm_mc_sums_alloc(ohm_mc_sums *s, const ohm_network *net, int handoff)
{
    size_t n = (size_t)(net->n ? net->n : 1), nf = (size_t)(net->nfaces ? net->nfaces : 1);
    *s = (ohm_mc_sums){0};
    if (handoff > 0 && !(s->handoff = calloc(n, sizeof(double)))) return -1;
    s->phi_sum = calloc(n, sizeof(double));
    s->phi_sq = calloc(n, sizeof(double));
    s->face_sum = calloc(nf, sizeof(double));
    s->exit_sq = calloc(n, sizeof(double));
    return s->phi_sum && s->phi_sq && s->face_sum && s->exit_sq ? 0 : -1;
}

void ohm_mc_sums_free(ohm_mc_sums *s)
{
    free(s->phi_sum);
    free(s->phi_sq);
    free(s->face_sum);
    free(s->exit_sq);
    free(s->handoff);
    *s = (ohm_mc_sums){0};
}

void ohm_mc_fold_faces(ohm_mc_sums *s, const ohm_network *net, const double *face)
{
    for (int64_t f = 0, end; f < net->nfaces; f = end) { /* a cell's exitance: the mean of its faces' */
        end = ohm_network_face_run_end(net, f);
        double sum = 0;
        for (int64_t q = f; q < end; ++q) {
            sum += face[q];
            s->face_sum[q] += face[q];
        }
        double mean = sum / (double)(end - f);
        s->exit_sq[net->face_unknown[f]] += mean * mean;
    }
}

void ohm_mc_fold_totals(ohm_mc_sums *s)
{
    double a = s->absorbed - s->batch_absorbed, o = s->out - s->batch_out;
    s->absorbed_sq += a * a;
    s->out_sq += o * o;
    s->batch_absorbed = s->absorbed;
    s->batch_out = s->out;
}

void ohm_mc_sums_merge(ohm_mc_sums *dst, const ohm_mc_sums *src, const ohm_network *net)
{
    for (int64_t v = 0; v < net->n; ++v) {
        dst->phi_sum[v] += src->phi_sum[v];
        dst->phi_sq[v] += src->phi_sq[v];
        dst->exit_sq[v] += src->exit_sq[v];
    }
    for (int64_t f = 0; f < net->nfaces; ++f) dst->face_sum[f] += src->face_sum[f];
    for (int64_t v = 0; v < net->n && dst->handoff; ++v) dst->handoff[v] += src->handoff[v];
    dst->handed += src->handed;
    dst->absorbed += src->absorbed;
    dst->out += src->out;
    dst->gated += src->gated;
    dst->absorbed_sq += src->absorbed_sq;
    dst->out_sq += src->out_sq;
    dst->truncated += src->truncated;
    dst->events += src->events;
}

/* The standard error of the mean of B batch values with sum s and sum of
 * squares q (times scale). */
static double batch_stderr(double s, double q, double scale)
{
    const double B = OHM_MC_BATCHES;
    double var = (q - s * s / B) / (B * (B - 1.0));
    return var > 0 ? scale * sqrt(var) : 0.0;
}

void ohm_mc_write_result(ohm_mc_result *res, const ohm_mc_sums *t, const ohm_network *net, int64_t per_batch,
                         double P)
{
    const double h = net->grid->h, B = OHM_MC_BATCHES;
    const double k = P / (double)per_batch / (h * h); /* batch tally -> W/mm^2 */
    for (int64_t v = 0; v < net->n; ++v) {
        res->fluence[v] = k * t->phi_sum[v] / B;
        res->fluence_se[v] = batch_stderr(t->phi_sum[v], t->phi_sq[v], k);
    }
    for (int64_t f = 0; f < net->nfaces; ++f) res->face_exitance[f] = k * t->face_sum[f] / B;
    for (int64_t f = 0, end; f < net->nfaces; f = end) {
        end = ohm_network_face_run_end(net, f);
        int64_t v = net->face_unknown[f];
        double sum = 0;
        for (int64_t q = f; q < end; ++q) sum += t->face_sum[q];
        res->exitance_se[v] = batch_stderr(sum / (double)(end - f), t->exit_sq[v], k);
    }
    double photons = (double)per_batch * B;
    res->power_in = P;
    res->power_absorbed = P * t->absorbed / photons;
    res->power_out = P * t->out / photons;
    res->power_handoff = P * t->handed / photons;
    for (int64_t v = 0; v < net->n && t->handoff; ++v) res->handoff[v] = P * t->handoff[v] / photons;
    res->power_gated = P * t->gated / photons;
    res->power_absorbed_se = batch_stderr(t->absorbed, t->absorbed_sq, P / (double)per_batch);
    res->power_out_se = batch_stderr(t->out, t->out_sq, P / (double)per_batch);
    res->photons = (int64_t)photons;
    res->truncated = t->truncated;
    res->events = t->events;
}

void ohm_mc_entry_cdf(double *cdf, const ohm_light_entry *entries, size_t nentries, int channel, double P)
{
    double run = 0;
    for (size_t e = 0; e < nentries; ++e) cdf[e] = (run += entries[e].power[channel]) / P;
    cdf[nentries - 1] = 1.0;
}
