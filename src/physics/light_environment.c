/* light_environment.c — an environment light: the sky all around the object,
 * uniform (radiance `intensity`, W/mm^2/sr) or an equirectangular image
 * read through OpenImageIO (sky=FILE, .hdr or .exr: its pixels times
 * intensity are the radiance).  Each surface point is lit by the part of the
 * sky it sees past the object's own geometry: its hemisphere is sampled by a
 * fixed set of cosine-weighted directions (the same at every point, turned to
 * its normal), each a shadow ray, so that
 *     E = integral of L(w) cos(theta) dw  ~=  (pi / M) sum_k L(w_k)
 * for M directions w_k drawn with density cos(theta) / pi (Pharr, Jakob &
 * Humphreys, Physically Based Rendering, 4th ed., sec. 13.6.3).  The
 * directions are a Fibonacci spiral on the unit disk lifted to the
 * hemisphere (Malley's method): deterministic, evenly spread, no clumps.
 *
 * The image's mapping is Blender's equirectangular one, z up: the top row is
 * the zenith (+z), the bottom the nadir, the middle column looks along +x and
 * the azimuth turns towards -y to the right (u = 1/2 - atan2(y, x) / 2 pi). */
#include "physics/light_kind.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ohm_oiio.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

enum { SKY_DEFAULT_DIRECTIONS = 256 };

struct ohm_sky_image {
    int w, h;
    float *rgb; /* 3 per pixel, row-major from the top */
    char path[1024];
};

static void release(ohm_light *l)
{
    if (!l->sky) return;
    free(l->sky->rgb);
    free(l->sky);
    l->sky = NULL;
}

static int read(ohm_light *l, const ohm_opt_reader *r, ohm_error *err)
{
    l->samples = r->given(r->ctx, "samples") ? (int)r->integer(r->ctx, "samples") : 0;
    if (!r->given(r->ctx, "sky")) return OHM_OK;
    const char *path = r->str(r->ctx, "sky");
    ohm_sky_image *sky = calloc(1, sizeof *sky);
    if (!sky) return ohm_fail(err, OHM_ERR_NOMEM, "%s: -light sky=%s: out of memory", r->where, path);
    snprintf(sky->path, sizeof sky->path, "%s", path);
    int rc = ohm_image_read_rgb(path, &sky->rgb, &sky->w, &sky->h, err);
    if (rc) {
        free(sky);
        char why[sizeof err->msg];
        snprintf(why, sizeof why, "%s", err->msg);
        return ohm_fail(err, rc, "%s: -light sky=: %s", r->where, why);
    }
    for (size_t i = 0; i < 3 * (size_t)sky->w * (size_t)sky->h; ++i)
        if (!(sky->rgb[i] >= 0) || !isfinite(sky->rgb[i])) {
            double bad = sky->rgb[i];
            free(sky->rgb);
            free(sky);
            return ohm_fail(err, OHM_ERR_PARSE, "%s: -light sky=%s: pixel %zu is %g: radiance must be finite and >= 0",
                            r->where, path, i / 3, bad);
        }
    l->sky = sky;
    l->channels = 3; /* the image's colours, each times its channel of intensity */
    return OHM_OK;
}

/* The sky's relative radiance along unit d (1 for a uniform sky). */
static void sky_radiance(const ohm_sky_image *sky, const double d[3], double out[3])
{
    if (!sky) {
        out[0] = out[1] = out[2] = 1.0;
        return;
    }
    double u = 0.5 - atan2(d[1], d[0]) / (2.0 * M_PI), v = 0.5 + asin(fmax(-1.0, fmin(1.0, d[2]))) / M_PI;
    int col = (int)floor(u * sky->w), row = (int)floor((1.0 - v) * sky->h);
    col = ((col % sky->w) + sky->w) % sky->w;
    row = row < 0 ? 0 : row >= sky->h ? sky->h - 1 : row;
    const float *px = sky->rgb + 3 * ((size_t)row * (size_t)sky->w + (size_t)col);
    for (int c = 0; c < 3; ++c) out[c] = px[c];
}

static int setup(ohm_light_setup *su, int max_rays, ohm_error *err)
{
    int m = su->light->samples > 0 ? su->light->samples : SKY_DEFAULT_DIRECTIONS;
    if (max_rays > 0 && m > max_rays) m = max_rays;
    su->pts = malloc((size_t)m * sizeof *su->pts);
    if (!su->pts) return ohm_fail(err, OHM_ERR_NOMEM, "light: out of memory for %d sky directions", m);
    const double golden = M_PI * (3.0 - sqrt(5.0)); /* the golden angle */
    for (int k = 0; k < m; ++k) {
        double s = (k + 0.5) / m, r = sqrt(s), phi = golden * k;
        su->pts[k][0] = r * cos(phi);
        su->pts[k][1] = r * sin(phi);
        su->pts[k][2] = sqrt(1.0 - s); /* cos(theta): density cos / pi */
    }
    su->npts = m;
    su->scale_each = M_PI / m;
    return OHM_OK;
}

static void rays(const ohm_light_setup *su, const double p[3], const double n[3], ohm_light_ray_fn emit, void *acc)
{
    (void)p;
    double t[3], b[3];
    ohm_light_plane_basis(n, t, b);
    for (int k = 0; k < su->npts; ++k) {
        const double *w = su->pts[k];
        ohm_light_ray ray;
        for (int a = 0; a < 3; ++a) ray.l[a] = w[0] * t[a] + w[1] * b[a] + w[2] * n[a];
        ray.dist = INFINITY;
        sky_radiance(su->light->sky, ray.l, ray.weight);
        /* irradiance on a surface square to the ray: the caller multiplies
         * by the cosine this direction was drawn with */
        for (int c = 0; c < 3; ++c) ray.weight[c] *= su->scale_each / w[2];
        emit(acc, &ray);
    }
}

static int toward(const ohm_light *l, const double centre[3], double out[3])
{
    (void)l, (void)centre;
    out[0] = out[1] = out[2] = 0;
    return 0; /* all around: no one direction */
}

static const char *pov_image_type(const char *path)
{
    size_t n = strlen(path);
    if (n >= 4 && strcmp(path + n - 4, ".hdr") == 0) return "hdr";
    if (n >= 4 && strcmp(path + n - 4, ".png") == 0) return "png";
    if (n >= 4 && strcmp(path + n - 4, ".jpg") == 0) return "jpeg";
    if (n >= 4 && strcmp(path + n - 4, ".tif") == 0) return "tiff";
    return "exr";
}

/* ohm's z (the sky's up) is POV-Ray's -z: the sky sphere (y up) is turned to it */
static void pov(FILE *f, const ohm_light *l)
{
    fputs("sky_sphere { pigment { ", f);
    if (l->sky) fprintf(f, "image_map { %s \"%s\" map_type 1 interpolate 2 }", pov_image_type(l->sky->path), l->sky->path);
    else ohm_light_pov_colour(f, l, 1.0);
    fputs(" } rotate <-90, 0, 0> } // environment: radiance W/mm^2/sr ", f);
    if (l->sky) fputs("(the pixels times ", f);
    ohm_light_pov_colour(f, l, 1.0);
    fputs(l->sky ? ")\n" : "\n", f);
}

const ohm_light_kind ohm_light_environment = {OHM_LIGHT_ENVIRONMENT, "environment", 0, 0, 1, read, setup, rays, toward,
                                              pov, release};
