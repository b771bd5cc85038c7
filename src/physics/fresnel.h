/* fresnel.h — the optics of a boundary between a medium of relative index
 * eta (inside) and index 1 (outside): Fresnel reflectance, its angular
 * moments, and the diffusion boundary constant A built from them.
 *
 * The Robin condition phi = 2 A D dphi/dn (docs/design.md §3) needs A.  Transport
 * gives it from the Fresnel moments C_n = int_0^{pi/2} R(theta) sin(theta)
 * cos^n(theta) dtheta of the reflectance R for light inside the medium:
 *     A = (1 + 3 C_2) / (1 - 2 C_1)
 * (Haskell et al., JOSA A 11, 1994; d'Eon, "A better dipole", 2012).  The
 * older A = (1 + F_dr)/(1 - F_dr) with F_dr from the polynomial fit of Egan &
 * Hilgeman (1979; Jensen et al. 2001, Eq. 16) is kept as an option: at
 * eta = 1.37 it gives 3.05 where the moments give 2.76, ~5% of the fluence
 * against Monte Carlo transport (docs/transport.md). */
#ifndef OHM_FRESNEL_H
#define OHM_FRESNEL_H

typedef enum ohm_fresnel {
    OHM_FRESNEL_EXACT = 0,     /* A from the exact moments (the default) */
    OHM_FRESNEL_POLYNOMIAL = 1 /* A from Egan & Hilgeman's F_dr fit      */
} ohm_fresnel;

/* Unpolarised Fresnel reflectance for light arriving from outside (index 1)
 * into a medium of relative index eta, at incidence cosine cos_i. */
double ohm_fresnel_reflectance(double eta, double cos_i);

/* Unpolarised reflectance for light inside the medium (index eta, outside 1)
 * meeting the surface at cosine mu from the normal; 1 beyond the critical
 * angle.  eta may be below 1 (no critical angle then); eta = 1 gives 0. */
double ohm_fresnel_reflectance_inside(double eta, double mu);

/* The moments C_1, C_2 of ohm_fresnel_reflectance_inside over the
 * hemisphere, to ~1e-15 (Gauss-Legendre on a smooth substitution; see
 * fresnel.c).  2 C_1 is the internal diffuse reflectance F_dr. */
void ohm_fresnel_moments(double eta, double *c1, double *c2);

/* F_dr, the polynomial fit of Egan & Hilgeman (1979). */
double ohm_fresnel_dr(double eta);

/* A = (1 + 3 C_2) / (1 - 2 C_1) from the moments (above). */
static inline double ohm_boundary_A_of_moments(double c1, double c2) { return (1.0 + 3.0 * c2) / (1.0 - 2.0 * c1); }

/* The boundary constant A for eta by the chosen formula (above). */
double ohm_boundary_A(double eta, ohm_fresnel how);

/* An interface between two media inside the object (docs/transport.md): the
 * moments C_1, C_2 of light in a medium of index eta_here meeting one of
 * index eta_there depend on m = eta_here / eta_there only, and a per-cell
 * index gives every face its own m.  The quadrature above costs ~5 us, so a
 * table over m in [1/3, 3] (cell indices lie in [1, 3]) is built once per
 * assembly and read by 4-point Lagrange interpolation.  The moments have a
 * kink at m = 1 and, for m > 1, grow like the critical cone's sqrt(m - 1);
 * so each side of 1 has its own nodes, uniform in u = sqrt(|m - 1|), where
 * the moments are smooth.  Interpolation error (test_fresnel): ~1e-12 at
 * indices like 1.3 or 1.6, 1e-11 at most beyond |m - 1| > 0.05, ~6e-9 at
 * worst within 1e-5 of m = 1. */
enum { OHM_FRESNEL_TABLE_STEPS = 1024 };
typedef struct ohm_fresnel_table {
    double c1[2][OHM_FRESNEL_TABLE_STEPS + 1]; /* [0]: m in [1/3, 1]; [1]: m in [1, 3] */
    double c2[2][OHM_FRESNEL_TABLE_STEPS + 1];
} ohm_fresnel_table;

void ohm_fresnel_table_init(ohm_fresnel_table *t);

/* C_1, C_2 at m in [1/3, 3] (clamped), from the table. */
void ohm_fresnel_table_moments(const ohm_fresnel_table *t, double m, double *c1, double *c2);

/* "exact" / "polynomial". */
const char *ohm_fresnel_name(ohm_fresnel how);

#endif
