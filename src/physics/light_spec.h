/* physics/light_spec.h — a light as the user gave it (ohm_light: its kind
 * and its parameters): the type that the sources it lights (light.h) and
 * the table of kinds that knows what each kind is (light_kind.h) both
 * speak, so that neither header includes the other. */
#ifndef OHM_PHYSICS_LIGHT_SPEC_H
#define OHM_PHYSICS_LIGHT_SPEC_H

#include "physics/material.h"

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

/* Whether light l shines in frame `frame` (0-based): one without an orbit in
 * every frame, an orbit's copy (frame = k >= 1) in frame k - 1 only. */
static inline int ohm_light_in_frame(const ohm_light *l, int frame) { return l->frame == 0 || l->frame == frame + 1; }

#endif
