/* input/scan_volume.h — a scan's in-memory form (ohm_scan: the values and
 * the map from voxel index to world mm) and what a read is asked
 * (ohm_scan_params) with its limits: the types that the scan's entry points (scan.h) and
 * its readers' shared helpers (scan_io.h) both speak, so that neither
 * header includes the other. */
#ifndef OHM_INPUT_SCAN_VOLUME_H
#define OHM_INPUT_SCAN_VOLUME_H

#include <stdint.h>

#include "base/log.h"

typedef struct ohm_scan {
    int32_t dims[3];              /* voxels per axis                                   */
    float *values;                /* dims[0]*dims[1]*dims[2], x fastest, scaled values */
    double index_to_world[3][4];  /* world mm = M (i, j, k, 1)^T, at voxel centres     */
    double min, max;              /* range of values                                   */
    double background;            /* the value outside the box: a .vdb's background
                                     value, else the lowest value (see below)          */
    char detail[192];             /* what the reader chose, for the log ("" if nothing) */
} ohm_scan;

typedef struct ohm_scan_params {
    const char *grid;             /* .vdb: grid name (NULL: "density")                 */
    int32_t dims[3];              /* raw: required                                      */
    const char *type;             /* raw: u8 | u16 | i16 | f32                          */
    const char *endian;           /* raw: little | big (NULL: little)                   */
    double spacing[3];            /* raw, stacks: voxel size mm (0: 1 mm)               */
    const char *series;           /* DICOM: SeriesInstanceUID (NULL: the only one)      */
    double max_expansion;         /* voxels per byte of file a large scan may have
                                     (0: OHM_SCAN_MAX_EXPANSION; see scan_io.h)         */
    const ohm_log *log;           /* slice stacks: progress per slice, and the run's
                                     cancellation (NULL: neither)                       */
} ohm_scan_params;

/* A scan needing more than OHM_SCAN_BOMB_FLOOR bytes to read may hold at
 * most this many voxels per byte of its files.  Scans hold 0.5-2 (the
 * walnut's raw.gz, Colin27's nii.gz, the skull's inr.gz); label masks more:
 * a 512^3 sphere's 165, a 1024^3 one's 377, the bundled liver's 254;
 * deflate's ceiling, and so a gzip bomb's, is 1032. */
#define OHM_SCAN_MAX_EXPANSION 500
#define OHM_SCAN_MAX_EXPANSION_TEXT "500" /* the same, for option defaults */
#define OHM_SCAN_BOMB_FLOOR (256.0 * 1048576.0)

#endif
