#include "physics/mc.h"

#include "physics/fresnel.h"
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

/* Below this weight (of a photon's 1 at entry) a photon ends, depositing the
 * rest where it is (mc.h). */
static const double W_MIN = 1e-6;
/* A photon still alive after this many path segments (a medium that neither
 * absorbs nor lets light out, in practice) ends the same way, and is counted. */
static const int64_t MAX_EVENTS = 100000000;

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

/* An optical depth to the next scattering: -ln(xi), xi in (0, 1]. */
static inline double rng_depth(rng *r)
{
    return -log(1.0 - rng_uniform(r));
}

/* ---- the scene, read by every thread ----------------------------------------- */

typedef struct mc_scene {
    const ohm_network *net;
    const ohm_channel_medium *med;
    const ohm_light_entry *entries;
    double *cdf;           /* nentries: cumulative entering power, last = 1 */
    size_t nentries;
    double g, ss_scale;    /* sigma_s = sigma_s' * ss_scale = sigma_s' / (1 - g); per cell
                              with med->g_v (cell_g)                           */
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

/* Coefficients of unknown v in 1/voxel (lengths below are in voxels). */
static inline void cell_coefficients(const mc_scene *sc, int64_t v, double *sa, double *ss)
{
    const ohm_channel_medium *m = sc->med;
    double h = sc->net->grid->h;
    ohm_medium_coefficients(m, v, sa, ss);
    double scale = m->g_v ? 1.0 / (1.0 - m->g_v[v]) : sc->ss_scale;
    *sa *= h;
    *ss *= scale * h;
}

/* ---- one thread's tallies ------------------------------------------------------ */

typedef struct mc_tally {
    const mc_scene *sc;
    int thread;
    double *phi, *face; /* this batch's, in voxel units of weight x length and weight */
    ohm_mc_sums sums;   /* over this thread's batches (mc_tally.h) */
    int cancelled;      /* it stopped early: the run was cancelled */
} mc_tally;

/* Where photon starts: entry e's point, or uniformly over its face; in voxel
 * coordinates where cell i spans [i, i+1). */
static void start_point(const mc_scene *sc, const ohm_light_entry *e, const int32_t c[3], rng *r, double p[3])
{
    const ohm_voxel_grid *g = sc->net->grid;
    int d = sc->net->face_dir[e->face], axis = d / 2;
    for (int a = 0; a < 3; ++a) {
        double x = e->at_point ? (e->point[a] - g->origin[a]) / g->h + 0.5 : c[a] + rng_uniform(r);
        /* on the face, and inside the cell's square on the other axes */
        if (x < c[a]) x = c[a];
        if (x > c[a] + 1.0) x = c[a] + 1.0;
        p[a] = x;
    }
    p[axis] = c[axis] + (ohm_face_offset[d][axis] > 0 ? 1.0 : 0.0);
}

static size_t pick_entry(const mc_scene *sc, double xi)
{
    size_t lo = 0, hi = sc->nentries - 1;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (sc->cdf[mid] <= xi) lo = mid + 1;
        else hi = mid;
    }
    return lo;
}

/* The unknown of grid cell n, or -1 outside the grid or the object. */
static inline int64_t unknown_at(const ohm_network *net, const int32_t n[3])
{
    const ohm_voxel_grid *g = net->grid;
    for (int a = 0; a < 3; ++a)
        if (n[a] < 0 || n[a] >= g->dims[a]) return -1;
    return ohm_network_unknown(net, ohm_voxel_index(g, n[0], n[1], n[2]));
}

/* The anisotropy of unknown v. */
static inline double cell_g(const mc_scene *sc, int64_t v)
{
    return sc->med->g_v ? sc->med->g_v[v] : sc->g;
}

/* The index of unknown v. */
static inline double cell_eta(const mc_scene *sc, int64_t v)
{
    return sc->med->eta_v ? sc->med->eta_v[v] : sc->eta;
}

/* the steps the device takes alike (mc_step.h): absorption, scattering,
 * an index change, the hybrid's handoff into this thread's sums */
typedef rng mc_rng;
typedef int64_t mc_index;
typedef struct mc_to {
    const mc_scene *sc;
    mc_tally *t;
} mc_to;
#define MC_UNIFORM(r) rng_uniform(r)
#define MC_REFLECTANCE_INSIDE(m, mu) ohm_fresnel_reflectance_inside(m, mu)
#define MC_UNKNOWN_AT(to, n) unknown_at((to)->sc->net, n)
#define MC_HANDOFF_ADD(to, u, w) ((to)->t->sums.handoff[u] += (w))
#include "physics/mc_step.h"

