/* test_mc_device.c — the Monte Carlo tracer on an OpenCL device
 * (mc_device.h, docs/devices.md), on PoCL's CPU device in CI, or the first device
 * with double precision:
 *  - its random numbers: Philox4x32-10 on the device gives Random123's
 *    known answers;
 *  - the published transport values (ohm_validate_mc: van de Hulst's slab,
 *    MCML's half-spaces, MCX's cube60 17.697%) within 4 standard errors;
 *  - the host's physics, cell by cell: a box with an inclusion of another
 *    medium (per-cell coefficients and g), a clear layer of another index
 *    on top (Fresnel inside the object), symmetry planes and a time gate,
 *    and the hybrid's handoff: every total within 4 combined standard
 *    errors of the host's, and the cells' fluence differences the size
 *    their standard errors say (mean z^2 near 1);
 *  - its books: in = absorbed + out + gated + handed off to round-off;
 *  - a seed repeats a run (to the order of the atomic additions), another
 *    seed gives another sample;
 *  - through ohm_solve (solver=mc device=): the solution names the device;
 *  - a cancelled run stops after its first launch, and the next one runs;
 *  - a device that is not there, no runtime (device=auto falls back to the
 *    host), too little device memory, a kernel that fails to build, a
 *    device without 64-bit atomics or double precision (test hooks): one
 *    error each, with its code.
 * Without OpenCL it prints SKIP, unless CI=true or OHM_REQUIRE_OPENCL. */

#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "device/devices.h"
#include "opencl_test.h"
#include "physics/mc_device_cl.h"
#include "physics/light.h"
#include "physics/mc_trace.h"
#include "solvers/solve.h"
#include "studies/scene.h"
#include "studies/validate.h"

/* ---- Philox against Random123's known-answer vectors (kat_vectors) ---- */

/* device= as a run reads it: the text parsed once (device/request.h); NULL
 * is the host */
static ohm_device_request req_of(const char *text)
{
    ohm_device_request r = {OHM_DEVICE_HOST, 0};
    ohm_error err;
    if (text && ohm_device_request_parse(&r, text, &err)) {
        fprintf(stderr, "test_mc_device: %s\n", err.msg);
        exit(1);
    }
    return r;
}

