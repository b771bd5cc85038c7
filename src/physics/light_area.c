/* light_area.c — an area light: a one-sided Lambertian rectangle or disk of
 * total power `intensity` (W), centred on pos and facing dir, seen through a
 * stratified grid of sample points (light_kind.h). */
#include "physics/light_kind.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

enum { AREA_MAX_SAMPLES = 4096, AREA_DEFAULT_SAMPLES = 64 };

static int read(ohm_light *l, const ohm_opt_reader *r, ohm_error *err)
{
    (void)err;
    l->disk = strcmp(r->str(r->ctx, "shape"), "disk") == 0;
    l->width = r->real(r->ctx, "width");
    l->height = l->disk ? l->width : r->real(r->ctx, "height");
    l->samples = r->given(r->ctx, "samples") ? (int)r->integer(r->ctx, "samples") : 0;
    return OHM_OK;
}

/* A stratified k x k grid over the rectangle (or over the disk's square,
 * mapped concentrically so every sample covers equal area: Shirley & Chiu
 * 1997). */
static int area_samples(const ohm_light *light, double (*pts)[3], int max)
{
    int k = (int)floor(sqrt((double)(light->samples > 0 ? light->samples : AREA_DEFAULT_SAMPLES)));
    if (k < 1) k = 1;
    if (k * k > max) k = (int)floor(sqrt((double)max));
    double u[3], v[3];
    ohm_light_plane_basis(light->dir, u, v);
    int n = 0;
    for (int j = 0; j < k; ++j)
        for (int i = 0; i < k; ++i) {
            double a = 2.0 * (i + 0.5) / k - 1.0, b = 2.0 * (j + 0.5) / k - 1.0, x, y;
            if (light->disk) {
                double r, phi, R = 0.5 * light->width;
                if (fabs(a) > fabs(b)) r = a, phi = (M_PI / 4) * (b / a);
                else r = b, phi = (M_PI / 2) - (M_PI / 4) * (a / b);
                x = R * r * cos(phi);
                y = R * r * sin(phi);
            } else {
                x = 0.5 * light->width * a;
                y = 0.5 * light->height * b;
            }
            for (int c = 0; c < 3; ++c) pts[n][c] = light->pos[c] + x * u[c] + y * v[c];
            ++n;
        }
    return n;
}

static int setup(ohm_light_setup *su, int max_rays, ohm_error *err)
{
    int max = max_rays > 0 && max_rays < AREA_MAX_SAMPLES ? max_rays : AREA_MAX_SAMPLES;
    su->pts = malloc((size_t)max * sizeof *su->pts);
    if (!su->pts) return ohm_fail(err, OHM_ERR_NOMEM, "light: out of memory for area samples");
    su->npts = area_samples(su->light, su->pts, max);
    /* Lambertian, total power I: radiant intensity (I / pi) cos(theta) */
    su->scale_each = 1.0 / (M_PI * su->npts);
    return OHM_OK;
}

static void rays(const ohm_light_setup *su, const double p[3], const double n[3], ohm_light_ray_fn emit, void *acc)
{
    (void)n;
    const ohm_light *l = su->light;
    for (int k = 0; k < su->npts; ++k) {
        ohm_light_ray ray;
        if (!ohm_light_point_ray(su->pts[k], p, &ray)) continue;
        double emit_cos = -(ray.l[0] * l->dir[0] + ray.l[1] * l->dir[1] + ray.l[2] * l->dir[2]);
        if (emit_cos <= 0) continue;
        for (int c = 0; c < 3; ++c) ray.weight[c] *= emit_cos * su->scale_each;
        emit(acc, &ray);
    }
}

static void pov(FILE *f, const ohm_light *l)
{
    double u[3], v[3];
    ohm_light_plane_basis(l->dir, u, v);
    char shape[320];
    /* POV-Ray is left-handed: z mirrored, as ohm_light_pov_vec does */
    snprintf(shape, sizeof shape,
             "area_light <%.9g, %.9g, %.9g>, <%.9g, %.9g, %.9g>, 8, 8 adaptive 1 jitter%s "
             "spotlight radius 90 falloff 90 tightness 1",
             l->width * u[0], l->width * u[1], -l->width * u[2], l->height * v[0], l->height * v[1],
             -l->height * v[2], l->disk ? " circular orient" : "");
    ohm_light_pov_aimed(f, l, 1.0 / M_PI, shape, "area, W/sr on its axis (its power / pi)");
}

const ohm_light_kind ohm_light_area = {OHM_LIGHT_AREA, "area", OHM_LIGHT_NEEDS_POS | OHM_LIGHT_NEEDS_DIR, 0, 0, read,
                                       setup, rays, ohm_light_toward_position, pov, NULL};
