/* mc_step.h — the Monte Carlo tracer's steps, which its photon loop
 * (mc_loop.h) takes on the host (mc.c) and on the device (mc_device.cl)
 * alike: one source for both, written in what C11 and OpenCL C share.
 * What the includer defines (the random numbers, the index types, the
 * scene and the tallies of the hybrid's handoff) is listed in mc_loop.h.
 * Lengths in voxels (cell i spans [i, i+1)), directions unit vectors. */
#ifndef OHM_PHYSICS_MC_STEP_H
#define OHM_PHYSICS_MC_STEP_H

#include "physics/fresnel_inside.h"

/* An optical depth to the next scattering: -ln(xi), xi in (0, 1]. */
static inline double mc_depth(mc_rng *r)
{
    return -log(1.0 - MC_UNIFORM(r));
}

/* The entry whose share of the power holds xi in [0, 1): the first with
 * cumulative power cdf[e] > xi (nentries of them, the last 1). */
static inline mc_long mc_pick_entry(MC_GLOBAL const double *cdf, mc_long nentries, double xi)
{
    mc_long lo = 0, hi = nentries - 1;
    while (lo < hi) {
        mc_long mid = lo + (hi - lo) / 2;
        if (cdf[mid] <= xi) lo = mid + 1;
        else hi = mid;
    }
    return lo;
}

/* Where a photon starts in cell c, entering through its face in direction
 * d (0..5, network.h): at the point `at` (at_point) or uniformly over the
 * face; on the face, and inside the cell's square on the other axes. */
static inline void mc_start_point(const int c[3], int d, int at_point, const double at[3], mc_rng *r, double p[3])
{
    int axis = d / 2;
    for (int a = 0; a < 3; ++a) {
        double x = at_point ? at[a] : c[a] + MC_UNIFORM(r);
        if (x < c[a]) x = c[a];
        if (x > c[a] + 1.0) x = c[a] + 1.0;
        p[a] = x;
    }
    p[axis] = c[axis] + ((d & 1) ? 1.0 : 0.0);
}

/* 1 - e^-x, the fraction of a segment's weight absorbed over optical depth
 * x: by its series where x is small (the common case: one exp per segment
 * was 15% of the host's time, measured). */
static inline double mc_absorbed_fraction(double x)
{
    if (x < 1e-2) return x * (1.0 - x * (0.5 - x * (1.0 / 6.0 - x * (1.0 / 24.0 - x / 120.0))));
    return -expm1(-x);
}

/* The next segment from p along u in cell c: to the nearest wall
 * (Amanatides & Woo 1987; *axis its axis), or shorter where it ends in a
 * scattering (optical depth tau left at scattering coefficient ss:
 * *scatters) or at the time gate (path_left: *gated).  Its length. */
static inline double mc_segment(const int c[3], const double p[3], const double u[3], double ss, double tau,
                                double path_left, int *axis, int *scatters, int *gated)
{
    double sb = INFINITY;
    *axis = 0;
    for (int a = 0; a < 3; ++a) {
        double ta = u[a] > 0 ? (c[a] + 1.0 - p[a]) / u[a] : u[a] < 0 ? (c[a] - p[a]) / u[a] : INFINITY;
        if (ta < sb) sb = ta, *axis = a;
    }
    if (sb < 0) sb = 0;
    *scatters = ss * sb > tau;
    double s = *scatters ? tau / ss : sb;
    *gated = s >= path_left;
    if (*gated) s = path_left, *scatters = 0;
    return s;
}

/* Henyey-Greenstein: a new direction at cosine cos_t from u (MCML's Spin,
 * Wang, Jacques & Zheng 1995, Eqs. 3.28-3.31). */