static void philox_known_answers(const char *spec)
{
    static const cl_uint ctr[3][4] = {{0, 0, 0, 0},
                                      {0xffffffffu, 0xffffffffu, 0xffffffffu, 0xffffffffu},
                                      {0x243f6a88u, 0x85a308d3u, 0x13198a2eu, 0x03707344u}};
    static const cl_uint key[3][2] = {{0, 0}, {0xffffffffu, 0xffffffffu}, {0xa4093822u, 0x299f31d0u}};
    static const cl_uint want[3][4] = {{0x6627e8d5u, 0xe169c58du, 0xbc57ac4cu, 0x9b00dbd8u},
                                       {0x408f276du, 0x41c83b0eu, 0xa20bc7c6u, 0x6d5451fdu},
                                       {0xd16cfe09u, 0x94fdccebu, 0x5001e420u, 0x24126ea1u}};
    ohm_error err;
    ohm_error_clear(&err);
    ohm_cl cl;
    ohm_device *list = NULL;
    int n = 0, picked = -1;
    const ohm_device_request req = req_of(spec);
    ohm_device_queue q = {0};
    cl_program prog = NULL;
    cl_kernel k = NULL;
    cl_mem m[3] = {NULL, NULL, NULL};
    cl_uint got[3][4];
    memset(got, 0, sizeof got);
    CHECK(ohm_cl_open(&cl, &err) == 0);
    CHECK(ohm_device_list(&list, &n, &cl, &err) == 0);
    CHECK(ohm_device_pick(&picked, list, n, &req, &err) == 0 && picked >= 0);
    CHECK_MSG(ohm_device_queue_open(&q, &cl, &list[picked], &err) == 0, "%s", err.msg);
    CHECK_MSG(ohm_device_build(&prog, &q, ohm_mc_device_source, "-D WG=64", &err) == 0, "%s", err.msg);
    cl_int st = CL_SUCCESS;
    if (prog) k = cl.CreateKernel(prog, "philox_check", &st);
    CHECK(k != NULL);
    if (k) {
        m[0] = cl.CreateBuffer(q.context, CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, sizeof ctr, (void *)ctr, &st);
        m[1] = cl.CreateBuffer(q.context, CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, sizeof key, (void *)key, &st);
        m[2] = cl.CreateBuffer(q.context, CL_MEM_READ_WRITE, sizeof got, NULL, &st);
        for (cl_uint i = 0; i < 3; ++i) cl.SetKernelArg(k, i, sizeof(cl_mem), &m[i]);
        size_t global = 3;
        CHECK(cl.EnqueueNDRangeKernel(q.queue, k, 1, NULL, &global, NULL, 0, NULL, NULL) == CL_SUCCESS);
        CHECK(cl.EnqueueReadBuffer(q.queue, m[2], CL_TRUE, 0, sizeof got, got, 0, NULL, NULL) == CL_SUCCESS);
    }
    for (int i = 0; i < 3; ++i)
        CHECK_MSG(memcmp(got[i], want[i], sizeof want[i]) == 0, "philox vector %d: %08x %08x %08x %08x", i,
                  got[i][0], got[i][1], got[i][2], got[i][3]);
    printf("philox4x32-10: Random123's three known answers\n");
    for (int i = 0; i < 3; ++i)
        if (m[i]) cl.ReleaseMemObject(m[i]);
    if (k) cl.ReleaseKernel(k);
    if (prog) cl.ReleaseProgram(prog);
    if (q.context) ohm_device_queue_close(&q);
    free(list);
    ohm_cl_close(&cl);
}

/* ---- the published values ---- */

static void published(const char *spec)
{
    ohm_validation v;
    memset(&v, 0, sizeof v);
    ohm_log quiet = {.verbosity = 0};
    ohm_error err;
    ohm_error_clear(&err);
    CHECK_MSG(ohm_validate_mc(&v, 100000, 7, 0, req_of(spec), &quiet, &err) == 0, "%s", err.msg);
    ohm_validation_print(stdout, &v);
    CHECK(v.n == 6);
    for (int i = 0; i < v.n; ++i)
        CHECK_MSG(v.rows[i].pass, "%s: %.6g against %.6g", v.rows[i].name, v.rows[i].measured, v.rows[i].expected);
}

/* ---- the host's physics, cell by cell ---- */

enum { NX = 16, NZ = 16, CLEAR = 2 };
static const double H = 0.5;

/* A quarter box (symmetry planes at x = y = 0), NX^2 x NZ cells of H mm: a
 * medium (sigma_a 0.05, sigma_s' 1, g 0.8, eta 1.4) with a sphere of
 * another (sigma_a 0.2, sigma_s' 2, g 0) under a clear layer CLEAR cells
 * thick of index 1.0 (sigma_a 0, sigma_s' 0.01, g 0), lit by a pencil beam
 * down the corner. */
typedef struct scene {
    ohm_voxel_grid grid;
    ohm_network net;
    ohm_light_entries in;
    ohm_coeff *sa, *ss;
    double *g, *eta;
    ohm_channel_medium med;
} scene;

static void scene_free(scene *s)
{
    ohm_light_entries_free(&s->in);
    ohm_network_free(&s->net);
    ohm_voxel_grid_free(&s->grid);
    free(s->sa), free(s->ss), free(s->g), free(s->eta);
}

