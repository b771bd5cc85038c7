#include "physics/light.h"

#include "physics/light_kind.h"

#include "base/parallel.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

const char *ohm_light_name(const ohm_light *l) { return ohm_light_kind_of(l)->name; }

int ohm_light_at_a_point(const ohm_light *l) { return ohm_light_kind_of(l)->at_a_point; }

/* Signed distance at a cell (negative inside); NaN when unknown. */
static double signed_dist(const ohm_voxel_grid *g, int32_t i, int32_t j, int32_t k)
{
    if (i < 0 || j < 0 || k < 0 || i >= g->dims[0] || j >= g->dims[1] || k >= g->dims[2]) return NAN;
    size_t idx = ohm_voxel_index(g, i, j, k);
    double d = ohm_voxel_dist(g, idx);
    if (isnan(d)) return NAN;
    if (!isfinite(d)) d = g->band;
    return g->inside[idx] ? -d : d;
}

void ohm_surface_normal(const ohm_network *net, int64_t f, double n[3])
{
    const ohm_voxel_grid *g = net->grid;
    int d = net->face_dir[f];
    int32_t c[3];
    ohm_voxel_coords(g, net->face_cell[f], c);
    double grad[3], len2 = 0;
    for (int a = 0; a < 3; ++a) {
        int32_t p[3] = {c[0], c[1], c[2]}, m[3] = {c[0], c[1], c[2]};
        p[a] += 1;
        m[a] -= 1;
        grad[a] = signed_dist(g, p[0], p[1], p[2]) - signed_dist(g, m[0], m[1], m[2]);
        len2 += grad[a] * grad[a];
    }
    if (isfinite(len2) && len2 > 0) {
        double inv = 1.0 / sqrt(len2);
        for (int a = 0; a < 3; ++a) n[a] = grad[a] * inv;
        /* a gradient pointing away from this face's side is noise: use the face */
        double along = n[0] * ohm_face_offset[d][0] + n[1] * ohm_face_offset[d][1] + n[2] * ohm_face_offset[d][2];
        if (along > 0) return;
    }
    for (int a = 0; a < 3; ++a) n[a] = ohm_face_offset[d][a];
}

static inline double med_sigma_t(const ohm_channel_medium *m, int64_t v)
{
    double sa, ss;
    ohm_medium_coefficients(m, v, &sa, &ss);
    return sa + ss;
}
static inline double med_albedo(const ohm_channel_medium *m, int64_t v)
{
    return ohm_medium_sigma_s(m, v) / med_sigma_t(m, v);
}

/* The column of cells below boundary face f, walked inward against its
 * outward normal: the unknown q cells down (q = 0: the face's own cell), or
 * -1 where the column leaves the object or the grid. */
typedef struct column {
    const ohm_network *net;
    int32_t c[3], step[3];
} column;

static void column_init(column *col, const ohm_network *net, int64_t f)
{
    int d = net->face_dir[f];
    col->net = net;
    for (int a = 0; a < 3; ++a) col->step[a] = -ohm_face_offset[d][a];
    ohm_voxel_coords(net->grid, net->face_cell[f], col->c);
}

static int64_t column_unknown(const column *col, int64_t q)
{
    const ohm_voxel_grid *g = col->net->grid;
    int32_t p[3];
    for (int a = 0; a < 3; ++a) {
        p[a] = col->c[a] + (int32_t)q * col->step[a];
        if (p[a] < 0 || p[a] >= g->dims[a]) return -1;
    }
    return ohm_network_unknown(col->net, ohm_voxel_index(g, p[0], p[1], p[2]));
}

