#include "solve.h"

#include "band.h"
#include "cg.h"
#include "memory.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* A piece whose sinks (ground + boundary conductance) are this small next to
 * its diagonal is nearly singular (e.g. sigma_a = 1e-9 with boundary=neumann):
 * x is a huge constant mode plus the variation that matters, and in double
 * precision sum(b - A x) = in - absorbed - out cannot fall below ~kappa eps,
 * however small the backward error (measured: 3.6e-9 at sink/diagonal ~ 1e-7,
 * 6e-10 at ~1e-6; tests/cli_extremes.sh).  For such pieces only, shift the constant
 * mode so the discrete conservation law holds exactly; the shift is reported
 * and the backward error is checked again afterwards. */
static const double NEAR_SINGULAR = 1e-5;

static int correct_constant_modes(ohm_solution *sol, double *X, const double *B, size_t ncols, const double *ga,
                                  const double *gb, const cholmod_sparse *A)
{
    const ohm_network *net = &sol->net;
    int64_t n = net->n, np = net->npieces;
    double *sink = calloc((size_t)np, sizeof *sink), *diag = calloc((size_t)np, sizeof *diag);
    double *defect = malloc((size_t)np * sizeof *defect), *vsink = malloc((size_t)n * sizeof *vsink);
    if (!sink || !diag || !defect || !vsink) {
        free(sink), free(diag), free(defect), free(vsink);
        return -1;
    }
    const int64_t *Ap = A->p;
    const double *Ax = A->x;
    for (int64_t v = 0; v < n; ++v) vsink[v] = ga[v];
    for (int64_t f = 0; f < net->nfaces; ++f) vsink[net->face_unknown[f]] += gb[f];
    for (int64_t v = 0; v < n; ++v) {
        sink[net->piece[v]] += vsink[v];
        diag[net->piece[v]] += Ax[Ap[v + 1] - 1]; /* the diagonal closes each column */
    }
    int any = 0;
    for (int64_t p = 0; p < np; ++p) any |= sink[p] < NEAR_SINGULAR * diag[p];
    for (size_t col = 0; any && col < ncols; ++col) {
        double *x = X + col * (size_t)n;
        const double *b = B + col * (size_t)n;
        for (int64_t p = 0; p < np; ++p) defect[p] = 0;
        for (int64_t v = 0; v < n; ++v) defect[net->piece[v]] += b[v] - vsink[v] * x[v];
        double xmax = 0;
        for (int64_t v = 0; v < n; ++v) xmax = fmax(xmax, fabs(x[v]));
        for (int64_t p = 0; p < np; ++p) {
            if (!(sink[p] < NEAR_SINGULAR * diag[p]) || !(sink[p] > 0)) continue;
            double c = defect[p] / sink[p];
            for (int64_t v = 0; v < n; ++v)
                if (net->piece[v] == p) x[v] += c;
            sol->mode_corrections++;
            if (xmax > 0 && fabs(c) / xmax > sol->mode_shift) sol->mode_shift = fabs(c) / xmax;
        }
    }
    free(sink), free(diag), free(defect), free(vsink);
    return any;
}

/* solver=auto.  The first two columns are always solved with CG and the
 * second, warm-started like every later one, is timed (t1 seconds, its1
 * iterations); the other `rest` columns then go to whichever is predicted
 * cheaper: CG at t1 each, or the direct path's analysis + one factorization per distinct
 * medium + a pair of triangular solves per column.  The direct costs are a
 * model of METIS nested dissection on a 3-D grid of n cells: ~3.5 n^(4/3)
 * entries in L (1.7 ns each per column solved), analysis 1.4e-6 n^1.155 s,
 * a factorization 1.02e-7 n^1.4 s (~n^2 flops at a rate that grows with the
 * supernodes) — power laws fitted to spot at dim 32/64/96/128 on a 2-core
 * machine (docs/accuracy.md has the measured times and where the choice
 * flips).  The probe keeps the choice honest where CG converges slowly. */
