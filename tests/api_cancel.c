/* api_cancel.c — progress and cancellation through the public API
 * (include/ohm.h, libohm.so only; docs/c-api.md):
 *  - a factorization of 96 x 96 x 12 = 110 592 cells is stopped by ohm_context_cancel
 *    called from the progress callback, and again from a second thread: each
 *    call returns OHM_ERR_CANCELLED before the factorization could have
 *    finished (its progress short of the end), and the scene then solves
 *    normally, conserving power;
 *  - a Monte Carlo run likewise, from the callback and from a thread;
 *  - a request made while nothing runs is dropped: the next call runs;
 *  - two threads, each with its own context and scene writing its own
 *    .vdb, give bit for bit the fluence one scene gives alone.
 * Built twice: api_cancel_host_lapack links LAPACK ahead of libohm, as
 * Blender does, so that the factorization is watched there only through
 * libohm's rebinding of CHOLMOD's calls (src/solvers/rebind.h).
 * The time from each request to the call's return is printed (docs/c-api.md
 * quotes it); the test asserts only that the call stopped early, with a
 * safety bound far above any machine's latency. */
#include <pthread.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "check.h"
#include "ohm.h"

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* What the progress callback saw, and whom it cancels. */
typedef struct watch {
    ohm_context *ctx;
    const char *stop_in;    /* cancel (from the callback) once this step has begun; NULL: never */
    double stop_after;      /* ... and reached this fraction */
    double t_request;       /* when the callback or the thread asked */
    double last_fraction;   /* the step's latest fraction */
    volatile int started;   /* the step has reported progress */
} watch;

static void on_progress(void *user, const char *what, double fraction)
{
    watch *w = user;
    if (!w->stop_in || !strstr(what, w->stop_in)) return;
    w->last_fraction = fraction;
    w->started = 1;
    if (w->stop_after >= 0 && fraction >= w->stop_after && w->t_request == 0) {
        w->t_request = now();
        ohm_context_cancel(w->ctx);
    }
}

/* A box of nx x ny x nz cells of 1 mm from a density array, grey, lit from
 * above; NULL on failure. */
