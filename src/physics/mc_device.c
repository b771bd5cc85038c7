/* physics/mc_device.c — see mc_device.h.  The host side of mc_device.cl:
 * the scene in the kernels' layout, the launches batch by batch, and the
 * batches' sums read back into mc_tally.h's.  A device kept open
 * (ohm_mc_device_open) keeps its queue, its built programs, the network's
 * layout and the tallies' buffers between traces; each trace sends its
 * medium and its entries. */
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
/* device=auto traces fewer photons than this on the host: here they take
 * the host's two cores about 0.7 s (190 photons/ms, docs/gpu.md), the
 * order of opening a device and building its kernels the first time
 * (0.2-1 s on PoCL).  To be re-measured on a GPU (docs/gpu.md). */
enum { AUTO_MIN_PHOTONS = 1 << 17 };

enum { K_TRACE, K_FOLD, K_ZERO, K_COUNT };
static const char *const kernel_names[K_COUNT] = {"trace", "fold", "fill_zero"};

/* Programs built for the scenes traced so far, by their build options (the
 * kernel specialised to the medium: mc_device.cl). */
enum { MAX_PROGRAMS = 4 };
typedef struct mc_program {
    char options[160];
    cl_program program;
    cl_kernel k[K_COUNT];
} mc_program;

struct ohm_mc_device {
    ohm_device_session s;
    size_t wg;
    mc_program prog[MAX_PROGRAMS];
    int nprog;
    cl_kernel *k; /* the trace's program's kernels */
    /* the network the buffers below hold: its layout and tallies */
    const ohm_network *net;
    int64_t n, nfaces;
    size_t ncells;
    cl_mem unknown, face_start, face_dir;
    cl_mem phi, phi_sum, phi_sq, face, handoff, partial;
    /* each trace's: its medium and its entries (entry_cap of them) */
    cl_mem coef, g, eta;
    cl_mem cdf, ecell, ev, egeo;
    size_t entry_cap;
    double *partial_host, *face_host;
};

/* ---- opening, and what a network keeps ----------------------------------------------------- */

static void release_network(ohm_mc_device *d)
{
    cl_mem *m[] = {&d->unknown, &d->face_start, &d->face_dir, &d->phi, &d->phi_sum, &d->phi_sq, &d->face,
                   &d->handoff, &d->partial, &d->coef, &d->g, &d->eta};
    for (size_t i = 0; i < sizeof m / sizeof *m; ++i) ohm_device_release(&d->s, m[i]);
    free(d->partial_host), free(d->face_host);
    d->partial_host = d->face_host = NULL;
    d->net = NULL;
    d->s.bytes = 0;
    d->entry_cap = 0;
    cl_mem *e[] = {&d->cdf, &d->ecell, &d->ev, &d->egeo};
    for (size_t i = 0; i < sizeof e / sizeof *e; ++i) ohm_device_release(&d->s, e[i]);
}

void ohm_mc_device_free(ohm_mc_device *d)
{
    if (!d) return;
    release_network(d);
    for (int p = 0; p < d->nprog; ++p) {
        for (int k = 0; k < K_COUNT; ++k)
            if (d->prog[p].k[k]) d->s.cl.ReleaseKernel(d->prog[p].k[k]);
        if (d->prog[p].program) d->s.cl.ReleaseProgram(d->prog[p].program);
    }
    ohm_device_session_close(&d->s);
    free(d);
}