static int scene_build(scene *s)
{
    ohm_error err;
    ohm_error_clear(&err);
    memset(s, 0, sizeof *s);
    ohm_mirrors mirror = {{1, 1, -1}, {-1, -1, -1}};
    if (ohm_scene_box(&s->grid, NX, NX, NZ, H, &err) || ohm_network_build(&s->net, &s->grid, &mirror, &err)) return -1;
    size_t n = (size_t)s->net.n;
    s->sa = malloc(n * sizeof *s->sa);
    s->ss = malloc(n * sizeof *s->ss);
    s->g = malloc(n * sizeof *s->g);
    s->eta = malloc(n * sizeof *s->eta);
    if (!s->sa || !s->ss || !s->g || !s->eta) return -1;
    for (size_t v = 0; v < n; ++v) {
        int32_t c[3];
        ohm_voxel_coords(&s->grid, ohm_network_cell(&s->net, (int64_t)v), c);
        double x = (c[0] - 0.5) * H, y = (c[1] - 0.5) * H, z = (c[2] - 0.5) * H - 4.0;
        int clear = c[2] > NZ - CLEAR, sphere = x * x + y * y + z * z < 2.0 * 2.0;
        s->sa[v] = (ohm_coeff)(clear ? 0.0 : sphere ? 0.2 : 0.05);
        s->ss[v] = (ohm_coeff)(clear ? 0.01 : sphere ? 2.0 : 1.0);
        s->g[v] = clear || sphere ? 0.0 : 0.8;
        s->eta[v] = clear ? 1.0 : 1.4;
    }
    s->med = (ohm_channel_medium){.sigma_a0 = 0.05, .sigma_s0 = 1.0, .sigma_a = s->sa, .sigma_s = s->ss,
                                  .eta = 1.4, .eta_v = s->eta, .g = 0.8, .g_v = s->g};
    ohm_light beam = ohm_scene_pencil((const double[3]){0.1, 0.1, NZ * H + 1.0}, (const double[3]){0, 0, -1.0});
    return ohm_light_entries_add(&s->in, &s->net, &beam, 1, 1.4, s->eta, NULL, &err);
}

typedef struct traced {
    double *phi, *phi_se, *face, *exit_se, *handoff;
    ohm_mc_result r;
} traced;

static void traced_free(traced *t)
{
    free(t->phi), free(t->phi_se), free(t->face), free(t->exit_se), free(t->handoff);
}

static int trace(traced *t, const scene *s, const char *device, uint64_t seed, int handoff, double max_path)
{
    size_t n = (size_t)s->net.n, nf = (size_t)s->net.nfaces;
    t->phi = calloc(n, 8), t->phi_se = calloc(n, 8), t->face = calloc(nf, 8), t->exit_se = calloc(n, 8);
    t->handoff = calloc(n, 8);
    t->r = (ohm_mc_result){.fluence = t->phi, .fluence_se = t->phi_se, .face_exitance = t->face,
                           .exitance_se = t->exit_se, .handoff = t->handoff};
    ohm_mc_params p = {.photons = 100000, .seed = seed, .threads = 2, .max_path = max_path, .handoff = handoff,
                       .device = req_of(device)};
    ohm_error err;
    ohm_error_clear(&err);
    int rc = ohm_mc_trace(&t->r, &s->net, &s->med, s->in.entry, s->in.count, 0, &p, &err);
    if (rc) fprintf(stderr, "ohm_mc_trace (%s): %s\n", device ? device : "host", err.msg);
    return rc;
}

/* in = absorbed + out + gated + handed off */
static void books(const char *what, const ohm_mc_result *r)
{
    double sum = r->power_absorbed + r->power_out + r->power_gated + r->power_handoff;
    CHECK_MSG(r->power_in > 0 && fabs(sum - r->power_in) <= 1e-10 * r->power_in, "%s: in %.15g, booked %.15g",
              what, r->power_in, sum);
}

/* a total of the device's against the host's, within 4 combined standard errors */
static void same_total(const char *what, double dev, double host, double se_dev, double se_host)
{
    double tol = 4.0 * sqrt(se_dev * se_dev + se_host * se_host);
    printf("  %-28s device %.6f, host %.6f (4 se %.6f)\n", what, dev, host, tol);
    CHECK_MSG(fabs(dev - host) <= tol, "%s: device %.6g, host %.6g, 4 se %.3g", what, dev, host, tol);
}

