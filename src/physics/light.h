/* light.h — lights and the source vector b (docs/lights.md).
 *
 * A light puts irradiance E = I max(0, n.l) on every boundary face it sees
 * (n the face's outward normal; point lights also fall off as 1/d^2).  Using
 * the voxel faces' own normals makes the captured power exactly the light's
 * irradiance times the object's projected area.  The fraction (1 - F_r) that
 * enters — Fresnel at the smooth surface normal, taken from the distance
 * field — is deposited along the inward normal with the reduced-intensity
 * profile alpha' (e^{-sigma_t' z0} - e^{-sigma_t' z1}) per cell it crosses,
 * each share acting at its centroid (deposit=exponential: light.c), all at depth 1/sigma_t' (deposit=point, the dipole's
 * assumption) or all in the first cell (deposit=surface, the paper's).
 * Shadow rays (shadow.h) decide which faces see the light.  What each kind
 * of light is — its options, the directions it arrives from at a surface
 * point, its preview and its POV-Ray text — is one entry of the table in
 * light_kind.h. */
#ifndef OHM_LIGHT_H
#define OHM_LIGHT_H

#include "physics/material.h"
#include "physics/network.h"
#include "base/ohm_error.h"
#include "physics/shadow.h"

typedef enum ohm_light_type {
    OHM_LIGHT_DIRECTIONAL = 0, /* intensity: irradiance (W/mm^2) on a face square to the light */
    OHM_LIGHT_POINT = 1,       /* intensity: W/sr                                              */
    OHM_LIGHT_PENCIL = 2,      /* intensity: beam power (W), entering at one surface point     */
    OHM_LIGHT_SPOT = 3,        /* intensity: W/sr on the axis dir, inside the cone              */
    OHM_LIGHT_AREA = 4,        /* intensity: total power (W) of a one-sided Lambertian emitter  */
    OHM_LIGHT_ENVIRONMENT = 5  /* intensity: sky radiance (W/mm^2/sr), times the sky image's pixels */
} ohm_light_type;

/* An environment light's equirectangular image (light_environment.c). */
typedef struct ohm_sky_image ohm_sky_image;

typedef struct ohm_light {
    ohm_light_type type;
    double pos[3];                  /* point, pencil: position (mm)                         */
    double dir[3];                  /* directional, pencil: direction light travels (unit)  */
    double intensity[OHM_MAX_CHANNELS];
    int channels;                   /* 1 (grey) or 3                                        */
    int frame;                      /* 0: lights every frame; k >= 1: only frame k (orbits) */
    double angle, falloff;          /* spot: cone half-angle and soft edge inside it (deg)  */
    int disk;                       /* area: a disk of radius width/2, else a rectangle     */
    double width, height;           /* area: size (mm), centred on pos, facing dir          */
    int samples;                    /* area: sample points (stratified); 0 means 64;
                                       environment: sky directions per face; 0 means 256    */
    ohm_sky_image *sky;             /* environment: the sky image, NULL for a uniform sky;
                                       owned by the light array (ohm_lights_free)           */
    char where[256];                /* how the user gave it ("argument 12"), for messages   */
} ohm_light;

/* The light's kind's name ("directional", ...; type= of -light), and
 * whether it enters at one surface point (a pencil beam) rather than through
 * the faces it lights: the table of kinds answers (light_kind.h). */
const char *ohm_light_name(const ohm_light *l);
int ohm_light_at_a_point(const ohm_light *l);

typedef enum ohm_deposit {
    OHM_DEPOSIT_EXPONENTIAL = 0,
    OHM_DEPOSIT_POINT = 1,
    OHM_DEPOSIT_SURFACE = 2
} ohm_deposit;

typedef struct ohm_source_power {
    double incident;   /* arriving on lit faces, before Fresnel (W) */
    double entered;    /* through the surface, after Fresnel (W)    */
    double deposited;  /* put into b: the scattered part (W)        */
} ohm_source_power;

/* Add light's contribution for channel c to b (n entries, not cleared).
 * occ (NULL: no shadows) decides which faces see the light. */
