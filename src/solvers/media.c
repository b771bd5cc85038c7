/* solvers/media.c — the media of a solve (solve.h): each channel's medium,
 * the depth band's compaction of per-cell arrays (band.h), the arrays and
 * curves the solution keeps for its output grids (taken, compacted or
 * copied: the solution owns them), which channels share one medium (and so
 * one factor), and the per-cell optics' ranges. */
#include "solvers/solver_impl.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "grid/band.h"

void ohm_medium_for(ohm_channel_medium *med, const ohm_material *mat, const ohm_solve_params *p, int c)
{
    memset(med, 0, sizeof *med);
    int mc = mat->channels == 1 ? 0 : c;
    med->resistance_mode = mat->kind == OHM_MATERIAL_RESISTANCE;
    med->resistance = mat->resistance;
    med->ground = mat->ground;
    med->sigma_a0 = mat->sigma_a[mc];
    med->sigma_s0 = mat->sigma_s[mc];
    med->sigma_a = p->media.sigma_a[c];
    med->sigma_s = p->media.sigma_s[c];
    med->density = p->media.density;
    med->sigma_a_curve = p->media.density_sa[c];
    med->sigma_s_curve = p->media.density_ss[c];
    med->resistance_v = p->media.resistance_v;
    med->ground_v = p->media.ground_v;
    med->eta = mat->eta;
    med->eta_v = med->resistance_mode ? NULL : p->media.eta_v;
    med->g = mat->g;
    med->g_v = med->resistance_mode ? NULL : p->media.g_v;
    med->fresnel = p->op.fresnel;
}

/* A per-interior-cell array of `size`-byte entries (the media's ohm_coeff,
 * the index's and anisotropy's doubles) compacted to the band's kept
 * unknowns (malloc'd; NULL: out of memory). */
static void *compact_to_band(const ohm_solution *sol, const ohm_voxel_grid *grid, const void *in, size_t size,
                             int64_t kept)
{
    char *o = malloc((size_t)(kept ? kept : 1) * size);
    if (!o) return NULL;
    const char *from = in;
    size_t ncells = (size_t)grid->dims[0] * (size_t)grid->dims[1] * (size_t)grid->dims[2];
    int64_t ii = 0, u = 0;
    for (size_t cell = 0; cell < ncells; ++cell) {
        if (!grid->inside[cell]) continue;
        if (sol->band_active[cell]) memcpy(o + size * (size_t)u++, from + size * (size_t)ii, size);
        ++ii;
    }
    return o;
}

/* The depth band (band.h): the depth band_k / sigma_tr, with sigma_tr the
 * smallest over channels and cells (the most penetrating light decides), and
 * per-cell media compacted from interior-cell order to the band's unknowns
 * into compact[] (the same array for the same input, so channels that share
 * a medium still share a factor).  *out is params with those arrays. */
