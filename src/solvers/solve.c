/* solvers/solve.c — the solver's driver (solve.h; the files it calls:
 * solver_impl.h): create and set up (the depth band, the network, the media
 * kept, the occluder, the backend), each distinct channel material's matrix
 * and backend set up in its slot, each channel's frames solved batch by
 * batch, the media one after another or on several threads at once. */
#include "solvers/solve.h"

#include "solvers/backend.h"
#include "solvers/solver_impl.h"
#include "solvers/transport.h"
#include "base/parallel.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void slot_release(ohm_solver *s, medium_slot *m)
{
    if (m->state) s->backend->destroy(m->state);
    cholmod_l_free_sparse(&m->A, &s->cc);
    ohm_stencil_free(&m->stencil);
    free(m->ga);
    free(m->gb);
    memset(m, 0, sizeof *m);
}

void ohm_solver_free(ohm_solver *s)
{
    if (!s) return;
    for (int k = 0; k < OHM_MAX_CHANNELS; ++k) slot_release(s, &s->slot[k]);
    for (int k = 0; k < OHM_MAX_CHANNELS; ++k) free(s->clear_owned[k]);
    if (s->cc_started) cholmod_l_finish(&s->cc);
    ohm_occluder_free(s->occ);
    ohm_clear_exchange_free(&s->exchange);
    free(s->clear_mask);
    free(s->petsc_options);
    ohm_solution_free(&s->sol);
    free(s);
}

/* The topology and the media of a solve (solve.h): the depth band, the
 * network, the media kept for the outputs, the occluder. */
static int solver_prepare(ohm_solver *s, const ohm_solve_params *params, ohm_error *err)
{
    ohm_solution *sol = &s->sol;
    int rc = ohm_check_cell_optics(s->grid, &params->media, err);
    if (rc) return rc;
    double t0 = ohm_now();
    /* per-cell media compacted to the band's unknowns (when there is one) */
    ohm_coeff *compact[2 * OHM_MAX_CHANNELS] = {NULL};
    rc = ohm_setup_band(sol, &s->params, compact, s->grid, &s->mat, params, s->log, err);
    snprintf(s->ordering, sizeof s->ordering, "%s", params->num.ordering ? params->num.ordering : "metis");
    s->params.num.ordering = s->ordering;
    if (params->num.petsc_options &&
        !(s->params.num.petsc_options = s->petsc_options = strdup(params->num.petsc_options)))
        rc = ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory");
    if (!rc) rc = ohm_network_build_band(&sol->net, s->grid, s->params.op.mirrors, sol->band_active, err);
    if (!rc) {
        sol->n = sol->net.n;
        sol->t_network = ohm_now() - t0;
        s->layout = ohm_grid_layout_of(&sol->net);
        rc = ohm_keep_media(sol, &s->params.media, compact, err);
    }
    if (!rc && params->op.clear_cells)
        rc = ohm_solver_couple_clear(s, params->op.clear_cells, params->op.clear_reach, err);
    for (int q = 0; q < 2 * OHM_MAX_CHANNELS; ++q) free(compact[q]);
    /* (the stages below take seconds only at 10^7 cells and more: a
     * cancellation is taken between them) */
    if (!rc && ohm_log_cancelled(s->log)) rc = ohm_fail_cancelled(err, "solve");
    if (rc) return rc;
    t0 = ohm_now();
    const ohm_source_params *src = &s->params.src;
    rc = ohm_occluder_create(&s->occ, src->shadows, s->grid, src->mesh, src->orientation, err);
    sol->t_shadow_setup = ohm_now() - t0;
    if (rc) return rc;
    if (!cholmod_l_start(&s->cc)) return ohm_fail(err, OHM_ERR_INTERNAL, "CHOLMOD failed to start");
    s->cc_started = 1;
    s->cc.print = 0;
    s->cc.error_handler = NULL;
    /* a kind that transports photons has a transport; every other, a backend */
    ohm_solver_kind kind = s->params.num.solver;
    s->transport = ohm_solver_kind_transport(kind);
    s->backend = ohm_solver_kind_backend(kind);
    if (!s->backend && !s->transport)
        return ohm_fail(err, OHM_ERR_USAGE, "solve: unknown solver '%s'", ohm_solver_kind_name(kind));
    snprintf(s->rep.reason, sizeof s->rep.reason, "asked for");
    return ohm_solver_find_clear(s, err);
}