static inline void mc_scatter(double u[3], double g, mc_rng *r)
{
    double cos_t;
    if (g != 0.0) {
        double q = (1.0 - g * g) / (1.0 - g + 2.0 * g * MC_UNIFORM(r));
        cos_t = (1.0 + g * g - q * q) / (2.0 * g);
        if (cos_t < -1.0) cos_t = -1.0;
        if (cos_t > 1.0) cos_t = 1.0;
    } else {
        cos_t = 2.0 * MC_UNIFORM(r) - 1.0;
    }
    /* (cos, sin) of a uniform azimuth by rejection from the unit disk (von
     * Neumann 1951): 1.27 draws on average, cheaper than sincos */
    double a, b, q2;
    do {
        a = 2.0 * MC_UNIFORM(r) - 1.0;
        b = 2.0 * MC_UNIFORM(r) - 1.0;
        q2 = a * a + b * b;
    } while (q2 > 1.0 || q2 < 1e-300);
    double sin_t = sqrt(1.0 - cos_t * cos_t), cos_p = (a * a - b * b) / q2, sin_p = 2.0 * a * b / q2;
    if (fabs(u[2]) > 0.99999) {
        u[0] = sin_t * cos_p;
        u[1] = sin_t * sin_p;
        u[2] = u[2] > 0 ? cos_t : -cos_t;
        return;
    }
    double tmp = sqrt(1.0 - u[2] * u[2]);
    double ux = sin_t * (u[0] * u[2] * cos_p - u[1] * sin_p) / tmp + u[0] * cos_t;
    double uy = sin_t * (u[1] * u[2] * cos_p + u[0] * sin_p) / tmp + u[1] * cos_t;
    double uz = -sin_t * cos_p * tmp + u[2] * cos_t;
    /* renormalise: the rotation's round-off would drift over thousands of events */
    double inv = 1.0 / sqrt(ux * ux + uy * uy + uz * uz);
    u[0] = ux * inv;
    u[1] = uy * inv;
    u[2] = uz * inv;
}

/* Crossing from a cell of index ev into one of ew along axis ax: reflected
 * with the Fresnel probability (u mirrored; returns 0) or refracted by
 * Snell's law, the tangential components times ev / ew (returns 1). */
static inline int mc_cross_interface(double u[3], int ax, double ev, double ew, mc_rng *r)
{
    double m = ev / ew, mu = fabs(u[ax]);
    double R = ohm_fresnel_inside(m, mu);
    if (R >= 1.0 || MC_UNIFORM(r) < R) {
        u[ax] = -u[ax];
        return 0;
    }
    double len2 = 0;
    for (int a = 0; a < 3; ++a)
        if (a != ax) {
            u[a] *= m;
            len2 += u[a] * u[a];
        }
    u[ax] = copysign(sqrt(fmax(0.0, 1.0 - len2)), u[ax]);
    return 1;
}

#ifdef MC_HANDOFF
/* The hybrid's handoff (mc.h): weight w at p in unknown v, cell c, shared
 * between the 8 cell centres around p by trilinear weights, which keeps its
 * centroid at p (a diffusion source acts at a cell centre); a share whose
 * cell is not an unknown stays in v. */
static inline void mc_hand_off(const mc_scene *sc, mc_to *to, mc_index v, const int c[3], const double p[3],
                               double w)
{
    int side[3];
    double f[3];
    for (int a = 0; a < 3; ++a) {
        double d = p[a] - (c[a] + 0.5);
        side[a] = d >= 0 ? 1 : -1;
        f[a] = fabs(d);
        /* toward a face of the object there is no cell centre to share with:
         * extrapolate from the one on the other side instead (a negative
         * share there), which keeps the centroid too */
        int n[3] = {c[0], c[1], c[2]};
        n[a] += side[a];
        if (mc_unknown_at(sc, n) < 0) {
            side[a] = -side[a];
            f[a] = -f[a];
        }
    }
    for (int q = 0; q < 8; ++q) {
        double wq = w;
        int n[3];
        for (int a = 0; a < 3; ++a) {
            int far = (q >> a) & 1;
            wq *= far ? f[a] : 1.0 - f[a];
            n[a] = c[a] + (far ? side[a] : 0);
        }
        if (wq == 0) continue;
        mc_index u = q ? mc_unknown_at(sc, n) : v;
        mc_tally_handoff(to, u >= 0 ? u : v, wq);
    }
}
#endif

#endif