static int choose_cg_after_probe(ohm_solution *sol, double t1, int64_t its1, double rest, int factors, int64_t n)
{
    double nd = (double)n;
    double t_analyze = 1.4e-6 * pow(nd, 1.155);
    double t_factor = factors * 1.02e-7 * pow(nd, 1.4);
    double t_column = 1.7e-9 * 3.5 * pow(nd, 4.0 / 3.0);
    double t_direct = t_analyze + t_factor + rest * t_column;
    double t_cg = rest * t1;
    snprintf(sol->solver_reason, sizeof sol->solver_reason,
             "a warm CG column took %.3g s (%lld iterations); for the other %.0f: predicted %.3g s with CG, "
             "%.3g s direct (analysis %.3g s, %d factorization(s) %.3g s)",
             t1, (long long)its1, rest, t_cg, t_direct, t_analyze, factors, t_factor);
    return t_cg <= t_direct;
}

static int prepare_cg(ohm_solution *sol, ohm_cg *cg, cholmod_sparse *A, const ohm_solve_params *params, int64_t n,
                      size_t batch, ohm_error *err)
{
    double need = ohm_cg_bytes(n) + 2.0 * sizeof(double) * (double)n * (double)batch;
    double limit = ohm_memory_limit(params->max_memory);
    if (need > limit) {
        char nb[32], lb[32];
        return ohm_fail(err, OHM_ERR_NOMEM,
                        "solve: conjugate gradients on %lld cells need about %s, more than the %s %s; use a smaller "
                        "dim= or a larger voxel=",
                        (long long)n, ohm_format_bytes(need, nb, 32), ohm_format_bytes(limit, lb, 32),
                        params->max_memory > 0 ? "max_memory= allows" : "available");
    }
    ohm_cg_free(cg);
    int rc = ohm_cg_setup(cg, A, err);
    if (rc) return rc;
    sol->t_cg_setup += cg->t_setup;
    sol->nnz_A = (double)A->nzmax;
    return OHM_OK;
}

/* Analyse (once per grid), check the factor fits, factorize.  With
 * solver=auto a factor that does not fit sets *too_big instead of failing. */
static int prepare_direct(ohm_solution *sol, ohm_solver *solver, cholmod_factor **L, cholmod_sparse *A,
                          const ohm_solve_params *params, const ohm_network *net, size_t batch, int *too_big,
                          const ohm_log *log, ohm_error *err)
{
    int64_t n = net->n;
    *too_big = 0;
    if (!solver->symbolic) {
        ohm_log_info(log, "solve: %lld unknowns, %lld boundary faces, %lld matrix entries; analysing (%s)",
                     (long long)n, (long long)net->nfaces, (long long)net->nnz, params->ordering);
        int rc = ohm_solver_analyze(solver, A, params->ordering, err);
        if (rc) return rc;
        sol->t_analyze += solver->t_analyze;
        sol->analyses++;
        sol->nnz_A = solver->nnz_A;
        sol->nnz_L = solver->nnz_L;
        sol->flops = solver->flops;
        snprintf(sol->ordering, sizeof sol->ordering, "%s", solver->ordering);
    }
    /* nnz(L) is known now, before factorizing: the factor stores at least its
     * values (supernodal: xsize, with amalgamation zeros) and their row
     * indices, and the symbolic copy is kept beside it */
    const cholmod_factor *F = solver->symbolic;
    double values = F->is_super ? fmax((double)F->xsize, solver->nnz_L) : solver->nnz_L;
    double index = F->is_super ? (double)F->ssize : solver->nnz_L;
    double need = 8.0 * values + 2.0 * 8.0 * index + 2.0 * sizeof(double) * (double)n * (double)batch;
    double limit = ohm_memory_limit(params->max_memory);
    if (need > limit) {
        char nb[32], lb[32];
        if (params->solver == OHM_SOLVER_AUTO) {
            snprintf(sol->solver_reason, sizeof sol->solver_reason,
                     "the factor would need about %s, more than the %s %s", ohm_format_bytes(need, nb, 32),
                     ohm_format_bytes(limit, lb, 32), params->max_memory > 0 ? "max_memory= allows" : "available");
            *too_big = 1;
            return OHM_OK;
        }
        return ohm_fail(err, OHM_ERR_NOMEM,
                        "solve: the Cholesky factor of %lld cells needs about %s (nnz(L) = %.3g), more than the %s "
                        "%s; use solver=cg (memory O(cells)), a smaller dim= or a larger voxel=",
                        (long long)n, ohm_format_bytes(need, nb, 32), solver->nnz_L, ohm_format_bytes(limit, lb, 32),
                        params->max_memory > 0 ? "max_memory= allows" : "available");
    }
    /* the next channel refactorizes into the same L: same pattern, and its
     * memory is already mapped */
    double tf = 0;
    int rc = ohm_solver_factorize(L, solver, A, &tf, err);
    if (rc) return rc;
    sol->t_factor += tf;
    sol->factors++;
    ohm_log_info(log, "solve: factorized (nnz(L) %.3g, %.3g flops) in %.2f s", sol->nnz_L, sol->flops, tf);
    return OHM_OK;
}