/* Over the cells whose fluence both runs know to 10%: the mean of
 * z^2 = (dev - host)^2 / (se_dev^2 + se_host^2), 1 when the two are
 * samples of one field (16 batches: ~1.07 expected), and the mean of z. */
static void same_field(const char *what, const double *a, const double *sa, const double *b, const double *sb,
                       int64_t n)
{
    double z2 = 0, z = 0;
    int64_t cells = 0;
    for (int64_t v = 0; v < n; ++v) {
        if (!(a[v] > 0 && b[v] > 0 && sa[v] < 0.1 * a[v] && sb[v] < 0.1 * b[v])) continue;
        double d = (a[v] - b[v]) / sqrt(sa[v] * sa[v] + sb[v] * sb[v]);
        z2 += d * d;
        z += d;
        ++cells;
    }
    z2 /= (double)(cells ? cells : 1);
    z /= (double)(cells ? cells : 1);
    printf("  %-28s %lld cells: mean z^2 %.3f, mean z %+.3f\n", what, (long long)cells, z2, z);
    CHECK_MSG(cells > 100, "%s: only %lld cells known to 10%%", what, (long long)cells);
    CHECK_MSG(z2 > 0.6 && z2 < 1.6 && fabs(z) < 0.3, "%s: mean z^2 %.3f, mean z %+.3f", what, z2, z);
}

static void against_host(const char *spec)
{
    scene s;
    CHECK(scene_build(&s) == 0);
    printf("a %d^2 x %d quarter box, %lld cells: an inclusion, a clear layer of index 1.0, g per cell\n", NX, NZ,
           (long long)s.net.n);
    for (int hybrid = 0; hybrid <= 1; ++hybrid) {
        traced d = {0}, h = {0};
        double gate = hybrid ? 0 : 40.0; /* mm of path: a photon's fifth mean absorption length */
        int handoff = hybrid ? 3 : 0;
        CHECK(trace(&d, &s, spec, 11, handoff, gate) == 0);
        CHECK(trace(&h, &s, NULL, 12, handoff, gate) == 0);
        const char *what = hybrid ? "hybrid (handoff after 3)" : "transport (gate 40 mm)";
        printf(" %s: device %.1f photons/ms, host %.1f\n", what, 1e-3 * (double)d.r.photons / d.r.seconds,
               1e-3 * (double)h.r.photons / h.r.seconds);
        CHECK_MSG(strcmp(d.r.device, "") != 0 && h.r.device[0] == '\0', "device '%s', host '%s'", d.r.device,
                  h.r.device);
        books("device", &d.r);
        books("host", &h.r);
        same_total("absorbed", d.r.power_absorbed, h.r.power_absorbed, d.r.power_absorbed_se, h.r.power_absorbed_se);
        same_total("out", d.r.power_out, h.r.power_out, d.r.power_out_se, h.r.power_out_se);
        /* gated and handed off: binomial-like, their se from the photons' count */
        double N = (double)d.r.photons;
        if (hybrid) {
            double p = h.r.power_handoff;
            same_total("handed off", d.r.power_handoff, p, sqrt(p * (1 - p) / N), sqrt(p * (1 - p) / N));
            CHECK(d.r.power_handoff > 0.3);
            double sum_d = 0, sum_h = 0;
            for (int64_t v = 0; v < s.net.n; ++v) sum_d += d.handoff[v], sum_h += h.handoff[v];
            CHECK_MSG(fabs(sum_d - d.r.power_handoff) <= 1e-10 && fabs(sum_h - h.r.power_handoff) <= 1e-10,
                      "the handoff field sums to %.15g (device) %.15g (host)", sum_d, sum_h);
        } else {
            double p = h.r.power_gated;
            same_total("gated", d.r.power_gated, p, sqrt(p * (1 - p) / N), sqrt(p * (1 - p) / N));
            CHECK(d.r.power_gated > 0.01);
        }
        same_field("fluence", d.phi, d.phi_se, h.phi, h.phi_se, s.net.n);
        traced_free(&d);
        traced_free(&h);
    }
    /* a seed repeats itself, another does not */
    traced a = {0}, b = {0}, c = {0};
    CHECK(trace(&a, &s, spec, 5, 0, 0) == 0);
    CHECK(trace(&b, &s, spec, 5, 0, 0) == 0);
    CHECK(trace(&c, &s, spec, 6, 0, 0) == 0);
    double same = 0, other = 0, peak = 0;
    for (int64_t v = 0; v < s.net.n; ++v) {
        same = fmax(same, fabs(a.phi[v] - b.phi[v]));
        other = fmax(other, fabs(a.phi[v] - c.phi[v]));
        peak = fmax(peak, a.phi[v]);
    }
    printf("  seed 5 twice: fluence differs by %.3g of the peak; seed 6: %.3g\n", same / peak, other / peak);
    CHECK_MSG(same <= 1e-12 * peak && fabs(a.r.power_absorbed - b.r.power_absorbed) <= 1e-12,
              "the same seed: %.3g of the peak apart", same / peak);
    CHECK_MSG(other > 1e-3 * peak, "another seed: only %.3g of the peak apart", other / peak);
    traced_free(&a), traced_free(&b), traced_free(&c);
    scene_free(&s);
}

