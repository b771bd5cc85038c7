/* bench.c — `ohm bench`: the seed paper's Table 2 for any mesh (see bench.h).
 *
 * One run: measure the machine (memory bandwidth, dense flop rate, available
 * memory), read and scale the mesh, then per grid size voxelize with the
 * bounding box fitted into the grid and ohm_solve `frames` lights.  With max=1
 * the 128x128x64 pattern grows by 1.25 per axis while the factor, estimated
 * from the symbolic analysis alone, fits in a share of the available memory;
 * only the largest grid that fits is factorized.  Results live in the structs
 * below, passed down and printed at the end: Markdown on stdout and md=, CSV
 * on csv=, progress on stderr. */
#include "base/options.h"
#include "studies/bench.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "solvers/direct.h"
#include "physics/light.h"
#include "base/log.h"
#include "physics/material.h"
#include "input/mesh.h"
#include "physics/network.h"
#include "base/ohm_error.h"
#include "base/output.h"
#include "solvers/solve.h"
#include "studies/device_bench.h"
#include "studies/subcommand.h"
#include "studies/triad.h"
#include "grid/voxelize.h"

/* The BLAS that CHOLMOD links (OpenBLAS on Debian): dense dgemm is the
 * ceiling a supernodal factorization can approach. */
void dgemm_(const char *transa, const char *transb, const int *m, const int *n, const int *k, const double *alpha,
            const double *a, const int *lda, const double *b, const int *ldb, const double *beta, double *c,
            const int *ldc);

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

enum { BENCH_MAX_SIZES = 32, BENCH_MAX_DIM = 4096 };

/* The paper's four Al/Dolphin grids and the next doubling. */
#define DEFAULT_SIZES_TEXT "8x8x4,16x16x8,32x32x16,64x64x32,128x128x64"

/* Machine measurement sizes.  The triad's three arrays together are ~200 MB,
 * far beyond the per-core caches: it measures what these threads can stream,
 * which is what a solve reading L gets too.  dgemm at n = 2000 runs near the
 * BLAS's peak.  Best of several: the fastest run is the least disturbed. */
static const double TRIAD_TOTAL_BYTES = 200e6;
static const int TRIAD_REPEATS = 5;
static const int DGEMM_N = 2000;
static const int DGEMM_REPEATS = 3;

/* max=1 grows 128x128x64 by this per axis per step. */
static const double MAX_GROWTH = 1.25;
static const int MAX_STEPS = 24;

/* Light orbit: elevation above the horizontal plane (the mesh's y is up, as
 * in OBJ files and the samples). */
static const double ORBIT_ELEVATION = M_PI / 4;

typedef struct bench_options {
    const char *mesh;
    double size_mm;
    const char *material;
    int sizes[BENCH_MAX_SIZES][3];
    size_t nsizes;
    int max;               /* also the largest grid that fits in memory       */
    double mem;            /* share of available memory max=1 may plan for    */
    double max_time;       /* max=1: stop when a predicted factor time exceeds this (s); 0: no limit */
    int frames;            /* lights, one per frame                           */
    int batch;             /* frames per solve; 0 = all of them               */
    const char *ordering;
    ohm_shadows shadows;
    const char *csv, *md;
    const char *device;    /* device=: also the device rows (device_bench.h); NULL: none */
    ohm_device_request device_request; /* the same, read once */
    int device_sizes[BENCH_MAX_SIZES]; /* the block medium's N^3 there     */
    size_t ndevice_sizes;
    double photons;        /* cube60 on the device; the host traces 1/100 (>= 1e5) */
    ohm_opt_values given;  /* the words as given (bench_opts); the texts above point into it */
} bench_options;

typedef struct bench_machine {
    int threads;           /* as OpenBLAS would use                           */
    double bandwidth;      /* triad, bytes/s                                  */
    double dense_rate;     /* dgemm, flop/s                                   */
    double available;      /* memory, bytes                                   */
    char *device_tables;   /* device=: its Markdown tables (device_bench.h), or NULL */
} bench_machine;

typedef struct bench_row {
    int fit[3];
    int is_max;
    int32_t dims[3];
    double h;
    int flipped;           /* the mesh is wound inside-out (for shadow rays)  */
    int64_t cells, faces;
    int channels, factors, frames, batch;
    double t_voxelize, t_shadow_setup, t_assemble, t_analyze, t_factor, t_source, t_solve;
    double nnz_A_upper, nnz_L, flops, residual;
    char ordering[16];
} bench_row;

/* What the table shows, derived from a row and the machine. */
typedef struct bench_figures {
    double nnz_A;          /* both triangles, as the paper counts             */
    double upper_bound;    /* n(n+1)/2                                        */
    double factor_one;     /* analyse + one numeric factorization (s)         */
    double factor_all;     /* analyse + every channel's factorization (s)     */
    double lights;         /* right-hand sides: frames x channels             */
    double source_light, solve_light, update_light, update_frame; /* s         */
    double bound_light;    /* bandwidth bound of one solve (s)                */
    double solve_ratio;    /* solve_light / bound_light                       */
    double factor_rate;    /* flop/s of one factorization                     */
    double factor_fraction;/* of the dgemm rate                               */
} bench_figures;

/* ---- usage and option parsing ------------------------------------------------ */

/* `ohm bench`'s options (base/options.h: the words checked as the
 * pipeline's are; the lists below are read after) */
