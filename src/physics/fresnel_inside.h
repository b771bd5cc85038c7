/* fresnel_inside.h — the Fresnel reflectance of light inside a medium, one
 * source for the host's C (fresnel.c, the tracer mc.c) and the OpenCL
 * tracer (mc_device.cl, which the build gives this text), written in what
 * C11 and OpenCL C share.
 *
 * Unpolarised reflectance for light inside a medium of relative index eta
 * (outside 1) meeting the surface at cosine mu from the normal: the mean of
 * the s and p Fresnel coefficients squared (Born & Wolf, Principles of
 * Optics, 1.5.2), 1 beyond the critical angle. */
#ifndef OHM_PHYSICS_FRESNEL_INSIDE_H
#define OHM_PHYSICS_FRESNEL_INSIDE_H

#ifndef __OPENCL_C_VERSION__
#include <math.h>
#endif

/* The reflectance with the transmitted cosine cos_t given (cos_t > 0). */
static inline double ohm_fresnel_inside_given_cos_t(double eta, double mu, double cos_t)
{
    double rs = (eta * mu - cos_t) / (eta * mu + cos_t);
    double rp = (mu - eta * cos_t) / (mu + eta * cos_t);
    return 0.5 * (rs * rs + rp * rp);
}

/* fresnel.h's ohm_fresnel_reflectance_inside: eta may be below 1 (no
 * critical angle then); eta = 1 gives 0. */
static inline double ohm_fresnel_inside(double eta, double mu)
{
    if (mu > 1.0) mu = 1.0;
    if (mu <= 0.0) return 1.0;
    double sin_t2 = eta * eta * (1.0 - mu * mu); /* Snell: sin_t = eta sin_i */
    if (sin_t2 >= 1.0) return 1.0;               /* total internal reflection */
    return ohm_fresnel_inside_given_cos_t(eta, mu, sqrt(1.0 - sin_t2));
}

#endif