int ohm_mc_device_open(ohm_mc_device **out, const ohm_device_request *req, int64_t photons, const ohm_log *log,
                       ohm_error *err)
{
    *out = NULL;
    if (!req || req->kind == OHM_DEVICE_HOST) return OHM_OK;
    if (photons <= 0) photons = 1000000; /* mc_params.h's default */
    if (req->kind == OHM_DEVICE_AUTO && photons < AUTO_MIN_PHOTONS) {
        ohm_log_info(log, "monte carlo: device=auto: %lld photons, fewer than %d: they run on the host",
                     (long long)photons, AUTO_MIN_PHOTONS);
        return OHM_OK;
    }
    ohm_mc_device *d = calloc(1, sizeof *d);
    if (!d) return ohm_fail(err, OHM_ERR_NOMEM, "monte carlo: out of memory");
    int opened = 0;
    int rc = ohm_device_session_open(&d->s, &opened, req, "monte carlo", log, err);
    if (rc || !opened) { /* an error, or device=auto on the host */
        ohm_mc_device_free(d);
        return rc;
    }
    const ohm_device *dev = ohm_device_session_device(&d->s);
    if (!dev->atomics64) {
        rc = ohm_fail(err, OHM_ERR_INVALID,
                      "monte carlo on %s (opencl:%d): the device has no 64-bit atomics (cl_khr_int64_base_atomics), "
                      "which the tallies need; use device=host",
                      dev->name, d->s.picked);
        ohm_mc_device_free(d);
        return rc;
    }
    d->wg = ohm_device_group_size(&d->s, WG_MAX);
    ohm_log_info(log, "monte carlo: on %s (opencl:%d), work-groups of %zu", dev->name, d->s.picked, d->wg);
    *out = d;
    return OHM_OK;
}

/* Device memory a network's trace needs (bytes), entries and medium included. */
static double device_need(const ohm_network *net, size_t ncells, const ohm_channel_medium *med, int varies,
                          size_t nentries, int handoff)
{
    double n = (double)net->n, nf = (double)net->nfaces;
    return 4.0 * (double)ncells + 4.0 * (n + 1) + nf + (varies ? 16.0 * n : 0) + (med->g_v ? 8.0 * n : 0) +
           (med->eta_v ? 8.0 * n : 0) + 48.0 * (double)nentries + (3.0 + (handoff > 0)) * 8.0 * n + 8.0 * nf +
           (double)MAX_LAUNCH / WG_MAX * NTOTALS * 8.0;
}

/* The network's layout on the device (its cells' unknowns and faces) and
 * the tallies' buffers, unless they are there already. */
static int bind_network(ohm_mc_device *d, const ohm_network *net, ohm_error *err)
{
    if (d->net == net && d->n == net->n && d->nfaces == net->nfaces) return OHM_OK;
    release_network(d);
    const ohm_voxel_grid *g = net->grid;
    if (net->n >= INT32_MAX || net->nfaces >= INT32_MAX)
        return ohm_fail(err, OHM_ERR_USAGE,
                        "monte carlo on a device: %lld cells and %lld faces; the device tracer numbers them in 32 "
                        "bits: use device=host",
                        (long long)net->n, (long long)net->nfaces);
    size_t n = (size_t)net->n, nf = (size_t)(net->nfaces ? net->nfaces : 1), groups = MAX_LAUNCH / d->wg;
    size_t ncells = (size_t)g->dims[0] * (size_t)g->dims[1] * (size_t)g->dims[2];
    int32_t *unknown = malloc(ncells * sizeof *unknown), *face_start = malloc((n + 1) * sizeof *face_start);
    int rc = unknown && face_start ? OHM_OK
                                   : ohm_fail(err, OHM_ERR_NOMEM, "monte carlo on a device: out of memory for the layout");
    if (!rc) {
        for (size_t c = 0; c < ncells; ++c) unknown[c] = -1;
        ohm_cell_cursor cells = ohm_network_cells(net, 0);
        for (size_t v = 0; v < n; ++v) unknown[ohm_cell_cursor_next(&cells)] = (int32_t)v;
        /* faces are stored in unknown order, a cell's together (network.h) */
        int64_t f = 0;
        for (size_t v = 0; v <= n; ++v) {
            while (f < net->nfaces && net->face_unknown[f] < (int64_t)v) ++f;
            face_start[v] = (int32_t)f;
        }
        rc = ohm_device_buffer(&d->s, &d->unknown, ncells * sizeof(int32_t), unknown, ADVICE, err);
    }
    if (!rc) rc = ohm_device_buffer(&d->s, &d->face_start, (n + 1) * sizeof(int32_t), face_start, ADVICE, err);
    free(unknown), free(face_start);
    if (!rc) rc = ohm_device_buffer(&d->s, &d->face_dir, (size_t)net->nfaces, net->face_dir, ADVICE, err);
    cl_mem *tallies[] = {&d->phi, &d->phi_sum, &d->phi_sq};
    for (size_t i = 0; !rc && i < 3; ++i) rc = ohm_device_buffer(&d->s, tallies[i], n * sizeof(double), NULL, ADVICE, err);
    if (!rc) rc = ohm_device_buffer(&d->s, &d->face, nf * sizeof(double), NULL, ADVICE, err);
    if (!rc) rc = ohm_device_buffer(&d->s, &d->partial, groups * NTOTALS * sizeof(double), NULL, ADVICE, err);
    if (!rc && (!(d->partial_host = malloc(groups * NTOTALS * sizeof(double))) ||
                !(d->face_host = malloc(nf * sizeof(double)))))
        rc = ohm_fail(err, OHM_ERR_NOMEM, "monte carlo on a device: out of memory");
    if (rc) {
        release_network(d);
        return rc;
    }
    d->net = net;
    d->n = net->n;
    d->nfaces = net->nfaces;
    d->ncells = ncells;
    return OHM_OK;
}