/* The solver's log is the caller's as it is now (callbacks, verbosity and
 * cancellation), with the solver's progress span: the backends hold
 * s->log from their set-up, so a relight reports where the caller now
 * listens.  Called as each of the solver's calls begins. */
static void follow_caller_log(ohm_solver *s)
{
    if (s->caller_log) s->log_own = *s->caller_log;
    else memset(&s->log_own, 0, sizeof s->log_own);
    s->log_own.span = &s->span;
    s->span = (ohm_progress_span){0, 0};
    s->log = &s->log_own;
}

int ohm_solver_create(ohm_solver **out, const ohm_voxel_grid *grid, const ohm_material *mat,
                      const ohm_solve_params *params, int keep, const ohm_log *log, ohm_error *err)
{
    *out = NULL;
    ohm_solver *s = calloc(1, sizeof *s);
    if (!s) {
        ohm_solution taken; /* give_media: freed whether it succeeds or fails */
        memset(&taken, 0, sizeof taken);
        ohm_take_media(&taken, &params->media);
        ohm_solution_free(&taken);
        return ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory");
    }
    ohm_take_media(&s->sol, &params->media);
    s->mat = *mat;
    s->grid = grid;
    s->caller_log = log;
    follow_caller_log(s);
    s->keep = keep;
    s->held = -1;
    int rc = solver_prepare(s, params, err);
    if (rc) {
        ohm_solver_free(s);
        return rc;
    }
    *out = s;
    return OHM_OK;
}

/* The network's stencil for medium med, with the clear regions' coupling
 * where there is one (its links beyond the grid: clear_exchange.h); ga and
 * gb as ohm_network_stencil's (ga needed with a coupling). */
static int coupled_stencil(ohm_stencil *st, double *ga, double *gb, const ohm_network *net,
                           const ohm_channel_medium *med, ohm_boundary boundary, const ohm_clear_exchange *ce,
                           ohm_error *err)
{
    int rc = ohm_network_stencil(st, ga, gb, net, med, boundary, err);
    if (!rc && ce && ce->nclear > 0) rc = ohm_clear_exchange_stencil(st, ga, gb, ce, med, boundary, err);
    return rc;
}

/* ohm_operator.make_stencil: the slot's stencil, made once.  The
 * assembly filled ga and gb already; the coupling's stencil needs them
 * again (it rewrites them as its matrix did), the plain one not. */
static int slot_make_stencil(void *maker, const ohm_stencil **out, ohm_error *err)
{
    medium_slot *m = maker;
    double *ga = m->exchange ? m->ga : NULL, *gb = m->exchange ? m->gb : NULL;
    int rc = m->stencil.gx ? OHM_OK
                           : coupled_stencil(&m->stencil, ga, gb, m->net, &m->med, m->boundary, m->exchange, err);
    *out = rc ? NULL : &m->stencil;
    return rc;
}

/* Medium k's slot assembled and set up: kept from an earlier solve, or (keep
 * = 0) the resources of the slot that held them, refilled (same pattern: the
 * direct backend keeps its symbolic analysis), or new. */
