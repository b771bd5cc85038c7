/* physics/mc_device.c — see mc_device.h.  The host side of mc_device.cl:
 * the scene in the kernels' layout, the launches batch by batch, and the
 * batches' sums read back into mc_tally.h's. */
#include "physics/mc_device.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/memory.h"
#include "device/session.h"
#include "physics/mc_device_cl.h" /* ohm_mc_device_source: mc_device.cl as a string, generated */
#include "physics/mc_tally.h"

enum { WG_MAX = 64, NTOTALS = 6 /* mc_device.cl's */ };
/* Photons in one launch, at most: launches are sized to take about
 * LAUNCH_SECONDS (so that a cancel or a progress report waits no longer),
 * from the first's FIRST_LAUNCH photons. */
enum { FIRST_LAUNCH = 4096, MAX_LAUNCH = 1 << 22 };
static const double LAUNCH_SECONDS = 0.1;
static const char ADVICE[] = "use a coarser grid or device=host";

enum { K_TRACE, K_FOLD, K_ZERO, K_COUNT };
static const char *const kernel_names[K_COUNT] = {"trace", "fold", "fill_zero"};

typedef struct mc_dev {
    ohm_device_session s;
    cl_program program;
    cl_kernel k[K_COUNT];
    size_t wg;
    /* the scene */
    cl_mem cdf, ecell, ev, egeo, unknown, face_start, face_dir, coef, g, eta;
    /* the tallies */
    cl_mem phi, phi_sum, phi_sq, face, handoff, partial;
    double *partial_host, *face_host;
} mc_dev;

static void mc_dev_free(mc_dev *d)
{
    cl_mem *m[] = {&d->cdf, &d->ecell,   &d->ev,     &d->egeo, &d->unknown, &d->face_start, &d->face_dir, &d->coef,
                   &d->g,   &d->eta,     &d->phi,    &d->phi_sum, &d->phi_sq, &d->face,      &d->handoff,  &d->partial};
    for (size_t i = 0; i < sizeof m / sizeof *m; ++i) ohm_device_release(&d->s, m[i]);
    for (int k = 0; k < K_COUNT; ++k)
        if (d->k[k]) d->s.cl.ReleaseKernel(d->k[k]);
    if (d->program) d->s.cl.ReleaseProgram(d->program);
    ohm_device_session_close(&d->s);
    free(d->partial_host);
    free(d->face_host);
}

/* ---- the scene in the kernels' layout ------------------------------------------------------ */

/* The host's copies, freed once they are on the device. */
typedef struct mc_layout {
    int32_t *unknown;    /* per grid cell: its unknown, or -1 */
    int32_t *face_start; /* n + 1 */
    double *coef;        /* 2 per unknown (sigma_a h, sigma_s h), when they vary */
    int32_t *ecell, *ev;
    double *cdf, *egeo;
    int varies;
    size_t ncells;
} mc_layout;

static void layout_free(mc_layout *l)
{
    free(l->unknown), free(l->face_start), free(l->coef), free(l->ecell), free(l->ev), free(l->cdf), free(l->egeo);
}

