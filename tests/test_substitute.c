/* test_substitute.c — substitution over CHOLMOD's supernodal factor
 * (solvers/substitute.h) against cholmod_solve, the reference: the same
 * solution to 1e-12 on grid matrices with conductance contrasts up to 1e6,
 * for every ordering ohm offers, a scaled backward error at rounding level,
 * and the simplicial factor refused (the caller then uses cholmod_solve).
 *
 *   test_substitute [time N [NX]]   also times N solves each way on an NX^3
 *                                   grid (default 32; printed only) */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/log.h"
#include "check.h"
#include "solvers/backend.h"
#include "solvers/substitute.h"

static double lcg(uint64_t *s) /* deterministic [0, 1) */
{
    *s = *s * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(*s >> 11) / 9007199254740992.0;
}

/* The 7-point conductance matrix of an nx^3 grid (upper triangle, stype 1):
 * face conductances 10^(contrast_decades * u), u uniform in [0, 1), and a
 * small absorption on the diagonal — a resistor network like ohm's. */
static cholmod_sparse *grid_matrix(int nx, double contrast_decades, uint64_t seed, cholmod_common *cc)
{
    size_t n = (size_t)nx * nx * nx;
    cholmod_triplet *T = cholmod_l_allocate_triplet(n, n, 4 * n, 1, CHOLMOD_REAL, cc);
    if (!T) return NULL;
    int64_t *ti = T->i, *tj = T->j;
    double *tx = T->x;
    double *diag = calloc(n, sizeof *diag);
    size_t nz = 0;
    for (int k = 0; k < nx; ++k)
        for (int j = 0; j < nx; ++j)
            for (int i = 0; i < nx; ++i) {
                int64_t c = i + (int64_t)nx * (j + (int64_t)nx * k);
                int64_t nb[3] = {i + 1 < nx ? c + 1 : -1, j + 1 < nx ? c + nx : -1,
                                 k + 1 < nx ? c + (int64_t)nx * nx : -1};
                for (int a = 0; a < 3; ++a) {
                    if (nb[a] < 0) continue;
                    double g = pow(10.0, contrast_decades * lcg(&seed));
                    ti[nz] = c, tj[nz] = nb[a], tx[nz] = -g, ++nz;
                    diag[c] += g, diag[nb[a]] += g;
                }
            }
    for (size_t c = 0; c < n; ++c) ti[nz] = tj[nz] = (int64_t)c, tx[nz] = diag[c] + 1e-3, ++nz;
    T->nnz = nz;
    free(diag);
    cholmod_sparse *A = cholmod_l_triplet_to_sparse(T, nz, cc);
    cholmod_l_free_triplet(&T, cc);
    return A;
}

static cholmod_factor *factor(cholmod_sparse *A, int ordering, int supernodal, cholmod_common *cc)
{
    cc->nmethods = 1;
    cc->method[0].ordering = ordering;
    cc->supernodal = supernodal ? CHOLMOD_SUPERNODAL : CHOLMOD_SIMPLICIAL;
    cc->final_ll = 1;
    cholmod_factor *L = cholmod_l_analyze(A, cc);
    if (L && !cholmod_l_factorize(A, L, cc)) cholmod_l_free_factor(&L, cc);
    return L;
}

/* Largest |x - ref| / max |ref|, and the scaled backward error of x. */
static void compare(double *diff, double *berr, cholmod_sparse *A, const cholmod_factor *L, const double *b,
                    cholmod_common *cc)
{
    size_t n = A->nrow;
    double *x = malloc(n * sizeof *x), *work = malloc(ohm_substitute_work_size(L) * sizeof *work);
    ohm_substitute(x, L, b, work);
    cholmod_dense B = {.nrow = n, .ncol = 1, .nzmax = n, .d = n, .x = (void *)b, .xtype = CHOLMOD_REAL};
    cholmod_dense *R = cholmod_l_solve(CHOLMOD_A, (cholmod_factor *)L, &B, cc);
    const double *ref = R->x;
    double worst = 0, scale = 0;
    for (size_t i = 0; i < n; ++i) {
        worst = fmax(worst, fabs(x[i] - ref[i]));
        scale = fmax(scale, fabs(ref[i]));
    }
    *diff = worst / scale;
    *berr = ohm_backward_error(A, b, x, 1, ohm_sym_upper_norm_inf(A));
    cholmod_l_free_dense(&R, cc);
    free(x);
    free(work);
}