double ohm_source_deposit_face(double *b, const ohm_network *net, int64_t f, double P, double mu,
                               const ohm_channel_medium *med, ohm_deposit deposit)
{
    /* depth per unit path along the refracted ray; clamped away from
     * grazing, where the light would need many cells to gain one */
    if (!(mu > 0.05)) mu = 0.05;
    if (mu > 1.0) mu = 1.0;
    const ohm_voxel_grid *g = net->grid;
    int64_t v0 = net->face_unknown[f];
    if (med->resistance_mode || deposit == OHM_DEPOSIT_SURFACE) {
        double w = med->resistance_mode ? P : P * med_albedo(med, v0);
        b[v0] += w;
        return w;
    }
    column col; /* walk inward: against the face's outward normal */
    column_init(&col, net, f);
    const double h = g->h;
    double put = 0.0;
    if (deposit == OHM_DEPOSIT_POINT) {
        /* everything at depth z0 = 1/sigma_t' (the dipole's real source),
         * split linearly between the two cell centres around it */
        double z0 = mu / med_sigma_t(med, v0), a0 = med_albedo(med, v0);
        double s = z0 / h - 0.5; /* position in cell-centre units */
        int64_t m = s <= 0 ? 0 : (int64_t)floor(s);
        double frac = s <= 0 ? 0.0 : s - (double)m;
        /* the column of interior cells below the face, down to cell m+1 */
        int64_t upper = v0, lower = -1;
        for (int64_t q = 1; q <= m + 1; ++q) {
            int64_t u = column_unknown(&col, q);
            if (u < 0) break;
            if (q <= m) upper = u;
            else lower = u;
        }
        /* a part thinner than z0 keeps everything in its deepest cell */
        if (lower < 0) frac = 0.0;
        b[upper] += a0 * P * (1.0 - frac);
        if (frac > 0) b[lower] += a0 * P * frac;
        return a0 * P;
    }
    /* exponential: optical depth accumulated cell by cell; each cell's share
     * alpha' P (e^-tau0 - e^-tau1) is split between it and the cell above so
     * that its centroid, not its cell's centre, is where it acts: the depth
     * distribution's first moment is then exact on any grid (lumped
     * at centres, the source sat 8% too deep at h = 1/sigma_t').  The first
     * cell has no cell above: its shallower part is extrapolated, a negative
     * share in the second cell (moment exact again), clamped so that no
     * cell's source turns negative. */
    double tau = 0.0, pending_up = 0.0; /* weight the previous cell owes the cell above it */
    double above = 1.0;                 /* e^-tau: the share still travelling at the cell's top */
    double x_last = -1.0, absorbed_last = 0.0, centroid_last = 0.5; /* the last cell's x and its terms */
    int64_t prev = -1, first = v0;
    for (int64_t q = 0;; ++q) {
        int64_t u = column_unknown(&col, q);
        if (u < 0) break; /* the rest passes through a thin part unscattered */
        double x = med_sigma_t(med, u) * h / mu, t1 = tau + x; /* optical depth of the cell along the ray */
        if (x != x_last) {
            /* 1 - e^-x, and the centroid of e^-sigma z over the cell from its
             * top, in cells: 1/x - e^-x / (1 - e^-x) (1/2 as x -> 0).  A
             * uniform column repeats x, so this runs once per face there: the
             * live update paid three transcendental calls per cell. */
            absorbed_last = -expm1(-x);
            centroid_last = x > 1e-6 ? 1.0 / x - (1.0 - absorbed_last) / absorbed_last : 0.5 - x / 12.0;
            x_last = x;
        }
        double w = med_albedo(med, u) * P * above * absorbed_last, centroid = centroid_last;
        above *= 1.0 - absorbed_last;
        double up = w * (0.5 - centroid); /* to move one cell up */
        if (q == 0) {
            b[u] += w;
            pending_up = up; /* extrapolated into the second cell below */
        } else {
            if (q == 1) { /* the first cell's extrapolation, clamped */
                double own = w - up, minus = fmin(pending_up, own);
                b[first] += minus;
                b[u] += own - minus;
                pending_up = 0.0;
            } else {
                b[u] += w - up;
            }
            b[prev] += up;
        }
        put += w;
        prev = u;
        tau = t1;
        if (tau > 40.0) break; /* e^-40: nothing left */
    }
    return put;
}

