/* scan.h — density volumes in (CT, MRI, any scalar field): stage "scans" of
 * docs/design.md §2.  One in-memory form for every reader: a dense float array,
 * x fastest, and the affine map from voxel index (voxel centres) to world mm.
 *
 * Readers: .vdb (a float grid, grid= picks it; default "density"), NIfTI-1/2
 * (.nii, .nii.gz: voxel spacing, sform (else qform), scl_slope/scl_inter
 * honoured), NRRD (.nrrd, .nhdr + its data file: through Teem,
 * scan_nrrd.c), MetaImage (.mha, .mhd + its data file: scan_meta.c),
 * INRIMAGE-4 (.inr, .inr.gz: scan_inr.c), DICOM series (a folder of
 * slices, a DICOMDIR, or one slice file: through GDCM, scan_dicom.c;
 * series= picks one of several), headerless raw (.raw, .raw.gz:
 * dims=, type=u8|u16|i16|f32, endian=little|big, spacing=; x fastest), and
 * TIFF/PNG stacks through OpenImageIO (a directory of slices sorted by name,
 * spacing=; a directory with DICOM files or a DICOMDIR is a DICOM series).
 * Every error names the file and what was expected; NaN or Inf
 * voxels are an error naming the first one.  The scan owns `values`;
 * ohm_scan_free releases it.
 *
 * Geometry: index_to_world is the whole affine map each format states
 * (spacing, direction cosines, origin), in RAS millimetres (NIfTI's world;
 * LPS formats are turned, scan_io.h).  An oblique scan (a tilted gantry, a
 * rotated NRRD space) keeps its map: sampling goes through its inverse, so
 * the scan is resampled onto ohm's axis-aligned grid with its placement
 * honoured, never straightened. */
#ifndef OHM_SCAN_H
#define OHM_SCAN_H

#include <stddef.h>
#include <stdint.h>

#include "base/log.h"
#include "base/ohm_error.h"
#include "input/scan_volume.h"

int ohm_scan_read(ohm_scan *out, const char *path, const ohm_scan_params *p, ohm_error *err);

/* 1 when ohm_scan_read takes path as a scan (by its extension, a folder, or
 * a DICOM file), 0 when it is for the mesh reader. */
int ohm_scan_is_volume_path(const char *path);
void ohm_scan_free(ohm_scan *s);

/* A scan's extent, one rule for every reader: its box is the hull of its
 * voxel centres, where its values are known.  An object made from the scan
 * alone (-voxelize threshold=) is the cells of that box whose value passes
 * the threshold, never a cell outside it, whatever the threshold (a uniform
 * or cropped scan is its box, not the whole grid).  Outside the box a scan
 * reads as its background: a .vdb states its own (the grid's background
 * value, which its inactive voxels also hold); for other formats it is the
 * lowest value (0 for most scans, air's -1000 or so for CT in Hounsfield
 * units), so a material sampled past such a scan, or a cell straddling its
 * box's face, is never denser than the scan is. */

/* Value at a world point: trilinear between voxel centres; outside the box
 * the scan's background. */
double ohm_scan_sample(const ohm_scan *s, const double world[3]);

/* Value at the point of the scan's box nearest to a world point (in index
 * space): the scan continued outwards without a step, for an iso-surface
 * that the box then cuts (ohm_scan_box_distance). */
double ohm_scan_sample_clamped(const ohm_scan *s, const double world[3]);

/* Signed distance, mm, from a world point to the scan's box: negative
 * inside, positive outside.  Exact inside and straight out from a face; past
 * an edge or a corner the largest distance along one axis (a lower bound). */
double ohm_scan_box_distance(const ohm_scan *s, const double world[3]);

/* Mean over the axis-aligned world box [lo, hi] (box filter, for grids
 * coarser than the scan): averages the voxels whose centres fall inside,
 * or the trilinear value at the centre when none does. */
double ohm_scan_box_mean(const ohm_scan *s, const double lo[3], const double hi[3]);

/* Voxel size along each of the scan's axes, mm (index_to_world's columns). */
void ohm_scan_spacing(const ohm_scan *s, double spacing[3]);

/* How far the scan's axes are turned from the world's: the largest angle,
 * in degrees, between an axis and the world axis nearest to it (0: axis-
 * aligned, possibly flipped). */
double ohm_scan_obliquity(const ohm_scan *s);

/* World bounds of the scan's voxel centres (lo, hi). */
void ohm_scan_bounds(const ohm_scan *s, double lo[3], double hi[3]);

#endif
