/* light_kind.h — every kind of light as one entry of a table.
 *
 * A kind (directional, point, spot, area, pencil, environment: one file each,
 * light_<kind>.c) supplies in one place everything the rest of ohm needs to
 * know about it:
 *   - its options: which of -light's options it reads and which it needs
 *     (the -light step, steps/actions.c, reads them through the table);
 *   - the directions its light arrives from at a surface point, each with
 *     the distance a shadow ray must clear and the irradiance it brings:
 *     ohm_light_irradiance adds them up, with the caller's visibility test,
 *     for the solver's boundary faces (light.c, shadow rays through
 *     shadow.h's occluder) and for the preview's surface points
 *     (steps/render.c, rays against the mesh), so the two cannot drift apart;
 *   - where it is, seen from the object (the camera of the preview and of
 *     the POV-Ray scene);
 *   - its POV-Ray text (outputs/export_df3.c's scene).
 * docs/lights.md describes the kinds for users; adding a kind is a new
 * light_<kind>.c, its entry in light_kind.c's table and its name in
 * ohm_light_opts' type= choices. */
#ifndef OHM_LIGHT_KIND_H
#define OHM_LIGHT_KIND_H

#include <stdio.h>

#include "base/ohm_error.h"
#include "base/opt_spec.h"
#include "physics/light_spec.h"

/* -light's options, every kind's, terminated by {0} (light_kind.c). */
extern const ohm_opt_spec ohm_light_opts[];

/* One direction light arrives from at a surface point. */
typedef struct ohm_light_ray {
    double l[3];      /* unit, from the point towards the light            */
    double dist;      /* how far a shadow ray must go (mm); INFINITY: all  */
    double weight[3]; /* irradiance per channel on a surface square to l,
                         per unit of the light's intensity                 */
} ohm_light_ray;

/* What a light needs computed once before its rays are asked for, many
 * times: an area light's sample points, an environment light's fixed set of
 * hemisphere directions. */
typedef struct ohm_light_setup {
    const ohm_light *light;
    const struct ohm_light_kind *kind;
    double (*pts)[3]; /* area: points on the emitter; environment: directions about +z */
    int npts;
    double scale_each; /* area: the share of the power per sample */
} ohm_light_setup;

/* Called by a kind's rays for each direction (acc: ohm_light_irradiance's sums). */
typedef void (*ohm_light_ray_fn)(void *acc, const ohm_light_ray *ray);

enum { OHM_LIGHT_NEEDS_POS = 1u, OHM_LIGHT_NEEDS_DIR = 2u };

typedef struct ohm_light_kind {
    ohm_light_type type;
    const char *name;  /* its type= value */
    unsigned needs;    /* OHM_LIGHT_NEEDS_*: options it cannot do without */
    int at_a_point;    /* 1: enters at one surface point (a pencil beam), not through the faces it lights */
    /* 1: Fresnel ray by ray (light from all around: a sky); 0: once per face,
     * at the irradiance-weighted direction (rays close together: a lamp) */
    int fresnel_per_ray;
    /* its own options, after the shared ones (type, pos, dir, intensity) */
    int (*read)(ohm_light *l, const ohm_opt_reader *r, ohm_error *err);
    /* NULL: one ray, no setup.  max_rays caps the rays per point (0: the light's own count) */
    int (*setup)(ohm_light_setup *su, int max_rays, ohm_error *err);
    /* the rays arriving at point p (mm) of a surface with unit outward normal n */
    void (*rays)(const ohm_light_setup *su, const double p[3], const double n[3], ohm_light_ray_fn emit, void *acc);
    /* unit direction from the point `centre` towards the light; 0 when it has none (a uniform sky) */
    int (*toward)(const ohm_light *l, const double centre[3], double out[3]);
    /* the light in a POV-Ray scene (ohm's coordinates, z mirrored as export_df3.c's) */
    void (*pov)(FILE *f, const ohm_light *l);
    void (*release)(ohm_light *l); /* NULL: owns nothing */
} ohm_light_kind;

