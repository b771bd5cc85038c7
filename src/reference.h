/* reference.h — analytic solutions the solver is checked against
 * (DESIGN.md §3).  All lengths mm, coefficients 1/mm, source power 1 W unless
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

#endif