static int layout_build(mc_layout *l, const ohm_network *net, const ohm_channel_medium *med,
                        const ohm_light_entry *entries, size_t nentries, int channel, double P, ohm_error *err)
{
    const ohm_voxel_grid *g = net->grid;
    memset(l, 0, sizeof *l);
    if (net->n >= INT32_MAX || net->nfaces >= INT32_MAX)
        return ohm_fail(err, OHM_ERR_USAGE,
                        "monte carlo on a device: %lld cells and %lld faces; the device tracer numbers them in 32 "
                        "bits: use device=host",
                        (long long)net->n, (long long)net->nfaces);
    size_t n = (size_t)net->n;
    l->ncells = (size_t)g->dims[0] * (size_t)g->dims[1] * (size_t)g->dims[2];
    l->varies = ohm_medium_varies(med) || med->g_v;
    l->unknown = malloc(l->ncells * sizeof *l->unknown);
    l->face_start = malloc((n + 1) * sizeof *l->face_start);
    l->cdf = malloc(nentries * sizeof *l->cdf);
    l->ecell = malloc(4 * nentries * sizeof *l->ecell);
    l->ev = malloc(nentries * sizeof *l->ev);
    l->egeo = malloc(6 * nentries * sizeof *l->egeo);
    if (l->varies) l->coef = malloc(2 * n * sizeof *l->coef);
    if (!l->unknown || !l->face_start || !l->cdf || !l->ecell || !l->ev || !l->egeo || (l->varies && !l->coef)) {
        layout_free(l);
        return ohm_fail(err, OHM_ERR_NOMEM, "monte carlo on a device: out of memory for the scene's layout");
    }
    for (size_t c = 0; c < l->ncells; ++c) l->unknown[c] = -1;
    for (size_t v = 0; v < n; ++v) l->unknown[net->cell[v]] = (int32_t)v;
    /* faces are stored in unknown order, a cell's together (network.h) */
    int64_t f = 0;
    for (size_t v = 0; v <= n; ++v) {
        while (f < net->nfaces && net->face_unknown[f] < (int64_t)v) ++f;
        l->face_start[v] = (int32_t)f;
    }
    const double h = g->h;
    for (size_t v = 0; l->varies && v < n; ++v) { /* mc.c's cell_coefficients */
        double sa, ss;
        ohm_medium_coefficients(med, (int64_t)v, &sa, &ss);
        l->coef[2 * v] = sa * h;
        l->coef[2 * v + 1] = ss * h / (1.0 - (med->g_v ? med->g_v[v] : med->g));
    }
    ohm_mc_entry_cdf(l->cdf, entries, nentries, channel, P);
    for (size_t e = 0; e < nentries; ++e) { /* mc.c's start_point, what does not draw */
        const ohm_light_entry *en = &entries[e];
        int64_t v = net->face_unknown[en->face];
        int32_t c[3];
        ohm_voxel_coords(g, net->cell[v], c);
        for (int a = 0; a < 3; ++a) {
            l->ecell[4 * e + (size_t)a] = c[a];
            l->egeo[6 * e + (size_t)a] = (en->point[a] - g->origin[a]) / h + 0.5;
            l->egeo[6 * e + 3 + (size_t)a] = en->dir[a];
        }
        l->ecell[4 * e + 3] = net->face_dir[en->face] + 8 * (en->at_point != 0);
        l->ev[e] = (int32_t)v;
    }
    return OHM_OK;
}

/* Device memory the run needs (bytes). */
static double device_need(const ohm_network *net, const mc_layout *l, const ohm_channel_medium *med,
                          size_t nentries, int handoff)
{
    double n = (double)net->n, nf = (double)net->nfaces;
    return 4.0 * (double)l->ncells + 4.0 * (n + 1) + nf + (l->varies ? 16.0 * n : 0) + (med->g_v ? 8.0 * n : 0) +
           (med->eta_v ? 8.0 * n : 0) + 48.0 * (double)nentries + (3.0 + (handoff > 0)) * 8.0 * n + 8.0 * nf +
           (double)MAX_LAUNCH / WG_MAX * NTOTALS * 8.0;
}

/* ---- kernels ------------------------------------------------------------------------------- */

static int build_kernels(mc_dev *d, const ohm_channel_medium *med, const mc_layout *l, int handoff,
                         ohm_error *err)
{
    d->wg = ohm_device_group_size(&d->s, WG_MAX);
    char options[160];
    snprintf(options, sizeof options, "-D WG=%zu%s%s%s%s", d->wg, l->varies ? " -D MC_VARIES" : "",
             med->g_v ? " -D MC_CELL_G" : "", med->eta_v ? " -D MC_CELL_ETA" : "", handoff > 0 ? " -D MC_HANDOFF" : "");
    return ohm_device_kernels(&d->s, &d->program, d->k, kernel_names, K_COUNT, ohm_mc_device_source, options, err);
}

