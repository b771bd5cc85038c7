/* solvers/mg_cycle.c — the K-cycle and the outer flexible CG of solver=mg,
 * over a machine's operations (mg_cycle.h, mg_ops.h). */
#include "solvers/mg_cycle.h"

#include <math.h>
#include <string.h>

/* The smoother: two Chebyshev steps on D^-1 A before and after each coarse
 * correction (Adams, Brezina, Hu and Tuminaro, "Parallel multigrid
 * smoothing: polynomial versus Gauss-Seidel", J. Comput. Phys. 188, 2003),
 * aimed at the eigenvalues in [LMAX / CHEB_RATIO, LMAX]; those below are the
 * coarse levels' to remove.  LMAX = 2 bounds D^-1 A's spectrum for any
 * diagonally dominant stencil (Gershgorin), so nothing is estimated.  By
 * measurement (docs/multigrid.md): on the block medium at 1e7 cells 17
 * iterations and 4.8-5.0 s against damped Jacobi's 19 and 5.4 s (omega
 * 0.9, two sweeps, the best of 0.67-1.0 and one to three sweeps) and
 * red-black Gauss-Seidel's 23 and 6.0 s (one symmetric sweep) or 15 and
 * 6.2 s (two); fewer iterations or as many on every test scene; ratio 5-8
 * as good as 6. */
static const double CHEB_LMAX = 2.0, CHEB_RATIO = 6.0;

/* Two Chebyshev steps for A out = b from y: x1 = y + D^-1 (b - A y) /
 * theta, then out = x1 + rho1 rho0 (x1 - y) + (2 rho1 / delta) D^-1 (b - A
 * x1) (the three-term recurrence of Saad, "Iterative Methods for Sparse
 * Linear Systems", 2nd ed., Algorithm 12.1, with d0 = x1 - y). */
void ohm_mg_smoother(double *w0, double *a, double *a2)
{
    const double lmin = CHEB_LMAX / CHEB_RATIO;
    const double theta = 0.5 * (CHEB_LMAX + lmin), delta = 0.5 * (CHEB_LMAX - lmin), sigma = theta / delta;
    const double rho0 = 1.0 / sigma, rho1 = 1.0 / (2.0 * sigma - rho0);
    *w0 = 1.0 / theta;
    *a = rho1 * rho0;
    *a2 = 2.0 * rho1 / delta;
}

/* The cycle on r, in single precision: level 0's x = M (s r), M near
 * A^-1, with s = ||A||_inf / ||r||.  Scaled so, the cycle's right-hand
 * sides are at most ||A||_inf and its corrections at most about cond(A) =
 * ||A|| ||A^-1||, free of h and of the coefficients' units (as with a
 * stencil scaled to ||A|| = 1), inside a float's range at any contrast the
 * stencil holds.  A^-1 r is then about x / s. */
double ohm_mg_rhs_scale(double norm_A, double nr) { return nr > 0 ? (norm_A > 0 ? norm_A : 1.0) / nr : 1.0; }

void ohm_mg_machine_init(ohm_mg_machine *mc, const ohm_mg_ops *ops, void *self, int64_t n, double norm_A,
                         int nlevels)
{
    *mc = (ohm_mg_machine){.ops = ops, .self = self, .n = n, .norm_A = norm_A, .nlevels = nlevels};
}

void ohm_mg_machine_level(ohm_mg_machine *mc, int l, int64_t n, int kcycle, const ohm_mg_vec vecs[7])
{
    mc->lev[l] = (ohm_mg_level_vecs){.n = n,
                                     .kcycle = kcycle,
                                     .b = vecs[0],
                                     .x = vecs[1],
                                     .t = vecs[2],
                                     .c1 = vecs[3],
                                     .v1 = vecs[4],
                                     .c2 = vecs[5],
                                     .rt = vecs[6]};
}

static void cycle(const ohm_mg_machine *mc, int l, ohm_mg_vec b, ohm_mg_vec x);

/* ec ~ A_l^-1 rc for coarse level l: exactly at the coarsest; else one
 * cycle, or the K-cycle's two steps of flexible CG preconditioned by it
 * (Notay and Vassilevski, "Recursive Krylov-based multigrid cycles", Numer.
 * Linear Algebra Appl. 15, 2008, Algorithm 2.1). */
