/* light_kind.c — the table of light kinds and what every kind shares
 * (light_kind.h). */
#include "physics/light_kind.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "base/vec3.h"

const ohm_opt_spec ohm_light_opts[] = {
    {"type", OHM_OPT_ENUM, "directional", "kind of light (docs/lights.md)",
     "directional|point|spot|area|pencil|environment", 0, 0, 0},
    {"pos", OHM_OPT_VEC3, NULL, "position in mm (point, spot, area centre, pencil)", NULL, 0, 0, 0},
    {"dir", OHM_OPT_VEC3, NULL,
     "direction the light travels (directional, spot axis, area facing, pencil): 0,0,-1 shines down", NULL, 0, 0,
     0},
    {"intensity", OHM_OPT_REAL13, "1",
     "directional: W/mm^2 on a face square to it; point, spot: W/sr; area: total W emitted; pencil: W; "
     "environment: the sky's radiance, W/mm^2/sr (a factor on sky='s pixels). One value or r,g,b",
     NULL, 0, 1e30, 0},
    {"angle", OHM_OPT_REAL, "30", "spot: cone half-angle, degrees", NULL, 0.01, 90, 0},
    {"falloff", OHM_OPT_REAL, "0", "spot: soft edge inside the cone, degrees", NULL, 0, 90, 0},
    {"shape", OHM_OPT_ENUM, "rect", "area: rectangle or disk", "rect|disk", 0, 0, 0},
    {"width", OHM_OPT_REAL, "10", "area: width, or the disk's diameter (mm)", NULL, 1e-9, 1e9, 0},
    {"height", OHM_OPT_REAL, "10", "area: height of the rectangle (mm)", NULL, 1e-9, 1e9, 0},
    {"samples", OHM_OPT_INT, NULL,
     "area: sample points, rounded down to a square (default 64); environment: sky directions per surface face, "
     "cosine-weighted (default 256)",
     NULL, 1, 4096, 0},
    {"sky", OHM_OPT_STRING, NULL,
     "environment: an equirectangular image (.hdr, .exr, any format OpenImageIO reads; z up, Blender's mapping) "
     "whose pixels times intensity are the sky's radiance; without it the sky is uniform",
     NULL, 0, 0, 0},
    {"orbit", OHM_OPT_INT, "0",
     "N > 0: N frames with the light turned about the object's centre (a .vdb sequence, one solver set-up)", NULL,
     0, 100000, 0},
    {"axis", OHM_OPT_ENUM, "y", "orbit axis through the object's centre", "x|y|z", 0, 0, 0},
    {0}};

/* Indexed by ohm_light_type. */
static const ohm_light_kind *const kinds[] = {&ohm_light_directional, &ohm_light_point, &ohm_light_pencil,
                                              &ohm_light_spot,        &ohm_light_area,  &ohm_light_environment};
enum { NKINDS = (int)(sizeof kinds / sizeof kinds[0]) };

const ohm_light_kind *ohm_light_kind_of(const ohm_light *l)
{
    return (int)l->type >= 0 && (int)l->type < NKINDS ? kinds[l->type] : kinds[0];
}

/* The kind of a type= name (NULL: none). */
static const ohm_light_kind *kind_named(const char *name)
{
    for (int k = 0; k < NKINDS; ++k)
        if (strcmp(kinds[k]->name, name) == 0) return kinds[k];
    return NULL;
}

int ohm_light_options_check(const ohm_opt_reader *r, ohm_error *err)
{
    const char *type = r->str(r->ctx, "type");
    const ohm_light_kind *kind = kind_named(type);
    if (!kind) return ohm_fail(err, OHM_ERR_USAGE, "%s: -light type=%s: no such kind of light", r->where, type);
    long long orbit = r->integer(r->ctx, "orbit");
    if (kind->type == OHM_LIGHT_ENVIRONMENT && orbit > 0)
        return ohm_fail(err, OHM_ERR_USAGE, "%s: -light type=environment orbit=%lld: an environment light is all "
                        "around: it has nothing to turn", r->where, orbit);
    if (kind->type != OHM_LIGHT_ENVIRONMENT && r->given(r->ctx, "sky"))
        return ohm_fail(err, OHM_ERR_USAGE, "%s: -light type=%s sky=: sky= is an environment light's image "
                        "(type=environment)", r->where, type);
    return OHM_OK;
}