/* The kind of a light. */
const ohm_light_kind *ohm_light_kind_of(const ohm_light *l);

/* -light's options that do not go together (type=environment with orbit=,
 * sky= with another type=), checked from the words alone: the command
 * line's parse calls it, before any step runs, and ohm_light_read again. */
int ohm_light_options_check(const ohm_opt_reader *r, ohm_error *err);

/* A light from -light's options (ohm_light_opts): type, the shared ones,
 * then its kind's.  On failure nothing is left owned. */
int ohm_light_read(ohm_light *l, const ohm_opt_reader *r, ohm_error *err);

/* The setup of light l (which must outlive it); max_rays as in the kind. */
int ohm_light_setup_init(ohm_light_setup *su, const ohm_light *l, int max_rays, ohm_error *err);
void ohm_light_setup_free(ohm_light_setup *su);

/* The fraction (0..1) of a surface point that sees along unit l for dist mm;
 * NULL: everything is seen. */
typedef double (*ohm_light_visibility)(const void *ctx, const double l[3], double dist);

/* What enters the surface of light arriving from unit direction l (towards
 * the light): the transmittance 1 - Fresnel, and in *mu the refracted ray's
 * cosine to the inward normal (the solver's faces: light.c). */
typedef double (*ohm_light_transmittance)(const void *ctx, const double l[3], double *mu);

/* Irradiance (W/mm^2) per channel (3; a grey light repeats its value) at
 * surface point p with unit outward normal n: sum over the light's rays of
 * intensity x weight x max(0, n.l) x visibility.  l_mean: the
 * irradiance-weighted direction towards the light, not normalised.
 * Returns the channels' mean. */
double ohm_light_irradiance(const ohm_light_setup *su, const double p[3], const double n[3],
                            ohm_light_visibility vis, const void *ctx, double E[3], double l_mean[3]);

/* The same, and what enters, ray by ray (Fresnel at each ray's own
 * direction: a sky's grazing rays enter less than its overhead ones):
 * entering[c] the irradiance times the transmittance, entering_mu[c] that
 * times mu. */
double ohm_light_irradiance_entering(const ohm_light_setup *su, const double p[3], const double n[3],
                                     ohm_light_visibility vis, const void *vctx, ohm_light_transmittance tr,
                                     const void *tctx, double E[3], double entering[3], double entering_mu[3],
                                     double l_mean[3]);

/* ohm_light_kind's toward and pov, for any light. */
int ohm_light_toward(const ohm_light *l, const double centre[3], double out[3]);
void ohm_light_pov(FILE *f, const ohm_light *l);

/* Release what each light owns (a sky image) and the array. */
void ohm_light_release(ohm_light *l);
void ohm_lights_free(ohm_light *lights, size_t n);

/* Helpers the kinds share (light_kind.c). */
void ohm_light_plane_basis(const double n[3], double u[3], double v[3]);
void ohm_light_pov_vec(FILE *f, const double v[3]);
void ohm_light_pov_colour(FILE *f, const ohm_light *l, double scale);
/* A light_source at l->pos, colour intensity x scale, `shape` (POV-Ray's
 * words: "spotlight radius ..."), pointed along l->dir; `note` a comment. */
void ohm_light_pov_aimed(FILE *f, const ohm_light *l, double scale, const char *shape, const char *note);
/* The ray from p to a light at pos (weight 1/d^2); 0 when p is there
 * (light_point.c). */
int ohm_light_point_ray(const double pos[3], const double p[3], ohm_light_ray *ray);
/* toward for a light with a position: towards pos, else against dir. */
int ohm_light_toward_position(const ohm_light *l, const double centre[3], double out[3]);

/* The kinds (light_<kind>.c). */
extern const ohm_light_kind ohm_light_directional, ohm_light_point, ohm_light_spot, ohm_light_area, ohm_light_pencil,
    ohm_light_environment;

#endif