static void coarse_solve(const ohm_mg_machine *mc, int l, ohm_mg_vec rc, ohm_mg_vec ec)
{
    const ohm_mg_ops *o = mc->ops;
    void *m = mc->self;
    const ohm_mg_level_vecs *L = &mc->lev[l];
    if (l == mc->nlevels - 1) {
        o->coarsest_solve(m, rc, ec);
        return;
    }
    if (!L->kcycle) {
        cycle(mc, l, rc, ec);
        return;
    }
    cycle(mc, l, rc, L->c1);
    double rho1 = o->apply_dot(m, l, L->c1, L->v1, NULL), alpha1 = o->dot(m, l, L->c1, rc);
    if (!(rho1 > 0)) {
        o->zero(m, l, ec);
        return;
    }
    double a1 = alpha1 / rho1;
    o->combine(m, l, L->rt, 1.0, rc, -a1, L->v1);
    cycle(mc, l, L->rt, L->c2);
    double beta = o->apply_dot(m, l, L->c2, NULL, NULL); /* c2.A c2: A c2 itself is not needed */
    double gamma = o->dot(m, l, L->c2, L->v1), alpha2 = o->dot(m, l, L->c2, L->rt);
    double rho2 = beta - gamma * gamma / rho1;
    if (!(rho2 > 0)) {
        o->combine(m, l, ec, a1, L->c1, 0, NULL);
        return;
    }
    double w1 = a1 - gamma * alpha2 / (rho1 * rho2), w2 = alpha2 / rho2;
    o->combine(m, l, ec, w1, L->c1, w2, L->c2);
}

/* x = M_l b: smooth from zero, correct on the next level, smooth again.
 * b and x are not level l's temporaries. */
static void cycle(const ohm_mg_machine *mc, int l, ohm_mg_vec b, ohm_mg_vec x)
{
    const ohm_mg_ops *o = mc->ops;
    void *m = mc->self;
    const ohm_mg_level_vecs *L = &mc->lev[l], *C = &mc->lev[l + 1];
    o->smooth(m, l, NULL, b, L->t, x);            /* pre-smoothed: x (t: its first step) */
    o->restrict_residual(m, l, x, b, L->t, C->b); /* t: the residual */
    coarse_solve(mc, l + 1, C->b, C->x);
    o->prolong_add(m, l, x, C->x, x); /* corrected, in place */
    o->smooth(m, l, x, b, L->t, x);   /* post-smoothed, in place */
}

void ohm_mg_cycle_level0(const ohm_mg_machine *mc)
{
    const ohm_mg_level_vecs *L0 = &mc->lev[0];
    if (mc->nlevels == 1) mc->ops->coarsest_solve(mc->self, L0->b, L0->x);
    else cycle(mc, 0, L0->b, L0->x);
}

/* ||b||_2, sum |b|, and whether every b >= 0 */
static void rhs_sizes(const double *b, int64_t n, double *norm2, double *sum_abs, int *nonnegative)
{
    double s2 = 0, s1 = 0;
    int nonneg = 1;
    for (int64_t i = 0; i < n; ++i) {
        s2 += b[i] * b[i];
        s1 += fabs(b[i]);
        nonneg &= b[i] >= 0;
    }
    *norm2 = sqrt(s2);
    *sum_abs = s1;
    *nonnegative = nonneg;
}

