/* scan_io.h — what the scan readers share (scan.c, scan_dicom.c, scan_inr.c,
 * scan_meta.c, scan_nrrd.c); private to input/.
 *
 * The careful-reader rules of scan.c hold for every reader: messages name
 * the file; no size a header declares is trusted before the bytes are
 * there; every size product is checked against OHM_SCAN_MAX_VOXELS before
 * anything is allocated.  World coordinates are NIfTI's: millimetres, x to
 * the patient's right, y anterior, z superior (RAS).  Formats whose world is
 * DICOM's LPS (MetaImage, DICOM, an NRRD with space: left-posterior-superior)
 * turn it into RAS with ohm_scan_lps_to_ras. */
#ifndef OHM_SCAN_IO_H
#define OHM_SCAN_IO_H

#include <stddef.h>
#include <stdint.h>

#include "base/ohm_error.h"
#include "input/scan_volume.h"

/* Largest volume ohm allocates (voxels). */
#define OHM_SCAN_MAX_VOXELS ((uint64_t)1 << 31)

/* Stored voxel types. */
typedef enum ohm_sample_type {
    OHM_SAMPLE_U8, OHM_SAMPLE_I8, OHM_SAMPLE_U16, OHM_SAMPLE_I16, OHM_SAMPLE_U32, OHM_SAMPLE_I32,
    OHM_SAMPLE_F32, OHM_SAMPLE_F64
} ohm_sample_type;

size_t ohm_sample_size(ohm_sample_type t);
const char *ohm_sample_name(ohm_sample_type t); /* "u8", "i16", "f32", ... */

/* Whether the file name ends with suffix, ignoring case. */
int ohm_scan_ends_with(const char *name, const char *suffix);

/* d's product into *n, each at least 1 and the product at most
 * OHM_SCAN_MAX_VOXELS; else OHM_ERR_PARSE naming path. */
int ohm_scan_voxel_count(const char *path, const int64_t d[3], size_t *n, ohm_error *err);

/* Before anything large is allocated: whether a read of `voxels` voxels
 * (their floats plus `buffer_bytes` of the reader's own decoding buffer)
 * from `stored_bytes` of files (0: not known) may go ahead.  Refused,
 * naming path: more than the memory available (ohm_memory_limit); or more
 * than OHM_SCAN_BOMB_FLOOR bytes at more than p->max_expansion voxels per
 * stored byte, a decompression bomb's mark (the message gives the
 * max_expansion= that would let a real scan through).  p may be NULL. */
int ohm_scan_check_budget(const char *path, const ohm_scan_params *p, size_t voxels, double buffer_bytes,
                          double stored_bytes, ohm_error *err);

/* s->values for d[0] x d[1] x d[2] voxels, s->dims set. */
int ohm_scan_alloc(ohm_scan *s, const char *path, const int64_t d[3], ohm_error *err);

/* n stored samples (little- or big-endian) as floats. */
void ohm_scan_convert(float *out, const unsigned char *in, size_t n, ohm_sample_type t, int big_endian);

/* Read exactly `want` bytes from `offset` on (gz: offsets in the gzip
 * stream's decompressed data) into buf; *actual is how many the file holds
 * from offset, or want + 1 when it holds more: reading stops one byte past
 * what is expected, so a decompression bomb costs no more than the volume. */
int ohm_scan_read_bytes(const char *path, int gz, uint64_t offset, unsigned char *buf, size_t want,
                        uint64_t *actual, ohm_error *err);

/* The same for a zlib (or gzip) stream that starts at byte `offset` of a
 * plain file (MetaImage's CompressedData): inflated into buf until it ends
 * or holds one byte more than want (*actual then says "too long"). */
/* The error for data of the wrong size: *actual bytes (want + 1: more)
 * where d's voxels of type t need want; `where` says what was read ("the
 * file", "the decompressed data"). */
int ohm_scan_size_error(const char *path, uint64_t actual, size_t want, const int64_t d[3], ohm_sample_type t,
                        const char *where, ohm_error *err);

int ohm_scan_inflate_bytes(const char *path, uint64_t offset, unsigned char *buf, size_t want, uint64_t *actual,
                           ohm_error *err);

/* Up to max - 1 bytes of the file's start (gz: decompressed) into buf,
 * NUL-terminated; *got is how many. */
int ohm_scan_read_head(const char *path, int gz, char *buf, size_t max, size_t *got, ohm_error *err);

/* Values of one "KEY = VALUE" or "KEY=VALUE" header line, spaces trimmed:
 * 1 when line (len bytes, no newline) has that form, with key and value
 * copied (each at most keymax / valmax - 1 bytes: longer is 0). */
int ohm_scan_header_line(const char *line, size_t len, char *key, size_t keymax, char *value, size_t valmax);

/* Up to 3 (or `count`) numbers of a header value ("0.5 0.5 1.2"); returns
 * how many were read, -1 when something else is there. */
int ohm_scan_numbers(const char *value, double *out, int count);

/* index_to_world from spacing (mm per voxel along each axis), the unit
 * direction of each axis (dir[axis][xyz], world) and the first voxel's
 * centre (world). */
void ohm_scan_set_geometry(ohm_scan *s, const double spacing[3], const double dir[3][3], const double origin[3]);

/* An LPS world (DICOM, ITK, MetaImage) made RAS: x and y negated. */
void ohm_scan_lps_to_ras(ohm_scan *s);

/* Readers behind ohm_scan_read (scan.h), one file each. */
int ohm_scan_read_inr(ohm_scan *s, const char *path, int gz, const ohm_scan_params *p, ohm_error *err);
int ohm_scan_read_meta(ohm_scan *s, const char *path, const ohm_scan_params *p, ohm_error *err);
int ohm_scan_read_nrrd(ohm_scan *s, const char *path, const ohm_scan_params *p, ohm_error *err);
int ohm_scan_read_dicom(ohm_scan *s, const char *path, const ohm_scan_params *p, ohm_error *err);

#endif