static int slot_acquire(ohm_solver *s, int k, const ohm_backend_config *bcfg, ohm_error *err)
{
    medium_slot *m = &s->slot[k];
    if (m->ready) return OHM_OK;
    if (!s->keep && s->held >= 0 && s->held != k) {
        *m = s->slot[s->held];
        m->ready = 0;
        memset(&s->slot[s->held], 0, sizeof *m);
    }
    s->held = k;
    const ohm_network *net = &s->sol.net;
    size_t nf = (size_t)(net->nfaces ? net->nfaces : 1);
    /* ga only where closure faces add to the ground (ground_of) */
    int need_ga = net->nclosure > 0 || s->exchange.nclear > 0;
    if (!m->ga && need_ga) m->ga = malloc((size_t)(net->n ? net->n : 1) * sizeof *m->ga);
    if (!m->gb) m->gb = malloc(nf * sizeof *m->gb);
    if ((!m->ga && need_ga) || !m->gb)
        return ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory for the network's conductances");
    if (ohm_log_cancelled(s->log)) return ohm_fail_cancelled(err, "solve");
    int rc = m->state ? OHM_OK : s->backend->create(&m->state, bcfg, err);
    if (rc) return rc;
    if (s->backend->release) s->backend->release(m->state); /* the last channel's set-up, before this assembly */
    ohm_channel_medium med;
    ohm_diffusion_medium(&med, s, k);
    double t0 = ohm_now();
    /* the form the backend reads; a refilled A keeps its pattern (the
     * backend's setup sees the new values), a refilled stencil its offsets */
    if (s->backend->caps & OHM_BACKEND_STENCIL) {
        rc = coupled_stencil(&m->stencil, m->ga, m->gb, net, &med, s->params.op.boundary, &s->exchange, err);
        m->op = (ohm_operator){.n = net->n, .stencil = &m->stencil};
    } else {
        /* the coupled matrix's pattern is not the network's: assembled
         * afresh, then coupled (the same pattern for every medium) */
        if (s->exchange.nclear > 0) cholmod_l_free_sparse(&m->A, &s->cc);
        rc = m->A ? ohm_network_assemble_into(m->A, m->ga, m->gb, net, &med, s->params.op.boundary, err)
                  : ohm_network_assemble(&m->A, m->ga, m->gb, net, &med, s->params.op.boundary, &s->cc, err);
        if (!rc && s->exchange.nclear > 0)
            rc = ohm_clear_exchange_apply(&m->A, m->ga, m->gb, &s->exchange, &med, s->params.op.boundary, &s->cc, err);
        ohm_stencil_free(&m->stencil); /* a refill: a stencil made before is of the medium before */
        m->net = net;
        m->med = med;
        m->boundary = s->params.op.boundary;
        m->exchange = s->exchange.nclear > 0 ? &s->exchange : NULL; /* the stencil coupled as A is */
        m->op = (ohm_operator){.n = net->n, .A = m->A, .make_stencil = slot_make_stencil, .maker = m};
    }
    s->sol.t_assemble += ohm_now() - t0;
    if (!rc && ohm_log_cancelled(s->log)) rc = ohm_fail_cancelled(err, "solve");
    if (!rc) rc = s->backend->setup(m->state, &m->op, &s->rep, err);
    m->ready = !rc;
    return rc;
}

/* The shape of a solve for these lights: its channels (the material's, or
 * more when a light has more) and frames (columns). */
static void lights_shape(const ohm_solver *s, const ohm_light *lights, size_t nlights, int *channels, int *frames)
{
    *channels = s->mat.channels;
    *frames = 1;
    for (size_t l = 0; l < nlights && lights; ++l) {
        if (lights[l].channels > *channels) *channels = lights[l].channels;
        if (lights[l].frame > *frames) *frames = lights[l].frame;
    }
}

/* A diffusion solve's plan, before any light is traced: the channels grouped
 * by medium (each distinct medium set up once: one factorization, or one
 * preconditioner, for all its channels), the batch of frames, and the
 * backend's configuration. */