/* ---- through ohm_solve ---- */

static void through_solve(const char *spec)
{
    ohm_error err;
    ohm_error_clear(&err);
    ohm_voxel_grid g;
    ohm_solution sol;
    CHECK(ohm_scene_box(&g, 12, 12, 12, 0.5, &err) == 0);
    ohm_material m = ohm_scene_grey(0.05, 1.0);
    m.g = 0.5;
    ohm_light l = ohm_scene_pencil((const double[3]){3.1, 3.1, 9.0}, (const double[3]){0, 0, -1.0});
    ohm_solve_params p;
    memset(&p, 0, sizeof p);
    p.num.solver = OHM_SOLVER_MC;
    p.mc = (ohm_mc_params){.photons = 20000, .seed = 3, .device = req_of(spec)};
    ohm_log quiet = {.verbosity = 0};
    CHECK_MSG(ohm_solve(&sol, &g, &m, &l, 1, &p, &quiet, &err) == 0, "%s", err.msg);
    printf("solver=mc device=%s: on '%s', in %.6f = absorbed %.6f + out %.6f\n", spec, sol.device, sol.power_in,
           sol.power_absorbed, sol.power_out);
    CHECK(sol.device[0] != '\0');
    CHECK(fabs(sol.power_in - sol.power_absorbed - sol.power_out) <= 1e-10 * sol.power_in);
    ohm_solution_free(&sol);
    ohm_voxel_grid_free(&g);
}

/* ---- refusals ---- */

static void refused(const char *what, const scene *s, const char *spec, int code, const char *says)
{
    traced t = {0};
    size_t n = (size_t)s->net.n, nf = (size_t)s->net.nfaces;
    t.phi = calloc(n, 8), t.phi_se = calloc(n, 8), t.face = calloc(nf, 8), t.exit_se = calloc(n, 8);
    t.r = (ohm_mc_result){.fluence = t.phi, .fluence_se = t.phi_se, .face_exitance = t.face, .exitance_se = t.exit_se};
    ohm_mc_params p = {.photons = 1000, .seed = 1, .device = req_of(spec)};
    ohm_error err;
    ohm_error_clear(&err);
    int rc = ohm_mc_trace(&t.r, &s->net, &s->med, s->in.entry, s->in.count, 0, &p, &err);
    printf("  %s: %d, '%s'\n", what, rc, err.msg);
    CHECK_MSG(rc == code && strstr(err.msg, says) && !strchr(err.msg, '\n'), "%s: %d '%s', expected %d '%s'", what,
              rc, err.msg, code, says);
    traced_free(&t);
}