int ohm_setup_band(ohm_solution *sol, ohm_solve_params *out, ohm_coeff *compact[2 * OHM_MAX_CHANNELS],
                   const ohm_voxel_grid *grid, const ohm_material *mat, const ohm_solve_params *params,
                   const ohm_log *log, ohm_error *err)
{
    *out = *params;
    if (!(params->op.band_k > 0)) return OHM_OK;
    if (mat->kind == OHM_MATERIAL_RESISTANCE || params->media.resistance_v)
        return ohm_fail(err, OHM_ERR_USAGE,
                        "solve: depth_band= needs optical coefficients (its depth is k / sigma_tr); with "
                        "resistance= leave depth_band=0");
    int64_t ni = (int64_t)grid->interior_cells;
    double sigma_tr = INFINITY;
    for (int c = 0; c < OHM_MAX_CHANNELS; ++c) {
        ohm_channel_medium med;
        ohm_medium_for(&med, mat, params, c);
        int per_cell = ohm_medium_varies(&med);
        if (c >= mat->channels && !per_cell) continue;
        int mc = mat->channels == 1 || c >= mat->channels ? 0 : c;
        med.sigma_a0 = mat->sigma_a[mc];
        med.sigma_s0 = mat->sigma_s[mc];
        for (int64_t v = 0; v < (per_cell ? ni : 1); ++v) {
            double sa = ohm_medium_sigma_a(&med, v), ss = ohm_medium_sigma_s(&med, v);
            sigma_tr = fmin(sigma_tr, sqrt(3.0 * sa * (sa + ss)));
        }
    }
    if (!(sigma_tr > 0) || !isfinite(sigma_tr)) {
        ohm_log_warn(log, "solve: depth_band=%g ignored: with sigma_a = 0 light reaches every depth",
                     params->op.band_k);
        return OHM_OK;
    }
    double depth = params->op.band_k / sigma_tr;
    int64_t kept = 0;
    int rc = ohm_depth_band(&sol->band_active, &kept, grid, depth, err);
    if (rc) return rc;
    if (kept == ni) { /* nothing is deeper: no band */
        free(sol->band_active);
        sol->band_active = NULL;
        ohm_log_info(log, "solve: depth_band=%g: every cell lies within %.3g mm of the surface; nothing to drop",
                     params->op.band_k, depth);
        return OHM_OK;
    }
    sol->band_depth = depth;
    sol->band_dropped = ni - kept;
    ohm_log_info(log, "solve: depth band %.3g mm (depth_band=%g / sigma_tr %.4g /mm): %lld of %lld cells, %.1f%% dropped",
                 depth, params->op.band_k, sigma_tr, (long long)kept, (long long)ni, 100.0 * (double)(ni - kept) / ni);
    /* compact the per-cell arrays: interior order -> band order */
    const ohm_coeff *const *src[2] = {params->media.sigma_a, params->media.sigma_s};
    const ohm_coeff **dst[2] = {out->media.sigma_a, out->media.sigma_s};
    int used = 0;
    for (int q = 0; q < 2; ++q)
        for (int c = 0; c < OHM_MAX_CHANNELS; ++c) {
            const ohm_coeff *in = src[q][c];
            if (!in) continue;
            const ohm_coeff *same = NULL; /* compacted already? */
            for (int q2 = 0; q2 <= q && !same; ++q2)
                for (int c2 = 0; c2 < OHM_MAX_CHANNELS && !same; ++c2)
                    if ((q2 < q || c2 < c) && src[q2][c2] == in) same = dst[q2][c2];
            if (same) {
                dst[q][c] = same;
                continue;
            }
            ohm_coeff *o = compact_to_band(sol, grid, in, sizeof *in, kept);
            if (!o) return ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory for the band's material");
            compact[used++] = o;
            dst[q][c] = o;
        }
    if (params->media.density) {
        float *o = compact_to_band(sol, grid, params->media.density, sizeof *params->media.density, kept);
        if (!o) return ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory for the band's density");
        free(sol->medium_density); /* a given one: no longer needed */
        out->media.density = sol->medium_density = o;
    }
    const size_t real = sizeof(double); /* the index and the anisotropy */
    if (params->media.eta_v &&
        !(out->media.eta_v = sol->band_eta = compact_to_band(sol, grid, params->media.eta_v, real, kept)))
        return ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory for the band's index");
    if (params->media.g_v &&
        !(out->media.g_v = sol->band_g = compact_to_band(sol, grid, params->media.g_v, real, kept)))
        return ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory for the band's anisotropy");
    return OHM_OK;
}

/* Add array a to the solution's owned media once (the same array may serve
 * several channels). */
static void own_medium(ohm_solution *sol, ohm_coeff *a)
{
    int q = 0;
    while (q < 2 * OHM_MAX_CHANNELS && sol->medium_owned[q] && sol->medium_owned[q] != a) ++q;
    if (q < 2 * OHM_MAX_CHANNELS) sol->medium_owned[q] = a; /* 2 per channel at most: always fits */
}

/* give_media: the caller's arrays are the solution's from the start, so that
 * every failure path frees them with the solution. */
void ohm_take_media(ohm_solution *sol, const ohm_media_params *p)
{
    if (!p->give_media) return;
    for (int c = 0; c < OHM_MAX_CHANNELS; ++c) {
        /* ours now (solve.h): the const is the params' promise not to write them */
        if (p->sigma_a[c]) own_medium(sol, (ohm_coeff *)(uintptr_t)p->sigma_a[c]);
        if (p->sigma_s[c]) own_medium(sol, (ohm_coeff *)(uintptr_t)p->sigma_s[c]);
    }
    /* paper mode's resistances: held for the solver's life, not output */
    if (p->resistance_v) own_medium(sol, (ohm_coeff *)(uintptr_t)p->resistance_v);
    if (p->ground_v) own_medium(sol, (ohm_coeff *)(uintptr_t)p->ground_v);
    sol->medium_density = (float *)(uintptr_t)p->density;
}

/* The curves of a scan's media (solve.h) copied into the solution, which may
 * outlive the caller's transfer function; p's curves then point at the
 * copies. */
static int keep_curves(ohm_solution *sol, ohm_media_params *p, ohm_error *err)
{
    ohm_curve *given[2] = {p->density_sa, p->density_ss}, *kept[2] = {sol->medium_sa_curve, sol->medium_ss_curve};
    size_t total = 0;
    for (int q = 0; q < 2; ++q)
        for (int c = 0; c < OHM_MAX_CHANNELS; ++c) total += 2 * given[q][c].n;
    if (!p->density || total == 0) return OHM_OK;
    double *store = sol->curve_store = malloc(total * sizeof *store);
    if (!store) return ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory for the transfer function");
    /* knots shared by given curves stay shared (ohm_medium_coefficients
     * searches them once for both coefficients) */
    const double *from[2 * OHM_MAX_CHANNELS];
    double *to[2 * OHM_MAX_CHANNELS];
    size_t nfrom = 0;
    for (int q = 0; q < 2; ++q)
        for (int c = 0; c < OHM_MAX_CHANNELS; ++c) {
            ohm_curve *k = &given[q][c];
            if (!k->n) continue;
            double *x = NULL, *y = store;
            store += k->n;
            for (size_t j = 0; j < nfrom && !x; ++j)
                if (from[j] == k->x) x = to[j];
            if (!x) {
                x = store;
                store += k->n;
                memcpy(x, k->x, k->n * sizeof *x);
                from[nfrom] = k->x;
                to[nfrom++] = x;
            }
            for (size_t i = 0; i < k->n; ++i) y[i] = k->y[i * k->stride];
            ohm_curve copy = {k->n, x, y, 1};
            *k = kept[q][c] = copy;
        }
    return OHM_OK;
}