/* One photon of weight 1, from entry to its end (mc.h). */
static void trace_photon(const mc_scene *sc, mc_tally *t, rng *r)
{
    const ohm_network *net = sc->net;
    const ohm_voxel_grid *g = net->grid;
    const ohm_light_entry *e = &sc->entries[pick_entry(sc, rng_uniform(r))];
    int64_t v = net->face_unknown[e->face];
    int32_t c[3];
    ohm_voxel_coords(g, net->face_cell[e->face], c);
    double p[3], u[3] = {e->dir[0], e->dir[1], e->dir[2]};
    start_point(sc, e, c, r, p);
    double w = 1.0, sa, ss;
    cell_coefficients(sc, v, &sa, &ss);
    double tau = rng_depth(r), path_left = sc->max_path;
    int scattered = 0;   /* the unscattered beam is not diffuse fluence (mc.h) */
    double reduced = 0;  /* reduced scatterings so far: sum of 1 - g (the hybrid's clock) */
    int64_t ev = 0;
    for (;; ++ev) {
        if (ev >= MAX_EVENTS) {
            t->sums.truncated++;
            break;
        }
        int ax, scatters, gated;
        double s = mc_segment(c, p, u, ss, tau, path_left, &ax, &scatters, &gated);
        path_left -= s;
        /* absorption along the segment, exactly: w e^(-sa s); its track
         * length integral w (1 - e^(-sa s)) / sa is the fluence tally */
        double x = sa * s, lost = mc_absorbed_fraction(x);
        if (scattered || sc->total_fluence) t->phi[v] += x > 1e-9 ? w * lost / sa : w * s;
        double w1 = w - w * lost;
        t->sums.absorbed += w - w1;
        w = w1;
        if (gated) {
            t->sums.gated += w;
            w = 0;
            break;
        }
        for (int a = 0; a < 3; ++a) p[a] += s * u[a];
        if (scatters) {
            double gv = cell_g(sc, v);
            scattered = 1;
            /* the hybrid's: diffusion from here (the margin: ten steps of 1 - 0.9 sum to 0.99..9) */
            if (sc->handoff > 0 && (reduced += 1.0 - gv) >= sc->handoff - 1e-9) {
                mc_hand_off(&(mc_to){sc, t}, v, c, p, w);
                t->sums.handed += w;
                w = 0;
                break;
            }
            mc_scatter(u, gv, r);
            tau = rng_depth(r);
        } else {
            tau -= ss * s;
            int step = u[ax] > 0 ? 1 : -1;
            p[ax] = (double)(step > 0 ? c[ax] + 1 : c[ax]);
            if (c[ax] == (step < 0 ? net->mirror.low[ax] : net->mirror.high[ax])) { /* symmetry plane */
                u[ax] = -u[ax];
                continue;
            }
            int32_t n[3] = {c[0], c[1], c[2]};
            n[ax] += step;
            int64_t nv = unknown_at(net, n);
            if (nv >= 0 && sc->med->eta_v && sc->med->eta_v[nv] != sc->med->eta_v[v] &&
                !mc_cross_interface(u, ax, sc->med->eta_v[v], sc->med->eta_v[nv], r)) {
                /* reflected at an internal change of index: stays in v */
            } else if (nv >= 0) {
                c[ax] = n[ax];
                v = nv;
                cell_coefficients(sc, v, &sa, &ss);
            } else { /* a boundary face: reflected with the Fresnel probability, else out */
                double R = ohm_fresnel_reflectance_inside(cell_eta(sc, v), fabs(u[ax]));
                if (R < 1.0 && rng_uniform(r) >= R) {
                    int64_t f = ohm_network_face(net, v, 2 * ax + (step > 0));
                    if (f >= 0) t->face[f] += w;
                    t->sums.out += w;
                    w = 0;
                    break;
                }
                u[ax] = -u[ax];
            }
        }
        if (w < W_MIN) break;
    }
    t->sums.absorbed += w; /* what is left ends here (mc.h) */
    t->sums.events += ev;
}

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
            trace_photon(sc, t, &r);
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
                   .nentries = nentries,
                   .g = med->g,
                   .ss_scale = 1.0 / (1.0 - med->g),
                   .eta = med->eta,
                   .seed = params->seed,
                   .total_fluence = params->total_fluence,
                   .handoff = params->handoff > 0 ? params->handoff : 0,
                   .max_path = params->max_path > 0 ? params->max_path / net->grid->h : INFINITY,
                   .log = params->log};
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