/* The best of five rounds, the two ways interleaved so that both see the
 * same machine load. */
static void time_solves(cholmod_sparse *A, const cholmod_factor *L, const double *b, int reps, cholmod_common *cc)
{
    size_t n = A->nrow;
    double *x = malloc(n * sizeof *x), *work = malloc(ohm_substitute_work_size(L) * sizeof *work);
    cholmod_dense B = {.nrow = n, .ncol = 1, .nzmax = n, .d = n, .x = (void *)b, .xtype = CHOLMOD_REAL};
    double best_sub = 1e300, best_chol = 1e300;
    for (int round = 0; round < 5; ++round) {
        double t0 = ohm_now();
        for (int r = 0; r < reps; ++r) ohm_substitute(x, L, b, work);
        double t1 = ohm_now();
        for (int r = 0; r < reps; ++r) {
            cholmod_dense *R = cholmod_l_solve(CHOLMOD_A, (cholmod_factor *)L, &B, cc);
            cholmod_l_free_dense(&R, cc);
        }
        double t2 = ohm_now();
        best_sub = fmin(best_sub, (t1 - t0) / reps);
        best_chol = fmin(best_chol, (t2 - t1) / reps);
    }
    printf("n %zu, %zu supernodes, xsize %zu (%.1f MB): substitute %.3f ms, cholmod_solve %.3f ms per solve\n", n,
           L->nsuper, L->xsize, 8e-6 * (double)L->xsize, 1e3 * best_sub, 1e3 * best_chol);
    free(x);
    free(work);
}

int main(int argc, char **argv)
{
    cholmod_common cc;
    cholmod_l_start(&cc);
    cc.print = 0;
    int reps = argc > 2 && strcmp(argv[1], "time") == 0 ? atoi(argv[2]) : 0;
    static const int orderings[] = {CHOLMOD_METIS, CHOLMOD_AMD, CHOLMOD_NESDIS};
    static const double decades[] = {0.0, 3.0, 6.0};
    int nx = reps ? (argc > 3 ? atoi(argv[3]) : 32) : 14;
    for (int d = 0; d < 3; ++d) {
        cholmod_sparse *A = grid_matrix(nx, decades[d], 7 + d, &cc);
        CHECK(A != NULL);
        size_t n = A->nrow;
        double *b = malloc(n * sizeof *b);
        uint64_t seed = 99;
        for (size_t i = 0; i < n; ++i) b[i] = lcg(&seed) < 0.1 ? lcg(&seed) : 0.0; /* a sparse source */
        for (int o = 0; o < 3; ++o) {
            cholmod_factor *L = factor(A, orderings[o], 1, &cc);
            CHECK(L != NULL && ohm_substitute_supports(L));
            if (!L) continue;
            double diff = 1, berr = 1;
            compare(&diff, &berr, A, L, b, &cc);
            CHECK_MSG(diff <= 1e-12, "contrast 1e%g, ordering %d: substitution differs from cholmod_solve by %.3g",
                   decades[d], o, diff);
            CHECK_MSG(berr <= 1e-14, "contrast 1e%g, ordering %d: backward error %.3g", decades[d], o, berr);
            if (reps && o == 0) time_solves(A, L, b, reps, &cc);
            cholmod_l_free_factor(&L, &cc);
        }
        cholmod_factor *S = factor(A, CHOLMOD_AMD, 0, &cc);
        CHECK(S != NULL && !ohm_substitute_supports(S)); /* simplicial: cholmod_solve's */
        cholmod_l_free_factor(&S, &cc);
        free(b);
        cholmod_l_free_sparse(&A, &cc);
    }
    cholmod_l_finish(&cc);
    return check_summary();
}
