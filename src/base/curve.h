/* curve.h — piecewise-linear functions of one variable, clamped outside their
 * knots: a transfer function's coefficients of density (transfer.h), kept as
 * the function itself so that a scan's media cost one density per cell,
 * evaluated where a cell's coefficient is needed (network.h). */
#ifndef OHM_CURVE_H
#define OHM_CURVE_H

#include <stddef.h>

typedef struct ohm_curve {
    size_t n;          /* knots; 0: no curve                          */
    const double *x;   /* n, increasing                               */
    const double *y;   /* the value at knot i is y[i * stride]        */
    size_t stride;
} ohm_curve;

/* The knots around t in x[0..n) (n > 0): the value is y0 + w (y1 - y0) with
 * y0, y1 those of knots i0, i1.  Below the first knot, or NaN: the first
 * knot's; at or above the last: the last's. */
static inline void ohm_curve_bracket(const double *x, size_t n, double t, size_t *i0, size_t *i1, double *w)
{
    if (!(t > x[0])) {
        *i0 = *i1 = 0;
        *w = 0.0;
        return;
    }
    if (t >= x[n - 1]) {
        *i0 = *i1 = n - 1;
        *w = 0.0;
        return;
    }
    size_t lo = 0, hi = n - 1; /* binary search: x[lo] <= t < x[hi] */
    while (hi - lo > 1) {
        size_t mid = lo + (hi - lo) / 2;
        if (x[mid] <= t) lo = mid;
        else hi = mid;
    }
    *i0 = lo;
    *i1 = hi;
    *w = (t - x[lo]) / (x[hi] - x[lo]);
}

/* The curve at t (c->n > 0). */
static inline double ohm_curve_at(const ohm_curve *c, double t)
{
    size_t i0, i1;
    double w;
    ohm_curve_bracket(c->x, c->n, t, &i0, &i1, &w);
    double y0 = c->y[i0 * c->stride], y1 = c->y[i1 * c->stride];
    return y0 + w * (y1 - y0);
}

#endif
