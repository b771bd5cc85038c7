/* light_spot.c — a spot light: a point light (light_point.c) inside a cone
 * of half-angle `angle` about dir, its edge softened over `falloff` degrees
 * inside it by a smoothstep (light_kind.h). */
#include "physics/light_kind.h"

#include <math.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

static int read(ohm_light *l, const ohm_opt_reader *r, ohm_error *err)
{
    l->angle = r->real(r->ctx, "angle");
    l->falloff = r->real(r->ctx, "falloff");
    if (l->falloff > l->angle)
        return ohm_fail(err, OHM_ERR_USAGE, "%s: -light falloff=%g is wider than angle=%g", r->where, l->falloff,
                        l->angle);
    return OHM_OK;
}

/* 1 inside angle - falloff, 0 outside angle, smoothstep between;
 * to_point: unit, from the light towards the lit point. */
static double cone(const ohm_light *l, const double to_point[3])
{
    double c = to_point[0] * l->dir[0] + to_point[1] * l->dir[1] + to_point[2] * l->dir[2];
    double outer = cos(l->angle * M_PI / 180.0), inner = cos((l->angle - l->falloff) * M_PI / 180.0);
    if (c >= inner) return 1.0;
    if (c <= outer) return 0.0;
    double t = (c - outer) / (inner - outer);
    return t * t * (3.0 - 2.0 * t);
}

static void rays(const ohm_light_setup *su, const double p[3], const double n[3], ohm_light_ray_fn emit, void *acc)
{
    (void)n;
    ohm_light_ray ray;
    if (!ohm_light_point_ray(su->light->pos, p, &ray)) return;
    double to_point[3] = {-ray.l[0], -ray.l[1], -ray.l[2]}, k = cone(su->light, to_point);
    if (k <= 0) return;
    for (int c = 0; c < 3; ++c) ray.weight[c] *= k;
    emit(acc, &ray);
}

static void pov(FILE *f, const ohm_light *l)
{
    char shape[96];
    snprintf(shape, sizeof shape, "spotlight radius %.9g falloff %.9g", l->angle - l->falloff, l->angle);
    ohm_light_pov_aimed(f, l, 1.0, shape, "spot, W/sr on its axis");
}

const ohm_light_kind ohm_light_spot = {OHM_LIGHT_SPOT, "spot", OHM_LIGHT_NEEDS_POS | OHM_LIGHT_NEEDS_DIR, 0, 0, read,
                                       NULL, rays, ohm_light_toward_position, pov, NULL};
