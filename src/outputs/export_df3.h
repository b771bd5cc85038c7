/* export_df3.h — the solved volume as POV-Ray density files plus a scene that
 * renders them (-export df3=, docs/outputs.md).
 *
 * BASE_r.df3, BASE_g.df3, BASE_b.df3 (BASE.df3 for grey): a header of three
 * big-endian uint16 sizes, then big-endian uint16 samples, x fastest.  The
 * grid is padded with one zero voxel on every side (POV-Ray's interpolation
 * wraps around at the edges), so the sizes are dims + 2.  Every channel uses
 * one scale, K = 65535 / (largest value over the channels), so the colours keep
 * their ratios: sample = round(quantity * K).
 *
 * BASE.pov places an emitting medium per channel in the object's world box
 * (mm; ohm's right-handed coordinates mirrored in z into POV-Ray's left-handed
 * ones), with a camera looking at the object from the lit side.  It names the
 * .df3 files without a directory: render it from its own directory (or pass
 * +L<dir>). */
#ifndef OHM_EXPORT_DF3_H
#define OHM_EXPORT_DF3_H

#include "base/ohm_error.h"
#include "base/output.h"
#include "solvers/solve.h"
#include "grid/voxelize.h"

typedef struct ohm_df3_params {
    int frame;                 /* 0-based                                        */
    int exitance;              /* 0: fluence, 1: exitance                         */
    double toward_light[3];    /* from the object towards the light (for the camera); 0: +y */
    const ohm_light *lights;   /* the lights, written into the scene by their kinds     */
    size_t nlights;            /* (physics/light_kind.h); those of other frames skipped */
} ohm_df3_params;

typedef struct ohm_df3_report {
    double max;                /* largest value written (before scaling)          */
    double scale;              /* K: sample = quantity * K                        */
    char pov[OHM_PATH_MAX];    /* the scene written                               */
    char first[OHM_PATH_MAX];  /* the first .df3 written                          */
} ohm_df3_report;

/* base: the output name without extension (a trailing .df3 or .pov is dropped). */
int ohm_export_df3(const char *base, const ohm_voxel_grid *grid, const ohm_solution *sol, const ohm_df3_params *p,
                   ohm_df3_report *rep, ohm_output_batch *batch, ohm_error *err);

#endif