int ohm_light_read(ohm_light *l, const ohm_opt_reader *r, ohm_error *err)
{
    memset(l, 0, sizeof *l);
    snprintf(l->where, sizeof l->where, "%s", r->where);
    int rc = ohm_light_options_check(r, err);
    if (rc) return rc;
    const char *type = r->str(r->ctx, "type");
    const ohm_light_kind *kind = kind_named(type);
    l->type = kind->type;
    if ((kind->needs & OHM_LIGHT_NEEDS_POS) && !r->given(r->ctx, "pos"))
        return ohm_fail(err, OHM_ERR_USAGE, "%s: -light type=%s needs pos=x,y,z", r->where, type);
    if ((kind->needs & OHM_LIGHT_NEEDS_DIR) && !r->given(r->ctx, "dir"))
        return ohm_fail(err, OHM_ERR_USAGE, "%s: -light type=%s needs dir=x,y,z", r->where, type);
    r->vec3(r->ctx, "pos", l->pos);
    if (kind->needs & OHM_LIGHT_NEEDS_DIR) {
        r->vec3(r->ctx, "dir", l->dir);
        if (!ohm_vec3_normalize(l->dir))
            return ohm_fail(err, OHM_ERR_USAGE, "%s: -light dir=%g,%g,%g has no direction", r->where, l->dir[0],
                            l->dir[1], l->dir[2]);
    }
    l->channels = r->real13(r->ctx, "intensity", l->intensity);
    return kind->read ? kind->read(l, r, err) : OHM_OK;
}

int ohm_light_setup_init(ohm_light_setup *su, const ohm_light *l, int max_rays, ohm_error *err)
{
    memset(su, 0, sizeof *su);
    su->light = l;
    su->kind = ohm_light_kind_of(l);
    su->scale_each = 1.0;
    return su->kind->setup ? su->kind->setup(su, max_rays, err) : OHM_OK;
}

void ohm_light_setup_free(ohm_light_setup *su)
{
    free(su->pts);
    su->pts = NULL;
}

/* ohm_light_irradiance's running sums. */
typedef struct irradiance_sum {
    const double *n;
    ohm_light_visibility vis;
    const void *ctx;
    ohm_light_transmittance tr; /* NULL: no entering sums */
    const void *tctx;
    double E[3], entering[3], entering_mu[3], l_mean[3];
} irradiance_sum;

static void add_ray(void *acc, const ohm_light_ray *ray)
{
    irradiance_sum *s = acc;
    double cos_n = ray->l[0] * s->n[0] + ray->l[1] * s->n[1] + ray->l[2] * s->n[2];
    if (cos_n <= 0) return; /* behind the surface: no shadow ray */
    if (!(ray->weight[0] > 0 || ray->weight[1] > 0 || ray->weight[2] > 0)) return;
    double v = s->vis ? s->vis(s->ctx, ray->l, ray->dist) : 1.0;
    if (v <= 0) return;
    double e = cos_n * v, mean = 0, mu = 1, T = s->tr ? s->tr(s->tctx, ray->l, &mu) : 1;
    for (int c = 0; c < 3; ++c) {
        s->E[c] += ray->weight[c] * e;
        s->entering[c] += ray->weight[c] * e * T;
        s->entering_mu[c] += ray->weight[c] * e * T * mu;
        mean += ray->weight[c] * e;
    }
    for (int a = 0; a < 3; ++a) s->l_mean[a] += mean * ray->l[a];
}

