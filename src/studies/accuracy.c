/* accuracy.c — `ohm accuracy`: the speed/accuracy trade, measured (accuracy.h).
 *
 * For a mesh, a light from above and each material: voxelize and solve at a
 * series of grid sizes (with each solver asked for), then once more at a
 * finer reference size with CG, and compare the surface exitance.  Exitance
 * lives on boundary faces, whose staircase differs from grid to grid, so it
 * is compared as power binned on a fixed world lattice: every boundary face's
 * power (exitance x h^2) is split trilinearly (cloud-in-cell) among the 8
 * lattice nodes around the face's centre, nodes NBINS to the longest side.
 * The error of a solution is sum |P - P_ref| / sum P_ref over the nodes and
 * channels (relative L1 of the binned exitance), and the worst relative error
 * over nodes holding > 1% of the brightest node's power.
 *
 * Richardson: with the two finest series grids h1 > h2 and the reference h3,
 * the observed order p solves |P2 - P1| / |P3 - P2| = (h1^p - h2^p) /
 * (h2^p - h3^p); when 0.5 <= p <= 4 the extrapolated P_inf = P3 - (P3 - P2)
 * h3^p / (h2^p - h3^p) node by node is a better reference than P3 (and gives
 * P3's own error).  The half-space scene (validate.c) is compared with its
 * exact solution instead.  Depth bands are compared with the full solve on the
 * same grid.  Peak memory is per row (VmHWM, reset before each row).  CSV on
 * csv=, Markdown on stdout, progress on stderr; nothing is asserted here
 * (tests/cli_accuracy.sh does that on a small run).  The lattice and the
 * scene's solve are outputs/exitance_probe.c's, which -voxelize error= uses. */
#include "studies/accuracy.h"

#include "base/options.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

#include "physics/light.h"
#include "base/log.h"
#include "physics/material.h"
#include "input/mesh.h"
#include "base/ohm_error.h"
#include "base/output.h"
#include "outputs/exitance_probe.h"
#include "solvers/solve.h"
#include "studies/subcommand.h"
#include "studies/validate.h"
#include "grid/voxelize.h"

enum { ACC_MAX_DIMS = 16, ACC_MAX_MATERIALS = 12, ACC_MAX_BANDS = 8 };

typedef struct acc_options {
    const char *mesh;
    double size;
    char materials[ACC_MAX_MATERIALS][24];
    int nmaterials;
    int dims[ACC_MAX_DIMS], ndims;
    int ref;
    int direct, cg;                 /* solvers to time                      */
    double bands[ACC_MAX_BANDS];
    int nbands, band_dim;
    double slab_h[ACC_MAX_DIMS];
    int nslab;
    const char *csv;
    int model_mc;                   /* model=mc: diffusion against transport */
    int64_t photons;                /* per Monte Carlo solve                 */
    ohm_opt_values given;           /* the words as given (accuracy_opts); the texts point into it */
} acc_options;

typedef struct acc_row {
    char scene[48], material[24], solver[8];
    int dim;
    double h, band, band_depth;
    int64_t cells, dropped, iters;
    double nnz_L, factor_mb, rss_mb;
    double t_voxelize, t_analyze, t_factor, t_cg, t_source, t_solve, t_total;
    double err_ref, err_max, err_rich, err_full, order;
    double err_model, mc_noise, t_mc; /* model=mc: against transport, its noise, its time; -1: not run */
    double *P; /* binned exitance power (owned), NULL for slab rows */
} acc_row;


/* Peak resident memory of this row alone: Linux (>= 4.0) resets the
 * high-water mark VmHWM when "5" is written to /proc/self/clear_refs, so
 * each row starts from what the process holds then.  Where that is not
 * possible the figure is the process's peak so far (getrusage). */
static void reset_peak_rss(void)
{
    FILE *f = fopen("/proc/self/clear_refs", "w");
    if (!f) return;
    fputs("5", f);
    fclose(f);
}