static int upload(mc_dev *d, const ohm_network *net, const ohm_channel_medium *med, const mc_layout *l,
                  size_t nentries, int handoff, ohm_error *err)
{
    size_t n = (size_t)net->n, nf = (size_t)(net->nfaces ? net->nfaces : 1), groups = MAX_LAUNCH / d->wg;
    int rc = ohm_device_buffer(&d->s, &d->unknown, l->ncells * sizeof(int32_t), l->unknown, ADVICE, err);
    if (!rc) rc = ohm_device_buffer(&d->s, &d->face_start, (n + 1) * sizeof(int32_t), l->face_start, ADVICE, err);
    if (!rc) rc = ohm_device_buffer(&d->s, &d->face_dir, (size_t)net->nfaces, net->face_dir, ADVICE, err);
    if (!rc && l->varies) rc = ohm_device_buffer(&d->s, &d->coef, 2 * n * sizeof(double), l->coef, ADVICE, err);
    if (!rc && med->g_v) rc = ohm_device_buffer(&d->s, &d->g, n * sizeof(double), med->g_v, ADVICE, err);
    if (!rc && med->eta_v) rc = ohm_device_buffer(&d->s, &d->eta, n * sizeof(double), med->eta_v, ADVICE, err);
    if (!rc) rc = ohm_device_buffer(&d->s, &d->cdf, nentries * sizeof(double), l->cdf, ADVICE, err);
    if (!rc) rc = ohm_device_buffer(&d->s, &d->ecell, 4 * nentries * sizeof(int32_t), l->ecell, ADVICE, err);
    if (!rc) rc = ohm_device_buffer(&d->s, &d->ev, nentries * sizeof(int32_t), l->ev, ADVICE, err);
    if (!rc) rc = ohm_device_buffer(&d->s, &d->egeo, 6 * nentries * sizeof(double), l->egeo, ADVICE, err);
    cl_mem *zeroed[] = {&d->phi, &d->phi_sum, &d->phi_sq, &d->handoff};
    for (size_t i = 0; !rc && i < 3 + (handoff > 0); ++i)
        rc = ohm_device_buffer(&d->s, zeroed[i], n * sizeof(double), NULL, ADVICE, err);
    if (!rc) rc = ohm_device_buffer(&d->s, &d->face, nf * sizeof(double), NULL, ADVICE, err);
    if (!rc) rc = ohm_device_buffer(&d->s, &d->partial, groups * NTOTALS * sizeof(double), NULL, ADVICE, err);
    if (!rc && (!(d->partial_host = malloc(groups * NTOTALS * sizeof(double))) ||
                !(d->face_host = malloc(nf * sizeof(double)))))
        rc = ohm_fail(err, OHM_ERR_NOMEM, "monte carlo on a device: out of memory");
    return rc;
}

#define ARG_MEM(kid, i, m) ohm_device_arg(&d->s, d->k[kid], i, sizeof(cl_mem), &(m))
#define ARG_VAL(kid, i, type, v)                                                                                \
    do {                                                                                                        \
        type value_ = (v);                                                                                      \
        ohm_device_arg(&d->s, d->k[kid], i, sizeof value_, &value_);                                            \
    } while (0)

/* a zeroed array (fill_zero) */
static void zero(mc_dev *d, cl_mem a, int64_t count)
{
    ARG_MEM(K_ZERO, 0, a);
    ARG_VAL(K_ZERO, 1, cl_long, count);
    ohm_device_launch(&d->s, d->k[K_ZERO], 64 * d->wg, d->wg);
}

/* The trace kernel's arguments that stay for the whole run (all but the
 * first two: the launch's first photon and count). */