int ohm_mg_fcg(const ohm_mg_machine *mc, double *x, const double *b, double tol, int64_t max_iter,
               const ohm_log *log, int64_t *iters, double *relres, ohm_error *err)
{
    const ohm_mg_ops *o = mc->ops;
    void *m = mc->self;
    int64_t n = mc->n;
    double nb, sb;
    int b_nonnegative;
    rhs_sizes(b, n, &nb, &sb, &b_nonnegative);
    /* Converged when the residual is tol of b's and so is its sum: the sum
     * of b - A x is the power in less what the solution absorbs and lets
     * out (A's column sums are the sinks), and ||r||_2 <= tol ||b||_2 alone
     * bounds it only by sqrt(n) tol. */
#define CONVERGED(nr, sr) ((nr) <= tol * nb && fabs(sr) <= tol * sb)
#define CHECKED() (o->checked ? o->checked(m, err) : OHM_OK)
    *iters = 0;
    *relres = 0.0;
    if (!(nb > 0)) {
        memset(x, 0, (size_t)n * sizeof *x);
        return OHM_OK;
    }
    int rc = o->begin ? o->begin(m, x, b, err) : OHM_OK;
    if (rc) return rc;
    int64_t it = 0;
    int restarts = 0, clamps = 0;
    ohm_progress prog;
    ohm_progress_begin(&prog, log, "solve: mg");
    double t_reported = prog.t_begin;
    while (!rc) {
        /* the true residual at every (re)start and at the end */
        double nr, sr;
        o->residual(m, &nr, &sr);
        if ((rc = CHECKED())) break;
        if (it == 0 && !(nr <= nb)) { /* a warm start worse than zero (or not finite): start cold */
            memset(x, 0, (size_t)n * sizeof *x);
            if ((rc = o->start_cold(m, x, b, err))) break;
            nr = nb;
            sr = 0;
            for (int64_t i = 0; i < n; ++i) sr += b[i];
        }
        *relres = nr / nb;
        /* A is an M-matrix, so A^-1 >= 0 and a source b >= 0 has x >= 0.
         * Where the fluence has decayed to ~1e-40 of its peak (a 100 mm
         * voxel, a 1e12 contrast) the iteration's error, tol of the peak,
         * leaves values of either sign: taken to the 0 they are within that
         * error of, and the true residual judged again, since the power
         * they held can be tol of the whole (a point source in the block
         * medium: 1.4e-10); a round from the clamped x removes it.  Twice
         * at most: then the clamped x stands (below). */
        if (CONVERGED(nr, sr) && b_nonnegative && clamps < 2 && o->clamp(m) != 0) {
            ++clamps;
            o->residual(m, &nr, &sr);
            if ((rc = CHECKED())) break;
            *relres = nr / nb;
        }
        if (CONVERGED(nr, sr)) break;
        if (restarts > 0) { /* stagnated at the floor */
            double berr;
            if ((rc = o->backward_error(m, x, b, &berr, err))) break;
            if (berr <= 0.01 * tol) break;
        }
        if (it >= max_iter || restarts > 5) {
            rc = ohm_fail(err, OHM_ERR_NUMERIC,
                          "mg: did not converge: relative residual %.3g after %lld iterations (cg_tol=%.1g); use "
                          "solver=direct, or a looser cg_tol=",
                          nr / nb, (long long)it, tol);
            break;
        }
        ++restarts;
        /* flexible CG (Notay, "Flexible conjugate gradients", SIAM J. Sci.
         * Comput. 22, 2000), one direction kept: p = kz z - beta p with
         * beta = kz z.q / p.q making p A-orthogonal to the last (q = A p),
         * z = M (s r) the cycle's result and kz = 1 / s. */
        double beta = 0, pq = 0, pr = 0;
        double s = ohm_mg_rhs_scale(mc->norm_A, nr); /* the cycle's right-hand side s r; then each step's */
        o->rhs(m, s);
        for (int first = 1; !CONVERGED(nr, sr) && it < max_iter; first = 0) {
            ohm_mg_cycle_level0(mc);
            double kz = 1.0 / s;
            if (!first) beta = kz * o->mixed_dot(m) / pq;
            o->direction(m, kz, beta);
            o->apply_dots(m, &pq, &pr);
            if ((rc = CHECKED())) break;
            if (!(pq > 0)) break; /* converged to round-off (or A not positive definite) */
            s = o->step(m, pr / pq, nr, &nr, &sr);
            if ((rc = CHECKED())) break;
            ++it;
            if (ohm_log_cancelled(log)) {
                rc = ohm_fail_cancelled(err, "mg");
                break;
            }
            if (log && ohm_now() - t_reported >= 0.05) {
                t_reported = ohm_now();
                ohm_progress_update(&prog, fmin(1.0, fmax(0.0, log10(nr / nb) / log10(tol))));
            }
        }
    }
#undef CONVERGED
    if (!rc && b_nonnegative) { /* a nonnegative source's solution is nonnegative (above) */
        o->clamp(m);
        rc = CHECKED();
    }
#undef CHECKED
    if (!rc && o->end) rc = o->end(m, x, err);
    *iters = it;
    ohm_progress_end(&prog);
    return rc;
}