static double peak_rss_mb(void)
{
    FILE *f = fopen("/proc/self/status", "r");
    if (f) {
        char line[256];
        while (fgets(line, sizeof line, f))
            if (strncmp(line, "VmHWM:", 6) == 0) {
                fclose(f);
                return strtod(line + 6, NULL) / 1024.0; /* kB */
            }
        fclose(f);
    }
    struct rusage ru;
    if (getrusage(RUSAGE_SELF, &ru) != 0) return 0;
    return (double)ru.ru_maxrss / 1024.0; /* KiB on Linux */
}

static int usage_error(ohm_error *err, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
static int usage_error(ohm_error *err, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int rc = ohm_subcommand_usage_error(err, "accuracy", fmt, ap);
    va_end(ap);
    return rc;
}

static void usage(FILE *f)
{
    fprintf(f,
            "usage: ohm accuracy [key=value ...]\n"
            "\n"
            "The speed/accuracy trade, measured: for each material, voxelize the mesh (longest side size= mm, lit\n"
            "from above by a directional light) at each of dims= and solve it with each of solvers=, then once at\n"
            "ref= with CG; report cells, time per stage, peak memory, nnz(L), and the error of the surface exitance\n"
            "(power binned on a fixed %d-node lattice) against the reference and against its Richardson\n"
            "extrapolation.  Depth bands (bands=) are compared with the full solve at band_dim=; the half-space\n"
            "scene with its exact solution at slab= voxel sizes.  Markdown on stdout, CSV on csv=; plot it with\n"
            "scripts/accuracy.sh, which runs the whole study.\n"
            "\n"
            "  mesh=FILE         mesh (default samples/spot.obj)\n"
            "  size=MM           longest side in mm (default 50)\n"
            "  materials=LIST    presets, comma-separated (default marble,skin1,ketchup): %s\n"
            "  dims=LIST         grid sizes along the longest side (default 16,24,32,48,64,96,128)\n"
            "  ref=DIM           the reference grid, solved with CG (default 192; 0: none, no errors)\n"
            "  solvers=LIST      direct,cg (default both)\n"
            "  bands=LIST        depth bands k (cells within k / sigma_tr), 0 = none (default 1,2,3,4)\n"
            "  band_dim=DIM      grid for the band study (default the largest of dims)\n"
            "  slab=LIST         half-space voxel sizes in mm, 0 = none (default 1,0.5,0.35,0.25)\n"
            "  model=mc          also trace Monte Carlo transport (solver=mc) on each series grid: the model's\n"
            "                    error (diffusion against transport, same grid) beside the discretisation error\n"
            "  photons=N         photons per Monte Carlo solve (default 1e6)\n"
            "  csv=FILE          every figure, one row per solve\n",
            OHM_EXITANCE_NBINS, ohm_preset_names);
}

/* "a,b,c" -> numbers in [lo, hi] */
static int parse_list(const char *key, const char *text, double lo, double hi, double *out, int max, int *n,
                      ohm_error *err)
{
    *n = 0;
    const char *p = text;
    while (*p) {
        char *end;
        double v = strtod(p, &end);
        if (end == p || !(v >= lo && v <= hi) || (*end && *end != ','))
            return usage_error(err, "%s=%s: expected comma-separated numbers in [%g, %g]", key, text, lo, hi);
        if (*n == max) return usage_error(err, "%s=%s: at most %d values", key, text, max);
        out[(*n)++] = v;
        p = *end ? end + 1 : end;
    }
    if (*n == 0) return usage_error(err, "%s=: expected at least one value", key);
    return OHM_OK;
}

/* `ohm accuracy`'s options (base/options.h: the words checked as the
 * pipeline's are; the lists are read after) */
static const ohm_opt_spec accuracy_opts[] = {
    {"mesh", OHM_OPT_STRING, "samples/spot.obj", "mesh to read", NULL, 0, 0, 0},
    {"size", OHM_OPT_REAL, "50", "scale the longest axis to this many mm", NULL, 1e-9, 1e9, 0},
    {"materials", OHM_OPT_STRING, "marble,skin1,ketchup", "presets, separated by commas", NULL, 0, 0, 0},
    {"dims", OHM_OPT_STRING, "16,24,32,48,64,96,128", "grid sizes, increasing", NULL, 0, 0, 0},
    {"ref", OHM_OPT_INT, "192", "the reference grid, 4..2048, or 0 for none", NULL, 0, 2048, 0},
    {"solvers", OHM_OPT_ENUM, "direct,cg", "the solvers timed", "direct|cg|direct,cg|cg,direct", 0, 0, 0},
    {"bands", OHM_OPT_STRING, "1,2,3,4", "depth bands", NULL, 0, 0, 0},
    {"band_dim", OHM_OPT_INT, "0", "the depth bands' grid (0: the largest of dims=)", NULL, 0, 2048, 0},
    {"slab", OHM_OPT_STRING, "1,0.5,0.35,0.25", "the slab's voxel sizes (mm), or 0 for none", NULL, 0, 0, 0},
    {"csv", OHM_OPT_STRING, NULL, "every row", NULL, 0, 0, 0},
    {"model", OHM_OPT_ENUM, "none", "mc: diffusion against Monte Carlo transport", "mc|none", 0, 0, 0},
    {"photons", OHM_OPT_REAL, "1e6", "photons per Monte Carlo solve", NULL, 16, 1e12, 0},
    {0}};

static int parse_options(acc_options *o, int argc, char **argv, ohm_error *err)
{
    memset(o, 0, sizeof *o);
    int rc0 = ohm_opt_words(&o->given, accuracy_opts, "accuracy", argc, (const char *const *)argv, err);
    if (rc0) return rc0;
    const ohm_opt_values *g = &o->given;
    long long n;
    double x;
    o->mesh = ohm_opt_text(g, "mesh");
    ohm_opt_parse_real(ohm_opt_text(g, "size"), &o->size);
    const char *mats = ohm_opt_text(g, "materials"), *dims = ohm_opt_text(g, "dims"), *bands = ohm_opt_text(g, "bands");
    const char *slab = ohm_opt_text(g, "slab");
    ohm_opt_parse_int(ohm_opt_text(g, "ref"), &n);
    if (n != 0 && n < 4) return usage_error(err, "ref=%lld: expected a grid size 4..2048, or 0 for none", n);
    o->ref = (int)n;
    const char *solvers = ohm_opt_text(g, "solvers");
    o->direct = strstr(solvers, "direct") != NULL;
    o->cg = strstr(solvers, "cg") != NULL;
    ohm_opt_parse_int(ohm_opt_text(g, "band_dim"), &n);
    o->band_dim = (int)n;
    o->csv = ohm_opt_text(g, "csv");
    o->model_mc = strcmp(ohm_opt_text(g, "model"), "mc") == 0;
    ohm_opt_parse_real(ohm_opt_text(g, "photons"), &x);
    o->photons = (int64_t)x;
    double d[ACC_MAX_DIMS];
    int rc = parse_list("dims", dims, 4, 2048, d, ACC_MAX_DIMS, &o->ndims, err);
    if (rc) return rc;
    for (int i = 0; i < o->ndims; ++i) {
        o->dims[i] = (int)d[i];
        if (i > 0 && o->dims[i] <= o->dims[i - 1]) return usage_error(err, "dims=%s: expected increasing sizes", dims);
    }
    if (o->ref && o->ref <= o->dims[o->ndims - 1])
        return usage_error(err, "ref=%d: expected a grid finer than the largest of dims= (%d)", o->ref,
                           o->dims[o->ndims - 1]);
    if (!o->band_dim) o->band_dim = o->dims[o->ndims - 1];
    rc = parse_list("bands", bands, 0, 100, o->bands, ACC_MAX_BANDS, &o->nbands, err);
    if (rc) return rc;
    rc = parse_list("slab", slab, 0, 100, o->slab_h, ACC_MAX_DIMS, &o->nslab, err);
    if (rc) return rc;
    if (o->nslab == 1 && o->slab_h[0] == 0) o->nslab = 0;
    /* materials */
    const char *p = mats;
    while (*p) {
        size_t len = strcspn(p, ",");
        if (o->nmaterials == ACC_MAX_MATERIALS || len == 0 || len >= sizeof o->materials[0])
            return usage_error(err, "materials=%s: expected preset names separated by commas", mats);
        memcpy(o->materials[o->nmaterials], p, len);
        o->materials[o->nmaterials][len] = 0;
        ohm_material m;
        ohm_error e2;
        ohm_error_clear(&e2);
        if (ohm_material_preset(&m, o->materials[o->nmaterials], &e2))
            return usage_error(err, "materials=: unknown preset '%s' (%s)", o->materials[o->nmaterials],
                               ohm_preset_names);
        o->nmaterials++;
        p += len;
        if (*p == ',') ++p;
    }
    return OHM_OK;
}

/* ---- errors ------------------------------------------------------------------ */

static void errors(const double *P, const double *ref, size_t n, double *rel_l1, double *worst)
{
    double top = 0, sum = 0;
    for (size_t i = 0; i < n; ++i) {
        top = fmax(top, ref[i]);
        sum += fabs(ref[i]);
    }
    *rel_l1 = sum > 0 ? ohm_exitance_l1_diff(P, ref, n) / sum : 0;
    *worst = 0;
    for (size_t i = 0; i < n; ++i)
        if (ref[i] > 0.01 * top) *worst = fmax(*worst, fabs(P[i] - ref[i]) / ref[i]);
}

/* The order p with d12 / d23 = (h1^p - h2^p) / (h2^p - h3^p), by bisection;
 * 0 when there is none in [0.25, 6]. */
static double observed_order(double d12, double d23, double h1, double h2, double h3)
{
    if (!(d12 > 0 && d23 > 0)) return 0;
    double target = d12 / d23, lo = 0.25, hi = 6;
    double flo = (pow(h1, lo) - pow(h2, lo)) / (pow(h2, lo) - pow(h3, lo)) - target;
    double fhi = (pow(h1, hi) - pow(h2, hi)) / (pow(h2, hi) - pow(h3, hi)) - target;
    if (flo * fhi > 0) return 0;
    for (int it = 0; it < 80; ++it) {
        double mid = 0.5 * (lo + hi);
        double fm = (pow(h1, mid) - pow(h2, mid)) / (pow(h2, mid) - pow(h3, mid)) - target;
        if ((fm > 0) == (fhi > 0)) hi = mid, fhi = fm;
        else lo = mid, flo = fm;
    }
    return 0.5 * (lo + hi);
}

/* ---- one solve ---------------------------------------------------------------- */

static int solve_one(acc_row *row, const ohm_exitance_lattice *Lat, const ohm_mesh *mesh, const ohm_material *mat,
                     int dim, int use_cg, double band, int64_t mc_photons, const ohm_log *log, ohm_error *err)
{
    ohm_light light;
    memset(&light, 0, sizeof light);
    light.type = OHM_LIGHT_DIRECTIONAL;
    light.dir[1] = -1;
    light.intensity[0] = 1;
    light.channels = 1;
    ohm_log_info(log, "accuracy: %s dim %d %s%s", row->material, dim, use_cg ? "cg" : "direct",
                 band > 0 ? " with a depth band" : "");
    ohm_voxel_grid g;
    ohm_solution sol;
    reset_peak_rss();
    int flipped;
    int rc = ohm_probe_voxelize_and_solve(&g, &sol, &row->t_voxelize, &flipped, mesh, mat, &light, 1, dim, use_cg,
                                          band, err);
    if (rc) return rc;
    row->dim = dim;
    row->h = g.h;
    row->band = band;
    snprintf(row->solver, sizeof row->solver, "%s", sol.solver);
    row->cells = sol.n;
    row->dropped = sol.band_dropped;
    row->band_depth = sol.band_depth;
    row->iters = sol.cg_iterations;
    row->nnz_L = sol.nnz_L;
    row->factor_mb = use_cg ? 0 : 12.0 * sol.nnz_L / 1048576.0; /* values + row indices */
    row->t_analyze = sol.t_analyze;
    row->t_factor = sol.t_factor;
    row->t_cg = sol.t_cg_setup;
    row->t_source = sol.t_source + sol.t_shadow_setup;
    row->t_solve = sol.t_solve;
    row->t_total = row->t_voxelize + sol.t_network + sol.t_assemble + sol.t_analyze + sol.t_factor + sol.t_cg_setup +
                   row->t_source + sol.t_solve;
    row->P = ohm_exitance_binned(Lat, &sol, &g);
    row->rss_mb = peak_rss_mb();
    ohm_solution_free(&sol);
    row->err_model = row->mc_noise = row->t_mc = -1;
    if (row->P && mc_photons > 0) { /* the same grid and light, traced */
        ohm_log_info(log, "accuracy: %s dim %d: Monte Carlo, %.3g photons", row->material, dim, (double)mc_photons);
        ohm_solution t;
        double t0 = ohm_now();
        rc = ohm_probe_solve(&t, &g, flipped, mesh, mat, &light, 1, OHM_SOLVER_MC, 0, mc_photons, err);
        if (!rc) {
            row->t_mc = ohm_now() - t0;
            double *Pmc = ohm_exitance_binned(Lat, &t, &g);
            if (Pmc) {
                double worst;
                errors(row->P, Pmc, Lat->nodes * 3, &row->err_model, &worst);
                row->mc_noise = ohm_exitance_binned_noise(Lat, &t, &g, Pmc);
            }
            free(Pmc);
            ohm_solution_free(&t);
            if (!Pmc) rc = ohm_fail(err, OHM_ERR_NOMEM, "accuracy: out of memory");
        }
    }
    ohm_voxel_grid_free(&g);
    if (rc) return rc;
    if (!row->P) return ohm_fail(err, OHM_ERR_NOMEM, "accuracy: out of memory");
    return OHM_OK;
}

/* ---- output ------------------------------------------------------------------- */

static void write_csv(FILE *f, const acc_row *rows, size_t n)
{
    fprintf(f, "scene,material,dim,h_mm,solver,band,cells,band_dropped,nnz_L,factor_mb,peak_rss_mb,t_voxelize,"
               "t_analyze,t_factor,t_cg_setup,t_source,t_solve,t_total,cg_iterations,err_ref,err_max_ref,err_rich,"
               "order,err_full,err_model,mc_noise,t_mc\n");
    for (size_t i = 0; i < n; ++i) {
        const acc_row *r = &rows[i];
        fprintf(f, "%s,%s,%d,%.6g,%s,%g,%lld,%lld,%.6g,%.4g,%.1f,%.4g,%.4g,%.4g,%.4g,%.4g,%.4g,%.4g,%lld,%.4g,%.4g,"
                   "%.4g,%.3g,%.4g,%.4g,%.4g,%.4g\n",
                r->scene, r->material, r->dim, r->h, r->solver, r->band, (long long)r->cells, (long long)r->dropped,
                r->nnz_L, r->factor_mb, r->rss_mb, r->t_voxelize, r->t_analyze, r->t_factor, r->t_cg, r->t_source,
                r->t_solve, r->t_total, (long long)r->iters, r->err_ref, r->err_max, r->err_rich, r->order,
                r->err_full, r->err_model, r->mc_noise, r->t_mc);
    }
}

static void write_markdown(FILE *f, const acc_row *rows, size_t n, const acc_options *o)
{
    fprintf(f, "### %s at %g mm, directional light from above; error of the binned surface exitance\n\n", o->mesh,
            o->size);
    fprintf(f, "| material | dim | h (mm) | cells | direct (s) | cg (s) | cg iterations | peak RSS direct / cg (MB) | factor (MB) "
               "| error vs ref | vs Richardson | worst node |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for (size_t i = 0; i < n; ++i) {
        const acc_row *r = &rows[i];
        int series = strcmp(r->scene, "series") == 0, ref = strcmp(r->scene, "reference") == 0;
        if (!series && !ref) continue;
        /* one line per (material, dim): join the direct and cg rows */
        if (series && i > 0 && strcmp(rows[i - 1].scene, "series") == 0 && rows[i - 1].dim == r->dim &&
            strcmp(rows[i - 1].material, r->material) == 0)
            continue;
        double td = -1, tc = -1, fm = 0, md = -1, mc = -1;
        int64_t it = 0;
        for (size_t j = i; j < n && rows[j].dim == r->dim && strcmp(rows[j].material, r->material) == 0 &&
                           strcmp(rows[j].scene, r->scene) == 0;
             ++j) {
            if (strcmp(rows[j].solver, "direct") == 0) td = rows[j].t_total, fm = rows[j].factor_mb, md = rows[j].rss_mb;
            else tc = rows[j].t_total, it = rows[j].iters, mc = rows[j].rss_mb;
        }
        char tds[32] = "-", tcs[32] = "-", rich[32] = "-", mem[48];
        if (md >= 0 && mc >= 0) snprintf(mem, sizeof mem, "%.0f / %.0f", md, mc);
        else snprintf(mem, sizeof mem, "%.0f", md >= 0 ? md : mc);
        if (td >= 0) snprintf(tds, sizeof tds, "%.3g", td);
        if (tc >= 0) snprintf(tcs, sizeof tcs, "%.3g", tc);
        if (r->err_rich > 0) snprintf(rich, sizeof rich, "%.2f%%", 100 * r->err_rich);
        fprintf(f, "| %s | %d%s | %.3g | %lld | %s | %s | %lld | %s | %.1f | %.2f%% | %s | %.2f%% |\n",
                r->material, r->dim, ref ? " (ref)" : "", r->h, (long long)r->cells, tds, tcs, (long long)it, mem, fm, 100 * r->err_ref, rich,
                100 * r->err_max);
    }
    if (o->model_mc) {
        fprintf(f, "\n### The model's error: diffusion against Monte Carlo transport (%.3g photons) on the same grid\n\n"
                   "| material | dim | h (mm) | cells | discretisation (vs ref) | model (vs transport) | transport noise "
                   "| transport (s) |\n|---|---|---|---|---|---|---|---|\n",
                (double)o->photons);
        for (size_t i = 0; i < n; ++i) {
            const acc_row *r = &rows[i];
            if (strcmp(r->scene, "series") != 0 || !(r->err_model >= 0)) continue;
            char disc[32] = "-";
            if (o->ref) snprintf(disc, sizeof disc, "%.2f%%", 100 * r->err_ref);
            fprintf(f, "| %s | %d | %.3g | %lld | %s | %.2f%% | %.2f%% | %.3g |\n", r->material, r->dim, r->h,
                    (long long)r->cells, disc, 100 * r->err_model, 100 * r->mc_noise, r->t_mc);
        }
    }
    fprintf(f, "\n### Depth band: error against the full solve on the same grid (cg)\n\n"
               "| material | dim | band k | depth (mm) | cells kept | dropped | time (s) | error vs full |\n"
               "|---|---|---|---|---|---|---|---|\n");
    for (size_t i = 0; i < n; ++i) {
        const acc_row *r = &rows[i];
        if (strcmp(r->scene, "band") != 0) continue;
        char depth[32] = "all cells";
        if (r->dropped) snprintf(depth, sizeof depth, "%.3g", r->band_depth);
        fprintf(f, "| %s | %d | %g | %s | %lld | %.1f%% | %.3g | %.3f%% |\n", r->material, r->dim, r->band, depth,
                (long long)r->cells,
                100.0 * (double)r->dropped / (double)(r->cells + r->dropped), r->t_total, 100 * r->err_full);
    }
    if (o->nslab) {
        fprintf(f, "\n### Half-space (sigma_a 0.05, sigma_s' 0.95 /mm, Robin): exitance J(r) against the exact "
                   "solution over 1/sigma_t' <= r <= 3/sigma_tr\n\n| h (mm) | cells | time (s) | L1 error | worst |\n"
                   "|---|---|---|---|---|\n");
        for (size_t i = 0; i < n; ++i)
            if (strcmp(rows[i].scene, "halfspace") == 0)
                fprintf(f, "| %g | %lld | %.3g | %.2f%% | %.2f%% |\n", rows[i].h, (long long)rows[i].cells,
                        rows[i].t_total, 100 * rows[i].err_ref, 100 * rows[i].err_max);
    }
}

/* ---- the run ------------------------------------------------------------------ */

static int push(acc_row **rows, size_t *n, size_t *cap, acc_row **out, ohm_error *err)
{
    if (*n == *cap) {
        size_t nc = *cap ? 2 * *cap : 32;
        acc_row *r = realloc(*rows, nc * sizeof *r);
        if (!r) return ohm_fail(err, OHM_ERR_NOMEM, "accuracy: out of memory");
        *rows = r;
        *cap = nc;
    }
    *out = &(*rows)[(*n)++];
    memset(*out, 0, sizeof **out);
    (*out)->err_model = (*out)->mc_noise = (*out)->t_mc = -1; /* model=mc not run */
    return OHM_OK;
}

/* Errors of rows[first..iref] against the reference rows[iref] and its
 * Richardson extrapolation from the two finest series grids (cg rows when
 * there are any). */
static int compare_to_reference(acc_row *rows, size_t first, size_t iref, const acc_options *o, size_t len,
                                const char *name, const ohm_log *log, ohm_error *err)
{
    const double *Pref = rows[iref].P;
    size_t i1 = SIZE_MAX, i2 = SIZE_MAX;
    for (size_t i = first; i < iref; ++i) {
        const acc_row *q = &rows[i];
        if (o->cg && strcmp(q->solver, "cg") != 0) continue;
        if (q->dim == o->dims[o->ndims - 1]) i2 = i;
        if (o->ndims > 1 && q->dim == o->dims[o->ndims - 2]) i1 = i;
    }
    double *Pinf = NULL, order = 0;
    if (i1 != SIZE_MAX && i2 != SIZE_MAX) {
        const acc_row *a = &rows[i1], *b = &rows[i2];
        order = observed_order(ohm_exitance_l1_diff(a->P, b->P, len), ohm_exitance_l1_diff(b->P, Pref, len), a->h,
                               b->h, rows[iref].h);
        if (order >= 0.5 && order <= 4) {
            Pinf = malloc(len * sizeof *Pinf);
            if (!Pinf) return ohm_fail(err, OHM_ERR_NOMEM, "accuracy: out of memory");
            double h2p = pow(b->h, order), h3p = pow(rows[iref].h, order);
            for (size_t k = 0; k < len; ++k) Pinf[k] = Pref[k] - (Pref[k] - b->P[k]) * h3p / (h2p - h3p);
        }
    }
    for (size_t i = first; i <= iref; ++i) {
        acc_row *q = &rows[i];
        errors(q->P, Pref, len, &q->err_ref, &q->err_max);
        double dummy;
        if (Pinf) errors(q->P, Pinf, len, &q->err_rich, &dummy);
        q->order = order;
    }
    free(Pinf);
    ohm_log_info(log, "accuracy: %s: observed order %.2f%s", name, order,
                 order >= 0.5 && order <= 4 ? " (Richardson used)" : " (no Richardson extrapolation)");
    return OHM_OK;
}

static int run_material(acc_row **rows, size_t *n, size_t *cap, const acc_options *o, const ohm_mesh *mesh,
                        const ohm_exitance_lattice *Lat, const char *name, const ohm_log *log, ohm_error *err)
{
    ohm_material mat;
    int rc = ohm_material_preset(&mat, name, err);
    if (rc) return rc;
    size_t first = *n;
    acc_row *r = NULL;
    for (int i = 0; i < o->ndims; ++i)
        for (int s = 0; s < 2; ++s) {
            if ((s == 0 && !o->direct) || (s == 1 && !o->cg)) continue;
            if ((rc = push(rows, n, cap, &r, err))) return rc;
            snprintf(r->scene, sizeof r->scene, "series");
            snprintf(r->material, sizeof r->material, "%s", name);
            /* the model's error once per grid, beside the first solver's row */
            int first_solver = s == 0 || !o->direct;
            int64_t ph = o->model_mc && first_solver ? o->photons : 0;
            if ((rc = solve_one(r, Lat, mesh, &mat, o->dims[i], s == 1, 0, ph, log, err))) return rc;
        }
    size_t len = Lat->nodes * 3;
    if (o->ref) {
        if ((rc = push(rows, n, cap, &r, err))) return rc;
        snprintf(r->scene, sizeof r->scene, "reference");
        snprintf(r->material, sizeof r->material, "%s", name);
        if ((rc = solve_one(r, Lat, mesh, &mat, o->ref, 1, 0, 0, log, err))) return rc;
        if ((rc = compare_to_reference(*rows, first, *n - 1, o, len, name, log, err))) return rc;
    }

    /* depth bands at band_dim, against the full cg solve there (rows may
     * move when the array grows: look the full solve up after each push) */
    for (int b = 0; b < o->nbands; ++b) {
        if (!(o->bands[b] > 0)) continue;
        if ((rc = push(rows, n, cap, &r, err))) return rc;
        snprintf(r->scene, sizeof r->scene, "band");
        snprintf(r->material, sizeof r->material, "%s", name);
        if ((rc = solve_one(r, Lat, mesh, &mat, o->band_dim, 1, o->bands[b], 0, log, err))) return rc;
        const double *Pfull = NULL;
        for (size_t i = first; i < *n; ++i)
            if (strcmp((*rows)[i].scene, "series") == 0 && (*rows)[i].dim == o->band_dim &&
                strcmp((*rows)[i].solver, "cg") == 0)
                Pfull = (*rows)[i].P;
        if (Pfull) {
            double worst;
            errors(r->P, Pfull, len, &r->err_full, &worst);
        }
    }
    return OHM_OK;
}

static int run(const acc_options *o, const ohm_log *log, ohm_error *err)
{
    ohm_mesh mesh;
    int rc = ohm_mesh_read(&mesh, o->mesh, err);
    if (rc) return rc;
    double lo[3], hi[3];
    ohm_mesh_bounds(&mesh, lo, hi);
    double ext = fmax(hi[0] - lo[0], fmax(hi[1] - lo[1], hi[2] - lo[2]));
    if (!(ext > 0) || !isfinite(ext)) {
        ohm_mesh_free(&mesh);
        return ohm_fail(err, OHM_ERR_INVALID, "%s: all vertices coincide, cannot scale to size=", o->mesh);
    }
    ohm_mesh_scale(&mesh, o->size / ext);
    ohm_exitance_lattice Lat;
    ohm_exitance_lattice_for(&Lat, &mesh);
    acc_row *rows = NULL;
    size_t n = 0, cap = 0;
    for (int m = 0; m < o->nmaterials && !rc; ++m)
        rc = run_material(&rows, &n, &cap, o, &mesh, &Lat, o->materials[m], log, err);
    for (int i = 0; i < o->nslab && !rc; ++i) {
        acc_row *r = NULL;
        if ((rc = push(&rows, &n, &cap, &r, err))) break;
        static const ohm_log quiet = {.verbosity = 0};
        ohm_halfspace_result hs;
        ohm_log_info(log, "accuracy: half-space at h = %g mm", o->slab_h[i]);
        rc = ohm_halfspace_accuracy(&hs, o->slab_h[i], 1, &quiet, err);
        if (rc) break;
        snprintf(r->scene, sizeof r->scene, "halfspace");
        snprintf(r->material, sizeof r->material, "sa0.05-ss0.95");
        snprintf(r->solver, sizeof r->solver, "cg");
        r->h = o->slab_h[i];
        r->cells = hs.cells;
        r->t_total = hs.seconds;
        r->err_ref = hs.mean;
        r->err_max = hs.worst;
        r->rss_mb = peak_rss_mb();
    }
    ohm_mesh_free(&mesh);
    if (!rc) {
        write_markdown(stdout, rows, n, o);
        if (o->csv) {
            ohm_output out;
            rc = ohm_output_begin(&out, o->csv, NULL, err);
            if (!rc) {
                write_csv(out.stream, rows, n);
                rc = ohm_output_commit(&out, err);
                if (rc) ohm_output_abort(&out);
            }
        }
    }
    for (size_t i = 0; i < n; ++i) free(rows[i].P);
    free(rows);
    return rc;
}

int ohm_accuracy_main(int argc, char **argv)
{
    if (ohm_subcommand_wants_help(argc, argv)) {
        usage(stdout);
        return 0;
    }
    ohm_error err;
    ohm_error_clear(&err);
    acc_options o;
    const ohm_log log = {.verbosity = 1};
    int rc = parse_options(&o, argc, argv, &err);
    if (!rc) rc = run(&o, &log, &err);
    ohm_opt_values_free(&o.given);
    return ohm_subcommand_exit(rc, &err, "accuracy failed");
}
