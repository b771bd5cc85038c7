/* test_fresnel.c — the Fresnel moments and the boundary constant A
 * (fresnel.h): no interface at eta = 1, the published values, reciprocity
 * between the two sides of an interface, agreement with the independent
 * Egan & Hilgeman fit of F_dr = 2 C1, and convergence of the quadrature. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "check.h"
#include "physics/fresnel.h"

/* The same moments by a plain midpoint rule in theta with many points: slow,
 * second order, but independent of fresnel.c's substitution and panels. */
static void moments_midpoint(double eta, double *c1, double *c2)
{
    const int n = 400000;
    const double dtheta = 0.5 * 3.14159265358979323846 / n;
    double s1 = 0, s2 = 0;
    for (int i = 0; i < n; ++i) {
        double th = (i + 0.5) * dtheta, mu = cos(th), R = ohm_fresnel_reflectance_inside(eta, mu);
        s1 += R * sin(th) * mu;
        s2 += R * sin(th) * mu * mu;
    }
    *c1 = s1 * dtheta;
    *c2 = s2 * dtheta;
}

static void test_no_interface(void)
{
    double c1 = -1, c2 = -1;
    ohm_fresnel_moments(1.0, &c1, &c2);
    CHECK(c1 == 0.0 && c2 == 0.0);
    CHECK(ohm_boundary_A(1.0, OHM_FRESNEL_EXACT) == 1.0);
    CHECK(fabs(ohm_fresnel_reflectance_inside(1.0, 0.3)) < 1e-30);
    /* just off 1, continuous from both sides */
    CHECK(fabs(ohm_boundary_A(1.0 + 1e-9, OHM_FRESNEL_EXACT) - 1.0) < 1e-6);
    CHECK(fabs(ohm_boundary_A(1.0 - 1e-9, OHM_FRESNEL_EXACT) - 1.0) < 1e-6);
}

/* A = 2.76 at eta 1.37 and 2.34 at 1.3 (Haskell et al. 1994,
 * d'Eon 2012 tabulate the same moments), against 3.05 and 2.60 by the fit. */
static void test_published(void)
{
    CHECK(fabs(ohm_boundary_A(1.37, OHM_FRESNEL_EXACT) - 2.76) < 0.005);
    CHECK(fabs(ohm_boundary_A(1.3, OHM_FRESNEL_EXACT) - 2.34) < 0.005);
    CHECK(fabs(ohm_boundary_A(1.37, OHM_FRESNEL_POLYNOMIAL) - 3.05) < 0.005);
    CHECK(fabs(ohm_boundary_A(1.3, OHM_FRESNEL_POLYNOMIAL) - 2.60) < 0.005);
}

/* Reciprocity across an interface: the diffuse transmittances from the two
 * sides satisfy 1 - F_dr(eta) = (1 - F_dr(1/eta)) / eta^2 (the radiance
 * n^2 law), with F_dr = 2 C1 on each side. */
static void test_reciprocity(void)
{
    const double etas[] = {1.05, 1.3, 1.4, 1.5, 2.0, 3.0};
    for (int i = 0; i < 6; ++i) {
        double e = etas[i], c1, c2, d1, d2;
        ohm_fresnel_moments(e, &c1, &c2);
        ohm_fresnel_moments(1.0 / e, &d1, &d2);
        CHECK_REL(1.0 - 2.0 * c1, (1.0 - 2.0 * d1) / (e * e), 1e-12);
    }
}

/* The fit of Egan & Hilgeman is of the same internal F_dr: within its own
 * ~1% over the range it was fitted for. */
static void test_fit(void)
{
    for (double e = 1.2; e <= 1.6001; e += 0.05) {
        double c1, c2;
        ohm_fresnel_moments(e, &c1, &c2);
        CHECK_REL(2.0 * c1, ohm_fresnel_dr(e), 0.01);
    }
}

/* The quadrature against a brute-force one, both sides of 1. */
static void test_quadrature(void)
{
    const double etas[] = {0.5, 0.8, 1.1, 1.3, 1.37, 1.5, 2.5};
    for (int i = 0; i < 7; ++i) {
        double c1, c2, r1, r2;
        ohm_fresnel_moments(etas[i], &c1, &c2);
        moments_midpoint(etas[i], &r1, &r2);
        /* below 1 the integrand is smooth and the midpoint rule is good to
         * ~1e-12; above 1, R rises like the square root of the distance to
         * the critical angle and the midpoint rule's error is ~h^1.5 ~ 1e-8
         * (C1 above 1 is held to 1e-12 by reciprocity, test_reciprocity) */
        double tol = etas[i] < 1.0 ? 1e-11 : 2e-8;
        CHECK_MSG(fabs(c1 - r1) < tol && fabs(c2 - r2) < tol, "eta %g: C1 %.15g vs %.15g, C2 %.15g vs %.15g",
                  etas[i], c1, r1, c2, r2);
        CHECK(c1 > 0 && c2 > 0 && c2 < c1 && c1 < 0.5);
    }
}

/* The interfaces' table (fresnel.h) against the quadrature: ~1e-11 at most
 * beyond |m - 1| > 0.05, ~6e-9 at worst right next to m = 1, both sides. */
static void test_table(void)
{
    ohm_fresnel_table *t = malloc(sizeof *t);
    CHECK(t != NULL);
    if (!t) return;
    ohm_fresnel_table_init(t);
    double worst = 0, worst_far = 0;
    for (int i = 0; i < 20000; ++i) {
        double m = 1.0 / 3.0 + (3.0 - 1.0 / 3.0) * (i + 0.37) / 20000.0, a1, a2, b1, b2;
        ohm_fresnel_moments(m, &a1, &a2);
        ohm_fresnel_table_moments(t, m, &b1, &b2);
        double e = fmax(fabs(a1 - b1), fabs(a2 - b2));
        worst = fmax(worst, e);
        if (fabs(m - 1.0) > 0.05) worst_far = fmax(worst_far, e);
    }
    const double near1[] = {1.0 + 1e-7, 1.0 - 1e-7, 1.0 + 1e-5, 1.0 - 1e-5};
    for (int i = 0; i < 4; ++i) {
        double a1, a2, b1, b2;
        ohm_fresnel_moments(near1[i], &a1, &a2);
        ohm_fresnel_table_moments(t, near1[i], &b1, &b2);
        worst = fmax(worst, fmax(fabs(a1 - b1), fabs(a2 - b2)));
    }
    double c1, c2;
    ohm_fresnel_table_moments(t, 1.0, &c1, &c2);
    CHECK(c1 == 0.0 && c2 == 0.0);
    printf("fresnel table: worst interpolation error %.3g (%.3g beyond |m - 1| > 0.05)\n", worst, worst_far);
    CHECK_MSG(worst < 1e-8, "table error %.3g", worst);
    CHECK_MSG(worst_far < 3e-11, "table error %.3g away from m = 1", worst_far);
    free(t);
}

int main(void)
{
    test_no_interface();
    test_published();
    test_reciprocity();
    test_fit();
    test_quadrature();
    test_table();
    return check_summary();
}