void ohm_source_unscattered_face(double *phi, const ohm_network *net, int64_t f, double P, double mu,
                                 const ohm_channel_medium *med)
{
    if (!(mu > 0.05)) mu = 0.05; /* as the deposit */
    if (mu > 1.0) mu = 1.0;
    column col;
    column_init(&col, net, f);
    const double h = net->grid->h, volume = h * h * h;
    double tau = 0.0;
    for (int64_t q = 0;; ++q) {
        int64_t u = column_unknown(&col, q);
        if (u < 0) break;
        /* the full sigma_t = sigma_a + sigma_s' / (1 - g): the unscattered beam
         * loses every photon that scatters, forward or not */
        double sa, ss;
        ohm_medium_coefficients(med, u, &sa, &ss);
        double st = sa + ss / (1.0 - med->g), t1 = tau + st * h / mu;
        /* track length in the cell along the ray, P int e^-st s ds, per volume */
        phi[u] += P * (exp(-tau) - exp(-t1)) / (st * volume);
        tau = t1;
        if (tau > 40.0) break;
    }
}

static void face_centre(const ohm_network *net, int64_t f, double p[3])
{
    const ohm_voxel_grid *g = net->grid;
    int32_t c[3];
    ohm_voxel_coords(g, net->face_cell[f], c);
    int d = net->face_dir[f];
    for (int a = 0; a < 3; ++a) p[a] = g->origin[a] + g->h * (c[a] + 0.5 * ohm_face_offset[d][a]);
}

/* Pencil beam: walk the ray through the grid (Amanatides & Woo 1987) to the
 * first interior cell; the face it crosses is where the beam enters (*face;
 * -1 when the beam misses the object: a light that reaches nothing, like any
 * other, adds nothing and the -solve step warns about it). */
static int pencil_entry_face(const ohm_network *net, const double pos[3], const double dir[3], int64_t *face,
                             ohm_error *err)
{
    *face = -1;
    const ohm_voxel_grid *g = net->grid;
    double gp[3], t_enter = 0.0, t_exit = INFINITY;
    for (int a = 0; a < 3; ++a) {
        gp[a] = (pos[a] - g->origin[a]) / g->h + 0.5; /* cell i spans [i, i+1) */
        double lo = 0.0, hi = (double)g->dims[a];
        if (fabs(dir[a]) < 1e-300) {
            if (gp[a] < lo || gp[a] >= hi) return OHM_OK; /* misses */
            continue;
        }
        double t0 = (lo - gp[a]) / dir[a], t1 = (hi - gp[a]) / dir[a];
        if (t0 > t1) { double tmp = t0; t0 = t1; t1 = tmp; }
        if (t0 > t_enter) t_enter = t0;
        if (t1 < t_exit) t_exit = t1;
    }
    if (t_enter > t_exit) return OHM_OK; /* misses the grid */
    int32_t c[3], stepv[3];
    double tmax[3], tdelta[3];
    for (int a = 0; a < 3; ++a) {
        double x = gp[a] + t_enter * dir[a];
        c[a] = (int32_t)floor(x);
        if (c[a] < 0) c[a] = 0;
        if (c[a] >= g->dims[a]) c[a] = g->dims[a] - 1;
        stepv[a] = dir[a] > 0 ? 1 : (dir[a] < 0 ? -1 : 0);
        if (stepv[a] == 0) {
            tmax[a] = INFINITY;
            tdelta[a] = INFINITY;
        } else {
            double next = stepv[a] > 0 ? c[a] + 1.0 : (double)c[a];
            tmax[a] = (next - gp[a]) / dir[a];
            tdelta[a] = 1.0 / fabs(dir[a]);
        }
    }
    int last_axis = -1;
    for (;;) {
        int64_t u = ohm_network_unknown(net, ohm_voxel_index(g, c[0], c[1], c[2]));
        if (u >= 0) {
            if (last_axis < 0)
                return ohm_fail(err, OHM_ERR_INVALID, "pencil beam starts inside the object: put pos= outside it");
            int d = 2 * last_axis + (stepv[last_axis] > 0 ? 0 : 1);
            *face = ohm_network_face(net, u, d);
            if (*face >= 0) return OHM_OK;
            return ohm_fail(err, OHM_ERR_INVALID, "pencil beam enters through a symmetry plane");
        }
        int a = tmax[0] < tmax[1] ? (tmax[0] < tmax[2] ? 0 : 2) : (tmax[1] < tmax[2] ? 1 : 2);
        c[a] += stepv[a];
        if (c[a] < 0 || c[a] >= g->dims[a]) return OHM_OK; /* passes the object by */
        tmax[a] += tdelta[a];
        last_axis = a;
    }
}

