/* scan_dicom.c — a DICOM series (a folder, a DICOMDIR or one of the
 * series' files) as a scan, through wrappers/gdcm.
 *
 * The shim sorts and checks the slices and rescales each by its own
 * slope/intercept (CT: Hounsfield units); here the volume is allocated under
 * the shared limits (scan_io.h), and the map from voxel index to DICOM's
 * patient coordinates (LPS) is turned into ohm's RAS. */
#include <stdio.h>
#include <string.h>

#include "ohm_gdcm.h"
#include "input/scan_io.h"

int ohm_scan_read_dicom(ohm_scan *s, const char *path, const ohm_scan_params *p, ohm_error *err)
{
    ohm_dicom_series *ds = NULL;
    int rc = ohm_dicom_open(&ds, path, p ? p->series : NULL, err);
    if (rc) return rc;
    int64_t d[3];
    double m[3][4], stored = 0, slice = 0;
    size_t n = 0;
    ohm_dicom_geometry(ds, d, m);
    ohm_dicom_sizes(ds, &stored, &slice);
    rc = ohm_scan_voxel_count(path, d, &n, err);
    if (!rc) rc = ohm_scan_check_budget(path, p, n, slice, stored, err);
    if (!rc) rc = ohm_scan_alloc(s, path, d, err);
    int64_t rescaled = 0;
    if (!rc) rc = ohm_dicom_read_voxels(ds, s->values, &rescaled, err);
    if (!rc) {
        memcpy(s->index_to_world, m, sizeof m);
        ohm_scan_lps_to_ras(s);
        snprintf(s->detail, sizeof s->detail, "DICOM series %.64s, %lld slices%s", ohm_dicom_series_uid(ds),
                 (long long)d[2], rescaled ? ", rescaled by their RescaleSlope/Intercept" : "");
    }
    ohm_dicom_close(ds);
    return rc;
}
