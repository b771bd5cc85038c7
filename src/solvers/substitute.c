/* solvers/substitute.c — forward and back substitution over a supernodal
 * Cholesky factor (substitute.h).  CHOLMOD's supernodal layout (CHOLMOD
 * User Guide, "cholmod_factor"): supernode s holds columns super[s] ..
 * super[s+1]-1; its row indices are Ls[pi[s] .. pi[s+1]-1], the first
 * nscol of them the supernode's own columns in order; its values are a
 * column-major nsrow x nscol block at Lx + px[s] (leading dimension nsrow),
 * the upper part of the diagonal block unused. */
#include "solvers/substitute.h"

#include <stdint.h>

int ohm_substitute_supports(const cholmod_factor *L)
{
    return L && L->is_super && L->is_ll && L->xtype == CHOLMOD_REAL && L->dtype == CHOLMOD_DOUBLE &&
           L->itype == CHOLMOD_LONG && L->x && L->Perm;
}

static size_t tallest_supernode(const cholmod_factor *L)
{
    const int64_t *pi = L->pi;
    size_t tallest = 0;
    for (size_t s = 0; s < L->nsuper; ++s)
        if ((size_t)(pi[s + 1] - pi[s]) > tallest) tallest = (size_t)(pi[s + 1] - pi[s]);
    return tallest;
}

size_t ohm_substitute_work_size(const cholmod_factor *L)
{
    return L->n + tallest_supernode(L);
}

/* The inner loops in GCC/Clang vector extensions, four doubles at a time:
 * at -O2 the compiler vectorizes neither the dot product (it may not
 * reassociate the sum) nor, for lack of AVX, more than two doubles.  The
 * kernels below are compiled twice, for AVX2 and for the baseline, and
 * ohm_substitute picks by the CPU once per call. */
typedef double v4d __attribute__((vector_size(32), aligned(8), may_alias)); /* unaligned access allowed */

#define OHM_INLINE static inline __attribute__((always_inline))
#define V4(p) (*(const v4d *)(const void *)(p))

/* w[0..m) -= a * col[0..m): the forward substitution's inner loop. */
OHM_INLINE void axpy_minus(double *restrict w, const double *restrict col, double a, int64_t m)
{
    int64_t i = 0;
    const v4d va = {a, a, a, a};
    for (; i + 4 <= m; i += 4) *(v4d *)(void *)(w + i) = V4(w + i) - V4(col + i) * va;
    for (; i < m; ++i) w[i] -= col[i] * a;
}

/* sum col[i] w[i] over [0, m), with two vector partial sums so that the
 * additions' latency overlaps. */
OHM_INLINE double dot(const double *restrict col, const double *restrict w, int64_t m)
{
    v4d s0 = {0, 0, 0, 0}, s1 = {0, 0, 0, 0};
    int64_t i = 0;
    for (; i + 8 <= m; i += 8) {
        s0 += V4(col + i) * V4(w + i);
        s1 += V4(col + i + 4) * V4(w + i + 4);
    }
    s0 += s1;
    double sum = (s0[0] + s0[1]) + (s0[2] + s0[3]);
    for (; i < m; ++i) sum += col[i] * w[i];
    return sum;
}

/* L y = y in place, supernode by supernode. */
OHM_INLINE void forward(double *y, const cholmod_factor *L, double *w)
{
    const int64_t *super = L->super, *pi = L->pi, *px = L->px, *rows_all = L->s;
    const double *Lx = L->x;
    for (size_t s = 0; s < L->nsuper; ++s) {
        const int64_t k1 = super[s], nscol = super[s + 1] - k1, nsrow = pi[s + 1] - pi[s];
        const int64_t *rows = rows_all + pi[s];
        const double *block = Lx + px[s];
        for (int64_t j = 0; j < nscol; ++j) w[j] = y[k1 + j];
        for (int64_t i = nscol; i < nsrow; ++i) w[i] = 0.0;
        for (int64_t j = 0; j < nscol; ++j) {
            const double *col = block + j * nsrow;
            const double wj = w[j] / col[j];
            w[j] = wj;
            axpy_minus(w + j + 1, col + j + 1, wj, nsrow - j - 1);
        }
        for (int64_t j = 0; j < nscol; ++j) y[k1 + j] = w[j];
        for (int64_t i = nscol; i < nsrow; ++i) y[rows[i]] += w[i];
    }
}

/* L^T y = y in place, supernodes in reverse. */
OHM_INLINE void backward(double *y, const cholmod_factor *L, double *w)
{
    const int64_t *super = L->super, *pi = L->pi, *px = L->px, *rows_all = L->s;
    const double *Lx = L->x;
    for (size_t s = L->nsuper; s-- > 0;) {
        const int64_t k1 = super[s], nscol = super[s + 1] - k1, nsrow = pi[s + 1] - pi[s];
        const int64_t *rows = rows_all + pi[s];
        const double *block = Lx + px[s];
        for (int64_t j = 0; j < nscol; ++j) w[j] = y[k1 + j];
        for (int64_t i = nscol; i < nsrow; ++i) w[i] = y[rows[i]];
        for (int64_t j = nscol; j-- > 0;) {
            const double *col = block + j * nsrow;
            w[j] = (w[j] - dot(col + j + 1, w + j + 1, nsrow - j - 1)) / col[j];
        }
        for (int64_t j = 0; j < nscol; ++j) y[k1 + j] = w[j];
    }
}

static void solve_baseline(double *y, const cholmod_factor *L, double *w)
{
    forward(y, L, w);
    backward(y, L, w);
}

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
__attribute__((target("avx2"))) static void solve_avx2(double *y, const cholmod_factor *L, double *w)
{
    forward(y, L, w);
    backward(y, L, w);
}
#define OHM_HAVE_AVX2_KERNEL 1
#endif

void ohm_substitute(double *x, const cholmod_factor *L, const double *b, double *work)
{
    const int64_t *perm = L->Perm;
    const size_t n = L->n;
    double *y = work, *w = work + n;
    for (size_t k = 0; k < n; ++k) y[k] = b[perm[k]];
#ifdef OHM_HAVE_AVX2_KERNEL
    if (__builtin_cpu_supports("avx2"))
        solve_avx2(y, L, w);
    else
#endif
        solve_baseline(y, L, w);
    for (size_t k = 0; k < n; ++k) x[perm[k]] = y[k];
}