static void set_scene(mc_dev *d, const ohm_network *net, const ohm_channel_medium *med, size_t nentries,
                      const ohm_mc_params *params)
{
    const ohm_voxel_grid *g = net->grid;
    const double h = g->h;
    cl_uint2 key = {{(cl_uint)params->seed, (cl_uint)(params->seed >> 32)}};
    ARG_VAL(K_TRACE, 2, cl_uint2, key);
    ARG_MEM(K_TRACE, 3, d->cdf);
    ARG_VAL(K_TRACE, 4, cl_long, (cl_long)nentries);
    ARG_MEM(K_TRACE, 5, d->ecell);
    ARG_MEM(K_TRACE, 6, d->ev);
    ARG_MEM(K_TRACE, 7, d->egeo);
    cl_int4 dims = {{g->dims[0], g->dims[1], g->dims[2], 0}};
    cl_int4 mlow = {{net->mirror.low[0], net->mirror.low[1], net->mirror.low[2], 0}};
    cl_int4 mhigh = {{net->mirror.high[0], net->mirror.high[1], net->mirror.high[2], 0}};
    ARG_VAL(K_TRACE, 8, cl_int4, dims);
    ARG_VAL(K_TRACE, 9, cl_int4, mlow);
    ARG_VAL(K_TRACE, 10, cl_int4, mhigh);
    ARG_MEM(K_TRACE, 11, d->unknown);
    ARG_MEM(K_TRACE, 12, d->face_start);
    ARG_MEM(K_TRACE, 13, d->face_dir);
    /* the uniform medium in 1/voxel (mc.c's cell_coefficients), its g and index */
    cl_double4 medium = {{med->sigma_a0 * h, med->sigma_s0 * h / (1.0 - med->g), med->g, med->eta}};
    ARG_VAL(K_TRACE, 14, cl_double4, medium);
    ARG_MEM(K_TRACE, 15, d->coef);
    ARG_MEM(K_TRACE, 16, d->g);
    ARG_MEM(K_TRACE, 17, d->eta);
    ARG_VAL(K_TRACE, 18, cl_double, params->max_path > 0 ? params->max_path / h : INFINITY);
    ARG_VAL(K_TRACE, 19, cl_int, params->total_fluence);
    ARG_VAL(K_TRACE, 20, cl_double, params->handoff > 0 ? (double)params->handoff : 0.0);
    ARG_MEM(K_TRACE, 21, d->phi);
    ARG_MEM(K_TRACE, 22, d->face);
    ARG_MEM(K_TRACE, 23, d->handoff);
    ARG_MEM(K_TRACE, 24, d->partial);
}

/* Photons first .. first + count - 1 traced; their totals added to s. */
static int trace_launch(mc_dev *d, ohm_mc_sums *s, int64_t first, int64_t count, ohm_error *err)
{
    ARG_VAL(K_TRACE, 0, cl_long, first);
    ARG_VAL(K_TRACE, 1, cl_long, count);
    size_t groups = ((size_t)count + d->wg - 1) / d->wg;
    ohm_device_launch(&d->s, d->k[K_TRACE], groups * d->wg, d->wg);
    int rc = ohm_device_checked(&d->s, err);
    if (!rc) rc = ohm_device_copy(&d->s, d->partial, d->partial_host, groups * NTOTALS * sizeof(double), 0, err);
    if (rc) return rc;
    for (size_t q = 0; q < groups; ++q) { /* group by group, in order */
        const double *t = d->partial_host + NTOTALS * q;
        s->absorbed += t[0];
        s->out += t[1];
        s->gated += t[2];
        s->handed += t[3];
        s->events += (int64_t)t[4];
        s->truncated += (int64_t)t[5];
    }
    return OHM_OK;
}

/* One batch's fluence folded on the device, its faces on the host. */
static int fold_batch(mc_dev *d, ohm_mc_sums *s, const ohm_network *net, ohm_error *err)
{
    ARG_MEM(K_FOLD, 0, d->phi);
    ARG_MEM(K_FOLD, 1, d->phi_sum);
    ARG_MEM(K_FOLD, 2, d->phi_sq);
    ARG_VAL(K_FOLD, 3, cl_long, net->n);
    ohm_device_launch(&d->s, d->k[K_FOLD], 256 * d->wg, d->wg);
    int rc = ohm_device_checked(&d->s, err);
    if (!rc && net->nfaces)
        rc = ohm_device_copy(&d->s, d->face, d->face_host, (size_t)net->nfaces * sizeof(double), 0, err);
    if (rc) return rc;
    zero(d, d->face, net->nfaces);
    ohm_mc_fold_faces(s, net, d->face_host);
    ohm_mc_fold_totals(s);
    return ohm_device_checked(&d->s, err);
}

/* The batches, launch by launch; cancellable between launches. */
static int run_batches(mc_dev *d, ohm_mc_sums *s, const ohm_network *net, int64_t per_batch,
                       const ohm_mc_params *params, const char *what, ohm_error *err)
{
    ohm_progress prog;
    ohm_progress_begin(&prog, params->log, what);
    int64_t launch = FIRST_LAUNCH;
    int rc = OHM_OK;
    for (int b = 0; b < OHM_MC_BATCHES && !rc; ++b) {
        for (int64_t k = 0; k < per_batch && !rc;) {
            int64_t count = per_batch - k < launch ? per_batch - k : launch;
            double t0 = ohm_now();
            rc = trace_launch(d, s, (int64_t)b * per_batch + k, count, err);
            double took = ohm_now() - t0;
            k += count;
            /* the next launch sized to about LAUNCH_SECONDS at this one's rate */
            double next = took > 0 ? (double)count * LAUNCH_SECONDS / took : (double)MAX_LAUNCH;
            launch = next > MAX_LAUNCH ? MAX_LAUNCH : next < (double)d->wg ? (int64_t)d->wg : (int64_t)next;
            if (!rc && ohm_progress_update(&prog, (b + (double)k / (double)per_batch) / OHM_MC_BATCHES))
                rc = ohm_fail_cancelled(err, "monte carlo");
        }
        if (!rc) rc = fold_batch(d, s, net, err);
    }
    if (!rc) ohm_progress_end(&prog);
    return rc;
}

