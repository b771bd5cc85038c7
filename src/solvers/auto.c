/* solvers/auto.c — solver=auto: a backend that chooses among the others
 * (backend.h), memory first, then the time predicted for the columns to come.
 *
 * The first columns are always solved by an iterative backend, the probe:
 * mg (its set-up costs about what one column does, and its iterations
 * hardly grow with the grid or the contrasts), or cg under mpirun, where mg
 * does not run on more than one rank; neither needs an analysis, so the
 * first answer is cheap whichever way the choice goes.  The second column,
 * warm-started like every later one, is timed (t1 seconds).  The remaining
 * `rest` columns then go to the cheapest of
 *   the probe  rest * t1;
 *   direct  analysis + one factorization per distinct material + a pair of
 *           triangular solves per column;
 *   amg     one BoomerAMG setup per material + a preconditioned CG solve per
 *           column;
 * and a backend whose memory does not fit is skipped (the direct one learns
 * that from its symbolic analysis, before factorizing; its setup then fails
 * with OHM_ERR_NOMEM and the next cheapest is taken).  When the probe fails
 * to converge, the columns go to the factor (or amg when the factor does
 * not fit).  The probe's columns are kept whichever way it goes.
 *
 * The direct costs are a model of METIS nested dissection on a 3-D grid of n
 * cells: ~3.5 n^(4/3) entries in L (1.7 ns each per column solved), analysis
 * 1.4e-6 n^1.155 s, a factorization 1.02e-7 n^1.4 s — power laws fitted to
 * spot at dim 32..128 on this 2-core machine (docs/accuracy.md).  The amg
 * costs are linear in n (its iteration count does not grow): per cell,
 * setup 810-2550 ns per material and one column 585-990 ns on one rank,
 * measured from 1e6 to 2.7e7 cells of the random block medium, marble Spot
 * and the Colin27 head on a quiet machine (docs/scale.md, at ab1c5c9).  mg
 * is the probe because it is the cheaper iterative solver everywhere it was
 * measured: 16-18 iterations and ~500 ns per cell a column on the block
 * medium from 1e5 to 1e7 cells, where cg took 3-4x that, and cg's time at
 * spot's 37 101 cells (docs/multigrid.md). */
#include "solvers/backend.h"

#include "base/memory.h"
#include "solvers/estimate.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const double AMG_SETUP_NS = 1800.0;
static const double AMG_COLUMN_NS = 800.0;
/* starting PETSc and MPI in a process that has not: spot at 1947 cells took
 * 0.45 s in all with amg against 0.14 s with the factor, of which the
 * solvers' own setups and solves were 9 and 12 ms */
static const double AMG_START_S = 0.3;

typedef struct auto_state {
    ohm_backend_config cfg;
    const ohm_backend_ops *probe_ops; /* mg, or cg under mpirun              */
    void *probe;                   /* its state                             */
    const ohm_backend_ops *chosen; /* NULL until decided                    */
    void *chosen_state;            /* == probe when the probe was chosen     */
    double columns_done;
    char probe_note[160];          /* why the probe is not mg, or ""        */
} auto_state;

static void auto_destroy(void *state)
{
    auto_state *s = state;
    if (!s) return;
    if (s->chosen && s->chosen_state != s->probe) s->chosen->destroy(s->chosen_state);
    if (s->probe_ops) s->probe_ops->destroy(s->probe);
    free(s);
}

static int auto_create(void **state, const ohm_backend_config *cfg, ohm_error *err)
{
    auto_state *s = calloc(1, sizeof *s);
    if (!s) return ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory");
    s->cfg = *cfg;
    s->probe_ops = ohm_mpi_ranks() > 1 ? &ohm_backend_cg : &ohm_backend_mg;
    int rc = s->probe_ops->create(&s->probe, cfg, err);
    if (rc) {
        free(s);
        return rc;
    }
    *state = s;
    return OHM_OK;
}