static ohm_scene *box(ohm_context *ctx, int nx, int ny, int nz)
{
    size_t count = (size_t)(nx + 1) * (ny + 1) * (nz + 1);
    float *ones = malloc(count * sizeof *ones);
    ohm_scene *scene = NULL;
    if (!ones) return NULL;
    for (size_t v = 0; v < count; ++v) ones[v] = 1.0f;
    const int64_t dims[3] = {nx + 1, ny + 1, nz + 1};
    const double m[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
    const char *vox[] = {"voxel=1", "threshold=0.5", NULL};
    const char *mat[] = {"sigma_a=0.01", "sigma_s=1", NULL};
    const char *light[] = {"type=directional", "dir=0,0,-1", NULL};
    if (ohm_scene_new(&scene, ctx) || ohm_scene_set_density(scene, ones, dims, m, "cube") ||
        ohm_scene_run(scene, "voxelize", vox) || ohm_scene_run(scene, "material", mat) ||
        ohm_scene_add_light(scene, light)) {
        CHECK_MSG(0, "%s", ohm_error_last());
        ohm_scene_free(scene);
        scene = NULL;
    }
    free(ones);
    return scene;
}

/* The safety bound on a request's latency: far above the ~0.1 s measured,
 * so that only a call that ran on to its end fails it. */
static const double SAFETY_S = 10.0;

static void expect_cancelled(int rc, const watch *w, double t_return, const char *what)
{
    CHECK_MSG(rc == OHM_ERR_CANCELLED, "%s: returned %d (%s), expected OHM_ERR_CANCELLED", what, rc, ohm_error_last());
    CHECK_MSG(strstr(ohm_error_last(), "cancelled") != NULL, "%s: message '%s'", what, ohm_error_last());
    CHECK_MSG(w->t_request > 0, "%s: the request was never made", what);
    CHECK_MSG(w->last_fraction < 1.0, "%s: ran to the end (fraction %g) before it stopped", what, w->last_fraction);
    double latency = t_return - w->t_request;
    printf("%s: stopped %.3f s after the request, at %.0f%% of the step\n", what, latency, 100 * w->last_fraction);
    CHECK_MSG(latency >= 0 && latency < SAFETY_S, "%s: %.3f s from the request to the return", what, latency);
}

static void solves_normally(ohm_scene *scene, const char *const *opts, const char *what)
{
    int rc = ohm_scene_solve(scene, opts);
    CHECK_MSG(rc == OHM_OK, "%s: the scene does not solve after the cancellation: %s", what, ohm_error_last());
    double in = 0, out = 0, absorbed = 0;
    if (rc) return;
    CHECK(ohm_scene_stat(&in, scene, "power_in") == OHM_OK && ohm_scene_stat(&out, scene, "power_out") == OHM_OK &&
          ohm_scene_stat(&absorbed, scene, "power_absorbed") == OHM_OK);
    CHECK_MSG(in > 0 && fabs(in - out - absorbed) <= 1e-6 * in, "%s: power in %g, out %g + absorbed %g", what, in,
              out, absorbed);
}

typedef struct canceller {
    watch *w;
    double wait_s; /* after the step has started */
} canceller;

static void *cancel_later(void *arg)
{
    canceller *c = arg;
    double t0 = now();
    while (!c->w->started && now() - t0 < 60) usleep(1000);
    usleep((useconds_t)(c->wait_s * 1e6));
    c->w->t_request = now();
    ohm_context_cancel(c->w->ctx);
    return NULL;
}

/* Solve with opts twice, stopped each time: from the progress callback
 * once `step` has reported `stop_after` of its work, then from a second
 * thread 0.2 s into the step; w is the context's progress watch. */
static void cancel_both_ways(ohm_scene *scene, watch *w, const char *const *opts, const char *step,
                             double stop_after, const char *what)
{
    char label[128];
    *w = (watch){.ctx = w->ctx, .stop_in = step, .stop_after = stop_after};
    int rc = ohm_scene_solve(scene, opts);
    snprintf(label, sizeof label, "%s, cancelled from the progress callback", what);
    expect_cancelled(rc, w, now(), label);
    *w = (watch){.ctx = w->ctx, .stop_in = step, .stop_after = -1};
    canceller c = {w, 0.2};
    pthread_t t;
    CHECK(pthread_create(&t, NULL, cancel_later, &c) == 0);
    rc = ohm_scene_solve(scene, opts);
    double t_return = now();
    pthread_join(t, NULL);
    snprintf(label, sizeof label, "%s, cancelled from another thread", what);
    expect_cancelled(rc, w, t_return, label);
}

/* A context watched by w (quiet) and a box scene on it; NULL on failure. */
static ohm_scene *watched_box(ohm_context **ctx, watch *w, int nx, int ny, int nz)
{
    *ctx = NULL;
    CHECK(ohm_context_new(ctx) == OHM_OK);
    ohm_context_set_verbosity(*ctx, 0);
    *w = (watch){.ctx = *ctx};
    ohm_context_set_progress(*ctx, on_progress, w);
    ohm_scene *scene = box(*ctx, nx, ny, nz);
    if (!scene) ohm_context_free(*ctx);
    return scene;
}

static void cancel_factorization(void)
{
    ohm_context *ctx;
    watch w;
    ohm_scene *scene = watched_box(&ctx, &w, 96, 96, 12);
    if (!scene) return;
    double cells = 0;
    CHECK(ohm_scene_stat(&cells, scene, "cells") == OHM_OK && cells >= 1e5);
    const char *direct[] = {"solver=direct", "ordering=metis", NULL};
    cancel_both_ways(scene, &w, direct, "factorize", 0.05, "factorization");
    /* and then the whole factorization */
    w = (watch){.ctx = ctx, .stop_in = "factorize", .stop_after = -1};
    double t0 = now();
    solves_normally(scene, direct, "factorization");
    printf("factorization of %.0f cells run to the end: %.2f s\n", cells, now() - t0);
    CHECK_MSG(w.last_fraction > 0.5, "the full factorization reported %g at most", w.last_fraction);
    ohm_scene_free(scene);
    ohm_context_free(ctx);
}

static void cancel_monte_carlo(void)
{
    ohm_context *ctx;
    watch w;
    ohm_scene *scene = watched_box(&ctx, &w, 12, 12, 12);
    if (!scene) return;
    /* 1e9 photons: hours, unless stopped (from the callback at its first report) */
    const char *mc[] = {"solver=mc", "photons=1e9", NULL};
    cancel_both_ways(scene, &w, mc, "monte carlo", 1e-9, "Monte Carlo");
    const char *short_mc[] = {"solver=mc", "photons=20000", NULL};
    solves_normally(scene, short_mc, "Monte Carlo");

    /* a request while nothing runs is aimed at no call: the next one runs
     * to its end (a late Esc must not stop the next solve) */
    ohm_context_cancel(ctx);
    const char *direct[] = {"solver=direct", NULL};
    solves_normally(scene, direct, "after a request made while nothing ran");
    /* likewise before a relight */
    ohm_context_cancel(ctx);
    CHECK_MSG(ohm_scene_relight(scene) == OHM_OK, "a relight after a request made while nothing ran: %s",
              ohm_error_last());
    ohm_scene_free(scene);
    ohm_context_free(ctx);
}

/* One scene from start to end on its own context, writing its own .vdb:
 * its fluence into fluence[] (cells of the grid). */
typedef struct job {
    const char *vdb;
    double *fluence;
    size_t cells;
    int rc;
} job;

static void *run_job(void *arg)
{
    job *j = arg;
    ohm_context *ctx = NULL;
    ohm_scene *scene = NULL;
    char write[256];
    snprintf(write, sizeof write, "file=%s", j->vdb);
    const char *read[] = {"file=samples/cow.obj", "size=30", NULL};
    const char *vox[] = {"dim=20", NULL};
    const char *mat[] = {"preset=marble", NULL};
    const char *light[] = {"type=point", "pos=0,40,30", "intensity=100", NULL};
    const char *solve[] = {"solver=direct", NULL};
    const char *out[] = {write, NULL};
    ohm_grid_info gi = OHM_GRID_INFO_INIT;
    j->rc = ohm_context_new(&ctx);
    if (!j->rc) ohm_context_set_verbosity(ctx, 0);
    if (!j->rc) j->rc = ohm_scene_new(&scene, ctx);
    if (!j->rc) j->rc = ohm_scene_run(scene, "read", read);
    if (!j->rc) j->rc = ohm_scene_run(scene, "voxelize", vox);
    if (!j->rc) j->rc = ohm_scene_run(scene, "material", mat);
    if (!j->rc) j->rc = ohm_scene_add_light(scene, light);
    if (!j->rc) j->rc = ohm_scene_solve(scene, solve);
    if (!j->rc) j->rc = ohm_scene_run(scene, "write", out);
    if (!j->rc) j->rc = ohm_scene_grid(&gi, scene);
    if (!j->rc) {
        j->cells = (size_t)gi.cells;
        j->fluence = malloc(j->cells * sizeof *j->fluence);
        j->rc = j->fluence ? ohm_scene_fluence(j->fluence, j->cells, scene, 0, 0) : OHM_ERR_NOMEM;
    }
    ohm_scene_free(scene);
    ohm_context_free(ctx);
    return NULL;
}

/* name: the program's, so that the two builds of this test (api_cancel and
 * api_cancel_host_lapack), run at once by ctest -j, write different files */
static void two_threads(const char *name)
{
    char paths[3][256];
    static const char *const which[3] = {"alone", "a", "b"};
    for (int i = 0; i < 3; ++i) snprintf(paths[i], sizeof paths[i], "%s_%s.vdb", name, which[i]);
    job alone = {paths[0], NULL, 0, 0}, a = {paths[1], NULL, 0, 0}, b = {paths[2], NULL, 0, 0};
    run_job(&alone);
    pthread_t ta, tb;
    CHECK(pthread_create(&ta, NULL, run_job, &a) == 0 && pthread_create(&tb, NULL, run_job, &b) == 0);
    pthread_join(ta, NULL);
    pthread_join(tb, NULL);
    CHECK_MSG(alone.rc == 0 && a.rc == 0 && b.rc == 0, "alone %d, threads %d and %d", alone.rc, a.rc, b.rc);
    if (!alone.rc && !a.rc && !b.rc) {
        CHECK(a.cells == alone.cells && b.cells == alone.cells);
        CHECK_MSG(memcmp(a.fluence, alone.fluence, alone.cells * sizeof *alone.fluence) == 0 &&
                      memcmp(b.fluence, alone.fluence, alone.cells * sizeof *alone.fluence) == 0,
                  "two threads' fluence differs from one scene's alone");
    }
    for (const job *j = &alone; j; j = j == &alone ? &a : j == &a ? &b : NULL) {
        CHECK_MSG(access(j->vdb, F_OK) == 0, "%s was not written", j->vdb);
        remove(j->vdb);
        free(j->fluence);
    }
}

int main(int argc, char **argv)
{
    const char *name = argc > 0 && argv[0] ? strrchr(argv[0], '/') : NULL;
    name = name ? name + 1 : argc > 0 && argv[0] ? argv[0] : "api_cancel";
    cancel_factorization();
    cancel_monte_carlo();
    two_threads(name);
    return check_summary();
}