/* What a shadow ray from boundary face f needs (ohm_light_visibility's ctx). */
typedef struct face_view {
    const ohm_occluder *occ;
    int32_t cell[3];
    int d;
} face_view;

static double face_visibility(const void *ctx, const double l[3], double dist)
{
    const face_view *fv = ctx;
    return ohm_face_visibility(fv->occ, fv->cell, fv->d, l, dist);
}

/* 1 - Fresnel reflectance for light travelling along unit direction
 * `travel` onto a surface of smooth outward normal ns, into index eta; *mu:
 * the refracted ray's cosine to the inward normal, the rate at which it
 * gains depth (Snell: sin_t = sin_i / eta). */
static double fresnel_transmittance(const double ns[3], const double travel[3], double eta, double *mu)
{
    double cos_i = -(ns[0] * travel[0] + ns[1] * travel[1] + ns[2] * travel[2]);
    if (cos_i < 0) cos_i = 0;
    *mu = sqrt(fmax(0.0, 1.0 - (1.0 - cos_i * cos_i) / (eta * eta)));
    return 1.0 - ohm_fresnel_reflectance(eta, cos_i);
}

/* ohm_light_transmittance at a face: its smooth normal (Fresnel at a voxel
 * face's own normal would make a sphere's shading a staircase) and index. */
typedef struct face_surface {
    double ns[3], eta;
} face_surface;

static double face_ray_transmittance(const void *ctx, const double l[3], double *mu)
{
    const face_surface *fs = ctx;
    double travel[3] = {-l[0], -l[1], -l[2]};
    return fresnel_transmittance(fs->ns, travel, fs->eta, mu);
}

/* The unit direction light travels, against l_mean (towards the light). */
static void unit_travel(const double l_mean[3], double travel[3])
{
    double len = sqrt(l_mean[0] * l_mean[0] + l_mean[1] * l_mean[1] + l_mean[2] * l_mean[2]);
    for (int a = 0; a < 3; ++a) travel[a] = -l_mean[a] / len;
}

/* What the light puts on boundary face f (shadow rays included), from the
 * face's centre along its own outward normal (the voxel faces' normals make
 * the captured power exactly the irradiance times the projected area), per
 * channel: E arriving, T_E entering (Fresnel into index eta, at the smooth
 * normal: ray by ray, or at the irradiance-weighted direction, as the kind
 * says) and T_E_mu that times the refracted cosine; l_mean the
 * irradiance-weighted direction towards the light (not normalised).
 * Returns the channels' mean of E: 0 when unlit. */
static double face_irradiance(const ohm_network *net, int64_t f, const ohm_light_setup *su, const ohm_occluder *occ,
                              double eta, double E[3], double T_E[3], double T_E_mu[3], double l_mean[3])
{
    face_view fv = {occ, {0, 0, 0}, net->face_dir[f]};
    ohm_voxel_coords(net->grid, net->face_cell[f], fv.cell);
    double p[3], n[3] = {ohm_face_offset[fv.d][0], ohm_face_offset[fv.d][1], ohm_face_offset[fv.d][2]};
    face_centre(net, f, p);
    face_surface fs;
    ohm_surface_normal(net, f, fs.ns);
    fs.eta = eta;
    if (su->kind->fresnel_per_ray)
        return ohm_light_irradiance_entering(su, p, n, occ ? face_visibility : NULL, &fv, face_ray_transmittance,
                                             &fs, E, T_E, T_E_mu, l_mean);
    double mean = ohm_light_irradiance(su, p, n, occ ? face_visibility : NULL, &fv, E, l_mean);
    if (!(mean > 0)) return mean;
    double travel[3], mu;
    unit_travel(l_mean, travel);
    double T = fresnel_transmittance(fs.ns, travel, eta, &mu);
    for (int c = 0; c < 3; ++c) {
        T_E[c] = T * E[c];
        T_E_mu[c] = T * E[c] * mu;
    }
    return mean;
}