static const ohm_opt_spec bench_opts[] = {
    {"mesh", OHM_OPT_STRING, "samples/spot.obj", "mesh to read", NULL, 0, 0, 0},
    {"size", OHM_OPT_REAL, "50", "scale the longest axis to this many mm", NULL, 1e-6, 1e9, 0},
    {"material", OHM_OPT_STRING, "marble", "measured preset", NULL, 0, 0, 0},
    {"sizes", OHM_OPT_STRING, DEFAULT_SIZES_TEXT, "grids, e.g. 8x8x4,16x16x8", NULL, 0, 0, 0},
    {"max", OHM_OPT_ENUM, "0", "also the largest grid that fits", "0|1", 0, 0, 0},
    {"mem", OHM_OPT_REAL, "0.6", "share of the available memory max=1 may plan for", NULL, 1e-6, 0.95, 0},
    {"max_time", OHM_OPT_REAL, "0", "max=1: stop growing past this predicted factorization time (s)", NULL, 0, 1e9,
     0},
    {"frames", OHM_OPT_INT, "16", "lights, one per frame", NULL, 1, 100000, 0},
    {"batch", OHM_OPT_STRING, "1", "frames per solve, or all", NULL, 0, 0, 0},
    {"ordering", OHM_OPT_ENUM, "grid", "the factor's ordering", "metis|amd|nesdis|grid|best", 0, 0, 0},
    {"shadows", OHM_OPT_ENUM, "mesh", "shadow rays in the source", "mesh|grid|none", 0, 0, 0},
    {"csv", OHM_OPT_STRING, NULL, "every raw figure, one row per grid", NULL, 0, 0, 0},
    {"md", OHM_OPT_STRING, NULL, "the Markdown table", NULL, 0, 0, 0},
    {"device", OHM_OPT_DEVICE, NULL, "also an OpenCL device against this machine's cores", NULL, 0, 0, 0},
    {"device_sizes", OHM_OPT_STRING, "100,216", "the block medium's N^3 grids on the device", NULL, 0, 0, 0},
    {"photons", OHM_OPT_REAL, "1e6", "cube60's photons on the device", NULL, 16, 1e12, 0},
    {0}};

static void usage(FILE *f)
{
    fprintf(f,
            "usage: ohm bench [key=value ...]\n"
            "\n"
            "The seed paper's Table 2 (Sharp & Machiraju) for any mesh: for each grid size the mesh's bounding\n"
            "box is fitted into that many cells (cubic voxels, largest count on the longest axis), and one light\n"
            "per frame, a directional light orbiting the vertical (y) axis, is solved with one Cholesky\n"
            "factorization per distinct channel.  The machine's memory bandwidth (triad) and dense flop rate\n"
            "(dgemm) are measured in the same run, and every solve and factorization is shown against them.\n"
            "Markdown table on stdout, progress on stderr.\n"
            "\n"
            "  mesh=FILE        mesh to read (default samples/spot.obj)\n"
            "  size=MM          scale the longest axis to this many mm (default 50)\n"
            "  material=NAME    measured preset (default marble): %s\n"
            "  sizes=LIST       grids, e.g. 8x8x4,16x16x8 (default " DEFAULT_SIZES_TEXT ")\n"
            "  max=0|1          also the largest grid that fits: 128x128x64 grown by %.2f per axis until the factor\n"
            "                   (estimated from the symbolic analysis, before factorizing) would take more than\n"
            "                   mem= of the available memory (default 0)\n"
            "  mem=FRACTION     share of available memory that max=1 may plan for (default 0.6)\n"
            "  max_time=S       max=1: also stop growing when the predicted factorization time exceeds S seconds\n"
            "                   (default 0: no limit)\n"
            "  frames=N         lights, one per frame (default 16)\n"
            "  batch=N|all      frames per solve: 1 solves one light at a time, the interactive case (default 1)\n"
            "  ordering=NAME    metis|amd|nesdis|grid|best (default grid, what -solve picks for a mesh)\n"
            "  shadows=MODE     shadow rays in the source: mesh (Embree, as -solve does) | grid | none (default mesh)\n"
            "  csv=FILE         every raw figure, one row per grid\n"
            "  md=FILE          the Markdown table\n"
            "  device=D         also an OpenCL device against this machine's cores (gpu, cpu, opencl:N, auto; see\n"
            "                   'ohm devices'): solver=mg on the block medium (sigma_s' 1 or 1e6 in blocks of 8^3)\n"
            "                   and the Monte Carlo tracer on MCX's cube60 (default: none)\n"
            "  device_sizes=N,...  the block medium's N^3 grids on the device (default 100,216: 1e6, 1e7 cells)\n"
            "  photons=N        cube60's photons on the device; the host traces N/100, at least 1e5 (default 1e6)\n",
            ohm_preset_names, MAX_GROWTH);
}

