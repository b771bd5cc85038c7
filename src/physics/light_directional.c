/* light_directional.c — a directional light (the sun): parallel rays along
 * dir, intensity the irradiance (W/mm^2) on a surface square to them
 * (light_kind.h). */
#include "physics/light_kind.h"

#include <math.h>

static void rays(const ohm_light_setup *su, const double p[3], const double n[3], ohm_light_ray_fn emit, void *acc)
{
    (void)p, (void)n;
    const ohm_light *l = su->light;
    ohm_light_ray ray = {{-l->dir[0], -l->dir[1], -l->dir[2]}, INFINITY, {1, 1, 1}};
    emit(acc, &ray);
}

static int toward(const ohm_light *l, const double centre[3], double out[3])
{
    (void)centre;
    for (int a = 0; a < 3; ++a) out[a] = -l->dir[a];
    return 1;
}

static void pov(FILE *f, const ohm_light *l)
{
    double far[3];
    for (int a = 0; a < 3; ++a) far[a] = -1e6 * l->dir[a];
    fputs("light_source { ", f);
    ohm_light_pov_vec(f, far);
    fputs(" color ", f);
    ohm_light_pov_colour(f, l, 1.0);
    fputs(" parallel point_at <0, 0, 0> } // directional, irradiance in W/mm^2\n", f);
}

const ohm_light_kind ohm_light_directional = {OHM_LIGHT_DIRECTIONAL, "directional", OHM_LIGHT_NEEDS_DIR, 0, 0, NULL,
                                              NULL, rays, toward, pov, NULL};
