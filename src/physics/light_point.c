/* light_point.c — a point light: intensity in W/sr in every direction, the
 * irradiance falling off as 1/d^2 (light_kind.h).  The spot light
 * (light_spot.c) is this within a cone. */
#include "physics/light_kind.h"

#include <math.h>

#include "base/vec3.h"

int ohm_light_point_ray(const double pos[3], const double p[3], ohm_light_ray *ray)
{
    double d2 = 0;
    for (int a = 0; a < 3; ++a) {
        ray->l[a] = pos[a] - p[a];
        d2 += ray->l[a] * ray->l[a];
    }
    if (!(d2 > 0)) return 0;
    ray->dist = sqrt(d2);
    for (int a = 0; a < 3; ++a) ray->l[a] /= ray->dist;
    ray->weight[0] = ray->weight[1] = ray->weight[2] = 1.0 / d2;
    return 1;
}

static void rays(const ohm_light_setup *su, const double p[3], const double n[3], ohm_light_ray_fn emit, void *acc)
{
    (void)n;
    ohm_light_ray ray;
    if (ohm_light_point_ray(su->light->pos, p, &ray)) emit(acc, &ray);
}

int ohm_light_toward_position(const ohm_light *l, const double centre[3], double out[3])
{
    for (int a = 0; a < 3; ++a) out[a] = l->pos[a] - centre[a];
    if (ohm_vec3_normalize(out)) return 1;
    for (int a = 0; a < 3; ++a) out[a] = -l->dir[a];
    return ohm_vec3_normalize(out);
}

static void pov(FILE *f, const ohm_light *l)
{
    fputs("light_source { ", f);
    ohm_light_pov_vec(f, l->pos);
    fputs(" color ", f);
    ohm_light_pov_colour(f, l, 1.0);
    fputs(" } // point, W/sr\n", f);
}

const ohm_light_kind ohm_light_point = {OHM_LIGHT_POINT, "point", OHM_LIGHT_NEEDS_POS, 0, 0, NULL, NULL, rays,
                                        ohm_light_toward_position, pov, NULL};
