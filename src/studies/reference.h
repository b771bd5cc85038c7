/* reference.h — analytic solutions the solver is checked against
 * (docs/design.md §3).  All lengths mm, coefficients 1/mm, source power 1 W unless
 * a parameter says otherwise. */
#ifndef OHM_REFERENCE_H
#define OHM_REFERENCE_H

/* A is the Robin boundary constant the solve being checked uses
 * (ohm_boundary_A): each reference is exact for any A. */

/* Infinite homogeneous medium, isotropic point source of power P:
 * phi(r) = P e^{-sigma_tr r} / (4 pi D r). */
double ohm_ref_infinite(double P, double sigma_a, double sigma_s, double r);

/* Semi-infinite medium, Robin (partial-current) boundary phi = z_b dphi/dz,
 * z_b = 2 A D, unit point source at depth z0: the exact surface exitance
 * J(r) = phi_s(r) / (2A), with
 * phi_s(r) = 2 G(sqrt(r^2+z0^2)) - (2/z_b) int_0^inf e^{-t/z_b} G(sqrt(r^2+(z0+t)^2)) dt,
 * G(d) = e^{-sigma_tr d} / (4 pi D d). */
double ohm_ref_halfspace_exitance(double r, double z0, double sigma_a, double sigma_s, double A);

/* Fraction of a unit point source at depth z0 that leaves the half-space
 * (the 1-D problem integrated over the plane, solved in closed form):
 * e^{-k z0} (1 - rho) / (4 A D k), rho = (1 - z_b k)/(1 + z_b k), k = sigma_tr. */
double ohm_ref_halfspace_escape(double z0, double sigma_a, double sigma_s, double A);

/* Jensen et al. 2001 dipole diffuse reflectance R_d(r) for a unit incident
 * pencil beam (includes the albedo), and its integral over the plane. */
double ohm_ref_dipole_Rd(double r, double sigma_a, double sigma_s, double A);
double ohm_ref_dipole_Rd_total(double sigma_a, double sigma_s, double A);

/* Two layers of a slab, 1-D (laterally infinite), lit at normal incidence
 * with entering power density TI (W/mm^2, after the top surface's Fresnel):
 * layer 0 on depth x in [0, L_0] (lit), layer 1 on [L_0, L_0 + L_1], each
 * with its sigma_a, sigma_s' and refractive index eta, under air on both
 * sides.  It solves
 *     -(D phi')' + sigma_a phi = sigma_s' TI e^(-tau(x)),  tau the optical depth in sigma_t',
 *     D phi'(0) = phi(0) / (2 A_0),   -D phi'(L) = phi(L) / (2 A_1)   (A_i = ohm_boundary_A(eta_i)),
 *     D phi' continuous at L_0, and the index interface of network.h:
 *     (T_0/4) phi_0 - (T_1/4) phi_1 = (3/2) (C_2,0 + C_2,1) J,  J = -D phi' (into layer 1),
 * T_i = 1 - 2 C_1,i, C_n,i the Fresnel moments for light in layer i meeting
 * the other (ohm_fresnel_moments(eta_i / eta_other)).  The unscattered beam
 * crosses the interface unreflected, as diffusion's deposit does.  In each
 * layer phi = a particular exponential + c e^(kx) + c' e^(-kx),
 * k^2 = sigma_a / D; the four constants from a 4 x 4 system
 * (docs/transport.md writes it out).  Equal indices give the matched case:
 * phi continuous. */
typedef struct ohm_ref_layer {
    double sigma_a, sigma_s, eta, thickness;
} ohm_ref_layer;

typedef struct ohm_ref_two_layer {
    double L0, L1;
    double D[2], k[2], t[2]; /* D, k = sqrt(sigma_a / D), sigma_t' per layer */
    double p[2];             /* the particular solutions' amplitudes        */
    double c[4];             /* c_0, c_0' (layer 0), c_1, c_1' (layer 1)    */
} ohm_ref_two_layer;

/* Fails (-1) only when the system is singular. */
int ohm_ref_two_layer_init(ohm_ref_two_layer *s, const ohm_ref_layer layer[2], double TI);
double ohm_ref_two_layer_phi(const ohm_ref_two_layer *s, double x);

#endif
