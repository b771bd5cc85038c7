/* ohm_oiio_module.h — between ohm_oiio_load.c and the module it opens.
 *
 * OpenImageIO and the ~260 shared libraries it pulls in (codecs, OpenEXR,
 * ffmpeg...) took 0.19 s of ohm's 0.24 s start-up, for every command, test
 * and Python import, though only -render and slice folders use images.  So
 * ohm_oiio.cpp is a separate module, libohm_oiio.so, that the image
 * functions of ohm_oiio.h load on first use: it exports one symbol, the
 * table below. */
#ifndef OHM_OIIO_MODULE_H
#define OHM_OIIO_MODULE_H

#include "base/ohm_error.h"

#ifdef __cplusplus
extern "C" {
#endif

#define OHM_OIIO_MODULE_FILE "libohm_oiio.so"

/* ohm_oiio.h's functions of the same names, in the module. */
typedef struct ohm_oiio_api {
    int (*write_to)(const char *path, const char *write_path, const float *rgb, int width, int height, int channels,
                    ohm_error *err);
    int (*read_gray)(const char *path, float **pixels, int *w, int *h, ohm_error *err);
    int (*size)(const char *path, int *w, int *h, int *channels, ohm_error *err);
    int (*read_rgb)(const char *path, float **pixels, int *w, int *h, ohm_error *err);
} ohm_oiio_api;

/* The module's one export (linked in directly by scripts/fuzz.sh). */
const ohm_oiio_api *ohm_oiio_module(void);

#ifdef __cplusplus
}
#endif
#endif