static int diffusion_plan(diffusion_run *run, ohm_backend_config *bcfg, ohm_solver *s, int channels, int frames,
                          ohm_error *err)
{
    const ohm_solve_params *params = &s->params;
    memset(run, 0, sizeof *run);
    run->s = s;
    run->channels = channels;
    run->hybrid = params->mc.handoff > 0 && !params->src.custom_source;
    int rc = run->hybrid ? ohm_hybrid_applies(s, err) : OHM_OK;
    if (rc) return rc;
    run->batch = ohm_batch_frames(s, (size_t)frames, run->hybrid);
    for (int c = 0; c < channels; ++c) {
        run->cls[c] = c;
        for (int e = 0; e < c; ++e)
            if (ohm_same_medium(&s->mat, &params->media, c, e)) {
                run->cls[c] = run->cls[e];
                break;
            }
        run->nclasses += run->cls[c] == c;
    }
    *bcfg = (ohm_backend_config){.ordering = params->num.ordering,
                                 .layout = &s->layout,
                                 .tol = params->num.cg_tol,
                                 .petsc_options = params->num.petsc_options,
                                 .max_memory = params->num.max_memory,
                                 .batch = run->batch,
                                 .columns = (double)frames * (double)channels,
                                 .materials = run->nclasses,
                                 .from_scan = params->num.from_scan,
                                 .device = params->num.device,
                                 .log = s->log};
#ifdef OHM_TEST_HOOKS
    /* test hook (tests/cli_solver_choice.sh; builds for the suite only): cap
     * every iterative backend's iterations so that the non-convergence paths
     * (the error; auto falling back to the factor) run */
    const char *iter_cap = getenv("OHM_TEST_MAX_ITER");
    if (iter_cap && atoll(iter_cap) > 0) bcfg->max_iter = atoll(iter_cap);
#endif
    return OHM_OK;
}

/* The set-up phase (solve.h, ohm_solver_setup): each medium's matrix
 * assembled and its backend set up, in medium order — every one (all), or
 * only the first (keep = 0 holds one at a time: the others are set up in
 * turn as the solve reaches them). */
static int setup_media(const diffusion_run *run, const ohm_backend_config *bcfg, int all, ohm_error *err)
{
    for (int k = 0; k < run->channels; ++k)
        if (run->cls[k] == k) {
            int rc = slot_acquire(run->s, k, bcfg, err);
            if (rc || !all) return rc;
        }
    return OHM_OK;
}

int ohm_solver_setup(ohm_solver *s, const ohm_light *lights, size_t nlights, ohm_error *err)
{
    follow_caller_log(s);
    if (s->transport) return OHM_OK; /* nothing to set up */
    int channels, frames;
    lights_shape(s, lights, nlights, &channels, &frames);
    diffusion_run run;
    ohm_backend_config bcfg;
    int rc = diffusion_plan(&run, &bcfg, s, channels, frames, err);
    if (!rc) rc = setup_media(&run, &bcfg, s->keep, err);
    ohm_solution_report_backend(&s->sol, &s->rep);
    return rc;
}

/* Channel `rank` of the `count` solved in turn: its share of the solve's
 * one progress bar (ohm_progress_span). */
typedef struct bar_share {
    int rank, count;
} bar_share;

/* The bar's span for the batch of frames [f0, f0 + nb) of the channel. */
static void share_bar(ohm_solver *s, const bar_share *bar, size_t f0, size_t nb, size_t frames)
{
    double w = 1.0 / bar->count;
    s->span.lo = (bar->rank + (double)f0 / (double)frames) * w;
    s->span.hi = (bar->rank + (double)(f0 + nb) / (double)frames) * w;
}

/* Every frame of channel c solved with medium k's setup, batch by batch:
 * sources, distinct columns, the backend, exact conservation, booking, and
 * what is added after the solve (the hybrid's part, the unscattered beam).
 * Writes channel c's arrays of the solution, *t and *rep only. */