/* The index light enters through face f. */
static inline double face_eta(const ohm_network *net, int64_t f, double eta, const double *eta_v)
{
    return eta_v ? eta_v[net->face_unknown[f]] : eta;
}

/* 1 - Fresnel reflectance for light travelling along unit direction `travel`
 * onto face f, at the smooth surface normal (Fresnel at a voxel face's own
 * normal would make a sphere's shading a staircase). */
static double face_transmittance(const ohm_network *net, int64_t f, const double travel[3], double eta, double *mu)
{
    double ns[3];
    ohm_surface_normal(net, f, ns);
    return fresnel_transmittance(ns, travel, eta, mu);
}


/* What ohm_light_face_powers shares between threads: the faces in blocks
 * of FACE_POWERS_BLOCK, each block taken whole by one thread
 * (ohm_parallel_for's counter: a light reaches one side of the object, and
 * faces are numbered by cell, so fixed halves would not balance).  Faces
 * own their entries of enter / enter_mu, blocks theirs of arrive (a block's
 * arriving power per channel, added up in block order afterwards), so
 * threads never share a write and the sums do not depend on the threads. */
typedef struct face_powers_job {
    double *const *enter, *const *enter_mu;
    double *arrive; /* [block * channels + c] */
    int channels, first; /* channels first .. first + channels - 1 of the light's irradiance */
    const ohm_network *net;
    const ohm_light_setup *su;
    double eta;
    const double *eta_v;
    const ohm_occluder *occ;
} face_powers_job;

enum { FACE_POWERS_BLOCK = 64 };

/* Face f's arriving and entering power, added for every channel (the
 * arriving into its block's sums, arrive). */
static void face_power(const face_powers_job *job, int64_t f, double *arrive)
{
    const ohm_network *net = job->net;
    const double area = net->grid->h * net->grid->h;
    double l_mean[3], E[3], T_E[3], T_E_mu[3];
    double eta = face_eta(net, f, job->eta, job->eta_v);
    if (!(face_irradiance(net, f, job->su, job->occ, eta, E, T_E, T_E_mu, l_mean) > 0)) return;
    for (int c = 0; c < job->channels; ++c) {
        int k = job->first + c;
        arrive[c] += E[k] * area;
        job->enter[c][f] += T_E[k] * area;
        if (job->enter_mu) job->enter_mu[c][f] += T_E_mu[k] * area;
    }
}

static void face_powers_block(void *arg, int64_t block)
{
    const face_powers_job *job = arg;
    const int64_t nfaces = job->net->nfaces, begin = block * FACE_POWERS_BLOCK;
    const int64_t end = begin + FACE_POWERS_BLOCK < nfaces ? begin + FACE_POWERS_BLOCK : nfaces;
    for (int64_t f = begin; f < end; ++f) face_power(job, f, job->arrive + block * job->channels);
}

/* Below this many boundary faces a second thread costs more than it saves. */
enum { FACE_POWERS_THREAD_MIN = 2048 };