/* The depth band (band.h): the depth band_k / sigma_tr, with sigma_tr the
 * smallest over channels and cells (the most penetrating light decides), and
 * per-cell media compacted from interior-cell order to the band's unknowns
 * into compact[] (the same array for the same input, so channels that share
 * a medium still share a factor).  *out is params with those arrays. */
static int setup_band(ohm_solution *sol, ohm_solve_params *out, double *compact[2 * OHM_MAX_CHANNELS],
                      const ohm_voxel_grid *grid, const ohm_material *mat, const ohm_solve_params *params,
                      const ohm_log *log, ohm_error *err)
{
    *out = *params;
    if (!(params->band_k > 0)) return OHM_OK;
    if (mat->kind == OHM_MATERIAL_RESISTANCE || params->resistance_v)
        return ohm_fail(err, OHM_ERR_USAGE,
                        "solve: depth_band= needs optical coefficients (its depth is k / sigma_tr); with "
                        "resistance= leave depth_band=0");
    size_t ncells = (size_t)grid->dims[0] * (size_t)grid->dims[1] * (size_t)grid->dims[2];
    int64_t ni = (int64_t)grid->interior_cells;
    double sigma_tr = INFINITY;
    for (int c = 0; c < OHM_MAX_CHANNELS; ++c) {
        int per_cell = params->sigma_a[c] || params->sigma_s[c];
        if (c >= mat->channels && !per_cell) continue;
        int mc = mat->channels == 1 || c >= mat->channels ? 0 : c;
        for (int64_t v = 0; v < (per_cell ? ni : 1); ++v) {
            double sa = params->sigma_a[c] ? params->sigma_a[c][v] : mat->sigma_a[mc];
            double ss = params->sigma_s[c] ? params->sigma_s[c][v] : mat->sigma_s[mc];
            sigma_tr = fmin(sigma_tr, sqrt(3.0 * sa * (sa + ss)));
        }
    }
    if (!(sigma_tr > 0) || !isfinite(sigma_tr)) {
        ohm_log_warn(log, "solve: depth_band=%g ignored: with sigma_a = 0 light reaches every depth", params->band_k);
        return OHM_OK;
    }
    double depth = params->band_k / sigma_tr;
    int64_t kept = 0;
    int rc = ohm_depth_band(&sol->band_active, &kept, grid, depth, err);
    if (rc) return rc;
    if (kept == ni) { /* nothing is deeper: no band */
        free(sol->band_active);
        sol->band_active = NULL;
        ohm_log_info(log, "solve: depth_band=%g: every cell lies within %.3g mm of the surface; nothing to drop",
                     params->band_k, depth);
        return OHM_OK;
    }
    sol->band_depth = depth;
    sol->band_dropped = ni - kept;
    ohm_log_info(log, "solve: depth band %.3g mm (depth_band=%g / sigma_tr %.4g /mm): %lld of %lld cells, %.1f%% dropped",
                 depth, params->band_k, sigma_tr, (long long)kept, (long long)ni, 100.0 * (double)(ni - kept) / ni);
    /* compact the per-cell arrays: interior order -> band order */
    const double *const *src[2] = {params->sigma_a, params->sigma_s};
    const double **dst[2] = {out->sigma_a, out->sigma_s};
    int used = 0;
    for (int q = 0; q < 2; ++q)
        for (int c = 0; c < OHM_MAX_CHANNELS; ++c) {
            const double *in = src[q][c];
            if (!in) continue;
            const double *same = NULL; /* compacted already? */
            for (int q2 = 0; q2 <= q && !same; ++q2)
                for (int c2 = 0; c2 < OHM_MAX_CHANNELS && !same; ++c2)
                    if ((q2 < q || c2 < c) && src[q2][c2] == in) same = dst[q2][c2];
            if (same) {
                dst[q][c] = same;
                continue;
            }
            double *o = malloc((size_t)kept * sizeof *o);
            if (!o) return ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory for the band's material");
            compact[used++] = o;
            int64_t ii = 0, u = 0;
            for (size_t cell = 0; cell < ncells; ++cell) {
                if (!grid->inside[cell]) continue;
                if (sol->band_active[cell]) o[u++] = in[ii];
                ++ii;
            }
            dst[q][c] = o;
        }
    return OHM_OK;
}

