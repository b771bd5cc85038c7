/* bench_mg.c — the multigrid cycle against the machine's memory bandwidth
 * (docs/multigrid.md): one application of mg's preconditioner (the K-cycle,
 * ohm_mg_precondition) timed on the scale study's block medium, the bytes
 * it streams (ohm_mg_cycle_bytes, counted kernel by kernel), and STREAM's
 * triad measured in the same process just before and just after, so that
 * the ratio compares the cycle with the bandwidth of the same minutes (this
 * VM's triad varies by 1.5x from run to run).  Then one whole solve to
 * 1e-10 from zero, for the outer iteration's share.
 *
 * Not a ctest (no timed assertions in the suite): tests/CMakeLists.txt builds
 * it as the bench_mg target, scripts/mg-cycle.sh runs it.
 *
 *   bench_mg N...   blocks of 8^3 cells, sigma_s' 1 or 1e6 at random,
 *                   sigma_a 0.001 /mm, 1 mm voxels, robin boundary, on an
 *                   N^3 grid; prints one Markdown row per N. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "base/log.h"
#include "base/parallel.h"
#include "blocks.h"
#include "solvers/grid_order.h"
#include "solvers/mg.h"
#include "studies/triad.h"

enum { CYCLES = 10 };

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double triad(int threads)
{
    ohm_error err;
    ohm_error_clear(&err);
    double rate = 0;
    if (ohm_triad(threads, 200e6, 5, &rate, &err)) fprintf(stderr, "bench_mg: %s\n", err.msg);
    return rate;
}

static int bench(int nx)
{
    ohm_voxel_grid g;
    ohm_coeff *ss = NULL;
    if (ohm_block_medium_grid(&g, nx, &ss, 8)) return 1;
    ohm_error err;
    ohm_error_clear(&err);
    ohm_channel_medium med;
    ohm_block_medium(&med, ss, 0.001);
    ohm_network net;
    ohm_stencil st = {0};
    ohm_mg *mg = NULL;
    double *b = NULL, *z = NULL, *x = NULL;
    int rc = 1;
    if (ohm_network_build(&net, &g, NULL, &err)) goto out_grid;
    if (ohm_network_stencil(&st, NULL, NULL, &net, &med, OHM_BOUNDARY_ROBIN, &err)) goto out;
    int64_t n = net.n;
    b = malloc((size_t)n * sizeof *b), z = malloc((size_t)n * sizeof *z), x = calloc((size_t)n, sizeof *x);
    if (!b || !z || !x) goto out;
    uint64_t seed = 3;
    for (int64_t v = 0; v < n; ++v) b[v] = ohm_lcg(&seed);
    ohm_grid_layout layout = ohm_grid_layout_of(&net);
    double t0 = ohm_now();
    if (ohm_mg_setup(&mg, &st, &layout, 0, &err)) goto out;
    double t_setup = ohm_now() - t0;
    int threads = ohm_usable_cores();
    double bw_before = triad(threads);
    ohm_mg_precondition(mg, b, z); /* the first touches the vectors' pages */
    double t[CYCLES];
    for (int r = 0; r < CYCLES; ++r) {
        t0 = ohm_now();
        ohm_mg_precondition(mg, b, z);
        t[r] = ohm_now() - t0;
    }
    double bw_after = triad(threads);
    qsort(t, CYCLES, sizeof *t, cmp_double);
    int64_t its = 0;
    double relres = 0;
    t0 = ohm_now();
    if (ohm_mg_solve(mg, x, b, 1e-10, 500, NULL, &its, &relres, &err)) goto out;
    double t_solve = ohm_now() - t0;
    int64_t cells = 0;
    int levels = ohm_mg_levels(mg, &cells);
    double bytes = ohm_mg_cycle_bytes(mg), bw = fmax(bw_before, bw_after);
    double bound = bytes / bw;
    printf("| %d^3 | %.3g | %d | %.2f | %.0f | %.1f | %.1f | %.1f–%.1f | %.1f | **%.2f** (%.2f) | %lld | %.2f | %.0f |\n",
           nx, (double)n, levels, t_setup, bytes / (double)n, bytes / 1e6, 1e3 * t[0], bw_before / 1e9,
           bw_after / 1e9, 1e3 * bound, t[0] / bound, t[CYCLES / 2] / bound, (long long)its, t_solve,
           100.0 * (double)its * t[CYCLES / 2] / t_solve);
    fflush(stdout);
    rc = 0;
out:
    if (rc) fprintf(stderr, "bench_mg: %d^3: %s\n", nx, err.msg);
    ohm_mg_free(mg);
    ohm_stencil_free(&st);
    ohm_network_free(&net);
out_grid:
    free(b), free(z), free(x);
    ohm_voxel_grid_free(&g);
    free(ss);
    return rc;
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: bench_mg N... (block medium on N^3 cells)\n");
        return 2;
    }
    printf("| grid | cells | levels | setup (s) | B/cell per cycle | MB per cycle | cycle (ms, best of %d) | triad "
           "(GB/s, before–after) | bound (ms) | cycle / bound (median's) | iterations | solve (s) | cycles' share "
           "of the solve (%%) |\n",
           CYCLES);
    printf("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    int rc = 0;
    for (int i = 1; i < argc; ++i) {
        int nx = atoi(argv[i]);
        if (nx < 8 || nx > 2000) {
            fprintf(stderr, "bench_mg: %s: not a grid size in 8..2000\n", argv[i]);
            return 2;
        }
        rc |= bench(nx);
    }
    return rc;
}