static int solve_channel(const diffusion_run *run, batch_work *w, channel_tally *t, ohm_backend_report *rep, int c,
                         int k, int warm_from, const bar_share *bar, ohm_error *err)
{
    ohm_solver *s = run->s;
    ohm_solution *sol = &s->sol;
    const ohm_solve_params *params = &s->params;
    const ohm_light *lights = run->lights;
    size_t nlights = run->nlights;
    medium_slot *m = &s->slot[k];
    /* diffusion's operator (clear.c), and the medium light enters and
     * photons fly through: the sources' and the traced parts' */
    ohm_channel_medium med, traced;
    ohm_diffusion_medium(&med, s, k);
    ohm_medium_for(&traced, &s->mat, params, k);
    size_t n = (size_t)sol->n, frames = (size_t)sol->frames;
    int rc = OHM_OK;
    for (size_t f0 = 0; f0 < frames && !rc; f0 += run->batch) {
        if (ohm_log_cancelled(s->log)) return ohm_fail_cancelled(err, "solve");
        size_t nb = frames - f0 < run->batch ? frames - f0 : run->batch;
        if (bar) share_bar(s, bar, f0, nb, frames);
        double t0 = ohm_now();
        const face_powers *fp = &run->fp;
        rc = run->hybrid ? ohm_hybrid_sources(sol, t, w->B, &w->hy, f0, nb, c, &traced, &s->mat, lights, nlights,
                                              params, s->occ, err)
                         : ohm_fill_sources(sol, t, w->B, f0, nb, c, &traced, lights, nlights, &params->src,
                                            fp->cached ? fp->enter : NULL, fp->enter_mu, fp->cached ? fp->arrive : NULL,
                                            s->occ, err);
        if (!rc && s->exchange.nclear > 0) ohm_clear_exchange_move_sources(&s->exchange, w->B, nb);
        t->t_source += ohm_now() - t0;
        if (rc) break;
        double *X = sol->fluence[c] + f0 * n;
        /* (the hybrid and fluence=total add to each frame after the solve: a
         * frame is not taken whole from the batch before, whose fluence
         * already holds that part) */
        size_t nu = ohm_distinct_columns(t, w->B, w->col_of, nb,
                                         f0 > 0 && !run->hybrid && !params->src.total_fluence ? w->prev_b : NULL, n);
        /* (without warm starts X is only written, and starts zeroed; a
         * relight's starts as the last solve's fluence of this frame) */
        if ((s->backend->caps & OHM_BACKEND_WARM_START) && !run->from_last) ohm_warm_start(X, sol, f0, c, warm_from, n);
        ohm_scale_unknowns(X, run->from_last ? nu : 1, n, &med, 0); /* the columns holding a guess */
        t0 = ohm_now();
        double t_setups = rep->t_analyze + rep->t_factor + rep->t_precond;
        double berr = 0;
        if (nu > 0 && !run->from_last) rc = s->backend->solve(m->state, &m->op, w->B, X, nu, &berr, rep, err);
        /* a relight's columns each start from their own last solution: one
         * at a time (a backend starts a later column from the one before) */
        for (size_t j = 0; j < nu && run->from_last && !rc; ++j) {
            double e = 0;
            rc = s->backend->solve(m->state, &m->op, w->B + j * n, X + j * n, 1, &e, rep, err);
            if (!(e <= berr)) berr = e;
        }
        if (!rc && nu > 0) rc = ohm_conserve_exactly(t, &sol->net, X, w->B, nu, m->ga, m->gb, &m->op, &med, &berr, err);
        ohm_scale_unknowns(X, nu, n, &med, 1);
        /* a backend that set up inside solve (auto switching) books that as
         * analysis / factor / preconditioner, not as solve */
        t->t_solve += ohm_now() - t0 - (rep->t_analyze + rep->t_factor + rep->t_precond - t_setups);
        if (rc) break;
        if (berr > t->residual) t->residual = berr;
        t->solves += (int64_t)nu;
        ohm_expand_columns(X, w->B, sol, w->col_of, nb, f0, c, w->prev_b, n);
        if (s->exchange.nclear > 0) ohm_clear_exchange_fill(&s->exchange, X, nb); /* no sink there: the books unchanged */
        ohm_book_power(sol, t, X, w->B, m->ga, m->gb, &med, f0, nb, c);
        if (run->hybrid) ohm_hybrid_add(sol, t, X, &w->hy, f0, nb, c);
        else if (params->src.total_fluence && lights) /* after the booking: absorption is G_a phi of the diffuse part */
            rc = ohm_add_unscattered(sol, X, f0, nb, c, &traced, &s->mat, lights, nlights, s->occ, err);
    }
    return rc;
}

