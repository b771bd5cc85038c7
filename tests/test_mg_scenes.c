/* test_mg_scenes.c — solver=mg through the whole -solve step, against
 * solver=direct on the same scenes (docs/multigrid.md): every cell's
 * fluence and every boundary face's exitance to 1e-6 of the largest, in
 * every channel and frame, and power conserved to 1e-10.  The scenes cover
 * what ohm solves: a mesh under each boundary mode, a CT scan through an RGB
 * transfer function (1e4 contrasts in sigma_s'), a per-cell refractive
 * index (interface resistances), a depth band, the paper's resistance mode,
 * an orbit of frames relit with keep=1 (warm-started: a relight with the
 * same light takes no iteration), and the hybrid's handed-off sources.
 * Then again with mg's solve on an OpenCL device (device=opencl:N,
 * docs/devices.md): PoCL's CPU device in CI, or the first device with double precision;
 * without one that pass prints SKIP, unless CI=true or OHM_REQUIRE_OPENCL. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "opencl_test.h"
#include "tmp_files.h"
#include "run_chain.h"

static double array_diff(const double *a, const double *b, size_t n, double *scale)
{
    double d = 0, m = 0;
    for (size_t i = 0; i < n; ++i) {
        d = fmax(d, fabs(a[i] - b[i]));
        m = fmax(m, fabs(b[i]));
    }
    *scale = m;
    return m > 0 ? d / m : d;
}

/* the second solver every scene is compared with: "mg", or "mg device=opencl:N" */
static const char *mg_solver = "mg";
/* " device=opencl:N" in the device pass: the hybrid's photons run where
 * device= says for either solver, so its direct solve traces them there too
 * (the same photons; mc_device.h) */
static char photon_device[48] = "";

/* The scene `lines` solved with `solve` + " solver=direct", then with
 * mg_solver; relight: after the solve, replace the light and relight. */
static void compare(const char *what, const char *lines, const char *solve, const char *relight_light)
{
    char text[2][2048];
    const char *solvers[2] = {"direct", mg_solver};
    ohm_state s[2];
    int ok = 1;
    for (int q = 0; q < 2; ++q) {
        snprintf(text[q], sizeof text[q], "%s%s solver=%s%s\n", lines, solve, solvers[q],
                 q == 0 && strstr(solve, "hybrid=") ? photon_device : "");
        ok &= run_lines(&s[q], text[q]) == 0;
    }
    for (int q = 0; ok && relight_light && q < 2; ++q) {
        ohm_error err;
        ohm_error_clear(&err);
        free(s[q].lights); /* as ohm_scene_clear_lights */
        s[q].lights = NULL;
        s[q].nlights = 0;
        s[q].have_solution = 0;
        char line[512];
        snprintf(line, sizeof line, "ohm-pipeline 1\n%s\n", relight_light);
        ohm_chain c;
        memset(&c, 0, sizeof c);
        int rc = ohm_chain_parse_text(&c, line, strlen(line), "test", &err);
        if (!rc) rc = ohm_chain_run(&c, &s[q], &err);
        if (!rc) rc = ohm_state_relight(&s[q], &err);
        ohm_chain_free(&c);
        CHECK_MSG(rc == 0, "%s: relight with %s: %s", what, solvers[q], err.msg);
        ok &= rc == 0;
    }
    if (ok) {
        const ohm_solution *d = ohm_state_solution(&s[0]), *m = ohm_state_solution(&s[1]);
        CHECK_MSG(d && m && strcmp(m->solver, "mg") == 0, "%s: solver %s", what, m ? m->solver : "none");
        CHECK_MSG(m && (strcmp(mg_solver, "mg") == 0) == (m->device[0] == 0), "%s: %s ran on '%s'", what, mg_solver,
                  m ? m->device : "");
        if (d && m) {
            size_t n = (size_t)d->n, nf = (size_t)(d->net.nfaces ? d->net.nfaces : 1);
            double worst_phi = 0, worst_ex = 0, scale;
            CHECK(m->channels == d->channels && m->frames == d->frames && m->n == d->n);
            for (int c = 0; c < d->channels && m->channels == d->channels; ++c) {
                worst_phi = fmax(worst_phi, array_diff(m->fluence[c], d->fluence[c], n * (size_t)d->frames, &scale));
                worst_ex = fmax(worst_ex, array_diff(m->face_exitance[c], d->face_exitance[c],
                                                     nf * (size_t)d->frames, &scale));
            }
            double cons = ohm_solution_conservation_error(m);
            CHECK_MSG(worst_phi <= 1e-6 && worst_ex <= 1e-6, "%s: mg vs direct: fluence %.3g, exitance %.3g", what,
                      worst_phi, worst_ex);
            CHECK_MSG(cons <= 1e-10, "%s: mg's conservation error %.3g", what, cons);
            CHECK_REL(m->power_out, d->power_out, 1e-6);
            fprintf(stderr, "%s: %-34s %7lld cells x %d ch x %d fr: %4lld its, fluence %.1e, exitance %.1e, "
                            "conservation %.1e\n",
                    mg_solver, what, (long long)n, d->channels, d->frames, (long long)m->cg_iterations, worst_phi, worst_ex,
                    cons);
        }
    }
    ohm_state_free(&s[0]);
    ohm_state_free(&s[1]);
}

/* A kept mg solver relit with the same light starts from the last solve's
 * fluence, which already solves it: no iteration, the same fluence. */