static int auto_setup(void *state, const ohm_operator *op, ohm_backend_report *rep, ohm_error *err)
{
    auto_state *s = state;
    if (s->chosen) return s->chosen->setup(s->chosen_state, op, rep, err);
    int rc = s->probe_ops->setup(s->probe, op, rep, err);
    if (rc != OHM_ERR_NOMEM || s->probe_ops == &ohm_backend_cg) return rc;
    /* mg's hierarchy does not fit (it takes about twice cg's memory): cg probes */
    const char *need = strstr(err->msg, "needs about ");
    snprintf(s->probe_note, sizeof s->probe_note, "mg skipped (%.*s); ", need ? (int)strcspn(need, ",") : 12,
             need ? need : "memory");
    ohm_error_clear(err);
    s->probe_ops->destroy(s->probe);
    s->probe = NULL;
    s->probe_ops = &ohm_backend_cg;
    rc = s->probe_ops->create(&s->probe, &s->cfg, err);
    return rc ? rc : s->probe_ops->setup(s->probe, op, rep, err);
}

double ohm_auto_direct_seconds(double n, int materials, double columns)
{
    double t_analyze = 1.4e-6 * pow(n, 1.155), t_factor = materials * 1.02e-7 * pow(n, 1.4);
    return t_analyze + t_factor + columns * 1.7e-9 * 3.5 * pow(n, 4.0 / 3.0);
}

double ohm_auto_amg_seconds(double n, int materials, double columns)
{
    /* under mpirun every rank takes a slab (assumed to scale: docs/scale.md) */
    return 1e-9 * n * (materials * AMG_SETUP_NS + columns * AMG_COLUMN_NS) / ohm_mpi_ranks() +
           (ohm_backend_amg_started() ? 0.0 : AMG_START_S);
}

typedef struct candidate {
    const ohm_backend_ops *ops;
    double t;
} candidate;

static int by_time(const void *a, const void *b)
{
    double ta = ((const candidate *)a)->t, tb = ((const candidate *)b)->t;
    return (ta > tb) - (ta < tb);
}

/* Switch to the first of cands[0..nc) whose setup succeeds on A; a setup
 * that fails for memory passes to the next.  rep->reason is extended. */
static int switch_to(auto_state *s, candidate *cands, int nc, const ohm_operator *op, ohm_backend_report *rep,
                     ohm_error *err)
{
    for (int i = 0; i < nc; ++i) {
        const ohm_backend_ops *ops = cands[i].ops;
        if (ops == s->probe_ops) {
            s->chosen = ops;
            s->chosen_state = s->probe;
            return OHM_OK;
        }
        if (ops == &ohm_backend_amg) { /* known before PETSc (and MPI) start */
            char nb[32];
            double need = ohm_amg_bytes_per_rank(op->n, (double)op->A->nzmax, ohm_mpi_ranks());
            if (need > ohm_memory_limit(s->cfg.max_memory)) {
                size_t len = strlen(rep->reason);
                snprintf(rep->reason + len, sizeof rep->reason - len, "; amg skipped: it needs about %s per rank",
                         ohm_format_bytes(need, nb, 32));
                continue;
            }
        }
        void *st = NULL;
        int rc = ops->create(&st, &s->cfg, err);
        if (!rc) rc = ops->setup(st, op, rep, err);
        if (!rc) {
            s->chosen = ops;
            s->chosen_state = st;
            return OHM_OK;
        }
        if (st) ops->destroy(st);
        if (rc != OHM_ERR_NOMEM) return rc;
        size_t len = strlen(rep->reason);
        snprintf(rep->reason + len, sizeof rep->reason - len, "; %s skipped: %.80s", ops->name, err->msg);
        ohm_error_clear(err);
    }
    return ohm_fail(err, OHM_ERR_NOMEM, "solve: solver=auto: no backend fits (%s)", rep->reason);
}

/* The candidates in order of predicted time for `rest` more columns, CG's
 * column costing t1 (< 0: CG failed and is no candidate). */