int ohm_mc_device_trace(int *ran, ohm_mc_result *res, const ohm_network *net, const ohm_channel_medium *med,
                        const ohm_light_entry *entries, size_t nentries, int channel, double P, int64_t per_batch,
                        const ohm_mc_params *params, ohm_error *err)
{
    *ran = 0;
    mc_dev d;
    memset(&d, 0, sizeof d);
    int rc = ohm_device_session_open(&d.s, ran, params->device, "monte carlo", params->log, err);
    if (rc || !*ran) return rc;
    const ohm_device *dev = ohm_device_session_device(&d.s);
    if (!dev->atomics64) {
        rc = ohm_fail(err, OHM_ERR_INVALID,
                      "monte carlo on %s (opencl:%d): the device has no 64-bit atomics (cl_khr_int64_base_atomics), "
                      "which the tallies need; use device=host",
                      dev->name, d.s.picked);
        mc_dev_free(&d);
        return rc;
    }
    mc_layout l;
    rc = layout_build(&l, net, med, entries, nentries, channel, P, err);
    if (rc) {
        mc_dev_free(&d);
        return rc;
    }
    double need = device_need(net, &l, med, nentries, params->handoff);
    if (need > 0.9 * dev->global_bytes) {
        char nb[32], db[32];
        rc = ohm_fail(err, OHM_ERR_NOMEM,
                      "monte carlo on %s (opencl:%d): the scene and tallies need %s, more than 90%% of the device's "
                      "%s; %s",
                      dev->name, d.s.picked, ohm_format_bytes(need, nb, sizeof nb),
                      ohm_format_bytes(dev->global_bytes, db, sizeof db), ADVICE);
    }
    if (!rc) rc = build_kernels(&d, med, &l, params->handoff, err);
    if (!rc) rc = upload(&d, net, med, &l, nentries, params->handoff, err);
    layout_free(&l);
    ohm_mc_sums sums = {0};
    if (!rc && ohm_mc_sums_alloc(&sums, net, params->handoff))
        rc = ohm_fail(err, OHM_ERR_NOMEM, "monte carlo: out of memory for the sums");
    if (!rc) {
        zero(&d, d.phi, net->n);
        zero(&d, d.phi_sum, net->n);
        zero(&d, d.phi_sq, net->n);
        zero(&d, d.face, net->nfaces);
        if (params->handoff > 0) zero(&d, d.handoff, net->n);
        set_scene(&d, net, med, nentries, params);
        rc = ohm_device_checked(&d.s, err);
    }
    char what[160];
    snprintf(what, sizeof what, "monte carlo on %s, channel %d, %lld photons", dev->name, channel,
             (long long)(per_batch * OHM_MC_BATCHES));
    if (!rc) rc = run_batches(&d, &sums, net, per_batch, params, what, err);
    size_t n = (size_t)net->n;
    if (!rc) rc = ohm_device_copy(&d.s, d.phi_sum, sums.phi_sum, n * sizeof(double), 0, err);
    if (!rc) rc = ohm_device_copy(&d.s, d.phi_sq, sums.phi_sq, n * sizeof(double), 0, err);
    if (!rc && params->handoff > 0) rc = ohm_device_copy(&d.s, d.handoff, sums.handoff, n * sizeof(double), 0, err);
    if (!rc) {
        ohm_mc_write_result(res, &sums, net, per_batch, P);
        res->threads = dev->compute_units;
        snprintf(res->device, sizeof res->device, "%s", dev->name);
    }
    ohm_mc_sums_free(&sums);
    mc_dev_free(&d);
    return rc;
}