void ohm_solution_free(ohm_solution *sol)
{
    if (!sol) return;
    for (int c = 0; c < OHM_MAX_CHANNELS; ++c) {
        free(sol->fluence[c]);
        free(sol->exitance[c]);
        free(sol->face_exitance[c]);
        free(sol->medium_sa[c]);
        free(sol->medium_ss[c]);
    }
    ohm_network_free(&sol->net);
    free(sol->band_active);
    memset(sol, 0, sizeof *sol);
}

double ohm_solution_conservation_error(const ohm_solution *sol)
{
    if (!(sol->power_in > 0)) return 0.0;
    return fabs(sol->power_in - sol->power_absorbed - sol->power_out) / sol->power_in;
}

static void medium_for(ohm_channel_medium *med, const ohm_material *mat, const ohm_solve_params *p, int c)
{
    memset(med, 0, sizeof *med);
    int mc = mat->channels == 1 ? 0 : c;
    med->resistance_mode = mat->kind == OHM_MATERIAL_RESISTANCE;
    med->resistance = mat->resistance;
    med->ground = mat->ground;
    med->sigma_a0 = mat->sigma_a[mc];
    med->sigma_s0 = mat->sigma_s[mc];
    med->sigma_a = p->sigma_a[c];
    med->sigma_s = p->sigma_s[c];
    med->resistance_v = p->resistance_v;
    med->ground_v = p->ground_v;
    med->eta = mat->eta;
}

/* Channels c and e share a factor when their coefficients are identical. */
static int same_medium(const ohm_material *mat, const ohm_solve_params *p, int c, int e)
{
    if (p->sigma_a[c] != p->sigma_a[e] || p->sigma_s[c] != p->sigma_s[e]) return 0;
    if (mat->kind == OHM_MATERIAL_RESISTANCE || mat->channels == 1) return 1;
    return mat->sigma_a[c] == mat->sigma_a[e] && mat->sigma_s[c] == mat->sigma_s[e];
}

