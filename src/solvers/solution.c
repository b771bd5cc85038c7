/* solvers/solution.c — the solution object (solve.h): its arrays allocated
 * and reset between solves, the backend's report copied into its
 * statistics, and what outputs read back from it (exitance per cell, the
 * conservation error, the medium per unknown).  The solution owns every
 * array it points to (ohm_solution_free). */
#include "solvers/solver_impl.h"
#include "solvers/solve.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The mean of face_exitance over faces [f, end) (one cell's run). */
static double run_mean(const double *fx, int64_t f, int64_t end)
{
    double sum = 0;
    for (int64_t q = f; q < end; ++q) sum += fx[q];
    return end > f ? sum / (double)(end - f) : 0.0;
}

void ohm_solution_exitance_frame(double *out, const ohm_solution *sol, int channel, int frame)
{
    const ohm_network *net = &sol->net;
    size_t nf = (size_t)(net->nfaces ? net->nfaces : 1);
    const double *fx = sol->face_exitance[channel] + (size_t)frame * nf;
    memset(out, 0, (size_t)sol->n * sizeof *out);
    for (int64_t f = 0, end; f < net->nfaces; f = end) {
        end = ohm_network_face_run_end(net, f);
        out[net->face_unknown[f]] = run_mean(fx, f, end);
    }
}

double ohm_solution_face_power(const ohm_solution *sol, int channel, int frame, int64_t f)
{
    const ohm_network *net = &sol->net;
    size_t nf = (size_t)(net->nfaces ? net->nfaces : 1);
    return sol->face_exitance[channel][(size_t)frame * nf + (size_t)f] * (net->grid->h * net->grid->h);
}

void ohm_solution_free(ohm_solution *sol)
{
    if (!sol) return;
    for (int c = 0; c < OHM_MAX_CHANNELS; ++c) {
        free(sol->fluence[c]);
        free(sol->face_exitance[c]);
        free(sol->fluence_se[c]);
        free(sol->exitance_se[c]);
    }
    for (int q = 0; q < 2 * OHM_MAX_CHANNELS; ++q) free(sol->medium_owned[q]);
    free(sol->medium_density);
    free(sol->curve_store);
    ohm_network_free(&sol->net);
    free(sol->band_active);
    ohm_clear_regions_free(&sol->clear);
    free(sol->band_eta);
    free(sol->band_g);
    memset(sol, 0, sizeof *sol);
}

int ohm_solution_medium(double *out, const ohm_solution *sol, int c, int ss)
{
    const ohm_coeff *values = ss ? sol->medium_ss[c] : sol->medium_sa[c];
    const ohm_curve *curve = ss ? &sol->medium_ss_curve[c] : &sol->medium_sa_curve[c];
    if (values) {
        for (int64_t v = 0; out && v < sol->n; ++v) out[v] = values[v];
        return 1;
    }
    if (!sol->medium_density || !curve->n) return 0;
    for (int64_t v = 0; out && v < sol->n; ++v) out[v] = ohm_curve_at(curve, sol->medium_density[v]);
    return 1;
}

int ohm_solution_medium_varies(const ohm_solution *sol)
{
    for (int c = 0; c < sol->channels; ++c)
        if (sol->medium_sa[c] || sol->medium_ss[c] || sol->medium_sa_curve[c].n || sol->medium_ss_curve[c].n)
            return 1;
    return 0;
}

double ohm_solution_conservation_error(const ohm_solution *sol)
{
    if (!(sol->power_in > 0)) return 0.0;
    return fabs(sol->power_in - sol->power_absorbed - sol->power_out) / sol->power_in;
}

/* The backend's report into the solution's statistics. */
void ohm_solution_report_backend(ohm_solution *sol, const ohm_backend_report *rep)
{
    snprintf(sol->solver, sizeof sol->solver, "%s", rep->solver);
    snprintf(sol->solver_reason, sizeof sol->solver_reason, "%s", rep->reason);
    if (rep->device[0]) /* else the hybrid's photons may have named one (transport.c) */
        snprintf(sol->device, sizeof sol->device, "%s", rep->device);
    snprintf(sol->ordering, sizeof sol->ordering, "%s", rep->ordering);
    sol->factors = rep->factors;
    sol->analyses = rep->analyses;
    sol->t_analyze = rep->t_analyze;
    sol->t_factor = rep->t_factor;
    sol->t_cg_setup = rep->t_precond;
    sol->nnz_A = rep->nnz_A;
    sol->nnz_L = rep->nnz_L;
    sol->flops = rep->flops;
    sol->cg_iterations = rep->iterations;
    sol->cg_relres = rep->relres;
    sol->cg_tol = rep->tol;
    sol->cg_stalled = rep->stalled;
    sol->refined = rep->refined;
    sol->solver_bytes = rep->bytes;
    sol->ranks = rep->ranks > 0 ? rep->ranks : 1;
    sol->mg_levels = rep->levels;
}

/* The solution's fluence and face exitance, every channel and frame, zeroed
 * (fluence arrays kept by ohm_solution_reset stay as they are). */
int ohm_solution_alloc(ohm_solution *sol, ohm_error *err)
{
    size_t n = (size_t)sol->n, nf = (size_t)(sol->net.nfaces ? sol->net.nfaces : 1), frames = (size_t)sol->frames;
    for (int c = 0; c < sol->channels; ++c) {
        if (!sol->fluence[c]) sol->fluence[c] = calloc(n * frames, sizeof(double)); /* else kept: reset */
        sol->face_exitance[c] = calloc(nf * frames, sizeof(double));
        if (!sol->fluence[c] || !sol->face_exitance[c])
            return ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory for the solution (%d frames)", sol->frames);
    }
    return OHM_OK;
}

/* The results of the solve before, and its per-solve statistics, cleared;
 * what the solver keeps (topology, media, setup statistics) stays, and with
 * keep_fluence the fluence arrays, as the next solve's starting guess. */
void ohm_solution_reset(ohm_solution *sol, ohm_backend_report *rep, int keep_fluence)
{
    for (int c = 0; c < OHM_MAX_CHANNELS; ++c) {
        if (!keep_fluence) {
            free(sol->fluence[c]);
            sol->fluence[c] = NULL;
        }
        free(sol->face_exitance[c]);
        free(sol->fluence_se[c]);
        free(sol->exitance_se[c]);
        sol->face_exitance[c] = sol->fluence_se[c] = sol->exitance_se[c] = NULL;
        sol->power_out_channel[c] = sol->power_in_channel[c] = 0;
    }
    sol->solves = sol->solves_skipped = 0;
    sol->mc_photons = sol->mc_events = sol->mc_truncated = 0;
    sol->mc_threads = 0;
    sol->t_source = sol->t_solve = 0;
    sol->residual = 0;
    sol->mode_corrections = 0;
    sol->mode_shift = 0;
    sol->power_incident = sol->power_entered = sol->power_in = sol->power_absorbed = sol->power_out = 0;
    rep->iterations = 0;
    rep->relres = 0;
    rep->stalled = 0;
    rep->refined = 0;
}
