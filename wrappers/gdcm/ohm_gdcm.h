/* ohm_gdcm.h — a small C API over GDCM (the only code that sees it): one
 * DICOM series as a volume.
 *
 * ohm_dicom_open takes a folder (its DICOMDIR when it has one, else the
 * DICOM files in it), a DICOMDIR file (the files its records reference) or
 * one DICOM file (the series it belongs to, among the files of its folder).
 * Every DICOM Part 10 file among them has each declared length checked
 * against its size first (dicom_check.h: GDCM allocates what a file
 * declares); the files are scanned for their series (0020,000E) and
 * geometry tags; one series is taken (the one asked for, or the only one;
 * a folder with several and none asked for is refused with the list of
 * them); its slices are
 * sorted by their position along the slice normal (the cross product of
 * ImageOrientationPatient's two directions) — never by file name or
 * InstanceNumber — and refused, with a message naming the files, when two
 * share a position, when the spacing between them is not uniform (a missing
 * slice), or when their orientations, sizes or pixel spacings differ.
 * ohm_dicom_read_voxels then decodes each slice (uncompressed pixel data
 * by the shim itself, masked to BitsStored and signed from it; compressed
 * transfer syntaxes through GDCM's ImageReader) and rescales it by its own
 * RescaleSlope/RescaleIntercept (CT: to Hounsfield units).
 *
 * Int status codes (0 ok, negative ohm error code); the message in the
 * caller's ohm_error names the folder or file.  Every exported body runs in
 * one catch-all (ohm_gdcm.cpp), so no C++ exception reaches C. */
#ifndef OHM_GDCM_H
#define OHM_GDCM_H

#include <stdint.h>

#include "base/ohm_error.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ohm_dicom_series ohm_dicom_series;

/* 1 when the folder has a DICOMDIR or a DICOM Part 10 file (the "DICM"
 * mark after a 128-byte preamble; files without it are not read). */
int ohm_dicom_folder_has_dicom(const char *dir);

/* 1 when the file is DICOM: "DICM" after the 128-byte preamble, or named
 * DICOMDIR. */
int ohm_dicom_is_file(const char *path);

/* The series `series_uid` (NULL or "": the only one, or the given file's)
 * of `path`, its slices sorted and checked; *out NULL on failure. */
int ohm_dicom_open(ohm_dicom_series **out, const char *path, const char *series_uid, ohm_error *err);

/* Columns, rows, slices; and the map from (column, row, slice) at voxel
 * centres to DICOM patient coordinates (LPS) in mm.  The slice axis is the
 * step between slice positions, so a tilted gantry shears it. */
void ohm_dicom_geometry(const ohm_dicom_series *s, int64_t dims[3], double index_to_world[3][4]);
const char *ohm_dicom_series_uid(const ohm_dicom_series *s);

/* The bytes of the series' files, and of one slice's decoded samples (the
 * reader's buffer beside the volume): for the scan readers' budget. */
void ohm_dicom_sizes(const ohm_dicom_series *s, double *stored_bytes, double *slice_bytes);

/* Every slice's rescaled values into out (columns fastest, then rows, then
 * slices in order along the normal); *rescaled counts the slices whose
 * slope/intercept is not 1/0. */
int ohm_dicom_read_voxels(ohm_dicom_series *s, float *out, int64_t *rescaled, ohm_error *err);

void ohm_dicom_close(ohm_dicom_series *s);

#ifdef __cplusplus
}
#endif
#endif