/* One medium after another: each assembled and set up (slot_acquire) and
 * all its channels' frames solved with it before the next (keep=0 holds one
 * setup at a time). */
static int solve_media_in_turn(const diffusion_run *run, channel_tally *tally, const ohm_backend_config *bcfg,
                               ohm_error *err)
{
    ohm_solver *s = run->s;
    batch_work w;
    int rc = ohm_batch_work_alloc(&w, &s->sol, run->batch, run->hybrid, err);
    int solved[OHM_MAX_CHANNELS] = {0};
    int rank = 0; /* channels solved so far: the progress bar's share */
    for (int k = 0; k < run->channels && !rc; ++k) {
        if (run->cls[k] != k) continue; /* not the first channel of its class */
        rc = slot_acquire(s, k, bcfg, err);
        for (int c = k; c < run->channels && !rc; ++c) {
            if (run->cls[c] != k) continue;
            /* warm start for iterative backends: this frame of a channel
             * solved before (same light, another colour or medium) */
            int warm_from = -1;
            for (int q = 0; q < run->channels; ++q)
                if (solved[q]) warm_from = q;
            bar_share bar = {rank++, run->channels};
            rc = solve_channel(run, &w, &tally[c], &s->rep, c, k, warm_from, &bar, err);
            solved[c] = 1;
        }
    }
    ohm_batch_work_free(&w);
    s->span = (ohm_progress_span){0, 0};
    return rc;
}

/* One medium's channels solved by one thread of solve_media_together. */
typedef struct medium_job {
    const diffusion_run *run;
    channel_tally *tally;       /* the run's, by channel                      */
    int k;                      /* the medium's first channel                 */
    ohm_backend_report rep;     /* what this medium's solves report           */
    ohm_error err;
    int rc;
} medium_job;

static void solve_medium_job(void *arg, int64_t i)
{
    medium_job *job = (medium_job *)arg + i;
    const diffusion_run *run = job->run;
    batch_work w;
    job->rc = ohm_batch_work_alloc(&w, &run->s->sol, run->batch, run->hybrid, &job->err);
    for (int c = job->k; c < run->channels && !job->rc; ++c)
        if (run->cls[c] == job->k) job->rc = solve_channel(run, &w, &job->tally[c], &job->rep, c, job->k, -1, NULL, &job->err);
    ohm_batch_work_free(&w);
}

/* Below this many unknowns a medium's solve takes too little time to pay
 * for a thread; the right-hand sides a second thread may allocate. */
enum { MEDIA_TOGETHER_MIN_UNKNOWNS = 4096 };
static const double MEDIA_TOGETHER_MAX_RHS_BYTES = 64.0 * 1048576.0;

/* Whether the media may be solved on several threads at once: each must
 * hold its own setup (keep=1, what a relight reuses), the backend must
 * allow it (backend.h, OHM_BACKEND_CONCURRENT_SOLVES: the factor, whose
 * solves touch only their own factor and work space), no solve may call
 * back into the caller (custom_source) or start threads of its own (the
 * hybrid's Monte Carlo), and the machine must have a core to spare. */
static int media_together(const diffusion_run *run)
{
    const ohm_solver *s = run->s;
    int nclasses = run->nclasses;
    double extra_rhs = (double)(nclasses - 1) * (double)run->batch * (double)s->sol.n * sizeof(double);
    return nclasses > 1 && s->keep && (s->backend->caps & OHM_BACKEND_CONCURRENT_SOLVES) && !run->hybrid &&
           !s->params.src.custom_source && s->sol.n >= MEDIA_TOGETHER_MIN_UNKNOWNS &&
           extra_rhs <= MEDIA_TOGETHER_MAX_RHS_BYTES && ohm_usable_cores() > 1;
}

/* Every medium set up first (one after another: the factorizations use the
 * BLAS's own threads), then the media's channels solved on the cores at
 * once, one medium per thread at a time: the paper's relight, three colours
 * for the wall time of about two (docs/bench-notes.md).  Only while each solve
 * runs on one core (the backend's concurrent_max_bytes: direct's
 * substitution over a small factor, direct.h); a larger
 * factor's solve already runs on every core through the BLAS and is bound
 * by memory, and two at once took twice as long (Spot, 297 250 cells,
 * relight 370 -> 764 ms): those are solved in turn. */
