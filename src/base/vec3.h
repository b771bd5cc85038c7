/* vec3.h — the one 3-vector operation several stages need safely. */
#ifndef OHM_VEC3_H
#define OHM_VEC3_H

#include <math.h>

/* v scaled to unit length, without overflow or underflow on the way (the
 * largest component is divided out first: 1e308,1e308,1e308 and 1e-320,0,0
 * are directions too); returns 0 and leaves v when it has no direction (zero
 * or not finite), else 1. */
static inline int ohm_vec3_normalize(double v[3])
{
    double m = fmax(fabs(v[0]), fmax(fabs(v[1]), fabs(v[2])));
    if (!(m > 0) || !isfinite(m)) return 0;
    double u[3] = {v[0] / m, v[1] / m, v[2] / m};
    double len = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    for (int a = 0; a < 3; ++a) v[a] = u[a] / len;
    return 1;
}

#endif