/* The kernels specialised to this medium (mc_device.cl's options), built
 * once per specialisation. */
static int select_program(ohm_mc_device *d, const ohm_channel_medium *med, int varies, int handoff, ohm_error *err)
{
    char options[160];
    snprintf(options, sizeof options, "-D WG=%zu%s%s%s%s", d->wg, varies ? " -D MC_VARIES" : "",
             med->g_v ? " -D MC_CELL_G" : "", med->eta_v ? " -D MC_CELL_ETA" : "", handoff > 0 ? " -D MC_HANDOFF" : "");
    for (int p = 0; p < d->nprog; ++p)
        if (strcmp(d->prog[p].options, options) == 0) {
            d->k = d->prog[p].k;
            return OHM_OK;
        }
    if (d->nprog == MAX_PROGRAMS) { /* the oldest makes room */
        for (int k = 0; k < K_COUNT; ++k) d->s.cl.ReleaseKernel(d->prog[0].k[k]);
        d->s.cl.ReleaseProgram(d->prog[0].program);
        memmove(&d->prog[0], &d->prog[1], (MAX_PROGRAMS - 1) * sizeof d->prog[0]);
        d->nprog--;
    }
    mc_program *p = &d->prog[d->nprog];
    memset(p, 0, sizeof *p);
    snprintf(p->options, sizeof p->options, "%s", options);
    int rc = ohm_device_kernels(&d->s, &p->program, p->k, kernel_names, K_COUNT, ohm_mc_device_source, options, err);
    if (rc) {
        for (int k = 0; k < K_COUNT; ++k)
            if (p->k[k]) d->s.cl.ReleaseKernel(p->k[k]);
        if (p->program) d->s.cl.ReleaseProgram(p->program);
        return rc;
    }
    d->nprog++;
    d->k = p->k;
    return OHM_OK;
}

/* a buffer of `bytes`, allocated at the first need, filled from host */
static int fill(ohm_mc_device *d, cl_mem *mem, size_t bytes, const void *host, ohm_error *err)
{
    if (!*mem) return ohm_device_buffer(&d->s, mem, bytes, host, ADVICE, err);
    return ohm_device_copy(&d->s, *mem, (void *)host, bytes, 1, err);
}

/* This trace's medium: per-cell coefficients in 1/voxel (mc.c's
 * mc_coefficients), anisotropy and index, where they vary. */
