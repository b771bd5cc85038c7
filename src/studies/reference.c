#include "studies/reference.h"

#include <math.h>
#include <string.h>

#include "physics/fresnel.h"

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

/* Solve the n x n system M x = r in place (Gaussian elimination, partial
 * pivoting); r receives x. */
static int gauss(int n, double *M, double *r)
{
    for (int c = 0; c < n; ++c) {
        int p = c;
        for (int i = c + 1; i < n; ++i)
            if (fabs(M[i * n + c]) > fabs(M[p * n + c])) p = i;
        if (M[p * n + c] == 0.0) return -1;
        if (p != c) {
            for (int j = 0; j < n; ++j) {
                double t = M[c * n + j];
                M[c * n + j] = M[p * n + j];
                M[p * n + j] = t;
            }
            double t = r[c];
            r[c] = r[p];
            r[p] = t;
        }
        for (int i = c + 1; i < n; ++i) {
            double f = M[i * n + c] / M[c * n + c];
            for (int j = c; j < n; ++j) M[i * n + j] -= f * M[c * n + j];
            r[i] -= f * r[c];
        }
    }
    for (int c = n - 1; c >= 0; --c) {
        double s = r[c];
        for (int j = c + 1; j < n; ++j) s -= M[c * n + j] * r[j];
        r[c] = s / M[c * n + c];
    }
    return 0;
}

int ohm_ref_two_layer_init(ohm_ref_two_layer *s, const ohm_ref_layer layer[2], double TI)
{
    memset(s, 0, sizeof *s);
    s->L0 = layer[0].thickness;
    s->L1 = layer[1].thickness;
    for (int i = 0; i < 2; ++i) {
        s->t[i] = layer[i].sigma_a + layer[i].sigma_s;
        s->D[i] = 1.0 / (3.0 * s->t[i]);
        s->k[i] = sqrt(layer[i].sigma_a / s->D[i]);
    }
    /* phi'' - k^2 phi = -Q e^{-t x}/D  ->  p = -Q / (D (t^2 - k^2)) */
    double Q0 = layer[0].sigma_s * TI, Q1 = layer[1].sigma_s * TI * exp(-s->t[0] * s->L0);
    s->p[0] = -Q0 / (s->D[0] * (s->t[0] * s->t[0] - s->k[0] * s->k[0]));
    s->p[1] = -Q1 / (s->D[1] * (s->t[1] * s->t[1] - s->k[1] * s->k[1]));
    double A0 = ohm_boundary_A(layer[0].eta, OHM_FRESNEL_EXACT), A1 = ohm_boundary_A(layer[1].eta, OHM_FRESNEL_EXACT);
    double c1a, c2a, c1b, c2b;
    ohm_fresnel_moments(layer[0].eta / layer[1].eta, &c1a, &c2a);
    ohm_fresnel_moments(layer[1].eta / layer[0].eta, &c1b, &c2b);
    double T0 = 0.25 * (1.0 - 2.0 * c1a), T1 = 0.25 * (1.0 - 2.0 * c1b), K = 1.5 * (c2a + c2b);
    const double D0 = s->D[0], D1 = s->D[1], k0 = s->k[0], k1 = s->k[1], t0 = s->t[0], t1 = s->t[1];
    const double p0 = s->p[0], p1 = s->p[1];
    double e0 = exp(-t0 * s->L0), ep0 = exp(k0 * s->L0), em0 = exp(-k0 * s->L0);
    double e1 = exp(-t1 * s->L1), ep1 = exp(k1 * s->L1), em1 = exp(-k1 * s->L1);
    double M[16] = {0}, r[4];
    /* top, x = 0: D phi' - phi/(2A_0) = 0 */
    M[0] = D0 * k0 - 1.0 / (2 * A0);
    M[1] = -D0 * k0 - 1.0 / (2 * A0);
    r[0] = -(-D0 * t0 * p0 - p0 / (2 * A0));
    /* the interface: T0 phi_0(L0) - T1 phi_1(0) + K D0 phi_0'(L0) = 0 (J = -D0 phi_0') */
    M[4] = (T0 + K * D0 * k0) * ep0;
    M[5] = (T0 - K * D0 * k0) * em0;
    M[6] = -T1;
    M[7] = -T1;
    r[1] = -(T0 * p0 * e0 - T1 * p1 - K * D0 * t0 * p0 * e0);
    /* D phi' continuous */
    M[8] = D0 * k0 * ep0;
    M[9] = -D0 * k0 * em0;
    M[10] = -D1 * k1;
    M[11] = D1 * k1;
    r[2] = -(-D0 * t0 * p0 * e0 + D1 * t1 * p1);
    /* bottom, y = L1: -D phi' - phi/(2A_1) = 0 */
    M[14] = -D1 * k1 * ep1 - ep1 / (2 * A1);
    M[15] = D1 * k1 * em1 - em1 / (2 * A1);
    r[3] = -(D1 * t1 * p1 * e1 - p1 * e1 / (2 * A1));
    if (gauss(4, M, r)) return -1;
    memcpy(s->c, r, sizeof r);
    return 0;
}

double ohm_ref_two_layer_phi(const ohm_ref_two_layer *s, double x)
{
    if (x <= s->L0) return s->p[0] * exp(-s->t[0] * x) + s->c[0] * exp(s->k[0] * x) + s->c[1] * exp(-s->k[0] * x);
    double y = x - s->L0;
    return s->p[1] * exp(-s->t[1] * y) + s->c[2] * exp(s->k[1] * y) + s->c[3] * exp(-s->k[1] * y);
}