static int solve_media_together(const diffusion_run *run, channel_tally *tally, const ohm_backend_config *bcfg,
                                ohm_error *err)
{
    ohm_solver *s = run->s;
    int nclasses = run->nclasses;
    medium_job job[OHM_MAX_CHANNELS];
    int njobs = 0;
    int rc = setup_media(run, bcfg, 1, err);
    if (rc) return rc;
    for (int k = 0; k < run->channels; ++k)
        if (run->cls[k] == k) job[njobs++] = (medium_job){.run = run, .tally = tally, .k = k};
    if (s->rep.bytes > s->backend->concurrent_max_bytes) return solve_media_in_turn(run, tally, bcfg, err);
    double t0 = ohm_now();
    int threads = ohm_usable_cores() < nclasses ? ohm_usable_cores() : nclasses;
    s->sol.solve_threads = ohm_parallel_for(njobs, threads, solve_medium_job, job);
    double wall = ohm_now() - t0, busy = 0;
    for (int c = 0; c < run->channels; ++c) busy += tally[c].t_source + tally[c].t_solve;
    /* the statistics' times add up to the wall clock: the threads' seconds
     * scaled to it, source and solve in their measured proportion */
    for (int c = 0; c < run->channels && busy > wall; ++c) {
        tally[c].t_source *= wall / busy;
        tally[c].t_solve *= wall / busy;
    }
    for (int j = 0; j < njobs; ++j) {
        s->rep.refined += job[j].rep.refined; /* all the direct backend's solve reports */
        if (job[j].rc && !rc) {
            rc = job[j].rc;
            if (err) *err = job[j].err;
        }
    }
    return rc;
}

/* One warning when an iterative backend accepted columns short of cg_tol:
 * its backward-error test (cg.c, mg_cycle.c, amg.c) keeps an answer whose
 * scaled backward error is small though ||b - A x|| / ||b|| is not, at the
 * iteration cap or a residual floor — a good answer for a well-conditioned
 * A, a less accurate one than asked where A is ill-conditioned (huge
 * diffusion coefficients in clear regions), so the user is told. */
static void warn_stopped_short(const ohm_backend_report *rep, const ohm_log *log)
{
    if (rep->stalled <= 0) return;
    ohm_log_warn(log,
                 "solve: %s stopped short of cg_tol=%.3g in %lld column(s): relative residual %.3g after %lld "
                 "iterations in all; the result is kept (its scaled backward error is small); for the accuracy asked "
                 "use solver=direct, or accept what was reached with a looser cg_tol=",
                 rep->solver, rep->tol, (long long)rep->stalled, rep->relres, (long long)rep->iterations);
}

/* The diffusion solve of every channel, medium by medium (diffusion_plan),
 * every frame of its channels solved with its set-up.  Grey materials with
 * grey lights have one channel. */
static int solve_diffusion(ohm_solver *s, const ohm_light *lights, size_t nlights, int from_last, ohm_error *err)
{
    ohm_solution *sol = &s->sol;
    const ohm_solve_params *params = &s->params;
    diffusion_run run;
    ohm_backend_config bcfg;
    int rc = diffusion_plan(&run, &bcfg, s, sol->channels, sol->frames, err);
    if (rc) return rc;
    run.lights = lights;
    run.nlights = nlights;
    run.from_last = from_last;
    double cap = params->num.max_rhs_bytes > 0 ? params->num.max_rhs_bytes : (double)(1u << 30);
    if (!params->src.custom_source && !run.hybrid) rc = ohm_face_powers_trace(&run.fp, s, lights, nlights, cap, err);
    channel_tally tally[OHM_MAX_CHANNELS];
    memset(tally, 0, sizeof tally);
    sol->solve_threads = 1;
    if (!rc)
        rc = media_together(&run) ? solve_media_together(&run, tally, &bcfg, err)
                                  : solve_media_in_turn(&run, tally, &bcfg, err);
    for (int c = 0; c < run.channels; ++c) ohm_tally_add(sol, &tally[c], c);
    ohm_solution_report_backend(sol, &s->rep);
    if (!rc) warn_stopped_short(&s->rep, s->log);
    ohm_face_powers_free(&run.fp);
    return rc;
}