static int send_medium(ohm_mc_device *d, const ohm_network *net, const ohm_channel_medium *med, int varies,
                       ohm_error *err)
{
    size_t n = (size_t)net->n;
    int rc = OHM_OK;
    if (varies) {
        double *coef = malloc(2 * n * sizeof *coef);
        if (!coef) return ohm_fail(err, OHM_ERR_NOMEM, "monte carlo on a device: out of memory for the medium");
        const double h = net->grid->h;
        for (size_t v = 0; v < n; ++v) {
            double sa, ss;
            ohm_medium_coefficients(med, (int64_t)v, &sa, &ss);
            coef[2 * v] = sa * h;
            coef[2 * v + 1] = ss * h / (1.0 - (med->g_v ? med->g_v[v] : med->g));
        }
        rc = fill(d, &d->coef, 2 * n * sizeof(double), coef, err);
        free(coef);
    }
    if (!rc && med->g_v) rc = fill(d, &d->g, n * sizeof(double), med->g_v, err);
    if (!rc && med->eta_v) rc = fill(d, &d->eta, n * sizeof(double), med->eta_v, err);
    return rc;
}

/* This trace's entries: their cumulative power in `channel`, their cells
 * and faces, their points and directions (mc_step.h's mc_start_point, what
 * does not draw). */
static int send_entries(ohm_mc_device *d, const ohm_network *net, const ohm_light_entry *entries, size_t nentries,
                        int channel, double P, ohm_error *err)
{
    const ohm_voxel_grid *g = net->grid;
    double *cdf = malloc(nentries * sizeof *cdf), *egeo = malloc(6 * nentries * sizeof *egeo);
    int32_t *ecell = malloc(4 * nentries * sizeof *ecell), *ev = malloc(nentries * sizeof *ev);
    int rc = cdf && egeo && ecell && ev ? OHM_OK
                                        : ohm_fail(err, OHM_ERR_NOMEM, "monte carlo on a device: out of memory");
    if (!rc) {
        ohm_mc_entry_cdf(cdf, entries, nentries, channel, P);
        for (size_t e = 0; e < nentries; ++e) {
            const ohm_light_entry *en = &entries[e];
            int64_t v = net->face_unknown[en->face];
            int32_t c[3];
            ohm_voxel_coords(g, net->face_cell[en->face], c);
            for (int a = 0; a < 3; ++a) {
                ecell[4 * e + (size_t)a] = c[a];
                egeo[6 * e + (size_t)a] = (en->point[a] - g->origin[a]) / g->h + 0.5;
                egeo[6 * e + 3 + (size_t)a] = en->dir[a];
            }
            ecell[4 * e + 3] = net->face_dir[en->face] + 8 * (en->at_point != 0);
            ev[e] = (int32_t)v;
        }
        if (nentries > d->entry_cap) { /* room for these, kept for the next trace */
            cl_mem *m[] = {&d->cdf, &d->ecell, &d->ev, &d->egeo};
            for (size_t i = 0; i < sizeof m / sizeof *m; ++i) ohm_device_release(&d->s, m[i]);
            d->entry_cap = nentries;
        }
        rc = fill(d, &d->cdf, nentries * sizeof(double), cdf, err);
        if (!rc) rc = fill(d, &d->ecell, 4 * nentries * sizeof(int32_t), ecell, err);
        if (!rc) rc = fill(d, &d->ev, nentries * sizeof(int32_t), ev, err);
        if (!rc) rc = fill(d, &d->egeo, 6 * nentries * sizeof(double), egeo, err);
    }
    free(cdf), free(egeo), free(ecell), free(ev);
    return rc;
}

#define ARG_MEM(kid, i, m) ohm_device_arg(&d->s, d->k[kid], i, sizeof(cl_mem), &(m))
#define ARG_VAL(kid, i, type, v)                                                                                \
    do {                                                                                                        \
        type value_ = (v);                                                                                      \
        ohm_device_arg(&d->s, d->k[kid], i, sizeof value_, &value_);                                            \
    } while (0)

/* a zeroed array (fill_zero) */
static void zero(ohm_mc_device *d, cl_mem a, int64_t count)
{
    ARG_MEM(K_ZERO, 0, a);
    ARG_VAL(K_ZERO, 1, cl_long, count);
    ohm_device_launch(&d->s, d->k[K_ZERO], 64 * d->wg, d->wg);
}