/* ohm_light_face_powers for channels first .. first + channels - 1. */
static int face_powers(double *const *enter, double *const *enter_mu, double *arrive, int channels, int first,
                       const ohm_network *net, const ohm_light *light, double eta, const double *eta_v,
                       const ohm_occluder *occ, ohm_error *err)
{
    int64_t nblocks = (net->nfaces + FACE_POWERS_BLOCK - 1) / FACE_POWERS_BLOCK;
    double *block_arrive = calloc((size_t)(nblocks ? nblocks : 1) * (size_t)channels, sizeof *block_arrive);
    if (!block_arrive)
        return ohm_fail(err, OHM_ERR_NOMEM, "light: out of memory for %lld faces", (long long)net->nfaces);
    ohm_light_setup su;
    int rc = ohm_light_setup_init(&su, light, 0, err);
    if (rc) {
        free(block_arrive);
        return rc;
    }
    /* The shadow rays are most of a live update's source (docs/live.md): the
     * faces are shared between the machine's cores.  Same sums on any
     * number of threads: each face is computed whole by one, each block's
     * sums added in order. */
    face_powers_job job = {enter, enter_mu, block_arrive, channels, first, net, &su, eta, eta_v, occ};
    int threads = net->nfaces >= FACE_POWERS_THREAD_MIN ? ohm_usable_cores() : 1;
    ohm_parallel_for(nblocks, threads, face_powers_block, &job);
    for (int64_t b = 0; b < nblocks; ++b)
        for (int c = 0; c < channels; ++c) arrive[c] += block_arrive[b * channels + c];
    ohm_light_setup_free(&su);
    free(block_arrive);
    return OHM_OK;
}

int ohm_light_face_powers(double *const *enter, double *const *enter_mu, double *arrive, int channels,
                          const ohm_network *net, const ohm_light *light, double eta, const double *eta_v,
                          const ohm_occluder *occ, ohm_error *err)
{
    return face_powers(enter, enter_mu, arrive, channels, 0, net, light, eta, eta_v, occ, err);
}

/* Snell's law at the smooth normal of face f: the direction inside of light
 * travelling along unit `travel` from outside (index 1) into index eta; a
 * direction the staircase face would send back out is mirrored in the face's
 * plane, so every photon starts into its cell. */
static void refract_in(const ohm_network *net, int64_t f, const double travel[3], double eta, double out[3])
{
    double ns[3];
    ohm_surface_normal(net, f, ns);
    double cos_i = -(ns[0] * travel[0] + ns[1] * travel[1] + ns[2] * travel[2]);
    if (cos_i < 0) cos_i = 0;
    double k = 1.0 / eta, sin2_t = k * k * (1.0 - cos_i * cos_i);
    double cos_t = sqrt(fmax(0.0, 1.0 - sin2_t)), len2 = 0;
    for (int a = 0; a < 3; ++a) {
        out[a] = k * travel[a] + (k * cos_i - cos_t) * ns[a];
        len2 += out[a] * out[a];
    }
    double inv = 1.0 / sqrt(len2);
    for (int a = 0; a < 3; ++a) out[a] *= inv;
    int d = net->face_dir[f], axis = d / 2;
    double outward = out[axis] * ohm_face_offset[d][axis];
    if (outward >= 0) out[axis] = -ohm_face_offset[d][axis] * fmax(outward, 1e-6);
}

static int push_entry(ohm_light_entries *list, const ohm_light_entry *e, ohm_error *err)
{
    if (list->count == list->capacity) {
        size_t cap = list->capacity ? 2 * list->capacity : 256;
        ohm_light_entry *grown = realloc(list->entry, cap * sizeof *grown);
        if (!grown) return ohm_fail(err, OHM_ERR_NOMEM, "light: out of memory for %zu entry points", cap);
        list->entry = grown;
        list->capacity = cap;
    }
    list->entry[list->count++] = *e;
    return OHM_OK;
}

/* Where a pencil beam crosses entry face f (world mm). */
static void pencil_entry_point(const ohm_network *net, int64_t f, const ohm_light *light, double point[3])
{
    double c[3];
    face_centre(net, f, c);
    int axis = net->face_dir[f] / 2;
    double t = fabs(light->dir[axis]) > 0 ? (c[axis] - light->pos[axis]) / light->dir[axis] : 0.0;
    for (int a = 0; a < 3; ++a) point[a] = light->pos[a] + t * light->dir[a];
    point[axis] = c[axis];
}