double ohm_light_irradiance_entering(const ohm_light_setup *su, const double p[3], const double n[3],
                                     ohm_light_visibility vis, const void *vctx, ohm_light_transmittance tr,
                                     const void *tctx, double E[3], double entering[3], double entering_mu[3],
                                     double l_mean[3])
{
    irradiance_sum s = {n, vis, vctx, tr, tctx, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
    su->kind->rays(su, p, n, add_ray, &s);
    const ohm_light *l = su->light;
    double mean = 0;
    for (int c = 0; c < 3; ++c) {
        double I = l->intensity[l->channels == 1 ? 0 : c];
        E[c] = I * s.E[c];
        if (entering) entering[c] = I * s.entering[c];
        if (entering_mu) entering_mu[c] = I * s.entering_mu[c];
        mean += E[c] / 3.0;
    }
    memcpy(l_mean, s.l_mean, sizeof s.l_mean);
    return mean;
}

double ohm_light_irradiance(const ohm_light_setup *su, const double p[3], const double n[3],
                            ohm_light_visibility vis, const void *ctx, double E[3], double l_mean[3])
{
    return ohm_light_irradiance_entering(su, p, n, vis, ctx, NULL, NULL, E, NULL, NULL, l_mean);
}

int ohm_light_toward(const ohm_light *l, const double centre[3], double out[3])
{
    return ohm_light_kind_of(l)->toward(l, centre, out);
}

void ohm_light_pov(FILE *f, const ohm_light *l)
{
    ohm_light_kind_of(l)->pov(f, l);
}

void ohm_light_release(ohm_light *l)
{
    const ohm_light_kind *kind = ohm_light_kind_of(l);
    if (kind->release) kind->release(l);
}

void ohm_lights_free(ohm_light *lights, size_t n)
{
    for (size_t i = 0; lights && i < n; ++i) ohm_light_release(&lights[i]);
    free(lights);
}

/* ---- helpers the kinds share ------------------------------------------------- */

void ohm_light_plane_basis(const double n[3], double u[3], double v[3])
{
    double up[3] = {0, 1, 0};
    if (fabs(n[1]) > 0.9) up[0] = 1, up[1] = 0;
    u[0] = up[1] * n[2] - up[2] * n[1];
    u[1] = up[2] * n[0] - up[0] * n[2];
    u[2] = up[0] * n[1] - up[1] * n[0];
    double len = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    for (int a = 0; a < 3; ++a) u[a] /= len;
    v[0] = n[1] * u[2] - n[2] * u[1];
    v[1] = n[2] * u[0] - n[0] * u[2];
    v[2] = n[0] * u[1] - n[1] * u[0];
}

/* POV-Ray is left-handed: ohm's z is mirrored (as export_df3.c's scene). */
void ohm_light_pov_vec(FILE *f, const double v[3]) { fprintf(f, "<%.9g, %.9g, %.9g>", v[0], v[1], -v[2]); }

void ohm_light_pov_colour(FILE *f, const ohm_light *l, double scale)
{
    double c[3];
    for (int k = 0; k < 3; ++k) c[k] = scale * l->intensity[l->channels == 1 ? 0 : k];
    fprintf(f, "rgb <%.9g, %.9g, %.9g>", c[0], c[1], c[2]);
}

void ohm_light_pov_aimed(FILE *f, const ohm_light *l, double scale, const char *shape, const char *note)
{
    double at[3];
    for (int a = 0; a < 3; ++a) at[a] = l->pos[a] + l->dir[a];
    fputs("light_source { ", f);
    ohm_light_pov_vec(f, l->pos);
    fputs(" color ", f);
    ohm_light_pov_colour(f, l, scale);
    fprintf(f, " %s point_at ", shape);
    ohm_light_pov_vec(f, at);
    fprintf(f, " } // %s\n", note);
}