int ohm_source_add(double *b, ohm_source_power *pw, const ohm_network *net, const ohm_light *light, int c,
                   const ohm_channel_medium *med, ohm_deposit deposit, const ohm_occluder *occ, ohm_error *err);

/* The channel-independent half of ohm_source_add, for every light but a
 * pencil beam: trace the shadow rays once and ADD, per channel c < channels,
 * the power arriving on the boundary faces (arrive[c], W, before Fresnel:
 * their sum, which is all the books need of it) and the power entering
 * each (enter[c][f], after Fresnel at relative index
 * eta, or eta_v of the face's cell) and, when enter_mu is not NULL, that power times the refracted ray's
 * cosine to the inward normal (enter_mu / enter: the mean cosine, for the
 * deposit's depth).  ohm_solve computes this once per frame and reuses it for every
 * channel: visibility does not depend on the colour. */
int ohm_light_face_powers(double *const *enter, double *const *enter_mu, double *arrive, int channels,
                          const ohm_network *net, const ohm_light *light, double eta, const double *eta_v,
                          const ohm_occluder *occ, ohm_error *err);

/* Where light enters the object, for Monte Carlo transport (mc.h): per lit
 * boundary face (per pencil beam, its entry point), the power arriving and
 * the power entering after Fresnel per channel, and the direction inside by
 * Snell's law at the smooth normal.  A face lit by an area light gets its
 * irradiance-weighted direction: one direction per face, not per sample. */
typedef struct ohm_light_entry {
    int64_t face;                       /* the boundary face                      */
    double incident[OHM_MAX_CHANNELS];  /* W arriving, before Fresnel             */
    double power[OHM_MAX_CHANNELS];     /* W entering                             */
    double dir[3];                      /* unit direction inside                  */
    double point[3];                    /* pencil beams: where it enters (mm)     */
    double mu;                          /* dir's cosine to the inward smooth normal */
    int at_point;                       /* 1: at point; 0: spread over the face   */
} ohm_light_entry;

typedef struct ohm_light_entries {
    ohm_light_entry *entry;
    size_t count, capacity;
} ohm_light_entries;

/* Append light's entries (channels < OHM_MAX_CHANNELS) to list.  Here and in
 * ohm_light_face_powers a face refracts into its own cell's index: eta_v[v]
 * per unknown, or eta for every face when eta_v is NULL. */
int ohm_light_entries_add(ohm_light_entries *list, const ohm_network *net, const ohm_light *light, int channels,
                          double eta, const double *eta_v, const ohm_occluder *occ, ohm_error *err);
void ohm_light_entries_free(ohm_light_entries *list);

/* Deposit per-face entering powers (nfaces) into b, at the depths of their
 * rays' cosines enter_mu / enter (NULL: normal incidence); returns the total
 * deposited. */
double ohm_source_deposit_faces(double *b, const ohm_network *net, const double *enter, const double *enter_mu,
                                const ohm_channel_medium *med, ohm_deposit deposit);

/* Deposit power P entering through boundary face f along a ray whose cosine
 * to the inward normal is mu (1: normal incidence): the column below the face
 * takes the depth profile e^(-sigma_t' z / mu), mean depth mu / sigma_t'
 * (used by ohm_source_add and by validation scenes that place a beam
 * themselves).  Returns what went in. */
double ohm_source_deposit_face(double *b, const ohm_network *net, int64_t f, double P, double mu,
                               const ohm_channel_medium *med, ohm_deposit deposit);

/* Add to phi (n entries) the fluence of the unscattered (reduced-intensity)
 * beam of power P entering through boundary face f, along the inward normal
 * like the deposit, attenuated by the full sigma_t = sigma_a + sigma_s
 * (sigma_s = sigma_s' / (1 - g)): what transport codes include in their
 * fluence, and diffusion's phi (whose source is the first scattering) does
 * not. */
void ohm_source_unscattered_face(double *phi, const ohm_network *net, int64_t f, double P, double mu,
                                 const ohm_channel_medium *med);

/* Outward unit normal of the surface at the interior cell of face f, from the
 * distance field (falls back to the face normal). */
void ohm_surface_normal(const ohm_network *net, int64_t f, double n[3]);

#endif