/* A run asked to stop: the device stops after its first launch with
 * OHM_ERR_CANCELLED, and the next run on the same scene traces normally. */
static void cancelled(const char *spec)
{
    scene s;
    CHECK(scene_build(&s) == 0);
    atomic_int stop = 1;
    ohm_log log = {.verbosity = 0, .cancel = &stop};
    size_t n = (size_t)s.net.n, nf = (size_t)s.net.nfaces;
    double *phi = calloc(n, 8), *se = calloc(n, 8), *face = calloc(nf, 8), *ese = calloc(n, 8);
    ohm_mc_result r = {.fluence = phi, .fluence_se = se, .face_exitance = face, .exitance_se = ese};
    ohm_mc_params p = {.photons = 10000000, .seed = 1, .device = req_of(spec), .log = &log};
    ohm_error err;
    ohm_error_clear(&err);
    int rc = ohm_mc_trace(&r, &s.net, &s.med, s.in.entry, s.in.count, 0, &p, &err);
    printf("a cancelled run: %d, '%s' after %.2f s\n", rc, err.msg, r.seconds);
    CHECK_MSG(rc == OHM_ERR_CANCELLED && strstr(err.msg, "cancelled"), "%d '%s'", rc, err.msg);
    atomic_store(&stop, 0);
    p.photons = 16000;
    ohm_error_clear(&err);
    CHECK_MSG(ohm_mc_trace(&r, &s.net, &s.med, s.in.entry, s.in.count, 0, &p, &err) == 0 && r.power_absorbed > 0,
              "after a cancel: %s", err.msg);
    free(phi), free(se), free(face), free(ese);
    scene_free(&s);
}

static void refusals(const char *spec)
{
    scene s;
    CHECK(scene_build(&s) == 0);
    refused("no such device", &s, "opencl:99", OHM_ERR_INVALID, "opencl:99");
    setenv("OHM_TEST_DEVICE_MEMORY_MB", "1", 1);
    refused("too little device memory", &s, spec, OHM_ERR_NOMEM, "more than 90% of the device's");
    unsetenv("OHM_TEST_DEVICE_MEMORY_MB");
    setenv("OHM_TEST_KERNEL_OPTIONS", "-D WG=", 1);
    refused("a kernel that fails to build", &s, spec, OHM_ERR_INTERNAL, "failed to build");
    unsetenv("OHM_TEST_KERNEL_OPTIONS");
    setenv("OHM_TEST_DEVICE_LACKS", "atomics64", 1);
    refused("a device without 64-bit atomics", &s, spec, OHM_ERR_INVALID, "has no 64-bit atomics");
    setenv("OHM_TEST_DEVICE_LACKS", "fp64", 1);
    refused("a device without double precision", &s, spec, OHM_ERR_INVALID, "has no double precision");
    unsetenv("OHM_TEST_DEVICE_LACKS");
    setenv("OHM_OPENCL_LIBRARY", "/nonexistent/libOpenCL.so.1", 1);
    refused("no runtime", &s, "gpu", OHM_ERR_INVALID, "OpenCL");
    traced t = {0};
    CHECK_MSG(trace(&t, &s, "auto", 1, 0, 0) == 0 && t.r.device[0] == '\0' && t.r.power_absorbed > 0,
              "device=auto without a runtime: the host");
    traced_free(&t);
    unsetenv("OHM_OPENCL_LIBRARY");
    scene_free(&s);
}

int main(void)
{
    char spec[32];
    if (!device_for_test(spec)) return check_summary();
    philox_known_answers(spec);
    published(spec);
    against_host(spec);
    through_solve(spec);
    cancelled(spec);
    refusals(spec);
    return check_summary();
}