static void relight_starts_from_last(const char *lines)
{
    char text[2048];
    snprintf(text, sizeof text, "%ssolve solver=%s keep=1\n", lines, mg_solver);
    ohm_state s;
    if (run_lines(&s, text) == 0) {
        const ohm_solution *sol = ohm_state_solution(&s);
        size_t n = (size_t)sol->n * (size_t)sol->frames;
        double *before = malloc(n * sizeof *before);
        memcpy(before, sol->fluence[0], n * sizeof *before);
        int64_t its_first = sol->cg_iterations;
        ohm_error err;
        ohm_error_clear(&err);
        CHECK_MSG(ohm_state_relight(&s, &err) == 0, "%s", err.msg);
        sol = ohm_state_solution(&s);
        double scale, d = sol ? array_diff(sol->fluence[0], before, n, &scale) : 1;
        CHECK_MSG(sol && sol->cg_iterations == 0 && its_first > 0 && d <= 1e-12,
                  "relit with the same light: %lld iterations (first solve %lld), fluence moved %.3g",
                  sol ? (long long)sol->cg_iterations : -1LL, (long long)its_first, d);
        free(before);
    }
    ohm_state_free(&s);
}

static void scenes(void)
{
    const char *cow = "read file=samples/cow.obj size=40\nvoxelize dim=48\n";
    char lines[1024];
    snprintf(lines, sizeof lines, "%smaterial preset=marble\nlight type=point pos=0,60,20 intensity=1000\n", cow);
    compare("mesh, robin, RGB", lines, "solve", NULL);
    compare("mesh, neumann", lines, "solve boundary=neumann", NULL);
    compare("mesh, dirichlet", lines, "solve boundary=dirichlet", NULL);
    compare("mesh, depth band", lines, "solve depth_band=0.5", NULL);
    snprintf(lines, sizeof lines,
             "%smaterial preset=marble\nlight type=spot pos=0,60,20 dir=0,-1,0 intensity=500 orbit=4\n",
             cow);
    compare("mesh, orbit of 4", lines, "solve", NULL);
    compare("mesh, keep=1 relight, orbit of 3", lines, "solve keep=1",
            "light type=point pos=30,0,30 intensity=800 orbit=3");
    relight_starts_from_last(lines);
    snprintf(lines, sizeof lines,
             "%smaterial sigma_a=0.01 sigma_s=1 eta=1.4\nlight type=pencil pos=0,0,40 dir=0,0,-1 intensity=1\n", cow);
    compare("mesh, hybrid pencil", lines, "solve hybrid=10 photons=20000", NULL);
    const char *walnut = "read file=samples/walnut_64x48x57_uint16.raw.gz dims=64,48,57 type=u16\n"
                         "voxelize threshold=5000\n";
    snprintf(lines, sizeof lines, "%smaterial transfer=samples/walnut.transfer\nlight type=point pos=0,0,60 "
             "intensity=1000\n", walnut);
    compare("walnut CT, RGB transfer", lines, "solve", NULL);
    snprintf(lines, sizeof lines, "%smaterial transfer=samples/paper-mode.transfer\nlight type=point pos=0,0,60 "
             "intensity=1000\n", walnut);
    compare("walnut CT, resistance mode", lines, "solve boundary=neumann", NULL);
    /* the index per cell from the density: interfaces between shell, kernel and air */
    static const char eta_tf[] = "ohm-transfer 1 eta=column\n0 0.5 0.01 1.0\n6000 0.02 1 1.45\n15000 0.2 5 1.6\n";
    const char *tf = write_tmp("eta.transfer", eta_tf, sizeof eta_tf - 1);
    snprintf(lines, sizeof lines, "%smaterial transfer=%s\nlight type=point pos=0,0,60 intensity=1000\n", walnut, tf);
    compare("walnut CT, per-cell index", lines, "solve", NULL);
    /* clear regions coupled by view factors (clear=radiosity): the walnut's
     * least dense class clear (sigma_s' 0.001 /mm, index 1.0), 6 364 cells
     * in 2 698 regions; mg reads the node pairs as its stencil's links
     * beyond the grid, on the host and, in the device pass, in the device's
     * kernels */
    static const char clear_tf[] = "ohm-transfer 1 eta=column\n0 0.0004 0.001 1.0\n5300 0.0004 0.001 1.0\n"
                                   "6100 0.02 1 1.45\n15000 0.2 5 1.6\n";
    tf = write_tmp("clear.transfer", clear_tf, sizeof clear_tf - 1);
    snprintf(lines, sizeof lines, "%smaterial transfer=%s\nlight type=point pos=0,0,60 intensity=1000\n", walnut, tf);
    compare("walnut CT, clear regions coupled", lines, "solve clear=radiosity", NULL);
}

/* "mg device=opencl:N" for the first device with double precision, or NULL */
static const char *device_solver(char buf[64])
{
    char spec[32];
    if (first_fp64_device(spec) < 0) return NULL;
    snprintf(buf, 64, "mg device=%s", spec);
    snprintf(photon_device, sizeof photon_device, " device=%s", spec);
    return buf;
}

int main(void)
{
    CHECK(tmp_begin("test_mg_scenes") == 0);
    scenes();
    char buf[64];
    if ((mg_solver = device_solver(buf))) {
        scenes();
    } else {
        CHECK_MSG(!opencl_required(), "no OpenCL device with double precision, but CI=true or OHM_REQUIRE_OPENCL is set");
        printf("SKIP: the device pass: no OpenCL device with double precision\n");
    }
    cleanup_tmp();
    return check_summary();
}