static int rank_candidates(candidate *c, const auto_state *s, double n, double t1, double rest,
                           ohm_backend_report *rep)
{
    int nc = 0;
    int materials = s->cfg.materials > 0 ? s->cfg.materials : 1;
    double t_direct = ohm_auto_direct_seconds(n, materials, rest);
    double t_amg = ohm_auto_amg_seconds(n, materials, rest);
    c[nc++] = (candidate){&ohm_backend_direct, t_direct};
    if (ohm_backend_amg_available()) c[nc++] = (candidate){&ohm_backend_amg, t_amg};
    if (t1 >= 0) c[nc++] = (candidate){s->probe_ops, rest * t1};
    qsort(c, (size_t)nc, sizeof *c, by_time);
    size_t len = strlen(rep->reason);
    snprintf(rep->reason + len, sizeof rep->reason - len, "for the other %.0f column(s), predicted:", rest);
    for (int i = 0; i < nc; ++i) {
        len = strlen(rep->reason);
        snprintf(rep->reason + len, sizeof rep->reason - len, " %s %.3g s%s", c[i].ops->name, c[i].t,
                 i + 1 < nc ? "," : "");
    }
    return nc;
}

static int auto_solve(void *state, const ohm_operator *op, const double *B, double *X, size_t ncols, double *berr,
                      ohm_backend_report *rep, ohm_error *err)
{
    auto_state *s = state;
    if (s->chosen) return s->chosen->solve(s->chosen_state, op, B, X, ncols, berr, rep, err);
    size_t n = (size_t)op->n;
    double total = s->cfg.columns > 0 ? s->cfg.columns : 1;
    *berr = 0;
    for (size_t j = 0; j < ncols; ++j) {
        double e = 0, t0 = ohm_now();
        int64_t its0 = rep->iterations;
        int rc = s->probe_ops->solve(s->probe, op, B + j * n, X + j * n, 1, &e, rep, err);
        double t1 = ohm_now() - t0;
        size_t next = j + 1; /* the first column the chosen backend solves */
        candidate c[4];
        int nc;
        if (rc == OHM_ERR_NUMERIC) { /* CG cannot solve this one: it goes too */
            snprintf(rep->reason, sizeof rep->reason, "%.120s%s failed: %.100s; ", s->probe_note, s->probe_ops->name,
                     err->msg);
            ohm_error_clear(err);
            nc = rank_candidates(c, s, (double)n, -1, total - s->columns_done, rep);
            memset(X + j * n, 0, n * sizeof *X);
            next = j;
        } else if (rc) {
            return rc;
        } else {
            if (e > *berr) *berr = e;
            s->columns_done += 1;
            if (s->columns_done < 2 && total > 2) continue;
            snprintf(rep->reason, sizeof rep->reason, "%.120sa warm %s column took %.3g s (%lld iterations); ",
                     s->probe_note, s->probe_ops->name, t1, (long long)(rep->iterations - its0));
            nc = rank_candidates(c, s, (double)n, t1, total - s->columns_done, rep);
        }
        rc = switch_to(s, c, nc, op, rep, err);
        if (rc) return rc;
        ohm_log_info(s->cfg.log, "solve: solver=auto uses %s: %s", s->chosen->name, rep->reason);
        if (next < ncols) {
            rc = s->chosen->solve(s->chosen_state, op, B + next * n, X + next * n, ncols - next, &e, rep, err);
            if (rc) return rc;
            if (e > *berr) *berr = e;
        }
        break;
    }
    if (!s->chosen) /* (a kept solver of one column per medium: the choice comes with the relight) */
        snprintf(rep->reason, sizeof rep->reason,
                 "%.120sthe probe, %s, solved the first column; auto chooses when it has timed a warm one (the next "
                 "solve of this medium)",
                 s->probe_note, s->probe_ops->name);
    return OHM_OK;
}

/* warm starts: passed on to cg when it chose cg */
const ohm_backend_ops ohm_backend_auto = {.name = "auto",
                                          .create = auto_create,
                                          .setup = auto_setup,
                                          .solve = auto_solve,
                                          .destroy = auto_destroy,
                                          .caps = OHM_BACKEND_WARM_START};
