/* material.h — optical coefficients per colour channel (docs/design.md §3).
 *
 * A material is either optical — absorption sigma_a and reduced scattering
 * sigma_s' (1/mm) per channel, relative index of refraction eta — or, in the
 * paper's mode, raw resistances (ohms) between neighbours and to ground.
 * One value means grey (one channel); three mean R,G,B.  Channels whose
 * coefficients are equal share one factorization (material_channel_class). */
#ifndef OHM_MATERIAL_H
#define OHM_MATERIAL_H

#include "physics/fresnel.h"
#include "base/ohm_error.h"

enum { OHM_MAX_CHANNELS = 3 };

typedef enum ohm_material_kind {
    OHM_MATERIAL_OPTICAL = 0,
    OHM_MATERIAL_RESISTANCE = 1
} ohm_material_kind;

typedef struct ohm_material {
    ohm_material_kind kind;
    int channels;                        /* 1 (grey) or 3 (R,G,B)                 */
    double sigma_a[OHM_MAX_CHANNELS];    /* absorption, 1/mm                      */
    double sigma_s[OHM_MAX_CHANNELS];    /* reduced scattering sigma_s', 1/mm     */
    double eta;                          /* relative index of refraction          */
    double g;                            /* scattering anisotropy (Henyey-Greenstein
                                            mean cosine): diffusion needs only
                                            sigma_s' = sigma_s (1 - g); transport
                                            (mc.h) traces sigma_s and g          */
    double resistance;                   /* paper mode: ohms between neighbours   */
    double ground;                       /* paper mode: ohms from a cell to ground */
    char name[64];                       /* preset name, or "custom"              */
} ohm_material;

/* The measured materials of Jensen et al. 2001 (sigma_s', sigma_a in 1/mm,
 * eta = 1.3, as tabulated in pbrt-v3/v4). */
typedef struct ohm_preset {
    const char *name;
    double sigma_s[3];
    double sigma_a[3];
} ohm_preset;
extern const ohm_preset ohm_presets[];   /* terminated by name == NULL */
extern const char *const ohm_preset_names; /* "apple|chicken1|..." */

int ohm_material_preset(ohm_material *out, const char *name, ohm_error *err);

/* Validate: finite, sigma_a >= 0, sigma_s > 0, 1 <= eta <= 3, -1 < g < 1, resistances > 0. */
int ohm_material_check(const ohm_material *m, ohm_error *err);

/* Derived quantities (docs/design.md §3). */
/* The boundary's Fresnel optics and A: fresnel.h. */

/* For channel c: sigma_t' = sigma_a + sigma_s', D = 1/(3 sigma_t'),
 * sigma_tr = sqrt(3 sigma_a sigma_t'), albedo alpha' = sigma_s'/sigma_t'. */
double ohm_material_D(const ohm_material *m, int c);
double ohm_material_sigma_tr(const ohm_material *m, int c);
double ohm_material_albedo(const ohm_material *m, int c);

/* Same coefficients as an earlier channel?  Returns the first channel with
 * identical values (so the caller reuses its factor), or c itself. */
int ohm_material_channel_class(const ohm_material *m, int c);

#endif
