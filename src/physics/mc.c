#include "physics/mc.h"

#include "physics/mc_device.h"
#include "physics/mc_tally.h"
#include "base/log.h"
#include "base/memory.h"
#include "base/parallel.h"

#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* ---- random numbers: xoshiro256+ (Blackman & Vigna 2018), seeded by splitmix64 */

typedef struct rng {
    uint64_t s[4];
} rng;

static inline uint64_t rotl(uint64_t x, int k)
{
    return (x << k) | (x >> (64 - k));
}

/* Uniform on [0, 1): the top 53 bits. */
static inline double rng_uniform(rng *r)
{
    uint64_t *s = r->s, result = s[0] + s[3], t = s[1] << 17;
    s[2] ^= s[0];
    s[3] ^= s[1];
    s[1] ^= s[2];
    s[0] ^= s[3];
    s[2] ^= t;
    s[3] = rotl(s[3], 45);
    return (double)(result >> 11) * 0x1.0p-53;
}

static uint64_t splitmix64(uint64_t *x)
{
    uint64_t z = (*x += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

/* One stream per batch: the state from (seed, batch) through splitmix64, as
 * the xoshiro authors recommend for seeding. */
static void rng_seed(rng *r, uint64_t seed, uint64_t batch)
{
    uint64_t x = seed ^ (0xd1342543de82ef95ULL * (batch + 1));
    for (int i = 0; i < 4; ++i) r->s[i] = splitmix64(&x);
}

/* ---- the scene, read by every thread ----------------------------------------- */

typedef struct mc_scene {
    const ohm_network *net;
    const ohm_channel_medium *med;
    const ohm_light_entry *entries;
    double *cdf;           /* nentries: cumulative entering power, last = 1 */
    int64_t nentries;
    int mirror_low[3], mirror_high[3]; /* the network's symmetry planes     */
    double g, ss_scale;    /* sigma_s = sigma_s' * ss_scale = sigma_s' / (1 - g); per cell
                              with med->g_v (mc_cell_g)                        */
    double eta;
    int64_t per_batch;     /* photons per batch                              */
    uint64_t seed;
    double max_path;       /* voxels; INFINITY: no gate                      */
    int total_fluence;     /* tally the unscattered beam's fluence too       */
    double handoff;        /* > 0: end photons after this many reduced
                              scatterings, each counting 1 - g (mc.h)          */
    int nthreads;
    const ohm_log *log;
    char what[64];         /* for the progress line                          */
} mc_scene;

/* ---- one thread's tallies ------------------------------------------------------ */

typedef struct mc_tally {
    const mc_scene *sc;
    int thread;
    double *phi, *face; /* this batch's, in voxel units of weight x length and weight */
    ohm_mc_sums sums;   /* over this thread's batches (mc_tally.h) */
    int cancelled;      /* it stopped early: the run was cancelled */
} mc_tally;

/* ---- one photon: the loop the device runs too (mc_loop.h) ------------------------ */

/* What mc_loop.h asks of its includer: the scene read through the network
 * and the medium, the tallies added into this thread's batch arrays and
 * sums. */
typedef rng mc_rng;
typedef int64_t mc_index;
typedef int64_t mc_long;
#define MC_GLOBAL
#define MC_UNIFORM(r) rng_uniform(r)
#define MC_HANDOFF 1
#define MC_ETA_VARIES(sc) ((sc)->med->eta_v != NULL)
#define MC_TOTAL(to, name) ((to)->sums.name)
typedef mc_tally mc_to;

/* Entry e's unknown, cell, face direction, point in voxel coordinates and
 * direction. */
static inline void mc_entry(const mc_scene *sc, mc_long e, mc_index *v, int c[3], int *d, int *at_point,
                            double at[3], double u[3])
{
    const ohm_network *net = sc->net;
    const ohm_voxel_grid *g = net->grid;
    const ohm_light_entry *en = &sc->entries[e];
    *v = net->face_unknown[en->face];
    ohm_voxel_coords(g, net->face_cell[en->face], c);
    *d = net->face_dir[en->face];
    *at_point = en->at_point != 0;
    for (int a = 0; a < 3; ++a) {
        if (en->at_point) at[a] = (en->point[a] - g->origin[a]) / g->h + 0.5;
        u[a] = en->dir[a];
    }
}

/* The unknown of grid cell n, or -1 outside the grid or the object. */
static inline mc_index mc_unknown_at(const mc_scene *sc, const int n[3])
{
    const ohm_voxel_grid *g = sc->net->grid;
    for (int a = 0; a < 3; ++a)
        if (n[a] < 0 || n[a] >= g->dims[a]) return -1;
    return ohm_network_unknown(sc->net, ohm_voxel_index(g, n[0], n[1], n[2]));
}

/* Coefficients of unknown v in 1/voxel (lengths below are in voxels). */
static inline void mc_coefficients(const mc_scene *sc, mc_index v, double *sa, double *ss)
{
    const ohm_channel_medium *m = sc->med;
    double h = sc->net->grid->h;
    ohm_medium_coefficients(m, v, sa, ss);
    double scale = m->g_v ? 1.0 / (1.0 - m->g_v[v]) : sc->ss_scale;
    *sa *= h;
    *ss *= scale * h;
}

/* The anisotropy of unknown v. */
static inline double mc_cell_g(const mc_scene *sc, mc_index v)
{
    return sc->med->g_v ? sc->med->g_v[v] : sc->g;
}

/* The index of unknown v. */
static inline double mc_cell_eta(const mc_scene *sc, mc_index v)
{
    return sc->med->eta_v ? sc->med->eta_v[v] : sc->eta;
}

static inline void mc_tally_fluence(mc_to *t, mc_index v, double x)
{
    t->phi[v] += x;
}

/* the host adds every segment where it is: nothing gathered per cell */
static inline void mc_tally_left(mc_to *t, mc_index v)
{
    (void)t, (void)v;
}

static inline void mc_tally_exit(const mc_scene *sc, mc_to *t, mc_index v, int d, double w)
{
    int64_t f = ohm_network_face(sc->net, v, d);
    if (f >= 0) t->face[f] += w;
}

static inline void mc_tally_handoff(mc_to *t, mc_index v, double w)
{
    t->sums.handoff[v] += w;
}

#include "physics/mc_loop.h"

/* Fold one batch into the thread's sums, then clear it. */
static void fold_batch(mc_tally *t)
{
    const ohm_network *net = t->sc->net;
    int64_t n = net->n;
    for (int64_t v = 0; v < n; ++v) {
        double x = t->phi[v];
        t->sums.phi_sum[v] += x;
        t->sums.phi_sq[v] += x * x;
    }
    ohm_mc_fold_faces(&t->sums, net, t->face);
    ohm_mc_fold_totals(&t->sums);
    memset(t->phi, 0, (size_t)n * sizeof *t->phi);
    memset(t->face, 0, (size_t)(net->nfaces ? net->nfaces : 1) * sizeof *t->face);
}

/* Photons between looks at the run's cancellation (and thread 0's progress):
 * a few milliseconds of tracing. */
enum { MC_CHUNK = 256 };

static void *thread_main(void *arg)
{
    mc_tally *t = arg;
    const mc_scene *sc = t->sc;
    ohm_progress prog;
    if (t->thread == 0) ohm_progress_begin(&prog, sc->log, sc->what);
    double t_reported = ohm_now();
    int mine = 0, done = 0;
    for (int b = t->thread; b < OHM_MC_BATCHES; b += sc->nthreads) ++mine;
    for (int b = t->thread; b < OHM_MC_BATCHES && !t->cancelled; b += sc->nthreads) {
        rng r;
        rng_seed(&r, sc->seed, (uint64_t)b);
        for (int64_t k = 0; k < sc->per_batch; ++k) {
            mc_trace_photon(sc, t, &r);
            if ((k + 1) % MC_CHUNK) continue;
            if (ohm_log_cancelled(sc->log)) {
                t->cancelled = 1;
                break;
            }
            if (t->thread == 0 && ohm_now() - t_reported >= 0.05) {
                t_reported = ohm_now();
                ohm_progress_update(&prog, (done + (double)k / (double)sc->per_batch) / mine);
            }
        }
        fold_batch(t);
        ++done;
    }
    if (t->thread == 0 && !t->cancelled) ohm_progress_end(&prog);
    return NULL;
}

static void tally_free(mc_tally *t)
{
    free(t->phi);
    free(t->face);
    ohm_mc_sums_free(&t->sums);
}

static int tally_alloc(mc_tally *t, const ohm_network *net, int handoff)
{
    size_t n = (size_t)(net->n ? net->n : 1), nf = (size_t)(net->nfaces ? net->nfaces : 1);
    t->phi = calloc(n, sizeof(double));
    t->face = calloc(nf, sizeof(double));
    return t->phi && t->face && !ohm_mc_sums_alloc(&t->sums, net, handoff) ? 0 : -1;
}

int ohm_mc_trace(ohm_mc_result *res, const ohm_network *net, const ohm_channel_medium *med,
                 const ohm_light_entry *entries, size_t nentries, int channel, const ohm_mc_params *params,
                 ohm_error *err)
{
    double t0 = ohm_now();
    if (med->resistance_mode)
        return ohm_fail(err, OHM_ERR_USAGE, "solve: solver=mc needs optical coefficients, not resistances");
    if (!(med->g > -1.0 && med->g < 1.0))
        return ohm_fail(err, OHM_ERR_USAGE, "solve: g=%g: the anisotropy must lie in (-1, 1)", med->g);
    mc_scene sc = {.net = net,
                   .med = med,
                   .entries = entries,
                   .nentries = (int64_t)nentries,
                   .g = med->g,
                   .ss_scale = 1.0 / (1.0 - med->g),
                   .eta = med->eta,
                   .seed = params->seed,
                   .total_fluence = params->total_fluence,
                   .handoff = params->handoff > 0 ? params->handoff : 0,
                   .max_path = params->max_path > 0 ? params->max_path / net->grid->h : INFINITY,
                   .log = params->log};
    for (int a = 0; a < 3; ++a) {
        sc.mirror_low[a] = net->mirror.low[a];
        sc.mirror_high[a] = net->mirror.high[a];
    }
    int64_t photons = params->photons > 0 ? params->photons : 1000000;
    sc.per_batch = (photons + OHM_MC_BATCHES - 1) / OHM_MC_BATCHES;
    snprintf(sc.what, sizeof sc.what, "monte carlo, channel %d, %lld photons", channel,
             (long long)(sc.per_batch * OHM_MC_BATCHES));
    int nthreads = params->threads > 0 ? params->threads : ohm_usable_cores();
    if (nthreads > OHM_MC_BATCHES) nthreads = OHM_MC_BATCHES;
    sc.nthreads = nthreads;
    res->threads = nthreads;
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
    if (!(P > 0)) { /* unlit in this channel: nothing to trace */
        res->seconds = ohm_now() - t0;
        return OHM_OK;
    }
    res->device[0] = '\0';
    ohm_mc_device *dev = params->kept;
    int rc = dev ? OHM_OK : ohm_mc_device_open(&dev, &params->device, sc.per_batch * OHM_MC_BATCHES, params->log, err);
    int on_device = dev != NULL;
    if (!rc && on_device)
        rc = ohm_mc_device_run(dev, res, net, med, entries, nentries, channel, P, sc.per_batch, params, err);
    if (dev != params->kept) ohm_mc_device_free(dev);
    if (rc || on_device) {
        res->seconds = ohm_now() - t0;
        return rc;
    }
    /* per thread: this batch's fluence and faces, the sums, the squares */
    double need = (double)nthreads * ((4.0 + (sc.handoff > 0)) * (double)n + 2.0 * (double)nf) * sizeof(double);
    double limit = ohm_memory_limit(params->max_memory);
    if (need > limit) {
        char nb[32], lb[32];
        return ohm_fail(err, OHM_ERR_NOMEM,
                        "solve: Monte Carlo's tallies need about %s (%d threads x %lld cells), more than the %s %s; "
                        "use threads=1 or a coarser grid",
                        ohm_format_bytes(need, nb, 32), nthreads, (long long)n, ohm_format_bytes(limit, lb, 32),
                        params->max_memory > 0 ? "max_memory= allows" : "available");
    }
    sc.cdf = malloc(nentries * sizeof *sc.cdf);
    mc_tally *tally = calloc((size_t)nthreads, sizeof *tally);
    rc = sc.cdf && tally ? OHM_OK : ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory for Monte Carlo");
    if (!rc) ohm_mc_entry_cdf(sc.cdf, entries, nentries, channel, P);
    for (int k = 0; k < nthreads && !rc; ++k) {
        tally[k].sc = &sc;
        tally[k].thread = k;
        if (tally_alloc(&tally[k], net, sc.handoff))
            rc = ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory for Monte Carlo tallies (%d threads x %lld cells)",
                          nthreads, (long long)n);
    }
    pthread_t *tid = rc ? NULL : malloc((size_t)nthreads * sizeof *tid);
    if (!rc && !tid) rc = ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory for threads");
    int started = 0;
    for (int k = 1; k < nthreads && !rc; ++k, ++started)
        if (pthread_create(&tid[k], NULL, thread_main, &tally[k])) {
            rc = ohm_fail(err, OHM_ERR_INTERNAL, "solve: could not start Monte Carlo thread %d", k);
            break;
        }
    if (!rc) thread_main(&tally[0]);
    for (int k = 1; k <= started; ++k) pthread_join(tid[k], NULL);
    for (int k = 0; k < nthreads && !rc; ++k)
        if (tally[k].cancelled) rc = ohm_fail_cancelled(err, "monte carlo");
    if (!rc) { /* thread k's sums into thread 0's, in thread order (reproducible) */
        for (int k = 1; k < nthreads; ++k) ohm_mc_sums_merge(&tally[0].sums, &tally[k].sums, net);
        ohm_mc_write_result(res, &tally[0].sums, net, sc.per_batch, P);
    }
    for (int k = 0; k < nthreads && tally; ++k) tally_free(&tally[k]);
    free(tally);
    free(tid);
    free(sc.cdf);
    res->seconds = ohm_now() - t0;
    return rc;
}