/* "bench: WHAT (see 'ohm bench help')", exit code 2. */
static int usage_error(ohm_error *err, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
static int usage_error(ohm_error *err, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int rc = ohm_subcommand_usage_error(err, "bench", fmt, ap);
    va_end(ap);
    return rc;
}

static int parse_long(const char *s, long lo, long hi, long *out)
{
    if (!*s) return -1;
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (*end || errno == ERANGE || v < lo || v > hi) return -1;
    *out = v;
    return 0;
}

/* "8x8x4,16x16x8": three positive counts per size, nothing else. */
static int parse_sizes(bench_options *o, const char *text, ohm_error *err)
{
    o->nsizes = 0;
    const char *p = text;
    for (;;) {
        if (o->nsizes == BENCH_MAX_SIZES)
            return ohm_fail(err, OHM_ERR_USAGE, "bench: sizes=: more than %d sizes (see 'ohm bench help')",
                            BENCH_MAX_SIZES);
        int *s = o->sizes[o->nsizes];
        for (int a = 0; a < 3; ++a) {
            char *end;
            errno = 0;
            long v = *p >= '0' && *p <= '9' ? strtol(p, &end, 10) : -1;
            if (v < 1 || v > BENCH_MAX_DIM || errno || (a < 2 && *end != 'x'))
                return usage_error(err, "sizes=%s: expected a list like %s (cells per axis, 1 to 4096)", text,
                                   DEFAULT_SIZES_TEXT);
            s[a] = (int)v;
            p = a < 2 ? end + 1 : end;
        }
        o->nsizes++;
        if (!*p) return OHM_OK;
        if (*p++ != ',')
            return usage_error(err, "sizes=%s: expected a list like %s (cells per axis, 1 to 4096)", text,
                               DEFAULT_SIZES_TEXT);
    }
}

static int parse_options(bench_options *o, int argc, char **argv, ohm_error *err)
{
    memset(o, 0, sizeof *o);
    int rc = ohm_opt_words(&o->given, bench_opts, "bench", argc, (const char *const *)argv, err);
    if (rc) return rc;
    const ohm_opt_values *g = &o->given;
    double x;
    long long n;
    o->mesh = ohm_opt_text(g, "mesh");
    ohm_opt_parse_real(ohm_opt_text(g, "size"), &o->size_mm);
    o->material = ohm_opt_text(g, "material");
    ohm_material m;
    if (ohm_material_preset(&m, o->material, NULL))
        return usage_error(err, "material=%s: expected a preset: %s", o->material, ohm_preset_names);
    rc = parse_sizes(o, ohm_opt_text(g, "sizes"), err);
    if (rc) return rc;
    o->max = strcmp(ohm_opt_text(g, "max"), "1") == 0;
    ohm_opt_parse_real(ohm_opt_text(g, "mem"), &o->mem);
    ohm_opt_parse_real(ohm_opt_text(g, "max_time"), &o->max_time);
    ohm_opt_parse_int(ohm_opt_text(g, "frames"), &n);
    o->frames = (int)n;
    const char *batch = ohm_opt_text(g, "batch");
    if (strcmp(batch, "all") == 0) o->batch = 0;
    else if (ohm_opt_parse_int(batch, &n) || n < 1 || n > 100000)
        return usage_error(err, "batch=%s: expected 'all' or an integer from 1 to 100000", batch);
    else o->batch = (int)n;
    o->ordering = ohm_opt_text(g, "ordering");
    const char *sh = ohm_opt_text(g, "shadows");
    o->shadows = strcmp(sh, "grid") == 0 ? OHM_SHADOWS_GRID : strcmp(sh, "none") == 0 ? OHM_SHADOWS_NONE
                                                                                        : OHM_SHADOWS_MESH;
    o->csv = ohm_opt_text(g, "csv");
    o->md = ohm_opt_text(g, "md");
    o->device = ohm_opt_text(g, "device");
    /* read once: typed from here on (the host is the baseline, not a device to compare) */
    if (o->device && (ohm_device_request_parse(&o->device_request, o->device, NULL) ||
                      o->device_request.kind == OHM_DEVICE_HOST))
        return usage_error(err, "device=%s: expected gpu, cpu, opencl:N or auto", o->device);
    const char *ds = ohm_opt_text(g, "device_sizes");
    for (const char *q = ds; *q;) {
        char *end;
        long nx = strtol(q, &end, 10);
        if (end == q || nx < 8 || nx > 2000 || o->ndevice_sizes == BENCH_MAX_SIZES || (*end && *end != ','))
            return usage_error(err, "device_sizes=%s: expected grid sizes 8..2000, e.g. 100,216", ds);
        o->device_sizes[o->ndevice_sizes++] = (int)nx;
        q = *end ? end + 1 : end;
    }
    if (!o->ndevice_sizes) return usage_error(err, "device_sizes=: expected grid sizes, e.g. 100,216");
    ohm_opt_parse_real(ohm_opt_text(g, "photons"), &x);
    o->photons = x;
    return OHM_OK;
}

/* ---- the machine ------------------------------------------------------------- */

/* Threads the BLAS uses: OpenBLAS reads these variables, else takes every
 * online processor; the triad uses as many so the two rates are comparable. */
static int blas_threads(void)
{
    const char *vars[] = {"OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS"};
    for (size_t i = 0; i < sizeof vars / sizeof *vars; ++i) {
        const char *v = getenv(vars[i]);
        long n;
        if (v && !parse_long(v, 1, 1024, &n)) return (int)n;
    }
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n < 1 ? 1 : n > 1024 ? 1024 : (int)n;
}

/* Bytes this process may still allocate: MemAvailable, lowered by a cgroup
 * limit when one is set (containers report the host's memory otherwise). */
static double available_memory(void)
{
    double avail = 0;
    FILE *f = fopen("/proc/meminfo", "r");
    if (f) {
        char line[256];
        double kb;
        while (fgets(line, sizeof line, f))
            if (sscanf(line, "MemAvailable: %lf kB", &kb) == 1) avail = kb * 1024.0;
        fclose(f);
    }
    if (!(avail > 0)) avail = (double)sysconf(_SC_PHYS_PAGES) * (double)sysconf(_SC_PAGESIZE);
    const char *limits[][2] = {{"/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current"},
                               {"/sys/fs/cgroup/memory/memory.limit_in_bytes",
                                "/sys/fs/cgroup/memory/memory.usage_in_bytes"}};
    for (size_t i = 0; i < 2; ++i) {
        double limit = 0, used = 0;
        FILE *fl = fopen(limits[i][0], "r"), *fu = fopen(limits[i][1], "r");
        int ok = fl && fu && fscanf(fl, "%lf", &limit) == 1 && fscanf(fu, "%lf", &used) == 1;
        if (fl) fclose(fl);
        if (fu) fclose(fu);
        /* "max" (v2) fails to scan; v1's "no limit" is ~2^63 */
        if (ok && limit > 0 && limit < 1e18 && limit - used < avail) avail = fmax(0.0, limit - used);
    }
    return avail;
}

static int measure_bandwidth(bench_machine *m, ohm_error *err)
{
    return ohm_triad(m->threads, TRIAD_TOTAL_BYTES, TRIAD_REPEATS, &m->bandwidth, err);
}

static int measure_dgemm(bench_machine *m, ohm_error *err)
{
    const int n = DGEMM_N;
    size_t nn = (size_t)n * (size_t)n;
    double *A = malloc(nn * sizeof *A), *B = malloc(nn * sizeof *B), *C = malloc(nn * sizeof *C);
    if (!A || !B || !C) {
        free(A), free(B), free(C);
        return ohm_fail(err, OHM_ERR_NOMEM, "bench: out of memory for the n = %d dgemm test", n);
    }
    /* any values away from 0 and denormals do; these are cheap */
    for (size_t i = 0; i < nn; ++i) {
        A[i] = 1.0 + (double)(i % 7) * 0.125;
        B[i] = 1.0 - (double)(i % 5) * 0.0625;
    }
    const double one = 1.0, zero = 0.0;
    double best = INFINITY;
    for (int r = 0; r < DGEMM_REPEATS; ++r) {
        double t0 = ohm_now();
        dgemm_("N", "N", &n, &n, &n, &one, A, &n, B, &n, &zero, C, &n);
        best = fmin(best, ohm_now() - t0);
    }
    int sane = isfinite(C[0]) && C[0] > 0;
    free(A), free(B), free(C);
    if (!sane || !(best > 0)) return ohm_fail(err, OHM_ERR_INTERNAL, "bench: the dgemm test went wrong");
    m->dense_rate = 2.0 * n * (double)n * (double)n / best;
    return OHM_OK;
}

static int measure_machine(bench_machine *m, const ohm_log *log, ohm_error *err)
{
    memset(m, 0, sizeof *m);
    m->threads = blas_threads();
    m->available = available_memory();
    int rc = measure_bandwidth(m, err);
    if (!rc) rc = measure_dgemm(m, err);
    if (rc) return rc;
    ohm_log_info(log, "bench: machine: %d threads, memory bandwidth %.1f GB/s (triad), dgemm %.1f GFlop/s, %.1f GB "
                 "available",
                 m->threads, m->bandwidth / 1e9, m->dense_rate / 1e9, m->available / 1e9);
    return OHM_OK;
}

/* ---- one grid -------------------------------------------------------------- */

static int distinct_channels(const ohm_material *mat)
{
    int k = 0;
    for (int c = 0; c < mat->channels; ++c) k += ohm_material_channel_class(mat, c) == c;
    return k;
}

static int voxelize_fit(ohm_voxel_grid *g, double *t, int *flipped, const ohm_mesh *mesh, const int fit[3],
                        ohm_error *err)
{
    static const ohm_log quiet = {.verbosity = 0};
    ohm_voxelize_params vp;
    memset(&vp, 0, sizeof vp);
    memcpy(vp.fit, fit, sizeof vp.fit);
    ohm_voxelize_report vr;
    double t0 = ohm_now();
    int rc = ohm_voxelize(g, &vr, mesh, &vp, &quiet, err);
    *t = ohm_now() - t0;
    *flipped = vr.flipped;
    return rc;
}

/* Solve `frames` orbiting lights on grid g and fill the row's figures. */
static int solve_grid(bench_row *row, const ohm_voxel_grid *g, const ohm_mesh *mesh, const ohm_material *mat,
                      const bench_options *o, const ohm_log *log, ohm_error *err)
{
    static const ohm_log quiet = {.verbosity = 0};
    ohm_light *lights = calloc((size_t)o->frames, sizeof *lights);
    if (!lights) return ohm_fail(err, OHM_ERR_NOMEM, "bench: out of memory for %d lights", o->frames);
    for (int f = 0; f < o->frames; ++f) {
        /* calloc: fields the light gains later keep their zero defaults */
        ohm_light *l = &lights[f];
        double az = 2.0 * M_PI * f / o->frames, ce = cos(ORBIT_ELEVATION);
        l->type = OHM_LIGHT_DIRECTIONAL;
        l->dir[0] = -ce * cos(az);
        l->dir[1] = -sin(ORBIT_ELEVATION);
        l->dir[2] = -ce * sin(az);
        l->intensity[0] = 1.0;
        l->channels = 1;
        l->frame = f + 1;
    }
    int batch = o->batch == 0 || o->batch > o->frames ? o->frames : o->batch;
    ohm_solve_params p;
    memset(&p, 0, sizeof p);
    p.op.boundary = OHM_BOUNDARY_ROBIN;
    p.num.ordering = o->ordering;
    p.src.deposit = OHM_DEPOSIT_EXPONENTIAL;
    p.src.shadows = o->shadows;
    p.src.mesh = mesh;
    p.src.orientation = row->flipped ? -1 : 1;
    /* ohm_solve takes cap / (2 x 8 x n) frames per batch: exactly `batch` */
    p.num.max_rhs_bytes = 2.0 * sizeof(double) * (double)g->interior_cells * batch;
    ohm_log_info(log, "bench: %dx%dx%d: %zu cells; solving %d frame(s) x %d channel(s), %d per solve", row->fit[0],
                 row->fit[1], row->fit[2], g->interior_cells, o->frames, mat->channels, batch);
    ohm_solution sol;
    int rc = ohm_solve(&sol, g, mat, lights, (size_t)o->frames, &p, &quiet, err);
    free(lights);
    if (rc) return rc;
    row->cells = sol.n;
    row->faces = sol.net.nfaces;
    row->channels = sol.channels;
    row->factors = sol.factors;
    row->frames = sol.frames;
    row->batch = batch;
    row->t_shadow_setup = sol.t_shadow_setup;
    row->t_assemble = sol.t_assemble;
    row->t_analyze = sol.t_analyze;
    row->t_factor = sol.t_factor;
    row->t_source = sol.t_source;
    row->t_solve = sol.t_solve;
    row->nnz_A_upper = sol.nnz_A;
    row->nnz_L = sol.nnz_L;
    row->flops = sol.flops;
    row->residual = sol.residual;
    snprintf(row->ordering, sizeof row->ordering, "%s", sol.ordering);
    ohm_solution_free(&sol);
    ohm_log_info(log, "bench: %dx%dx%d: analyse %.3f s, %d factorization(s) %.3f s, %lld solve(s) %.3f s, sources %.3f s",
                 row->fit[0], row->fit[1], row->fit[2], row->t_analyze, row->factors, row->t_factor,
                 (long long)row->frames * row->channels, row->t_solve, row->t_source);
    return OHM_OK;
}

static void row_from_grid(bench_row *row, const int fit[3], const ohm_voxel_grid *g, int flipped)
{
    row->flipped = flipped;
    memcpy(row->fit, fit, sizeof row->fit);
    memcpy(row->dims, g->dims, sizeof row->dims);
    row->h = g->h;
    row->cells = (int64_t)g->interior_cells;
}

/* ---- max=1: the largest grid that fits ---------------------------------------- */

typedef struct bench_plan {
    double nnz_L, flops;   /* from the symbolic analysis                       */
    double factor_bytes;   /* L's values, indices and CHOLMOD's workspace      */
    double bytes;          /* factor + the solve's own arrays                  */
} bench_plan;

/* Analyse grid g (channel 0's matrix: every channel has the same pattern) and
 * estimate what ohm_solve will hold at its peak, without factorizing. */
static int plan_grid(bench_plan *plan, const ohm_voxel_grid *g, const ohm_material *mat, const bench_options *o,
                     ohm_error *err)
{
    memset(plan, 0, sizeof *plan);
    ohm_network net;
    int rc = ohm_network_build(&net, g, NULL, err);
    if (rc) return rc;
    ohm_cholesky s;
    rc = ohm_cholesky_start(&s, err);
    if (rc) {
        ohm_network_free(&net);
        return rc;
    }
    ohm_channel_medium med;
    memset(&med, 0, sizeof med);
    med.sigma_a0 = mat->sigma_a[0];
    med.sigma_s0 = mat->sigma_s[0];
    med.eta = mat->eta;
    cholmod_sparse *A = NULL;
    rc = ohm_network_assemble(&A, NULL, NULL, &net, &med, OHM_BOUNDARY_ROBIN, &s.cc, err);
    ohm_grid_layout layout = ohm_grid_layout_of(&net);
    if (!rc) rc = ohm_cholesky_analyze(&s, A, o->ordering, &layout, NULL, NULL, err);
    if (!rc) {
        const cholmod_factor *F = s.symbolic;
        plan->nnz_L = s.nnz_L;
        plan->flops = s.flops;
        /* A supernodal factor stores its supernodes' dense blocks (xsize
         * values, more than nnz(L): relaxed amalgamation stores some zeros),
         * their row indices (ssize, in the numeric copy and in the kept
         * symbolic factor) and factorizes through an update workspace
         * (maxcsize).  The brief rule "nnz(L) x 8 bytes" is the floor. */
        double values = F->is_super ? fmax((double)F->xsize, s.nnz_L) : s.nnz_L;
        double extra = F->is_super ? 2.0 * (double)F->ssize + (double)F->maxcsize : s.nnz_L;
        plan->factor_bytes = 8.0 * (values + extra);
        double n = (double)net.n, frames = o->frames;
        double batch = o->batch == 0 || o->batch > o->frames ? frames : o->batch;
        double grid_cells = (double)g->dims[0] * g->dims[1] * g->dims[2];
        /* solution (fluence + exitance per frame and channel, face exitance),
         * right-hand sides in and out, the network and A */
        double solution = 8.0 * mat->channels * frames * (2.0 * n + (double)net.nfaces);
        double rhs = 4.0 * 8.0 * n * batch;
        double network = 8.0 * (grid_cells + 3.0 * n + 2.0 * (double)net.nfaces) + 16.0 * s.nnz_A;
        plan->bytes = plan->factor_bytes + solution + rhs + network;
    }
    cholmod_l_free_sparse(&A, &s.cc);
    ohm_cholesky_finish(&s);
    ohm_network_free(&net);
    return rc;
}

/* Grow 128x128x64 by MAX_GROWTH per axis; keep the last grid whose plan fits.
 * *found = 0 when not even the first step fits. */
static int find_max(bench_row *row, int *found, const ohm_mesh *mesh, const ohm_material *mat,
                    const bench_options *o, const bench_machine *m, double rate_hint, const ohm_log *log,
                    ohm_error *err)
{
    *found = 0;
    double budget = o->mem * m->available;
    int factors = distinct_channels(mat);
    ohm_voxel_grid best;
    memset(&best, 0, sizeof best);
    int best_fit[3] = {0, 0, 0};
    double best_tv = 0;
    int best_flipped = 0;
    int rc = OHM_OK;
    for (int k = 1; k <= MAX_STEPS && !rc; ++k) {
        double s = pow(MAX_GROWTH, k);
        int fit[3] = {(int)floor(128 * s + 0.5), (int)floor(128 * s + 0.5), (int)floor(64 * s + 0.5)};
        if (fit[0] > BENCH_MAX_DIM) break;
        ohm_voxel_grid g;
        double tv = 0;
        int flipped = 0;
        rc = voxelize_fit(&g, &tv, &flipped, mesh, fit, err);
        if (rc == OHM_ERR_NOMEM) { /* the dense voxel grid itself is too big */
            ohm_log_info(log, "bench: max: %dx%dx%d: %s", fit[0], fit[1], fit[2], err->msg);
            ohm_error_clear(err);
            rc = OHM_OK;
            break;
        }
        if (rc) break;
        bench_plan plan;
        double t0 = ohm_now();
        rc = plan_grid(&plan, &g, mat, o, err);
        double ta = ohm_now() - t0;
        if (rc) {
            ohm_voxel_grid_free(&g);
            break;
        }
        double predicted = plan.flops * factors / rate_hint;
        int fits = plan.bytes <= budget;
        int in_time = !(o->max_time > 0) || predicted <= o->max_time;
        ohm_log_info(log,
                     "bench: max: %dx%dx%d: %zu cells, nnz(L) %.3g: about %.2f GB at peak (factor %.2f GB) against "
                     "%.3g%% of %.1f GB available: %s; %.3g flops x %d factorization(s), about %.0f s at %.1f "
                     "GFlop/s (analysed in %.1f s)",
                     fit[0], fit[1], fit[2], g.interior_cells, plan.nnz_L, plan.bytes / 1e9, plan.factor_bytes / 1e9,
                     100 * o->mem, m->available / 1e9, fits ? "fits" : "does not fit", plan.flops, factors,
                     predicted, rate_hint / 1e9, ta);
        if (!fits || !in_time) {
            if (fits) ohm_log_info(log, "bench: max: stop: predicted factor time over max_time=%g s", o->max_time);
            ohm_voxel_grid_free(&g);
            break;
        }
        ohm_voxel_grid_free(&best);
        best = g;
        memcpy(best_fit, fit, sizeof best_fit);
        best_tv = tv;
        best_flipped = flipped;
        *found = 1;
    }
    if (!rc && *found) {
        memset(row, 0, sizeof *row);
        row_from_grid(row, best_fit, &best, best_flipped);
        row->is_max = 1;
        row->t_voxelize = best_tv;
        rc = solve_grid(row, &best, mesh, mat, o, log, err);
    } else if (!rc) {
        ohm_log_warn(log, "bench: max=1: no grid larger than 128x128x64 fits in %.3g%% of the available memory",
                     100 * o->mem);
    }
    ohm_voxel_grid_free(&best);
    return rc;
}

/* ---- output ------------------------------------------------------------------- */

static void figures(bench_figures *f, const bench_row *r, const bench_machine *m)
{
    memset(f, 0, sizeof *f);
    double n = (double)r->cells;
    f->nnz_A = 2.0 * r->nnz_A_upper - n; /* the diagonal once */
    f->upper_bound = n * (n + 1) / 2;
    int factors = r->factors > 0 ? r->factors : 1;
    f->factor_one = r->t_analyze + r->t_factor / factors;
    f->factor_all = r->t_analyze + r->t_factor;
    f->lights = (double)r->frames * r->channels;
    if (f->lights > 0) {
        f->source_light = r->t_source / f->lights;
        f->solve_light = r->t_solve / f->lights;
        f->update_light = f->source_light + f->solve_light;
        f->update_frame = (r->t_source + r->t_solve) / r->frames;
    }
    /* L read twice (forward and back substitution), 8 bytes per entry */
    f->bound_light = 2.0 * r->nnz_L * 8.0 / m->bandwidth;
    f->solve_ratio = f->bound_light > 0 ? f->solve_light / f->bound_light : 0;
    double tf = r->t_factor / factors;
    f->factor_rate = tf > 0 ? r->flops / tf : 0;
    f->factor_fraction = m->dense_rate > 0 ? f->factor_rate / m->dense_rate : 0;
}

/* 2.40e5, as the paper prints its counts */
static const char *sci(char *buf, size_t size, double x)
{
    if (!(x > 0)) {
        snprintf(buf, size, "0");
        return buf;
    }
    int e = (int)floor(log10(x));
    double mant = x / pow(10, e);
    if (mant >= 9.995) mant /= 10, ++e;
    snprintf(buf, size, "%.2fe%d", mant, e);
    return buf;
}

static const char *seconds(char *buf, size_t size, double t)
{
    snprintf(buf, size, t < 10 ? "%.4f" : "%.2f", t);
    return buf;
}

static const char *ms(char *buf, size_t size, double t)
{
    double v = t * 1e3;
    snprintf(buf, size, v < 0.01 ? "%.4f" : v < 10 ? "%.3f" : "%.1f", v);
    return buf;
}

static const char *base_name(const char *path)
{
    const char *s = strrchr(path, '/');
    return s ? s + 1 : path;
}

static void write_markdown(FILE *f, const bench_row *rows, size_t nrows, const bench_machine *m,
                           const bench_options *o, const ohm_material *mat)
{
    fprintf(f, "### ohm bench: %s, %g mm, %s\n\n", base_name(o->mesh), o->size_mm, mat->name);
    fprintf(f,
            "Machine: %d threads; memory bandwidth %.1f GB/s (triad on %.0f MB, best of %d); dense dgemm %.1f GFlop/s "
            "(n = %d, best of %d); %.1f GB available.  ",
            m->threads, m->bandwidth / 1e9, TRIAD_TOTAL_BYTES / 1e6, TRIAD_REPEATS, m->dense_rate / 1e9, DGEMM_N,
            DGEMM_REPEATS, m->available / 1e9);
    int batch = o->batch == 0 || o->batch > o->frames ? o->frames : o->batch;
    fprintf(f,
            "Lights: %d frames, one directional light each, orbiting the vertical (y) axis at 45 degrees elevation; "
            "shadow rays: %s; %d channel(s), %d factorization(s) per grid (one per distinct channel), ordering %s; %d "
            "light(s) per solve.\n\n",
            o->frames, ohm_shadows_name(o->shadows), mat->channels, distinct_channels(mat), o->ordering, batch);
    fprintf(f, "| grid | cells | factor, 1 channel (s) | factor, all (s) | source / light (ms) | solve / light (ms) | "
               "nnz(A) | nnz(L) | upper bound n(n+1)/2 | update / light (ms) | update / frame (ms) | solve / bound | "
               "factor GFlop/s | of dgemm |\n");
    fprintf(f, "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for (size_t i = 0; i < nrows; ++i) {
        const bench_row *r = &rows[i];
        bench_figures g;
        figures(&g, r, m);
        char b[14][32];
        fprintf(f, "| %dx%dx%d%s | %lld | %s | %s | %s | %s | %s | %s | %s | %s | %s | %.2f | %.1f | %.0f%% |\n",
                r->fit[0], r->fit[1], r->fit[2], r->is_max ? " (max)" : "", (long long)r->cells,
                seconds(b[0], 32, g.factor_one), seconds(b[1], 32, g.factor_all), ms(b[2], 32, g.source_light),
                ms(b[3], 32, g.solve_light), sci(b[4], 32, g.nnz_A), sci(b[5], 32, r->nnz_L),
                sci(b[6], 32, g.upper_bound), ms(b[7], 32, g.update_light), ms(b[8], 32, g.update_frame),
                g.solve_ratio, g.factor_rate / 1e9, 100 * g.factor_fraction);
    }
    fprintf(f,
            "\n"
            "* grid: the bounding box fitted into that many cells (cubic voxels, the largest count on the longest "
            "axis); cells: interior cells = unknowns n.\n"
            "* factor, 1 channel: analyse (ordering + symbolic, once per grid) + one numeric factorization; factor, "
            "all: analyse + every channel's factorization, what a run pays.\n"
            "* light: one right-hand side, one channel of one frame.  Source and solve are totals over frames x "
            "channels divided by their number; update / light = source + solve, the paper's interactive update; "
            "update / frame = all channels of one frame.\n"
            "* nnz(A) counts both triangles (as the paper does); nnz(L) includes the diagonal; upper bound "
            "n(n+1)/2 = a full triangular factor, the paper's \"Upper Bound Fill for L\".\n"
            "* solve / bound: solve time per light over its memory-bandwidth bound, L read twice (forward and back "
            "substitution) = 2 nnz(L) x 8 bytes / bandwidth; 8 bytes per entry (values only) because a supernodal "
            "factor's index traffic is small.  The solve time includes the backward-error check ohm makes after "
            "every solve.\n"
            "* factor GFlop/s: CHOLMOD's flop count for one factorization over its time; of dgemm: that rate over "
            "the dense dgemm rate above.\n");
    if (m->device_tables) fprintf(f, "\n%s", m->device_tables);
}

/* device=: the device's tables (device_bench.h) into m->device_tables. */
static int measure_device(bench_machine *m, const bench_options *o, const ohm_log *log, ohm_error *err)
{
    size_t size = 0;
    FILE *f = open_memstream(&m->device_tables, &size);
    if (!f) return ohm_fail(err, OHM_ERR_NOMEM, "bench: out of memory for the device's tables");
    ohm_log_info(log, "bench: device=%s: the block medium and cube60, on the device and on the host", o->device);
    fprintf(f, "### On device=%s: solver=mg on the block medium\n\n", o->device);
    fprintf(f, "σs′ 1 or 10⁶ in blocks of 8³ cells at random, σa 0.001/mm, robin; one light to 1e-10 from zero; "
               "the hierarchy built on the host once and copied to the device (timed apart).\n\n");
    ohm_device_bench_mg_header(f);
    int rc = OHM_OK;
    for (size_t i = 0; i < o->ndevice_sizes && !rc; ++i) rc = ohm_device_bench_mg(f, &o->device_request, o->device_sizes[i], err);
    if (!rc) {
        fprintf(f, "\n### On device=%s: the Monte Carlo tracer on MCX's cube60\n\n", o->device);
        fprintf(f, "60³ cells of 1 mm, σa 0.005, σs 1/mm, g 0.01, a pencil beam, no reflection, a 5 ns gate; the time "
                   "includes opening the device, building the kernels and copying the scene.\n\n");
        ohm_device_bench_mc_header(f);
        rc = ohm_device_bench_cube60(f, &o->device_request, (int64_t)o->photons, 1, err);
    }
    if (!rc) rc = ohm_device_bench_cube60(f, NULL, (int64_t)fmax(1e5, o->photons / 100), 1, err);
    fclose(f);
    return rc;
}

/* A CSV field: quoted when it holds a comma, quote or newline. */
static void csv_text(FILE *f, const char *s)
{
    if (!strpbrk(s, ",\"\n")) {
        fputs(s, f);
        return;
    }
    fputc('"', f);
    for (; *s; ++s) {
        if (*s == '"') fputc('"', f);
        fputc(*s, f);
    }
    fputc('"', f);
}

static void write_csv(FILE *f, const bench_row *rows, size_t nrows, const bench_machine *m, const bench_options *o,
                      const ohm_material *mat)
{
    fputs("mesh,size_mm,material,grid,fit_x,fit_y,fit_z,max,dims_x,dims_y,dims_z,voxel_mm,cells,boundary_faces,"
          "channels,factors,frames,batch,ordering,shadows,t_voxelize_s,t_shadow_setup_s,t_assemble_s,t_analyze_s,t_factorize_s,"
          "t_factor_one_channel_s,t_factor_all_s,t_source_s,t_solve_s,nnz_A,nnz_A_upper,nnz_L,upper_bound_fill,"
          "flops_per_factorization,source_per_light_s,solve_per_light_s,update_per_light_s,update_per_frame_s,"
          "solve_bound_per_light_s,solve_over_bound,factor_gflops,factor_fraction_of_dgemm,backward_error,"
          "bandwidth_gbs,dgemm_gflops,threads\n",
          f);
    for (size_t i = 0; i < nrows; ++i) {
        const bench_row *r = &rows[i];
        bench_figures g;
        figures(&g, r, m);
        csv_text(f, o->mesh);
        fprintf(f, ",%.17g,", o->size_mm);
        csv_text(f, mat->name);
        fprintf(f,
                ",%dx%dx%d,%d,%d,%d,%d,%d,%d,%d,%.9g,%lld,%lld,%d,%d,%d,%d,%s,%s,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,"
                "%.17g,%.17g,%.17g,%.17g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%d\n",
                r->fit[0], r->fit[1], r->fit[2], r->fit[0], r->fit[1], r->fit[2], r->is_max, r->dims[0], r->dims[1],
                r->dims[2], r->h, (long long)r->cells, (long long)r->faces, r->channels, r->factors, r->frames,
                r->batch, r->ordering, ohm_shadows_name(o->shadows), r->t_voxelize, r->t_shadow_setup, r->t_assemble, r->t_analyze, r->t_factor, g.factor_one,
                g.factor_all, r->t_source, r->t_solve, g.nnz_A, r->nnz_A_upper, r->nnz_L, g.upper_bound, r->flops,
                g.source_light, g.solve_light, g.update_light, g.update_frame, g.bound_light, g.solve_ratio,
                g.factor_rate / 1e9, g.factor_fraction, r->residual, m->bandwidth / 1e9, m->dense_rate / 1e9,
                m->threads);
    }
}

typedef void (*writer_fn)(FILE *, const bench_row *, size_t, const bench_machine *, const bench_options *,
                          const ohm_material *);

static int write_file(const char *path, writer_fn fn, const bench_row *rows, size_t nrows, const bench_machine *m,
                      const bench_options *o, const ohm_material *mat, ohm_error *err)
{
    ohm_output out;
    int rc = ohm_output_begin(&out, path, NULL, err);
    if (rc) return rc;
    fn(out.stream, rows, nrows, m, o, mat);
    rc = ohm_output_commit(&out, err);
    if (rc) ohm_output_abort(&out);
    return rc;
}

/* ---- the run ------------------------------------------------------------------ */

static int read_mesh(ohm_mesh *mesh, const bench_options *o, const ohm_log *log, ohm_error *err)
{
    int rc = ohm_mesh_read(mesh, o->mesh, err);
    if (rc) return rc;
    double lo[3], hi[3];
    ohm_mesh_bounds(mesh, lo, hi);
    double extent = fmax(hi[0] - lo[0], fmax(hi[1] - lo[1], hi[2] - lo[2]));
    if (!(extent > 0) || !isfinite(extent)) {
        ohm_mesh_free(mesh);
        return ohm_fail(err, OHM_ERR_INVALID, "%s: all vertices coincide, cannot scale to size=", o->mesh);
    }
    ohm_mesh_scale(mesh, o->size_mm / extent);
    ohm_log_info(log, "bench: %s: %zu triangles, %.4g x %.4g x %.4g mm", o->mesh, mesh->ntris,
                 (hi[0] - lo[0]) * o->size_mm / extent, (hi[1] - lo[1]) * o->size_mm / extent,
                 (hi[2] - lo[2]) * o->size_mm / extent);
    return OHM_OK;
}

static int run(const bench_options *o, const ohm_log *log, ohm_error *err)
{
    ohm_material mat;
    int rc = ohm_material_preset(&mat, o->material, err);
    if (rc) return rc;
    ohm_mesh mesh;
    rc = read_mesh(&mesh, o, log, err);
    if (rc) return rc;
    bench_machine machine = {0};
    bench_row *rows = calloc(o->nsizes + 1, sizeof *rows);
    size_t nrows = 0;
    if (!rows) rc = ohm_fail(err, OHM_ERR_NOMEM, "bench: out of memory");
    if (!rc) rc = measure_machine(&machine, log, err);
    if (!rc && o->device) rc = measure_device(&machine, o, log, err);
    for (size_t i = 0; i < o->nsizes && !rc; ++i) {
        bench_row *row = &rows[nrows];
        ohm_voxel_grid g;
        double tv = 0;
        int flipped = 0;
        rc = voxelize_fit(&g, &tv, &flipped, &mesh, o->sizes[i], err);
        if (rc) break;
        row_from_grid(row, o->sizes[i], &g, flipped);
        row->t_voxelize = tv;
        if (g.interior_cells == 0) {
            /* a thin object on a coarse grid: no row, but say so */
            ohm_log_warn(log, "bench: %dx%dx%d: no cell centre lies inside %s; skipped", o->sizes[i][0],
                         o->sizes[i][1], o->sizes[i][2], o->mesh);
            ohm_voxel_grid_free(&g);
            memset(row, 0, sizeof *row);
            continue;
        }
        rc = solve_grid(row, &g, &mesh, &mat, o, log, err);
        ohm_voxel_grid_free(&g);
        if (!rc) ++nrows;
    }
    if (!rc && o->max) {
        /* predict with the rate the largest grid so far reached */
        double rate = 0.3 * machine.dense_rate;
        for (size_t i = 0; i < nrows; ++i) {
            bench_figures g;
            figures(&g, &rows[i], &machine);
            if (g.factor_rate > 0 && rows[i].t_factor > 0.05) rate = g.factor_rate;
        }
        int found = 0;
        rc = find_max(&rows[nrows], &found, &mesh, &mat, o, &machine, rate, log, err);
        if (!rc && found) ++nrows;
    }
    ohm_mesh_free(&mesh);
    if (!rc) {
        write_markdown(stdout, rows, nrows, &machine, o, &mat);
        fflush(stdout);
    }
    if (!rc && o->md) rc = write_file(o->md, write_markdown, rows, nrows, &machine, o, &mat, err);
    if (!rc && o->csv) rc = write_file(o->csv, write_csv, rows, nrows, &machine, o, &mat, err);
    free(rows);
    free(machine.device_tables);
    return rc;
}

int ohm_bench_main(int argc, char **argv)
{
    if (ohm_subcommand_wants_help(argc, argv)) {
        usage(stdout);
        return 0;
    }
    ohm_error err;
    ohm_error_clear(&err);
    bench_options o;
    const ohm_log log = {.verbosity = 1};
    int rc = parse_options(&o, argc, argv, &err);
    if (!rc) rc = run(&o, &log, &err);
    ohm_opt_values_free(&o.given);
    return ohm_subcommand_exit(rc, &err, "bench failed");
}
