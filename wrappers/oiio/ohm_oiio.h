/* ohm_oiio.h — a small C API over OpenImageIO (the only code that sees OIIO).
 *
 * Int status codes (0 ok, negative ohm error code) and a caller-owned
 * ohm_error for the message, which names the file.  The functions that touch
 * images run in the module libohm_oiio.so, loaded on first use
 * (ohm_oiio_module.h); each body there runs inside one catch-all
 * (OHM_OIIO_TRY in ohm_oiio.cpp), so no C++ exception ever reaches C.
 *
 * Pixels are linear floats, row-major from the top-left, `channels` (1, 3 or
 * 4) interleaved per pixel.  The format comes from the extension of `path`:
 *   .png  8-bit, sRGB-encoded here (the standard sRGB transfer curve), values
 *         clamped to [0, 1];
 *   .exr  half float, linear (zip compression).
 * Anything else is OHM_ERR_USAGE. */
#ifndef OHM_OIIO_H
#define OHM_OIIO_H

#include "base/ohm_error.h"

#ifdef __cplusplus
extern "C" {
#endif

/* 1 when path ends in an extension ohm_image_write handles (.png, .exr,
 * case-insensitive), else 0. */
int ohm_image_format_supported(const char *path);

/* Write an image: the bytes go to `write_path` (a temporary name from
 * ohm_output_tmp_path, which has no image extension) while the format and
 * every message come from `path`, the final name. */
int ohm_image_write_to(const char *path, const char *write_path, const float *rgb, int width, int height,
                       int channels, ohm_error *err);

/* Read one image as a single grey channel: *pixels is a malloc'd w*h array,
 * row-major from the top-left, that the caller frees.  Integer pixels keep
 * their stored values (0-255 for 8-bit, 0-65535 for 16-bit); float pixels are
 * as stored.  Two channels are grey + alpha (alpha ignored); RGB(A) becomes
 * the mean of R, G and B.  Any format OpenImageIO reads (TIFF, PNG, ...);
 * only the first subimage. */
int ohm_image_read_gray(const char *path, float **pixels, int *w, int *h, ohm_error *err);

/* Read one image as linear RGB: *pixels is a malloc'd 3*w*h array of floats
 * (row-major from the top-left) that the caller frees.  Float pixels are as
 * stored (.hdr, .exr: radiance); integer ones are scaled to [0, 1]; a grey
 * image repeats its channel; alpha is ignored.  Only the first subimage. */
int ohm_image_read_rgb(const char *path, float **pixels, int *w, int *h, ohm_error *err);

/* An image's width, height and channels, from its header alone (nothing
 * decoded): for checking a slice before reading it. */
int ohm_image_size(const char *path, int *w, int *h, int *channels, ohm_error *err);

#ifdef __cplusplus
}
#endif
#endif