int ohm_light_entries_add(ohm_light_entries *list, const ohm_network *net, const ohm_light *light, int channels,
                          double eta, const double *eta_v, const ohm_occluder *occ, ohm_error *err)
{
    const double area = net->grid->h * net->grid->h;
    ohm_light_entry e;
    memset(&e, 0, sizeof e);
    if (ohm_light_at_a_point(light)) {
        int64_t f;
        int rc = pencil_entry_face(net, light->pos, light->dir, &f, err);
        if (rc || f < 0) return rc;
        double ef = face_eta(net, f, eta, eta_v), T = face_transmittance(net, f, light->dir, ef, &e.mu);
        e.face = f;
        e.at_point = 1;
        pencil_entry_point(net, f, light, e.point);
        refract_in(net, f, light->dir, ef, e.dir);
        for (int c = 0; c < channels; ++c) {
            e.incident[c] = light->intensity[light->channels == 1 ? 0 : c];
            e.power[c] = T * e.incident[c];
        }
        return push_entry(list, &e, err);
    }
    ohm_light_setup su;
    int rc = ohm_light_setup_init(&su, light, 0, err);
    for (int64_t f = 0; f < net->nfaces && !rc; ++f) {
        double l_mean[3], travel[3], E[3], T_E[3], T_E_mu[3], ef = face_eta(net, f, eta, eta_v);
        if (!(face_irradiance(net, f, &su, occ, ef, E, T_E, T_E_mu, l_mean) > 0)) continue;
        /* one direction inside per face: the irradiance-weighted one's, and
         * its cosine; the power entering is Fresnel's ray by ray */
        unit_travel(l_mean, travel);
        refract_in(net, f, travel, ef, e.dir);
        face_transmittance(net, f, travel, ef, &e.mu);
        e.face = f;
        for (int c = 0; c < channels; ++c) {
            e.incident[c] = E[c] * area;
            e.power[c] = T_E[c] * area;
        }
        rc = push_entry(list, &e, err);
    }
    ohm_light_setup_free(&su);
    return rc;
}

void ohm_light_entries_free(ohm_light_entries *list)
{
    if (!list) return;
    free(list->entry);
    memset(list, 0, sizeof *list);
}

double ohm_source_deposit_faces(double *b, const ohm_network *net, const double *enter, const double *enter_mu,
                                const ohm_channel_medium *med, ohm_deposit deposit)
{
    double put = 0;
    for (int64_t f = 0; f < net->nfaces; ++f)
        if (enter[f] > 0)
            put += ohm_source_deposit_face(b, net, f, enter[f], enter_mu ? enter_mu[f] / enter[f] : 1.0, med, deposit);
    return put;
}

int ohm_source_add(double *b, ohm_source_power *pw, const ohm_network *net, const ohm_light *light, int c,
                   const ohm_channel_medium *med, ohm_deposit deposit, const ohm_occluder *occ, ohm_error *err)
{
    double I = light->intensity[light->channels == 1 ? 0 : c];
    double eta = med->resistance_mode ? 1.0 : med->eta;
    if (ohm_light_at_a_point(light)) {
        int64_t f;
        int rc = pencil_entry_face(net, light->pos, light->dir, &f, err);
        if (rc || f < 0) return rc;
        double mu, T = face_transmittance(net, f, light->dir, face_eta(net, f, eta, med->eta_v), &mu);
        pw->incident += I;
        pw->entered += T * I;
        pw->deposited += ohm_source_deposit_face(b, net, f, T * I, mu, med, deposit);
        return OHM_OK;
    }
    size_t nf = (size_t)(net->nfaces ? net->nfaces : 1);
    double *enter = calloc(nf, sizeof *enter), *enter_mu = calloc(nf, sizeof *enter_mu), arrive = 0;
    if (!enter || !enter_mu) {
        free(enter);
        free(enter_mu);
        return ohm_fail(err, OHM_ERR_NOMEM, "light: out of memory");
    }
    /* one channel: c of the light's irradiance */
    int rc = face_powers(&enter, &enter_mu, &arrive, 1, c < 3 ? c : 2, net, light, eta, med->eta_v, occ, err);
    if (!rc) {
        pw->incident += arrive;
        for (int64_t f = 0; f < net->nfaces; ++f) pw->entered += enter[f];
        pw->deposited += ohm_source_deposit_faces(b, net, enter, enter_mu, med, deposit);
    }
    free(enter_mu);
    free(enter);
    return rc;
}
