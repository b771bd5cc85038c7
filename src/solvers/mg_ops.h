/* solvers/mg_ops.h — the multigrid's operations on one machine, as a
 * table: what the K-cycle and the outer flexible CG (mg_cycle.c, written
 * once) ask of the machine that holds the hierarchy's vectors.  Two
 * implementations: the host's (mg.c, on the host's cores) and an OpenCL
 * device's (mg_device.c, kernels in mg_device.cl), with the same arithmetic.
 * As HPGMG writes its cycle once over smooth / residual / restriction /
 * interpolation, and PETSc's PCMG over Mat and Vec.
 *
 * A vector is an opaque handle, where the machine keeps it: the host's
 * float *, the device's cl_mem.  The cycle's vectors are single precision;
 * the outer iteration's (x, b and its residual r in double, its direction
 * p and q = A p as the machine keeps them: the host's p in floats times a
 * scale, q in two floats) are the machine's own, named by no handle: the
 * outer operations work on them. */
#ifndef OHM_SOLVERS_MG_OPS_H
#define OHM_SOLVERS_MG_OPS_H

#include <stdint.h>

#include "base/ohm_error.h"

typedef void *ohm_mg_vec;

enum { OHM_MG_LEVELS_MAX = 40 };

typedef struct ohm_mg_ops {
    /* ---- a level l's (single precision) ---- */
    /* out = two Chebyshev steps for A_l out = b from y (NULL: zero), the
     * first into tmp; out may be y (the second step reads y in its own row
     * only), tmp is neither */
    void (*smooth)(void *self, int l, ohm_mg_vec y, ohm_mg_vec b, ohm_mg_vec tmp, ohm_mg_vec out);
    /* level l + 1's rc = P^T (b - A_l x); scratch: a vector of level l's to
     * hold the residual */
    void (*restrict_residual)(void *self, int l, ohm_mg_vec x, ohm_mg_vec b, ohm_mg_vec scratch, ohm_mg_vec rc);
    /* out = x + P e, e level l + 1's (out may be x) */
    void (*prolong_add)(void *self, int l, ohm_mg_vec x, ohm_mg_vec e, ohm_mg_vec out);
    /* y = A_l x, returning x.q (q NULL: x.y) from the same pass; y NULL:
     * only x.A x (the product kept nowhere the cycle reads) */
    double (*apply_dot)(void *self, int l, ohm_mg_vec x, ohm_mg_vec y, ohm_mg_vec q);
    double (*dot)(void *self, int l, ohm_mg_vec x, ohm_mg_vec y);
    /* out = a x + a2 y (y NULL: a x) */
    void (*combine)(void *self, int l, ohm_mg_vec out, double a, ohm_mg_vec x, double a2, ohm_mg_vec y);
    void (*zero)(void *self, int l, ohm_mg_vec x);
    /* x = A^-1 b at the coarsest level, by its dense factor */
    void (*coarsest_solve)(void *self, ohm_mg_vec b, ohm_mg_vec x);

    /* ---- the outer iteration's (double, on the network's stencil) ---- */
    /* the solve's b and warm start x (the caller's, on the host) to the
     * machine; at the end, x back (NULL: the machine works on the caller's
     * arrays, the host's) */
    int (*begin)(void *self, double *x, const double *b, ohm_error *err);
    int (*end)(void *self, double *x, ohm_error *err);
    /* r = b - A x: ||r||_2 and sum r */
    void (*residual)(void *self, double *nr, double *sr);
    /* x = 0 (the caller's x already zeroed), r = b */
    int (*start_cold)(void *self, double *x, const double *b, ohm_error *err);
    /* x's negative values set to 0: how many there were, or -1 when the
     * machine does not count them */
    int64_t (*clamp)(void *self);
    /* ohm_scaled_backward_error of the current x and r (backend.h) */
    int (*backward_error)(void *self, double *x, const double *b, double *berr, ohm_error *err);
    /* level 0's b = s r, the cycle's right-hand side */
    void (*rhs)(void *self, double s);
    /* z.q, z the cycle's result (level 0's x) */
    double (*mixed_dot)(void *self);
    /* p = kz z - beta p (beta 0: kz z) */
    void (*direction)(void *self, double kz, double beta);
    /* q = A p: p.q and p.r */
    void (*apply_dots)(void *self, double *pq, double *pr);
    /* x += alpha p, r -= alpha q: the new ||r||_2 and sum r; and the next
     * cycle's right-hand side s r (nr: ||r||_2 before the step): returns s */
    double (*step)(void *self, double alpha, double nr, double *nr_after, double *sr_after);
    /* a failure the machine met since the last check, as an error (the
     * host's: none, NULL) */
    int (*checked)(void *self, ohm_error *err);
} ohm_mg_ops;

/* A level's vectors and shape, as the cycle walks them: its right-hand
 * side and correction (level 0's: the preconditioner's input and output),
 * the cycle's temporary (not at the coarsest), the K-cycle's four where it
 * solves this level. */
typedef struct ohm_mg_level_vecs {
    int64_t n;
    int kcycle;
    ohm_mg_vec b, x, t, c1, v1, c2, rt;
} ohm_mg_level_vecs;

/* A hierarchy on a machine: its operations and their `self`, its levels'
 * vectors, and ||A||_inf of the network's stencil. */
typedef struct ohm_mg_machine {
    const ohm_mg_ops *ops;
    void *self;
    int64_t n; /* unknowns */
    double norm_A;
    int nlevels;
    ohm_mg_level_vecs lev[OHM_MG_LEVELS_MAX];
} ohm_mg_machine;

#endif