/* The trace kernel's arguments that stay for the whole run (all but the
 * first two: the launch's first photon and count). */
static void set_scene(ohm_mc_device *d, const ohm_network *net, const ohm_channel_medium *med, size_t nentries,
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
    /* the uniform medium in 1/voxel (mc.c's mc_coefficients), its g and index */
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
static int trace_launch(ohm_mc_device *d, ohm_mc_sums *s, int64_t first, int64_t count, ohm_error *err)
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
static int fold_batch(ohm_mc_device *d, ohm_mc_sums *s, const ohm_network *net, ohm_error *err)
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
static int run_batches(ohm_mc_device *d, ohm_mc_sums *s, const ohm_network *net, int64_t per_batch,
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

int ohm_mc_device_run(ohm_mc_device *d, ohm_mc_result *res, const ohm_network *net, const ohm_channel_medium *med,
                      const ohm_light_entry *entries, size_t nentries, int channel, double P, int64_t per_batch,
                      const ohm_mc_params *params, ohm_error *err)
{
    const ohm_device *dev = ohm_device_session_device(&d->s);
    const ohm_voxel_grid *g = net->grid;
    size_t ncells = (size_t)g->dims[0] * (size_t)g->dims[1] * (size_t)g->dims[2];
    int varies = ohm_medium_varies(med) || med->g_v;
    double need = device_need(net, ncells, med, varies, nentries, params->handoff);
    if (need > 0.9 * dev->global_bytes) {
        char nb[32], db[32];
        return ohm_fail(err, OHM_ERR_NOMEM,
                        "monte carlo on %s (opencl:%d): the scene and tallies need %s, more than 90%% of the "
                        "device's %s; %s",
                        dev->name, d->s.picked, ohm_format_bytes(need, nb, sizeof nb),
                        ohm_format_bytes(dev->global_bytes, db, sizeof db), ADVICE);
    }
    int rc = select_program(d, med, varies, params->handoff, err);
    if (!rc) rc = bind_network(d, net, err);
    if (!rc && params->handoff > 0 && !d->handoff)
        rc = ohm_device_buffer(&d->s, &d->handoff, (size_t)net->n * sizeof(double), NULL, ADVICE, err);
    if (!rc) rc = send_medium(d, net, med, varies, err);
    if (!rc) rc = send_entries(d, net, entries, nentries, channel, P, err);
    ohm_mc_sums sums = {0};
    if (!rc && ohm_mc_sums_alloc(&sums, net, params->handoff))
        rc = ohm_fail(err, OHM_ERR_NOMEM, "monte carlo: out of memory for the sums");
    if (!rc) {
        zero(d, d->phi, net->n);
        zero(d, d->phi_sum, net->n);
        zero(d, d->phi_sq, net->n);
        zero(d, d->face, net->nfaces);
        if (params->handoff > 0) zero(d, d->handoff, net->n);
        set_scene(d, net, med, nentries, params);
        rc = ohm_device_checked(&d->s, err);
    }
    char what[160];
    snprintf(what, sizeof what, "monte carlo on %s, channel %d, %lld photons", dev->name, channel,
             (long long)(per_batch * OHM_MC_BATCHES));
    if (!rc) rc = run_batches(d, &sums, net, per_batch, params, what, err);
    size_t n = (size_t)net->n;
    if (!rc) rc = ohm_device_copy(&d->s, d->phi_sum, sums.phi_sum, n * sizeof(double), 0, err);
    if (!rc) rc = ohm_device_copy(&d->s, d->phi_sq, sums.phi_sq, n * sizeof(double), 0, err);
    if (!rc && params->handoff > 0) rc = ohm_device_copy(&d->s, d->handoff, sums.handoff, n * sizeof(double), 0, err);
    if (!rc) {
        ohm_mc_write_result(res, &sums, net, per_batch, P);
        res->threads = dev->compute_units;
        snprintf(res->device, sizeof res->device, "%s", dev->name);
    }
    ohm_mc_sums_free(&sums);
    return rc;
}