/* Whether a relight starts each channel from the last solve's fluence: a
 * kept solver whose backend takes a starting guess, the same channels and
 * frames, and a last fluence that is diffusion's alone (the hybrid's and
 * fluence=total's add parts that are no solution of A). */
static int relight_from_last(const ohm_solver *s, int channels, int frames)
{
    const ohm_solve_params *p = &s->params;
    return s->keep && s->solved && s->backend && (s->backend->caps & OHM_BACKEND_WARM_START) &&
           channels == s->sol.channels && frames == s->sol.frames && !(p->mc.handoff > 0) && !p->src.total_fluence;
}

int ohm_solver_solve(ohm_solver *s, const ohm_light *lights, size_t nlights, ohm_error *err)
{
    follow_caller_log(s);
    ohm_solution *sol = &s->sol;
    int channels, frames;
    lights_shape(s, lights, nlights, &channels, &frames);
    int from_last = relight_from_last(s, channels, frames);
    s->solved = 0;
    ohm_solution_reset(sol, &s->rep, from_last);
    if (nlights == 0 && !s->params.src.custom_source)
        return ohm_fail(err, OHM_ERR_INVALID, "solve: no lights: add -light before -solve");
    sol->channels = channels;
    sol->frames = frames;
    int rc = ohm_solution_alloc(sol, err);
    if (rc) return rc;
    if (s->transport) return s->transport->solve(s, lights, nlights, err);
    rc = solve_diffusion(s, lights, nlights, from_last, err);
    if (!s->keep) /* a one-shot solve: the last medium's setup is not needed again */
        for (int k = 0; k < OHM_MAX_CHANNELS; ++k) slot_release(s, &s->slot[k]);
    s->solved = !rc;
    return rc;
}

const ohm_solution *ohm_solver_solution(const ohm_solver *s)
{
    return &s->sol;
}

int ohm_solver_light_reaches(const ohm_solver *s, const ohm_light *light, int *reaches, ohm_error *err)
{
    ohm_light_entries in = {0}; /* the lit faces (or the pencil's one), traced as for transport */
    int rc = ohm_light_entries_add(&in, &s->sol.net, light, 1, 1.0, NULL, s->occ, err);
    *reaches = in.count > 0;
    ohm_light_entries_free(&in);
    return rc;
}

int ohm_solver_settle_auto_hybrid(ohm_solver *s, const ohm_light *lights, size_t nlights, ohm_error *err)
{
    int reaching = 0;
    for (size_t l = 0; l < nlights && !reaching; ++l) {
        if (!ohm_light_at_a_point(&lights[l])) continue;
        int rc = ohm_solver_light_reaches(s, &lights[l], &reaching, err);
        if (rc) return rc;
    }
    if (!reaching) s->params.mc.handoff = 0;
    return OHM_OK;
}

const ohm_solve_params *ohm_solver_params(const ohm_solver *s)
{
    return &s->params;
}

int ohm_solve(ohm_solution *sol, const ohm_voxel_grid *grid, const ohm_material *mat, const ohm_light *lights,
              size_t nlights, const ohm_solve_params *params, const ohm_log *log, ohm_error *err)
{
    memset(sol, 0, sizeof *sol);
    ohm_solver *s = NULL;
    int rc = ohm_solver_create(&s, grid, mat, params, 0, log, err);
    if (!rc) rc = ohm_solver_solve(s, lights, nlights, err);
    if (!rc) { /* the solution moves out; the solver's setup goes */
        *sol = s->sol;
        memset(&s->sol, 0, sizeof s->sol);
    }
    ohm_solver_free(s);
    return rc;
}
