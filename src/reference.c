#include "reference.h"

#include <math.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

double ohm_ref_infinite(double P, double sigma_a, double sigma_s, double r)
{
    double st = sigma_a + sigma_s, D = 1.0 / (3.0 * st), str = sqrt(3.0 * sigma_a * st);
    return P * exp(-str * r) / (4.0 * M_PI * D * r);
}

static double green(double d, double D, double str) { return exp(-str * d) / (4.0 * M_PI * D * d); }

double ohm_ref_halfspace_exitance(double r, double z0, double sigma_a, double sigma_s, double A)
{
    double st = sigma_a + sigma_s, D = 1.0 / (3.0 * st), str = sqrt(3.0 * sigma_a * st);
    double zb = 2.0 * A * D;
    /* The integral in u = t / z_b over [0, 60] (e^-60 ~ 1e-26), composite
     * Simpson with 6000 panels: the integrand is smooth and decays like e^-u,
     * so this is exact to ~1e-12 relative. */
    const int n = 6000;
    const double umax = 60.0, du = umax / n;
    double sum = 0.0;
    for (int i = 0; i <= n; ++i) {
        double u = i * du, t = u * zb;
        double f = exp(-u) * green(sqrt(r * r + (z0 + t) * (z0 + t)), D, str);
        sum += f * (i == 0 || i == n ? 1.0 : (i % 2 ? 4.0 : 2.0));
    }
    double integral = sum * du / 3.0 * zb; /* dt = z_b du */
    double phi_s = 2.0 * green(sqrt(r * r + z0 * z0), D, str) - (2.0 / zb) * integral;
    return phi_s / (2.0 * A);
}

double ohm_ref_halfspace_escape(double z0, double sigma_a, double sigma_s, double A)
{
    double st = sigma_a + sigma_s, D = 1.0 / (3.0 * st), k = sqrt(3.0 * sigma_a * st);
    double zb = 2.0 * A * D;
    if (k == 0) return 1.0; /* nothing absorbs: everything leaves */
    double rho = (1.0 - zb * k) / (1.0 + zb * k);
    return exp(-k * z0) * (1.0 - rho) / (4.0 * A * D * k);
}

double ohm_ref_dipole_Rd(double r, double sigma_a, double sigma_s, double A)
{
    double st = sigma_a + sigma_s, alpha = sigma_s / st, D = 1.0 / (3.0 * st), str = sqrt(3.0 * sigma_a * st);
    double zr = 1.0 / st, zv = zr + 4.0 * A * D;
    double dr = sqrt(r * r + zr * zr), dv = sqrt(r * r + zv * zv);
    return alpha / (4.0 * M_PI) *
           (zr * (str * dr + 1.0) * exp(-str * dr) / (dr * dr * dr) +
            zv * (str * dv + 1.0) * exp(-str * dv) / (dv * dv * dv));
}

double ohm_ref_dipole_Rd_total(double sigma_a, double sigma_s, double A)
{
    double st = sigma_a + sigma_s, alpha = sigma_s / st;
    double s = sqrt(3.0 * (1.0 - alpha));
    return 0.5 * alpha * (1.0 + exp(-4.0 / 3.0 * A * s)) * exp(-s);
}