int ohm_solve(ohm_solution *sol, const ohm_voxel_grid *grid, const ohm_material *mat, const ohm_light *lights,
              size_t nlights, const ohm_solve_params *params, const ohm_log *log, ohm_error *err)
{
    memset(sol, 0, sizeof *sol);
    if (nlights == 0 && !params->custom_source)
        return ohm_fail(err, OHM_ERR_INVALID, "solve: no lights: add -light before -solve");
    int channels = mat->channels, frames = 1;
    for (size_t l = 0; l < nlights && lights; ++l) {
        if (lights[l].channels > channels) channels = lights[l].channels;
        if (lights[l].frame > frames) frames = lights[l].frame;
    }
    sol->channels = channels;
    sol->frames = frames;

    double t0 = ohm_now();
    /* per-cell media compacted to the band's unknowns (when there is one) */
    double *compact[2 * OHM_MAX_CHANNELS] = {NULL};
    ohm_solve_params band_params;
    int rc = setup_band(sol, &band_params, compact, grid, mat, params, log, err);
    if (rc) {
        for (int q = 0; q < 2 * OHM_MAX_CHANNELS; ++q) free(compact[q]);
        ohm_solution_free(sol);
        return rc;
    }
    params = &band_params;
    rc = ohm_network_build_band(&sol->net, grid, params->mirror_low, sol->band_active, err);
    if (rc) {
        for (int q = 0; q < 2 * OHM_MAX_CHANNELS; ++q) free(compact[q]);
        ohm_solution_free(sol);
        return rc;
    }
    const ohm_network *net = &sol->net;
    int64_t n = net->n;
    sol->n = n;
    sol->t_assemble += ohm_now() - t0;

    /* Frames per batch: B and X together within the memory cap. */
    double cap = params->max_rhs_bytes > 0 ? params->max_rhs_bytes : (double)(1u << 30);
    size_t batch = (size_t)(cap / (2.0 * sizeof(double) * (double)n));
    if (batch < 1) batch = 1;
    if (batch > (size_t)frames) batch = (size_t)frames;

    ohm_occluder *occ = NULL;
    t0 = ohm_now();
    rc = ohm_occluder_create(&occ, params->shadows, grid, params->mesh, params->orientation, err);
    sol->t_shadow_setup = ohm_now() - t0;
    if (rc) {
        ohm_solution_free(sol);
        return rc;
    }
    ohm_solver solver;
    rc = ohm_solver_start(&solver, err);
    if (rc) {
        ohm_occluder_free(occ);
        ohm_solution_free(sol);
        return rc;
    }
    size_t nf = (size_t)(net->nfaces ? net->nfaces : 1);
    double *B = malloc((size_t)n * batch * sizeof *B);
    double *X = malloc((size_t)n * batch * sizeof *X);
    double *ga = malloc((size_t)n * sizeof *ga);
    double *gb = malloc(nf * sizeof *gb);
    int *face_count = calloc((size_t)n, sizeof *face_count);
    size_t *col_of = malloc(batch * sizeof *col_of);       /* batch column -> distinct column */
    double *prev_b = malloc((size_t)n * sizeof *prev_b);   /* the last frame's right-hand side */
    cholmod_sparse *A = NULL;
    cholmod_factor *L = NULL;
    ohm_cg cg;
    memset(&cg, 0, sizeof cg);
    /* per-face powers per frame, shared by the channels (below); declared
     * before the first goto so `done:` may free them */
    double *fp_enter[OHM_MAX_CHANNELS] = {NULL}, *fp_arrive[OHM_MAX_CHANNELS] = {NULL};
    if (!B || !X || !ga || !gb || !face_count || !col_of || !prev_b) {
        rc = ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory for %zu right-hand sides of %lld unknowns", batch,
                      (long long)n);
        goto done;
    }
    for (int c = 0; c < channels; ++c) {
        sol->fluence[c] = calloc((size_t)n * (size_t)frames, sizeof(double));
        sol->exitance[c] = calloc((size_t)n * (size_t)frames, sizeof(double));
        sol->face_exitance[c] = calloc(nf * (size_t)frames, sizeof(double));
        if (!sol->fluence[c] || !sol->exitance[c] || !sol->face_exitance[c]) {
            rc = ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory for the solution (%d frames)", frames);
            goto done;
        }
    }
    for (int64_t f = 0; f < net->nfaces; ++f) face_count[net->face_unknown[f]]++;
    for (int c = 0; c < channels; ++c) {
        const double *src[2] = {params->sigma_a[c], params->sigma_s[c]};
        double **dst[2] = {&sol->medium_sa[c], &sol->medium_ss[c]};
        for (int q = 0; q < 2; ++q) {
            if (!src[q]) continue;
            *dst[q] = malloc((size_t)n * sizeof(double));
            if (!*dst[q]) {
                rc = ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory");
                goto done;
            }
            memcpy(*dst[q], src[q], (size_t)n * sizeof(double));
        }
    }

    /* Shadow rays and Fresnel do not depend on the channel: trace every
     * frame's lights once, keep the per-face powers for all channels (when
     * they fit in the batch budget), deposit them per channel below. */
    int cached = 0;
    const double face_cache_cap = cap > 256.0 * 1048576.0 ? cap : 256.0 * 1048576.0;
    if (!params->custom_source &&
        2.0 * sizeof(double) * (double)nf * (double)frames * (double)channels <= face_cache_cap) {
        cached = 1;
        for (int c = 0; c < channels && cached; ++c) {
            fp_enter[c] = calloc(nf * (size_t)frames, sizeof(double));
            fp_arrive[c] = calloc(nf * (size_t)frames, sizeof(double));
            if (!fp_enter[c] || !fp_arrive[c]) cached = 0; /* fall back to tracing per channel */
        }
        t0 = ohm_now();
        double eta = mat->kind == OHM_MATERIAL_RESISTANCE ? 1.0 : mat->eta;
        for (int fr = 0; fr < frames && cached && !rc; ++fr) {
            double *en[OHM_MAX_CHANNELS], *ar[OHM_MAX_CHANNELS];
            for (int c = 0; c < channels; ++c) {
                en[c] = fp_enter[c] + (size_t)fr * nf;
                ar[c] = fp_arrive[c] + (size_t)fr * nf;
            }
            for (size_t l = 0; l < nlights && !rc; ++l) {
                if (lights[l].type == OHM_LIGHT_PENCIL) continue;
                if (lights[l].frame != 0 && lights[l].frame != fr + 1) continue;
                rc = ohm_light_face_powers(en, ar, channels, net, &lights[l], eta, occ, err);
            }
        }
        sol->t_source += ohm_now() - t0;
        if (rc) goto done;
    }

    /* Group channels by medium: each distinct medium is assembled and
     * factorized once, and all its channels' frames are solved with it.
     * Grey materials with grey lights have one channel. */
    int cls[OHM_MAX_CHANNELS];
    for (int c = 0; c < channels; ++c) {
        cls[c] = c;
        for (int e = 0; e < c; ++e)
            if (same_medium(mat, params, c, e)) {
                cls[c] = cls[e];
                break;
            }
    }
    /* auto starts with CG on the first column and decides after it */
    int use_cg = params->solver != OHM_SOLVER_DIRECT;
    int decided = params->solver != OHM_SOLVER_AUTO, probed = 0;
    snprintf(sol->solver_reason, sizeof sol->solver_reason, "asked for");
    int nclasses = 0;
    for (int c = 0; c < channels; ++c) nclasses += cls[c] == c;
    int solved[OHM_MAX_CHANNELS] = {0};
    const double cg_tol = params->cg_tol > 0 ? params->cg_tol : 1e-10;
    /* test hook (tests/cli_solver_choice.sh): cap CG's iterations so that the
     * non-convergence paths (the error; auto falling back to the factor) run */
    int64_t cg_max_iter = 20000;
    const char *iter_cap = getenv("OHM_TEST_CG_MAX_ITER");
    if (iter_cap && atoll(iter_cap) > 0) cg_max_iter = atoll(iter_cap);
    for (int k = 0; k < channels && !rc; ++k) {
        if (cls[k] != k) continue; /* not the first channel of its class */
        ohm_channel_medium med;
        medium_for(&med, mat, params, k);
        t0 = ohm_now();
        cholmod_l_free_sparse(&A, &solver.cc);
        rc = ohm_network_assemble(&A, ga, gb, net, &med, params->boundary, &solver.cc, err);
        sol->t_assemble += ohm_now() - t0;
        if (rc) break;
        if (use_cg) {
            rc = prepare_cg(sol, &cg, A, params, n, batch, err);
        } else {
            int too_big = 0;
            rc = prepare_direct(sol, &solver, &L, A, params, net, batch, &too_big, log, err);
            if (!rc && too_big) { /* auto: the factor does not fit, CG does */
                use_cg = 1;
                decided = 1;
                ohm_log_info(log, "solve: solver=auto uses cg: %s", sol->solver_reason);
                rc = prepare_cg(sol, &cg, A, params, n, batch, err);
            }
        }
        if (rc) break;

        for (int c = k; c < channels && !rc; ++c) {
            if (cls[c] != k) continue;
            for (size_t f0 = 0; f0 < (size_t)frames && !rc; f0 += batch) {
                size_t nb = (size_t)frames - f0 < batch ? (size_t)frames - f0 : batch;
                /* sources: column j is frame f0 + j + 1 */
                t0 = ohm_now();
                memset(B, 0, (size_t)n * nb * sizeof *B);
                if (params->custom_source) {
                    if (params->custom_source(params->custom_user, B, nb, net, c))
                        rc = ohm_fail(err, OHM_ERR_INVALID, "solve: the scene's source failed");
                } else {
                    for (size_t j = 0; j < nb && cached; ++j) {
                        const double *en = fp_enter[c] + (f0 + j) * nf, *ar = fp_arrive[c] + (f0 + j) * nf;
                        ohm_source_deposit_faces(B + j * (size_t)n, net, en, &med, params->deposit);
                        for (int64_t f = 0; f < net->nfaces; ++f) sol->power_incident += ar[f];
                    }
                    for (size_t l = 0; l < nlights && !rc; ++l) {
                        int lf = lights[l].frame;
                        if (cached && lights[l].type != OHM_LIGHT_PENCIL) continue; /* traced above */
                        for (size_t j = 0; j < nb && !rc; ++j) {
                            if (lf != 0 && lf != (int)(f0 + j + 1)) continue;
                            ohm_source_power pw = {0, 0};
                            rc = ohm_source_add(B + j * (size_t)n, &pw, net, &lights[l], c, &med, params->deposit,
                                                occ, err);
                            sol->power_incident += pw.incident;
                        }
                    }
                }
                sol->t_source += ohm_now() - t0;
                if (rc) break;
                /* frames whose light did not change (the same right-hand
                 * side as the frame before) are not solved again: the batch
                 * is compacted to its distinct columns, solved, expanded */
                size_t nu = 0;
                for (size_t j = 0; j < nb; ++j) {
                    const double *bj = B + j * (size_t)n;
                    /* the previous frame's right-hand side: in this batch, or
                     * the last one of the previous batch */
                    const double *bp = j > 0 && col_of[j - 1] != SIZE_MAX ? B + col_of[j - 1] * (size_t)n
                                       : f0 > 0                           ? prev_b
                                                                          : NULL;
                    int dup = bp && !memcmp(bj, bp, (size_t)n * sizeof *B);
                    if (dup) {
                        col_of[j] = bp == prev_b ? SIZE_MAX : col_of[j - 1];
                        sol->solves_skipped++;
                        continue;
                    }
                    if (nu != j) memcpy(B + nu * (size_t)n, bj, (size_t)n * sizeof *B);
                    col_of[j] = nu++;
                }
                t0 = ohm_now();
                double berr = 0;
                int refined = 0;
                if (use_cg) {
                    /* warm start: the previous frame of this channel, else this
                     * frame of a channel solved before (same light, another
                     * colour or medium), else zero */
                    int e = -1;
                    for (int q = 0; q < channels; ++q)
                        if (solved[q]) e = q;
                    for (size_t j = 0; j < nu && !rc; ++j) {
                        double *x = X + j * (size_t)n;
                        size_t fr = f0 + j;
                        if (j > 0) memcpy(x, X + (j - 1) * (size_t)n, (size_t)n * sizeof *x);
                        else if (fr > 0) memcpy(x, sol->fluence[c] + (fr - 1) * (size_t)n, (size_t)n * sizeof *x);
                        else if (e >= 0) memcpy(x, sol->fluence[e] + fr * (size_t)n, (size_t)n * sizeof *x);
                        else memset(x, 0, (size_t)n * sizeof *x);
                        int64_t its = 0;
                        double relres = 0;
                        double tc = ohm_now();
                        rc = ohm_cg_solve(&cg, x, B + j * (size_t)n, cg_tol, cg_max_iter, &its, &relres, err);
                        sol->cg_iterations += its;
                        if (relres > sol->cg_relres) sol->cg_relres = relres;
                        if (rc && !decided && rc == OHM_ERR_NUMERIC) {
                            /* solver=auto: CG cannot solve this one: the factor can */
                            decided = 1;
                            use_cg = 0;
                            snprintf(sol->solver_reason, sizeof sol->solver_reason, "cg failed: %.170s", err->msg);
                            ohm_error_clear(err);
                            ohm_log_info(log, "solve: solver=auto switches to direct: %s", sol->solver_reason);
                            int too_big = 0;
                            double tp = ohm_now();
                            rc = prepare_direct(sol, &solver, &L, A, params, net, batch, &too_big, log, err);
                            t0 += ohm_now() - tp;
                            if (!rc && too_big)
                                rc = ohm_fail(err, OHM_ERR_NUMERIC,
                                              "solve: conjugate gradients did not converge and the factor does not "
                                              "fit (%s)",
                                              sol->solver_reason);
                            if (!rc) {
                                double e2 = 0;
                                rc = ohm_solver_solve(X, &solver, L, A, B, nu, &e2, &refined, err);
                            }
                            break;
                        }
                        if (rc || decided) continue;
                        /* solver=auto: the first two columns are solved with
                         * CG; the second (warm-started, like every later one)
                         * is timed, and the rest go where the prediction is
                         * cheaper */
                        double total = (double)frames * (double)channels;
                        if (++probed < 2 && total > 2) continue;
                        decided = 1;
                        double rest = total - (double)probed;
                        if (!choose_cg_after_probe(sol, ohm_now() - tc, its, rest, nclasses, n)) {
                            use_cg = 0;
                            ohm_log_info(log, "solve: solver=auto switches to direct: %s", sol->solver_reason);
                            int too_big = 0;
                            double tp = ohm_now();
                            rc = prepare_direct(sol, &solver, &L, A, params, net, batch, &too_big, log, err);
                            t0 += ohm_now() - tp; /* booked as t_analyze / t_factor, not t_solve */
                            if (!rc && too_big) {
                                use_cg = 1; /* the factor does not fit after all: stay */
                                ohm_log_info(log, "solve: solver=auto stays with cg: %s", sol->solver_reason);
                            } else if (!rc && j + 1 < nu) {
                                double e2 = 0;
                                rc = ohm_solver_solve(x + (size_t)n, &solver, L, A, B + (j + 1) * (size_t)n,
                                                      nu - j - 1, &e2, &refined, err);
                                break;
                            }
                        } else {
                            ohm_log_info(log, "solve: solver=auto stays with cg: %s", sol->solver_reason);
                        }
                    }
                    if (!rc && nu > 0) rc = ohm_solver_backward_error(&berr, &solver, A, B, X, nu, err);
                } else if (nu > 0) {
                    rc = ohm_solver_solve(X, &solver, L, A, B, nu, &berr, &refined, err);
                }
                if (!rc && nu > 0) {
                    int corrected = correct_constant_modes(sol, X, B, nu, ga, gb, A);
                    if (corrected < 0) rc = ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory");
                    else if (corrected > 0) {
                        rc = ohm_solver_backward_error(&berr, &solver, A, B, X, nu, err);
                        if (!rc && !use_cg && !(berr <= 1e-10))
                            rc = ohm_fail(err, OHM_ERR_NUMERIC,
                                          "solve: backward error %.3g after the constant-mode correction", berr);
                    }
                }
                sol->t_solve += ohm_now() - t0;
                if (rc) break;
                if (berr > sol->residual) sol->residual = berr;
                sol->refined += refined;
                sol->solves += (int64_t)nu;
                /* expand: column j is distinct column col_of[j] (<= j), or the
                 * previous batch's last frame */
                for (size_t j = nb; j-- > 0;) {
                    double *xj = X + j * (size_t)n, *bj = B + j * (size_t)n;
                    if (col_of[j] == SIZE_MAX) {
                        memcpy(xj, sol->fluence[c] + (f0 - 1) * (size_t)n, (size_t)n * sizeof *X);
                        memcpy(bj, prev_b, (size_t)n * sizeof *B);
                    } else if (col_of[j] != j) {
                        memcpy(xj, X + col_of[j] * (size_t)n, (size_t)n * sizeof *X);
                        memcpy(bj, B + col_of[j] * (size_t)n, (size_t)n * sizeof *B);
                    }
                }
                memcpy(prev_b, B + (nb - 1) * (size_t)n, (size_t)n * sizeof *B);

                /* book the power per frame */
                const double area = grid->h * grid->h;
                double in = 0, absorbed = 0, out = 0;
                for (size_t j = 0; j < nb; ++j) {
                    size_t fr = f0 + j;
                    const double *x = X + j * (size_t)n, *b = B + j * (size_t)n;
                    double *phi = sol->fluence[c] + fr * (size_t)n, *ex = sol->exitance[c] + fr * (size_t)n;
                    double *fx = sol->face_exitance[c] + fr * nf;
                    for (int64_t v = 0; v < n; ++v) {
                        phi[v] = x[v];
                        in += b[v];
                        absorbed += ga[v] * x[v];
                    }
                    for (int64_t f = 0; f < net->nfaces; ++f) {
                        int64_t v = net->face_unknown[f];
                        double p = gb[f] * x[v];
                        out += p;
                        fx[f] = p / area;
                        ex[v] += p / (area * face_count[v]);
                    }
                }
                sol->power_in += in;
                sol->power_absorbed += absorbed;
                sol->power_out += out;
                sol->power_in_channel[c] += in;
                sol->power_out_channel[c] += out;
            }
            solved[c] = 1;
        }
    }
    snprintf(sol->solver, sizeof sol->solver, "%s", use_cg ? "cg" : "direct");

done:
    for (int q = 0; q < 2 * OHM_MAX_CHANNELS; ++q) free(compact[q]);
    for (int c = 0; c < OHM_MAX_CHANNELS; ++c) {
        free(fp_enter[c]);
        free(fp_arrive[c]);
    }
    ohm_occluder_free(occ);
    ohm_cg_free(&cg);
    free(face_count);
    free(col_of);
    free(prev_b);
    ohm_factor_free(&L, &solver);
    cholmod_l_free_sparse(&A, &solver.cc);
    ohm_solver_finish(&solver);
    free(B);
    free(X);
    free(ga);
    free(gb);
    if (rc) ohm_solution_free(sol);
    return rc;
}
