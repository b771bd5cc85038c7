/* fresnel.c — Fresnel reflectance and the boundary constant A (fresnel.h). */
#include "physics/fresnel.h"

#include "physics/fresnel_inside.h"

#include <math.h>

double ohm_fresnel_reflectance(double eta, double cos_i)
{
    if (cos_i > 1.0) cos_i = 1.0;
    if (cos_i <= 0.0) return 1.0;
    double sin_t2 = (1.0 - cos_i * cos_i) / (eta * eta);
    if (sin_t2 >= 1.0) return 1.0; /* cannot happen entering a denser medium */
    double cos_t = sqrt(1.0 - sin_t2);
    double rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    double rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    return 0.5 * (rs * rs + rp * rp);
}

double ohm_fresnel_reflectance_inside(double eta, double mu)
{
    return ohm_fresnel_inside(eta, mu);
}

/* 8-point Gauss-Legendre on [-1, 1] (Abramowitz & Stegun, Table 25.4). */
static const double GL_X[4] = {0.1834346424956498, 0.5255324099163290, 0.7966664774136267, 0.9602898564975363};
static const double GL_W[4] = {0.3626837833783620, 0.3137066458778873, 0.2223810344533745, 0.1012285362903763};
enum { PANELS = 64 };

/* int_0^1 f(s) ds, composite over PANELS panels, for a smooth f. */
static void integrate(double eta, int tir, double *c1, double *c2)
{
    double s1 = 0.0, s2 = 0.0;
    for (int p = 0; p < PANELS; ++p) {
        double a = (double)p / PANELS, half = 0.5 / PANELS, mid = a + half;
        for (int q = 0; q < 8; ++q) {
            double s = mid + (q < 4 ? -1.0 : 1.0) * half * GL_X[q & 3], w = half * GL_W[q & 3];
            double mu, weight, R;
            if (tir) {
                /* Beyond the critical cosine mu_c the transmitted cosine t
                 * rises from 0 like sqrt(mu - mu_c); in t the integrand is
                 * smooth: mu^2 = 1 - (1 - t^2)/eta^2, mu dmu = t dt / eta^2. */
                double t = s;
                mu = sqrt(1.0 - (1.0 - t * t) / (eta * eta));
                weight = t / (eta * eta * mu); /* dmu/dt */
                R = t > 0.0 ? ohm_fresnel_inside_given_cos_t(eta, mu, t) : 1.0;
            } else {
                mu = s;
                weight = 1.0;
                R = ohm_fresnel_inside(eta, mu);
            }
            s1 += w * weight * R * mu;
            s2 += w * weight * R * mu * mu;
        }
    }
    *c1 = s1;
    *c2 = s2;
}

void ohm_fresnel_moments(double eta, double *c1, double *c2)
{
    if (eta == 1.0) { /* no interface: nothing reflects */
        *c1 = *c2 = 0.0;
        return;
    }
    if (eta < 1.0) { /* no critical angle from inside: smooth over mu in [0, 1] */
        integrate(eta, 0, c1, c2);
        return;
    }
    /* R = 1 below the critical cosine mu_c: int_0^mu_c mu^n dmu exactly */
    double mu_c = sqrt(1.0 - 1.0 / (eta * eta)), t1, t2;
    integrate(eta, 1, &t1, &t2);
    *c1 = 0.5 * mu_c * mu_c + t1;
    *c2 = mu_c * mu_c * mu_c / 3.0 + t2;
}

double ohm_fresnel_dr(double eta) { return -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta; }

double ohm_boundary_A(double eta, ohm_fresnel how)
{
    if (how == OHM_FRESNEL_POLYNOMIAL) {
        double f = ohm_fresnel_dr(eta);
        return (1.0 + f) / (1.0 - f);
    }
    double c1, c2;
    ohm_fresnel_moments(eta, &c1, &c2);
    return ohm_boundary_A_of_moments(c1, c2);
}

/* The table's coordinate: u = sqrt(|m - 1|) from 0 to U_MAX[s] (m = 1/3 on
 * side 0, m = 3 on side 1). */
static const double U_MAX[2] = {0.81649658092772603 /* sqrt(2/3) */, 1.4142135623730951 /* sqrt(2) */};

void ohm_fresnel_table_init(ohm_fresnel_table *t)
{
    for (int s = 0; s < 2; ++s)
        for (int q = 0; q <= OHM_FRESNEL_TABLE_STEPS; ++q) {
            double u = U_MAX[s] * q / OHM_FRESNEL_TABLE_STEPS, m = s ? 1.0 + u * u : 1.0 - u * u;
            ohm_fresnel_moments(m, &t->c1[s][q], &t->c2[s][q]);
        }
}

/* 4-point Lagrange interpolation of y at fractional node `at`, through the
 * nodes q-1 .. q+2 (shifted inwards at the ends). */
static double lagrange4(const double *y, double at)
{
    int q = (int)at;
    if (q < 1) q = 1;
    if (q > OHM_FRESNEL_TABLE_STEPS - 2) q = OHM_FRESNEL_TABLE_STEPS - 2;
    double x = at - q;
    double l0 = -x * (x - 1) * (x - 2) / 6, l1 = (x + 1) * (x - 1) * (x - 2) / 2;
    double l2 = -(x + 1) * x * (x - 2) / 2, l3 = (x + 1) * x * (x - 1) / 6;
    return l0 * y[q - 1] + l1 * y[q] + l2 * y[q + 1] + l3 * y[q + 2];
}

void ohm_fresnel_table_moments(const ohm_fresnel_table *t, double m, double *c1, double *c2)
{
    if (m == 1.0) {
        *c1 = *c2 = 0.0;
        return;
    }
    int s = m > 1.0;
    double at = sqrt(fabs(m - 1.0)) / U_MAX[s] * OHM_FRESNEL_TABLE_STEPS;
    if (!(at <= OHM_FRESNEL_TABLE_STEPS)) at = OHM_FRESNEL_TABLE_STEPS; /* clamped to [1/3, 3] */
    *c1 = lagrange4(t->c1[s], at);
    *c2 = lagrange4(t->c2[s], at);
}

const char *ohm_fresnel_name(ohm_fresnel how) { return how == OHM_FRESNEL_POLYNOMIAL ? "polynomial" : "exact"; }
