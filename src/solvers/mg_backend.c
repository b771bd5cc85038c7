/* solvers/mg_backend.c — solver=mg as a backend (backend.h): the hierarchy
 * (mg.h) set up once per operator, and each column solved on the host or,
 * where device= names one, on an OpenCL device (mg_device.h). */
#include <stdio.h>
#include <stdlib.h>

#include "base/parallel.h"
#include "physics/stencil_rows.h"
#include "solvers/backend.h"
#include "solvers/mg.h"
#include "solvers/mg_device.h"

typedef struct mg_state {
    ohm_mg *mg;
    ohm_mg_device *device; /* the hierarchy on an OpenCL device (device=), or NULL: the host */
    ohm_backend_config cfg;
    double idle_checked; /* when the machine was last looked at (ohm_now)   */
    int idle_cores;      /* what that look found (0: none yet: every core) */
} mg_state;

static void mg_release(void *state)
{
    mg_state *s = state;
    ohm_mg_device_free(s->device);
    s->device = NULL;
    ohm_mg_free(s->mg);
    s->mg = NULL;
}

static void mg_destroy(void *state)
{
    if (!state) return;
    mg_release(state);
    free(state);
}

static int mg_create(void **state, const ohm_backend_config *cfg, ohm_error *err)
{
    mg_state *s = calloc(1, sizeof *s);
    if (!s) return ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory");
    s->cfg = *cfg;
    ohm_backend_iterative_defaults(&s->cfg, 1000);
    *state = s;
    return OHM_OK;
}

static int mg_setup(void *state, const ohm_operator *op, ohm_backend_report *rep, ohm_error *err)
{
    mg_state *s = state;
    if ((!op->stencil && !op->make_stencil) || !s->cfg.layout || s->cfg.layout->n != op->n)
        return ohm_fail(err, OHM_ERR_INTERNAL, "solve: solver=mg needs the network's stencil and its cells");
    int64_t n = op->n;
    double columns = (double)(s->cfg.batch ? s->cfg.batch : 1);
    double need = ohm_mg_bytes_estimate(n) + 2.0 * sizeof(double) * (double)n * columns;
    if (op->A) need += 24.0 * (double)op->A->nzmax; /* A is held beside the stencil made for mg */
    char what[64];
    snprintf(what, sizeof what, "multigrid on %lld cells", (long long)n);
    int rc =
        ohm_backend_check_memory(need, s->cfg.max_memory, what, NULL, "use a smaller dim= or a larger voxel=", err);
    if (rc) return rc;
    mg_release(s);
    double t0 = ohm_now();
    const ohm_stencil *st = op->stencil;
    if (!st) rc = op->make_stencil(op->maker, &st, err);
    if (!rc) rc = ohm_mg_setup(&s->mg, st, s->cfg.layout, 0, err);
    if (!rc) rc = ohm_mg_device_open(&s->device, s->mg, &s->cfg.device, s->cfg.log, err);
    if (rc) return rc;
    if (s->device) snprintf(rep->device, sizeof rep->device, "%s", ohm_mg_device_name(s->device));
    rep->t_precond += ohm_now() - t0;
    rep->precond_setups++;
    rep->levels = ohm_mg_levels(s->mg, NULL);
    snprintf(rep->solver, sizeof rep->solver, "mg");
    double held = ohm_mg_bytes(s->mg) + ohm_stencil_bytes(st); /* and the stencil it reads */
    if (held > rep->bytes) rep->bytes = held;
    return OHM_OK;
}

/* A column of at least this many cells first looks whether the machine is
 * busy (ohm_idle_cores over 4 ms: 2% of a relight of 3e5 cells' channel);
 * below, the cycle's loops run on one core anyway (stencil_rows.h). */
enum { BUSY_CHECK_CELLS = OHM_ROWS_PARALLEL_MIN };

/* ... and at most this often (s): the channels and lights of one relight
 * share a look */
static const double BUSY_CHECK_EVERY = 0.25;

static int mg_column(void *solver, double *x, const double *b, int64_t *iters, double *relres, ohm_error *err)
{
    mg_state *s = solver;
    if (s->device) return ohm_mg_device_solve(s->device, x, b, s->cfg.tol, s->cfg.max_iter, s->cfg.log, iters, relres, err);
    /* on a busy machine the cycle's threads only on the cores left idle,
     * as the factor's BLAS (direct.c): every kernel ends when its last
     * piece does, and a thread the scheduler has put behind another
     * process (even at nice 19) holds that end up */
    double now = ohm_now();
    if (s->cfg.layout && s->cfg.layout->n >= BUSY_CHECK_CELLS && now - s->idle_checked > BUSY_CHECK_EVERY) {
        s->idle_cores = ohm_idle_cores(0.004);
        s->idle_checked = now;
    }
    ohm_mg_set_threads(s->mg, s->idle_cores); /* a hierarchy set up since takes the last look too */
    return ohm_mg_solve(s->mg, x, b, s->cfg.tol, s->cfg.max_iter, s->cfg.log, iters, relres, err);
}

static int mg_solve(void *state, const ohm_operator *op, const double *B, double *X, size_t ncols, double *berr,
                    ohm_backend_report *rep, ohm_error *err)
{
    mg_state *s = state;
    int rc = ohm_backend_solve_columns(mg_column, s, (size_t)op->n, B, X, ncols, s->cfg.tol, rep, err);
    if (!rc) *berr = ohm_operator_backward_error(op, B, X, ncols, ohm_mg_norm_inf(s->mg));
    return rc;
}

const ohm_backend_ops ohm_backend_mg = {.name = "mg",
                                        .create = mg_create,
                                        .setup = mg_setup,
                                        .solve = mg_solve,
                                        .destroy = mg_destroy,
                                        .release = mg_release,
                                        .caps = OHM_BACKEND_STENCIL | OHM_BACKEND_WARM_START};
