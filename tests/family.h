/* family.h — one solve of a medium of the held-in family
 * (studies/block_medium.h: ohm_family_medium_grid) by mg, measured by what
 * does not depend on a busy machine's minutes: its iterations to the
 * tolerance, its conservation, and its agreement with the Cholesky factor
 * where that fits; for tests/test_mg_family.c and tests/bench_mg_family.c
 * (docs/multigrid.md, "Any medium"). */
#ifndef OHM_TESTS_FAMILY_H
#define OHM_TESTS_FAMILY_H

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "base/log.h"
#include "base/parallel.h"
#include "physics/network.h"
#include "physics/stencil.h"
#include "solvers/direct.h"
#include "solvers/grid_order.h"
#include "solvers/mg.h"
#include "studies/block_medium.h"

typedef struct family_result {
    int64_t n, iterations, level_cells;
    int levels;
    double t_setup;      /* seconds, the hierarchy's set-up (a busy machine's) */
    double t_solve;      /* seconds, the solve after it (likewise) */
    double relres;       /* the final relative residual */
    double conservation; /* |sum b - sum sink x| / sum b: the power the books miss */
    double vs_direct;    /* max |x - x_direct| / max |x_direct|; -1: not solved by direct */
} family_result;

/* The right-hand side: a unit source in the centre cell and sources in 5%
 * of the cells at random, all nonnegative (power in). */
static inline void family_source(double *b, int64_t n)
{
    uint64_t seed = 7;
    for (int64_t v = 0; v < n; ++v) b[v] = ohm_lcg(&seed) < 0.05 ? ohm_lcg(&seed) : 0.0;
    b[n / 2] = 1.0;
}

/* x solved by the Cholesky factor of the same network under the robin boundary. */
static inline int family_direct(double *x, const ohm_network *net, const ohm_channel_medium *med, const double *b,
                                ohm_error *err)
{
    ohm_cholesky s;
    if (ohm_cholesky_start(&s, err)) return -1;
    cholmod_sparse *A = NULL;
    cholmod_factor *L = NULL;
    double berr = 0;
    int rc = ohm_network_assemble(&A, NULL, NULL, net, med, OHM_BOUNDARY_ROBIN, &s.cc, err) ||
             ohm_cholesky_analyze(&s, A, "metis", NULL, NULL, NULL, err) ||
             ohm_cholesky_factorize(&L, &s, A, NULL, NULL, err) ||
             ohm_cholesky_solve(x, &s, L, A, b, 1, &berr, NULL, err);
    ohm_cholesky_factor_free(&L, &s);
    if (A) cholmod_l_free_sparse(&A, &s.cc);
    ohm_cholesky_finish(&s);
    return rc ? -1 : 0;
}

static inline double family_max_diff(const double *x, const double *ref, int64_t n)
{
    double d = 0, m = 0;
    for (int64_t v = 0; v < n; ++v) {
        d = fmax(d, fabs(x[v] - ref[v]));
        m = fmax(m, fabs(ref[v]));
    }
    return m > 0 ? d / m : d;
}

/* The mg solve of its stencil to tol from zero, and its books. */
static inline int family_mg(family_result *res, const ohm_stencil *st, const ohm_network *net, double *x,
                            const double *b, double tol, int threads, ohm_error *err)
{
    ohm_grid_layout layout = ohm_grid_layout_of(net);
    ohm_mg *mg = NULL;
    double t0 = ohm_now();
    if (ohm_mg_setup(&mg, st, &layout, threads, err)) return -1;
    res->t_setup = ohm_now() - t0;
    res->levels = ohm_mg_levels(mg, &res->level_cells);
    t0 = ohm_now();
    int rc = ohm_mg_solve(mg, x, b, tol, 1000, NULL, &res->iterations, &res->relres, err);
    res->t_solve = ohm_now() - t0;
    ohm_mg_free(mg);
    if (rc) return -1;
    double in = 0, sunk = 0;
    for (int64_t v = 0; v < net->n; ++v) in += b[v], sunk += st->sink[v] * x[v];
    res->conservation = fabs(in - sunk) / in;
    return 0;
}

/* Medium `which` at nx^3 solved by mg to tol (on `threads` cores; 0: all),
 * and by direct too when with_direct; 0, or non-zero with err set. */
static inline int family_solve(ohm_family_medium which, int nx, double tol, int threads, int with_direct,
                               family_result *res, ohm_error *err)
{
    memset(res, 0, sizeof *res);
    res->vs_direct = -1;
    ohm_voxel_grid g;
    ohm_coeff *ss = NULL, *sa = NULL;
    if (ohm_family_medium_grid(&g, nx, which, &ss, &sa)) return ohm_fail(err, OHM_ERR_NOMEM, "%d^3: out of memory", nx);
    ohm_channel_medium med;
    ohm_block_medium(&med, ss, 0);
    med.sigma_a = sa;
    ohm_network net;
    ohm_stencil st = {0};
    double *b = NULL, *x = NULL, *xd = NULL;
    int rc = -1;
    if (ohm_network_build(&net, &g, NULL, err)) goto out_grid;
    if (ohm_network_stencil(&st, NULL, NULL, &net, &med, OHM_BOUNDARY_ROBIN, err)) goto out;
    res->n = net.n;
    b = malloc((size_t)net.n * sizeof *b), x = calloc((size_t)net.n, sizeof *x);
    if (!b || !x) {
        ohm_fail(err, OHM_ERR_NOMEM, "%d^3: out of memory", nx);
        goto out;
    }
    family_source(b, net.n);
    if (family_mg(res, &st, &net, x, b, tol, threads, err)) goto out;
    if (with_direct) {
        xd = malloc((size_t)net.n * sizeof *xd);
        if (!xd || family_direct(xd, &net, &med, b, err)) goto out;
        res->vs_direct = family_max_diff(x, xd, net.n);
    }
    rc = 0;
out:
    ohm_stencil_free(&st);
    ohm_network_free(&net);
out_grid:
    free(b), free(x), free(xd);
    ohm_voxel_grid_free(&g);
    free(ss), free(sa);
    return rc;
}

#endif