/* The medium the solution keeps for its output grids (solve.h), from p (the
 * params' media after the band): with a band, p's arrays are compact[]
 * (moved into the solution; given originals are freed now, no longer
 * needed); given arrays are kept as they are; others are copied once each. */
int ohm_keep_media(ohm_solution *sol, ohm_media_params *p, ohm_coeff *compact[2 * OHM_MAX_CHANNELS],
                   ohm_error *err)
{
    if (sol->band_active) {
        for (int q = 0; q < 2 * OHM_MAX_CHANNELS; ++q) {
            free(sol->medium_owned[q]);
            sol->medium_owned[q] = compact[q];
            compact[q] = NULL;
        }
    }
    const ohm_coeff *const *src[2] = {p->sigma_a, p->sigma_s};
    const ohm_coeff **dst[2] = {sol->medium_sa, sol->medium_ss};
    for (int q = 0; q < 2; ++q)
        for (int c = 0; c < OHM_MAX_CHANNELS; ++c) {
            const ohm_coeff *in = src[q][c];
            if (!in) continue;
            int owned = 0;
            for (int k = 0; k < 2 * OHM_MAX_CHANNELS && !owned; ++k) owned = sol->medium_owned[k] == in;
            const ohm_coeff *same = owned ? in : NULL; /* copied already? */
            for (int q2 = 0; q2 <= q && !same; ++q2)
                for (int c2 = 0; c2 < OHM_MAX_CHANNELS && !same; ++c2)
                    if ((q2 < q || c2 < c) && src[q2][c2] == in) same = dst[q2][c2];
            if (!same) {
                ohm_coeff *copy = malloc((size_t)sol->net.n * sizeof *copy);
                if (!copy) return ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory for the medium");
                memcpy(copy, in, (size_t)sol->net.n * sizeof *copy);
                own_medium(sol, copy);
                same = copy;
            }
            dst[q][c] = same;
        }
    if (p->density && !sol->medium_density) {
        float *copy = malloc((size_t)(sol->net.n ? sol->net.n : 1) * sizeof *copy);
        if (!copy) return ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory for the density");
        memcpy(copy, p->density, (size_t)sol->net.n * sizeof *copy);
        p->density = sol->medium_density = copy;
    }
    return keep_curves(sol, p, err);
}

/* Whether curves a and b are one function (knot for knot). */
static int same_curve(const ohm_curve *a, const ohm_curve *b)
{
    if (a->n != b->n) return 0;
    for (size_t i = 0; i < a->n; ++i)
        if (a->x[i] != b->x[i] || a->y[i * a->stride] != b->y[i * b->stride]) return 0;
    return 1;
}

/* Channels c and e share a factor when their coefficients are identical. */
int ohm_same_medium(const ohm_material *mat, const ohm_media_params *p, int c, int e)
{
    if (p->sigma_a[c] != p->sigma_a[e] || p->sigma_s[c] != p->sigma_s[e]) return 0;
    if (!same_curve(&p->density_sa[c], &p->density_sa[e]) || !same_curve(&p->density_ss[c], &p->density_ss[e]))
        return 0;
    if (mat->kind == OHM_MATERIAL_RESISTANCE || mat->channels == 1) return 1;
    return mat->sigma_a[c] == mat->sigma_a[e] && mat->sigma_s[c] == mat->sigma_s[e];
}

/* The per-cell index and anisotropy (interior cells) within their ranges:
 * the Fresnel table covers indices in [1, 3]; g = 1 has no sigma_s. */
int ohm_check_cell_optics(const ohm_voxel_grid *grid, const ohm_media_params *p, ohm_error *err)
{
    size_t ni = grid->interior_cells;
    for (size_t u = 0; u < ni && p->eta_v; ++u)
        if (!(p->eta_v[u] >= 1.0 && p->eta_v[u] <= 3.0))
            return ohm_fail(err, OHM_ERR_INVALID, "solve: interior cell %zu has refractive index %g, expected 1 .. 3",
                            u, p->eta_v[u]);
    for (size_t u = 0; u < ni && p->g_v; ++u)
        if (!(p->g_v[u] > -1.0 && p->g_v[u] < 1.0))
            return ohm_fail(err, OHM_ERR_INVALID, "solve: interior cell %zu has anisotropy g = %g, expected -1 < g < 1",
                            u, p->g_v[u]);
    return OHM_OK;
}
