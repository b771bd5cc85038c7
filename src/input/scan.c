/* scan.c — the density-volume readers behind scan.h (.vdb, NIfTI-1/2, raw,
 * directories of TIFF/PNG slices through wrappers/oiio).
 *
 * Careful-reader rules as in mesh_io.c: every message names the file; no size
 * declared by a header is trusted before the bytes are there (raw files must be
 * exactly dims x bytes-per-voxel long, checked before any voxel is converted);
 * every size product is overflow-checked.  NIfTI goes through Debian's
 * libnifti2 (which reads both versions, plain or gzip), headers first so a bad
 * datatype or shape is refused before the data is loaded; and before that,
 * nifti_precheck reads the header itself, because libnifti2 does not survive
 * every bad one.  A .vdb passes ohm_vdb_check (scan_check.c) before OpenVDB,
 * which trusts every size in the file, reads it.  Content errors are
 * OHM_ERR_PARSE, unopenable files OHM_ERR_IO, bad parameters OHM_ERR_USAGE. */
#include "input/scan.h"

#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <dirent.h>
#include <sys/stat.h>
#include <zlib.h>

#include <nifti2_io.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

#include "ohm_gdcm.h"
#include "ohm_oiio.h"
#include "ohm_vdb.h"
#include "input/scan_check.h"
#include "input/scan_io.h"

static size_t scan_count(const ohm_scan *s)
{
    return (size_t)s->dims[0] * (size_t)s->dims[1] * (size_t)s->dims[2];
}

/* NaN/Inf check and range; a scan whose format states no background
 * (every one but .vdb) reads as its lowest value outside its box. */
static int finish_values(ohm_scan *s, const char *path, ohm_error *err)
{
    size_t n = scan_count(s);
    double lo = INFINITY, hi = -INFINITY;
    for (size_t i = 0; i < n; ++i) {
        float v = s->values[i];
        if (!isfinite(v)) {
            size_t nx = (size_t)s->dims[0], ny = (size_t)s->dims[1];
            return ohm_fail(err, OHM_ERR_PARSE, "%s: voxel (%zu, %zu, %zu) is %s, expected a finite value", path,
                            i % nx, (i / nx) % ny, i / (nx * ny), isnan(v) ? "NaN" : "infinite");
        }
        if (v < lo) lo = v;
        if (v > hi) hi = v;
    }
    s->min = lo;
    s->max = hi;
    if (isnan(s->background)) s->background = lo;
    return 0;
}

static void scan_bounds_of(const ohm_scan *s, double lo[3], double hi[3]);

/* The voxel-to-world map must be invertible and put every voxel at a finite
 * place (a fuzz finding: a NIfTI sform of 1e296 gave infinite bounds). */
static int check_placement(const ohm_scan *s, const char *path, ohm_error *err)
{
    const double(*m)[4] = s->index_to_world;
    double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                 m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    if (!isfinite(det) || det == 0)
        return ohm_fail(err, OHM_ERR_PARSE,
                        "%s: the voxel-to-world transform is singular or overflows (determinant %g), expected "
                        "an invertible map",
                        path, det);
    double lo[3], hi[3];
    scan_bounds_of(s, lo, hi);
    for (int a = 0; a < 3; ++a)
        if (!isfinite(lo[a]) || !isfinite(hi[a]))
            return ohm_fail(err, OHM_ERR_PARSE,
                            "%s: the voxel-to-world transform puts the volume at non-finite coordinates "
                            "(axis %d: %g .. %g mm)",
                            path, a, lo[a], hi[a]);
    return 0;
}

/* ------------------------------------------------------------------------ */
/* .vdb                                                                      */

typedef struct densify {
    ohm_scan *s;
    int32_t lo[3];
} densify;

static int densify_voxel(void *user, const int32_t ijk[3], float value)
{
    densify *d = user;
    size_t i = (size_t)(ijk[0] - d->lo[0]), j = (size_t)(ijk[1] - d->lo[1]), k = (size_t)(ijk[2] - d->lo[2]);
    if (i >= (size_t)d->s->dims[0] || j >= (size_t)d->s->dims[1] || k >= (size_t)d->s->dims[2]) return 0;
    d->s->values[(k * (size_t)d->s->dims[1] + j) * (size_t)d->s->dims[0] + i] = value;
    return 0;
}

static int read_vdb(ohm_scan *s, const char *path, const ohm_scan_params *p, ohm_error *err)
{
    const char *want = p && p->grid && *p->grid ? p->grid : "density";
    ohm_vdb_grid **grids = NULL;
    size_t n = 0;
    /* OpenVDB trusts every size in the file: check them all first. */
    int rc = ohm_vdb_check(path, err);
    if (rc) return rc;
    rc = ohm_vdb_read(&grids, &n, path, err);
    if (rc) return rc;
    if (n == 0) return ohm_fail(err, OHM_ERR_PARSE, "%s: the file holds no grids, expected a float grid named '%s'", path, want);
    ohm_vdb_grid *g = NULL;
    ohm_vdb_grid_info info = {0};
    char names[512] = "";
    size_t used = 0;
    for (size_t i = 0; i < n && !g; ++i) {
        ohm_vdb_grid_info gi;
        rc = ohm_vdb_grid_get_info(grids[i], &gi, err);
        if (rc) goto done;
        if (strcmp(gi.name, want) == 0) {
            g = grids[i];
            info = gi;
        } else if (used < sizeof names - 1) {
            int w = snprintf(names + used, sizeof names - used, "%s'%s'", used ? ", " : "", gi.name);
            if (w > 0) used += (size_t)w;
            if (used >= sizeof names) used = sizeof names - 1;
        }
    }
    if (!g) {
        rc = ohm_fail(err, OHM_ERR_USAGE, "%s: no float grid named '%s' (grids present: %s)", path, want,
                      n ? names : "none");
        goto done;
    }
    if (info.active_voxels == 0) {
        rc = ohm_fail(err, OHM_ERR_PARSE, "%s: grid '%s' has no active voxels, expected a density volume", path,
                      want);
        goto done;
    }
    int64_t d[3];
    for (int k = 0; k < 3; ++k) d[k] = (int64_t)info.bbox_max[k] - info.bbox_min[k] + 1;
    size_t dense = 0;
    struct stat st;
    rc = ohm_scan_voxel_count(path, d, &dense, err);
    if (!rc) rc = ohm_scan_check_budget(path, p, dense, 0, stat(path, &st) == 0 ? (double)st.st_size : 0, err);
    if (!rc) rc = ohm_scan_alloc(s, path, d, err);
    if (rc) goto done;
    if (!isfinite(info.background)) {
        rc = ohm_fail(err, OHM_ERR_PARSE, "%s: grid '%s' has background value %g, expected a finite value", path, want,
                      (double)info.background);
        goto done;
    }
    /* the grid's outside, inactive voxels in its box and all past it */
    s->background = info.background;
    size_t nv = scan_count(s);
    for (size_t i = 0; i < nv; ++i) s->values[i] = info.background;
    densify ds = {s, {info.bbox_min[0], info.bbox_min[1], info.bbox_min[2]}};
    rc = ohm_vdb_grid_foreach_active(g, densify_voxel, &ds, err);
    if (rc) goto done;
    memset(s->index_to_world, 0, sizeof s->index_to_world);
    for (int k = 0; k < 3; ++k) {
        s->index_to_world[k][k] = info.voxel_size;
        s->index_to_world[k][3] = info.origin[k] + info.voxel_size * info.bbox_min[k];
    }
done:
    for (size_t i = 0; i < n; ++i) ohm_vdb_grid_free(grids[i]);
    free(grids);
    return rc;
}

/* ------------------------------------------------------------------------ */
/* NIfTI-1/2                                                                 */

/* The voxel data of a header-only nifti_image: exactly nvox * nbyper bytes
 * from iname_offset of iname (plain or gzip, through znzlib), byte-swapped to
 * the host's order. */
static int load_nifti_data(nifti_image *nim, const char *path, const ohm_scan_params *p, size_t nvox, void **out,
                           ohm_error *err)
{
    int nbyper = 0, swapsize = 0;
    nifti_datatype_sizes(nim->datatype, &nbyper, &swapsize);
    if (nbyper <= 0 || nvox > SIZE_MAX / (size_t)nbyper)
        return ohm_fail(err, OHM_ERR_PARSE, "%s: bad datatype size for %zu voxels", path, nvox);
    size_t want = nvox * (size_t)nbyper;
    const char *iname = nim->iname ? nim->iname : path;
    if (nim->iname_offset < 0)
        return ohm_fail(err, OHM_ERR_PARSE, "%s: vox_offset %" PRId64 " is negative", path,
                        (int64_t)nim->iname_offset);
    /* Never allocate what the file cannot hold: a plain file must have the
     * bytes; a gzip stream expands at most ~1032:1 (deflate's limit). */
    struct stat st;
    double stored = 0;
    if (stat(iname, &st) == 0 && S_ISREG(st.st_mode)) {
        stored = (double)st.st_size;
        double have = (double)st.st_size - (double)nim->iname_offset;
        if (nifti_is_gzfile(iname)) have = 1032.0 * (double)st.st_size;
        if ((double)want > have)
            return ohm_fail(err, OHM_ERR_PARSE,
                            "%s: truncated: %zu voxels of %s need %zu bytes from byte %" PRId64
                            ", more than the %lld-byte file can hold",
                            path, nvox, nifti_datatype_string(nim->datatype), want, (int64_t)nim->iname_offset,
                            (long long)st.st_size);
    }
    int rc = ohm_scan_check_budget(path, p, nvox, (double)want, stored, err);
    if (rc) return rc;
    znzFile f = znzopen(iname, "rb", nifti_is_gzfile(iname));
    if (znz_isnull(f)) return ohm_fail(err, OHM_ERR_IO, "%s: cannot open image data %s", path, iname);
    unsigned char *buf = malloc(want ? want : 1);
    if (!buf) rc = ohm_fail(err, OHM_ERR_NOMEM, "%s: out of memory reading %zu bytes", path, want);
    else if (znzseek(f, (znz_off_t)nim->iname_offset, SEEK_SET) < 0)
        rc = ohm_fail(err, OHM_ERR_PARSE, "%s: cannot seek to the voxel data at byte %" PRId64, path,
                      (int64_t)nim->iname_offset);
    else {
        size_t got = 0;
        while (got < want) {
            size_t chunk = want - got > ((size_t)1 << 30) ? (size_t)1 << 30 : want - got;
            size_t r = znzread(buf + got, 1, chunk, f);
            if (r == 0) break;
            got += r;
        }
        if (got != want)
            rc = ohm_fail(err, OHM_ERR_PARSE,
                          "%s: truncated: %zu voxels of %s need %zu bytes from byte %" PRId64 ", found %zu", path,
                          nvox, nifti_datatype_string(nim->datatype), want, (int64_t)nim->iname_offset, got);
    }
    znzclose(f);
    if (rc) {
        free(buf);
        return rc;
    }
    if (swapsize > 1 && nim->byteorder != nifti_short_order()) nifti_swap_Nbytes((int64_t)nvox, swapsize, buf);
    *out = buf;
    return 0;
}

/* The bytes of a NIfTI header field, printable: "n+1", "\x00\r\n"... */
static void show_bytes(char *out, size_t outlen, const unsigned char *b, size_t n)
{
    size_t used = 0;
    out[0] = 0;
    while (n > 0 && b[n - 1] == 0) n--; /* trailing NULs are padding */
    for (size_t i = 0; i < n && used + 5 < outlen; ++i) {
        int w = b[i] >= 0x20 && b[i] < 0x7f && b[i] != '\'' && b[i] != '\\'
                    ? snprintf(out + used, outlen - used, "%c", b[i])
                    : snprintf(out + used, outlen - used, "\\x%02x", b[i]);
        if (w > 0) used += (size_t)w;
    }
}

static uint64_t nii_u(const unsigned char *b, int nbytes, int swap)
{
    uint64_t v = 0;
    for (int i = 0; i < nbytes; ++i) v |= (uint64_t)b[swap ? nbytes - 1 - i : i] << (8 * i);
    return v;
}
static int64_t nii_i16(const unsigned char *b, int swap) { return (int16_t)nii_u(b, 2, swap); }
static int64_t nii_i32(const unsigned char *b, int swap) { return (int32_t)nii_u(b, 4, swap); }
static int64_t nii_i64(const unsigned char *b, int swap) { return (int64_t)nii_u(b, 8, swap); }
static double nii_f32(const unsigned char *b, int swap)
{
    uint32_t u = (uint32_t)nii_u(b, 4, swap);
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}
static double nii_f64(const unsigned char *b, int swap)
{
    uint64_t u = nii_u(b, 8, swap);
    double d;
    memcpy(&d, &u, sizeof d);
    return d;
}

/* What libnifti2 would "repair" without a word: a non-finite scl_slope or
 * scl_inter (read as no scaling) and, when the voxel size is what places the
 * voxels (no sform), a zero, negative or NaN pixdim (read as 1 mm).  Refused
 * instead, naming the field.  Offsets: NIfTI-1 pixdim float[8] at 76,
 * scl_slope/scl_inter at 112/116, sform_code at 254; NIfTI-2 pixdim
 * double[8] at 104, scl_slope/scl_inter at 176/184, sform_code at 348. */
static int nifti_check_scaling(const unsigned char *h, int v2, int swap, const char *path, const char *ver,
                               ohm_error *err)
{
    const double slope = v2 ? nii_f64(h + 176, swap) : nii_f32(h + 112, swap);
    const double inter = v2 ? nii_f64(h + 184, swap) : nii_f32(h + 116, swap);
    if (!isfinite(slope) || !isfinite(inter))
        return ohm_fail(err, OHM_ERR_PARSE, "%s: %s scl_slope %g, scl_inter %g: expected finite numbers (a slope of 0 "
                                            "means no scaling)", path, ver, slope, inter);
    const int64_t sform_code = v2 ? nii_i32(h + 348, swap) : nii_i16(h + 254, swap);
    if (sform_code > 0) return 0; /* the sform places the voxels; pixdim is not used */
    for (int k = 1; k <= 3; ++k) {
        const double d = v2 ? nii_f64(h + 104 + 8 * k, swap) : nii_f32(h + 76 + 4 * k, swap);
        if (!(d > 0) || !isfinite(d))
            return ohm_fail(err, OHM_ERR_PARSE, "%s: %s pixdim[%d] (the voxel size along axis %d) is %g, expected a "
                                                "positive size in mm", path, ver, k, k - 1, d);
    }
    return 0;
}

/* Check a NIfTI-1/2 header ourselves before libnifti2 sees it: libnifti2 3.0.1
 * smashes its stack on a NIfTI-2 header with a bad datatype, reads a wrong
 * magic as Analyze 7.5 and a negative dimension as 1 (docs/fuzzing.md).  The
 * first 348 or 540 bytes are read through zlib (plain or gzip alike). */
/* The voxel types ohm converts (checked on the raw header, then again on
 * what libnifti2 parsed). */
static int nifti_type_supported(int64_t t)
{
    return t == NIFTI_TYPE_UINT8 || t == NIFTI_TYPE_INT16 || t == NIFTI_TYPE_UINT16 || t == NIFTI_TYPE_INT32 ||
           t == NIFTI_TYPE_FLOAT32 || t == NIFTI_TYPE_FLOAT64;
}

static int nifti_precheck(const char *path, ohm_error *err)
{
    unsigned char h[540];
    errno = 0;
    gzFile f = gzopen(path, "rb");
    if (!f) return ohm_fail(err, OHM_ERR_IO, "%s: cannot open: %s", path, errno ? strerror(errno) : "zlib");
    size_t got = 0;
    int zerr = Z_OK;
    while (got < sizeof h) {
        int r = gzread(f, h + got, (unsigned)(sizeof h - got));
        if (r <= 0) {
            if (r < 0) gzerror(f, &zerr);
            break;
        }
        got += (size_t)r;
    }
    if (zerr == Z_OK && got < sizeof h) gzerror(f, &zerr);
    gzclose(f);
    if (got < 4) {
        if (zerr != Z_OK && zerr != Z_BUF_ERROR)
            return ohm_fail(err, OHM_ERR_PARSE, "%s: corrupt gzip stream before the NIfTI header", path);
        return ohm_fail(err, OHM_ERR_PARSE, "%s: truncated NIfTI header: %zu bytes, expected 348 (NIfTI-1) or 540 (NIfTI-2)",
                        path, got);
    }
    int swap = 0, v2 = 0;
    int64_t sz = nii_i32(h, 0);
    if (sz == 348 || sz == 540) v2 = sz == 540;
    else if (nii_i32(h, 1) == 348 || nii_i32(h, 1) == 540) {
        swap = 1;
        v2 = nii_i32(h, 1) == 540;
    } else
        return ohm_fail(err, OHM_ERR_PARSE,
                        "%s: NIfTI sizeof_hdr is %" PRId64 ", expected 348 (NIfTI-1) or 540 (NIfTI-2) in either byte order",
                        path, sz);
    const size_t hsize = v2 ? 540 : 348;
    const char *ver = v2 ? "NIfTI-2" : "NIfTI-1";
    if (got < hsize)
        return ohm_fail(err, OHM_ERR_PARSE, "%s: truncated %s header: %zu bytes, expected %zu", path, ver, got,
                        hsize);
    char shown[64];
    if (v2 ? memcmp(h + 4, "n+2\0\r\n\032\n", 8) != 0 : memcmp(h + 344, "n+1\0", 4) != 0) {
        show_bytes(shown, sizeof shown, v2 ? h + 4 : h + 344, v2 ? 8 : 4);
        return ohm_fail(err, OHM_ERR_PARSE, "%s: %s magic is '%s', expected '%s' (a single-file .nii)", path, ver,
                        shown, v2 ? "n+2\\x00\\x0d\\x0a\\x1a\\x0a" : "n+1");
    }
    int64_t datatype = nii_i16(h + (v2 ? 12 : 70), swap);
    if (!nifti_type_supported(datatype))
        return ohm_fail(err, OHM_ERR_PARSE,
                        "%s: %s datatype %" PRId64 " (%s) is unsupported, expected uint8 (2), int16 (4), int32 (8), "
                        "float32 (16), float64 (64) or uint16 (512)",
                        path, ver, datatype, nifti_datatype_string((int)datatype));
    int64_t dim[8];
    for (int k = 0; k < 8; ++k) dim[k] = v2 ? nii_i64(h + 16 + 8 * k, swap) : nii_i16(h + 40 + 2 * k, swap);
    if (dim[0] < 1 || dim[0] > 7)
        return ohm_fail(err, OHM_ERR_PARSE, "%s: %s dim[0] (the number of dimensions) is %" PRId64 ", expected 1 to 7",
                        path, ver, dim[0]);
    for (int k = 1; k <= dim[0]; ++k) {
        if (dim[k] < 1)
            return ohm_fail(err, OHM_ERR_PARSE, "%s: %s dim[%d] is %" PRId64 ", expected at least 1", path, ver, k,
                            dim[k]);
        if (k > 3 && dim[k] != 1)
            return ohm_fail(err, OHM_ERR_PARSE,
                            "%s: %s dim[%d] is %" PRId64 ", expected 1 (a single 3-D volume)", path, ver, k, dim[k]);
    }
    int64_t d3[3] = {1, 1, 1};
    for (int k = 1; k <= 3 && k <= dim[0]; ++k) d3[k - 1] = dim[k];
    size_t nvox;
    int rc = ohm_scan_voxel_count(path, d3, &nvox, err);
    if (rc) return rc;
    /* vox_offset: float32 in NIfTI-1, int64 in NIfTI-2; at most 2^40 so that
     * libnifti's conversion to int64 is defined and seeks stay sane. */
    double off = v2 ? (double)nii_i64(h + 168, swap) : nii_f32(h + 108, swap);
    if (!isfinite(off) || off < (double)hsize || off > 1099511627776.0)
        return ohm_fail(err, OHM_ERR_PARSE, "%s: %s vox_offset is %g, expected a finite byte offset of at least %zu",
                        path, ver, off, hsize);
    return nifti_check_scaling(h, v2, swap, path, ver, err);
}

static int read_nifti(ohm_scan *s, const char *path, const ohm_scan_params *p, ohm_error *err)
{
    nifti_set_debug_level(0);
    int prc = nifti_precheck(path, err);
    if (prc) return prc;
    nifti_image *nim = nifti_image_read(path, 0);
    void *data = NULL;
    if (!nim)
        return ohm_fail(err, OHM_ERR_PARSE, "%s: not a readable NIfTI-1/2 file (bad or truncated header)", path);
    int rc = 0;
    if (!nifti_type_supported(nim->datatype)) {
        rc = ohm_fail(err, OHM_ERR_PARSE,
                      "%s: unsupported datatype %d (%s), expected uint8, int16, uint16, int32, float32 or float64",
                      path, nim->datatype, nifti_datatype_string(nim->datatype));
        goto done;
    }
    if (nim->ndim < 1 || nim->ndim > 7) {
        rc = ohm_fail(err, OHM_ERR_PARSE, "%s: dim[0] = %" PRId64 ", expected 1 to 7", path, nim->ndim);
        goto done;
    }
    for (int k = 4; k <= nim->ndim; ++k)
        if (nim->dim[k] > 1) {
            rc = ohm_fail(err, OHM_ERR_PARSE,
                          "%s: dimension %d has %" PRId64 " entries, expected a single 3-D volume", path, k,
                          nim->dim[k]);
            goto done;
        }
    int64_t d[3] = {nim->nx, nim->ny, nim->nz};
    for (int k = nim->ndim; k < 3; ++k) d[k] = 1; /* 1-D / 2-D images */
    size_t nvox;
    rc = ohm_scan_voxel_count(path, d, &nvox, err);
    if (rc) goto done;
    if ((uint64_t)nim->nvox != (uint64_t)nvox) {
        rc = ohm_fail(err, OHM_ERR_PARSE, "%s: header says %" PRId64 " voxels but dims give %zu", path, nim->nvox,
                      nvox);
        goto done;
    }
    double slope = nim->scl_slope, inter = nim->scl_inter;
    if (!isfinite(slope) || !isfinite(inter)) {
        rc = ohm_fail(err, OHM_ERR_PARSE, "%s: scl_slope %g / scl_inter %g not finite", path, slope, inter);
        goto done;
    }
    if (slope == 0) slope = 1;
    nifti_dmat44 m = nim->sform_code > 0 ? nim->sto_xyz : nim->qto_xyz;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c) {
            if (!isfinite(m.m[r][c])) {
                rc = ohm_fail(err, OHM_ERR_PARSE, "%s: %s matrix has a non-finite entry", path,
                              nim->sform_code > 0 ? "sform" : "qform");
                goto done;
            }
            s->index_to_world[r][c] = m.m[r][c];
        }
    /* Only now read the data, ourselves: nifti_image_load silently turns
     * NaN/Inf floats into 0, and ohm wants to report them. */
    rc = load_nifti_data(nim, path, p, nvox, &data, err);
    if (rc) goto done;
    rc = ohm_scan_alloc(s, path, d, err);
    if (rc) goto done;
    const void *src = data;
    for (size_t i = 0; i < nvox; ++i) {
        double v;
        switch (nim->datatype) {
        case NIFTI_TYPE_UINT8: v = ((const uint8_t *)src)[i]; break;
        case NIFTI_TYPE_INT16: v = ((const int16_t *)src)[i]; break;
        case NIFTI_TYPE_UINT16: v = ((const uint16_t *)src)[i]; break;
        case NIFTI_TYPE_INT32: v = ((const int32_t *)src)[i]; break;
        case NIFTI_TYPE_FLOAT32: v = ((const float *)src)[i]; break;
        default: v = ((const double *)src)[i]; break;
        }
        s->values[i] = (float)(v * slope + inter);
    }
done:
    free(data);
    nifti_image_free(nim);
    return rc;
}

/* ------------------------------------------------------------------------ */
/* raw                                                                       */

static int read_raw(ohm_scan *s, const char *path, int gz, const ohm_scan_params *p, ohm_error *err)
{
    if (!p || p->dims[0] <= 0 || p->dims[1] <= 0 || p->dims[2] <= 0)
        return ohm_fail(err, OHM_ERR_USAGE, "%s: a raw volume needs dims=NX,NY,NZ (all at least 1)%s", path,
                        p ? "" : ", none given");
    const char *type = p->type ? p->type : "";
    ohm_sample_type sample;
    if (strcmp(type, "u8") == 0) sample = OHM_SAMPLE_U8;
    else if (strcmp(type, "u16") == 0) sample = OHM_SAMPLE_U16;
    else if (strcmp(type, "i16") == 0) sample = OHM_SAMPLE_I16;
    else if (strcmp(type, "f32") == 0) sample = OHM_SAMPLE_F32;
    else
        return ohm_fail(err, OHM_ERR_USAGE, "%s: raw type '%s', expected type=u8, u16, i16 or f32", path,
                        p->type ? p->type : "(none)");
    size_t bpv = ohm_sample_size(sample);
    int big = 0;
    if (p->endian && strcmp(p->endian, "big") == 0) big = 1;
    else if (p->endian && strcmp(p->endian, "little") != 0)
        return ohm_fail(err, OHM_ERR_USAGE, "%s: endian '%s', expected little or big", path, p->endian);
    double sp[3];
    for (int k = 0; k < 3; ++k) {
        sp[k] = p->spacing[k] == 0 ? 1.0 : p->spacing[k];
        if (!isfinite(sp[k]) || sp[k] < 0)
            return ohm_fail(err, OHM_ERR_USAGE, "%s: spacing %g on axis %d, expected a positive size in mm", path,
                            p->spacing[k], k);
    }
    int64_t d[3] = {p->dims[0], p->dims[1], p->dims[2]};
    size_t n;
    int rc = ohm_scan_voxel_count(path, d, &n, err);
    if (rc) return rc;
    size_t want = n * bpv;
    struct stat st;
    if (stat(path, &st) != 0) return ohm_fail(err, OHM_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    if (!gz) {
        if (S_ISREG(st.st_mode) && (uint64_t)st.st_size != (uint64_t)want)
            return ohm_fail(err, OHM_ERR_PARSE,
                            "%s: %s: %" PRId64 " x %" PRId64 " x %" PRId64 " %s voxels need %zu bytes, the file has %" PRIu64,
                            path, (uint64_t)st.st_size < want ? "truncated" : "too long", d[0], d[1], d[2], type,
                            want, (uint64_t)st.st_size);
    }
    rc = ohm_scan_check_budget(path, p, n, (double)want, S_ISREG(st.st_mode) ? (double)st.st_size : 0, err);
    if (rc) return rc;
    unsigned char *buf = malloc(want);
    if (!buf) return ohm_fail(err, OHM_ERR_NOMEM, "%s: out of memory reading %zu bytes", path, want);
    uint64_t actual = 0;
    rc = ohm_scan_read_bytes(path, gz, 0, buf, want, &actual, err);
    if (!rc && actual != (uint64_t)want)
        rc = ohm_scan_size_error(path, actual, want, d, sample, gz ? "the decompressed data" : "the file", err);
    if (!rc) rc = ohm_scan_alloc(s, path, d, err);
    if (rc) {
        free(buf);
        return rc;
    }
    ohm_scan_convert(s->values, buf, n, sample, big);
    free(buf);
    memset(s->index_to_world, 0, sizeof s->index_to_world);
    for (int k = 0; k < 3; ++k) s->index_to_world[k][k] = sp[k];
    return 0;
}

/* ------------------------------------------------------------------------ */
/* TIFF / PNG stacks: a directory of images, one slice each, sorted by name  */

static int is_slice_name(const char *n)
{
    return n[0] != '.' && (ohm_scan_ends_with(n, ".tif") || ohm_scan_ends_with(n, ".tiff") || ohm_scan_ends_with(n, ".png"));
}

static int cmp_names(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

/* A PNG slice's chunks, walked before the decoder sees it: each must lie
 * within the file, and the last be IEND.  A truncated slice is then one
 * error naming it, and libpng never reaches its end of file (OpenImageIO
 * 2.4's reader leaks the message when libpng longjmps out there). */
static int png_complete(const char *path, ohm_error *err)
{
    FILE *f = fopen(path, "rb");
    if (!f) return ohm_fail(err, OHM_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    struct stat st;
    int64_t size = fstat(fileno(f), &st) == 0 ? (int64_t)st.st_size : 0, at = 8;
    unsigned char b[8];
    int rc = OHM_OK;
    int png = fread(b, 1, 8, f) == 8 && memcmp(b, "\x89PNG\r\n\x1a\n", 8) == 0;
    while (png) { /* (not a PNG at all: the decoder says so) */
        if (at + 8 > size || fseek(f, (long)at, SEEK_SET) != 0 || fread(b, 1, 8, f) != 8) {
            rc = ohm_fail(err, OHM_ERR_PARSE, "%s: cannot read pixels: truncated (the file ends at byte %lld, with no "
                          "IEND chunk)", path, (long long)size);
            break;
        }
        int64_t len = (int64_t)b[0] << 24 | (int64_t)b[1] << 16 | (int64_t)b[2] << 8 | b[3];
        int64_t end = at + 12 + len; /* length, type, data, CRC */
        if (end > size) {
            rc = ohm_fail(err, OHM_ERR_PARSE, "%s: cannot read pixels: truncated (the file ends at byte %lld, inside "
                          "a chunk that runs to byte %lld)", path, (long long)size, (long long)end);
            break;
        }
        if (memcmp(b + 4, "IEND", 4) == 0) break;
        at = end;
    }
    fclose(f);
    return rc;
}

/* The stack's volume, sized from the first slice's header, under the
 * readers' budget: the slices' files against the volume they declare, and
 * beside it one decoded slice (up to 3 channels, then grey). */
static int stack_alloc(ohm_scan *s, const char *path, const ohm_scan_params *p, const char *const *names, size_t n,
                       ohm_error *err)
{
    int w = 0, h = 0, channels = 0;
    int rc = ohm_image_size(names[0], &w, &h, &channels, err);
    if (rc) return rc;
    double stored = 0;
    for (size_t z = 0; z < n; ++z) {
        struct stat st;
        if (stat(names[z], &st) == 0) stored += (double)st.st_size;
    }
    const int64_t d[3] = {w, h, (int64_t)n};
    size_t voxels = 0;
    rc = ohm_scan_voxel_count(path, d, &voxels, err);
    const double slice_bytes = (double)w * (double)h * sizeof(float) * (channels >= 3 ? 4 : 2);
    if (!rc) rc = ohm_scan_check_budget(path, p, voxels, slice_bytes, stored, err);
    if (!rc) rc = ohm_scan_alloc(s, path, d, err);
    return rc;
}

static int read_stack(ohm_scan *s, const char *path, const ohm_scan_params *p, ohm_error *err)
{
    double sp[3];
    for (int k = 0; k < 3; ++k) {
        sp[k] = !p || p->spacing[k] == 0 ? 1.0 : p->spacing[k];
        if (!isfinite(sp[k]) || sp[k] < 0)
            return ohm_fail(err, OHM_ERR_USAGE, "%s: spacing %g on axis %d, expected a positive size in mm", path,
                            sp[k], k);
    }
    DIR *dir = opendir(path);
    if (!dir) return ohm_fail(err, OHM_ERR_IO, "%s: cannot open directory: %s", path, strerror(errno));
    char **names = NULL;
    size_t n = 0, cap = 0;
    int rc = 0;
    struct dirent *de;
    while ((de = readdir(dir)) != NULL) {
        if (!is_slice_name(de->d_name)) continue;
        if (n == cap) {
            size_t nc = cap ? cap * 2 : 64;
            char **q = nc < SIZE_MAX / sizeof *q ? realloc(names, nc * sizeof *q) : NULL;
            if (!q) {
                rc = ohm_fail(err, OHM_ERR_NOMEM, "%s: out of memory listing the directory", path);
                break;
            }
            names = q;
            cap = nc;
        }
        size_t len = strlen(path) + strlen(de->d_name) + 2;
        names[n] = malloc(len);
        if (!names[n]) {
            rc = ohm_fail(err, OHM_ERR_NOMEM, "%s: out of memory listing the directory", path);
            break;
        }
        snprintf(names[n], len, "%s/%s", path, de->d_name);
        n++;
    }
    closedir(dir);
    if (!rc && n == 0)
        rc = ohm_fail(err, OHM_ERR_PARSE,
                      "%s: no DICOM files, DICOMDIR or .tif, .tiff or .png images in the folder, expected a DICOM "
                      "series or an image stack", path);
    if (!rc) qsort(names, n, sizeof *names, cmp_names);
    for (size_t z = 0; z < n && !rc; ++z) /* every PNG slice whole before any is decoded */
        if (ohm_scan_ends_with(names[z], ".png")) rc = png_complete(names[z], err);
    if (!rc) rc = stack_alloc(s, path, p, (const char *const *)names, n, err);
    const int w0 = s->dims[0], h0 = s->dims[1];
    ohm_progress prog;
    ohm_progress_begin(&prog, p ? p->log : NULL, "read: slices");
    for (size_t z = 0; z < n && !rc; ++z) {
        if (p && p->log && ohm_progress_update(&prog, (double)z / (double)n)) {
            rc = ohm_fail_cancelled(err, "read");
            break;
        }
        float *px = NULL;
        int w = 0, h = 0, channels = 0;
        /* each later slice's size from its header before its pixels are
         * decoded (the first's sized the volume) */
        if (z > 0) rc = ohm_image_size(names[z], &w, &h, &channels, err);
        else w = w0, h = h0;
        if (!rc && (w != w0 || h != h0))
            rc = ohm_fail(err, OHM_ERR_PARSE, "%s: slice %zu is %d x %d pixels, expected %d x %d like the first (%s)",
                          names[z], z, w, h, w0, h0, names[0]);
        if (!rc) rc = ohm_image_read_gray(names[z], &px, &w, &h, err);
        if (!rc && (w != w0 || h != h0))
            rc = ohm_fail(err, OHM_ERR_PARSE, "%s: the file changed while it was read", names[z]);
        if (!rc) memcpy(s->values + z * (size_t)w0 * (size_t)h0, px, (size_t)w0 * (size_t)h0 * sizeof(float));
        free(px);
    }
    for (size_t i = 0; i < n; ++i) free(names[i]);
    free(names);
    if (rc) return rc;
    ohm_progress_end(&prog);
    memset(s->index_to_world, 0, sizeof s->index_to_world);
    for (int k = 0; k < 3; ++k) s->index_to_world[k][k] = sp[k];
    return 0;
}

/* ------------------------------------------------------------------------ */

/* The reader for a path: by the file name's ending; a folder is a DICOM
 * series when it holds DICOM files (or a DICOMDIR), else a slice stack; a
 * file named DICOMDIR, or with DICOM's "DICM" mark and no known ending, is
 * DICOM. */
typedef enum scan_format {
    SCAN_UNKNOWN, SCAN_STACK, SCAN_VDB, SCAN_NIFTI, SCAN_RAW, SCAN_RAW_GZ, SCAN_NRRD, SCAN_META, SCAN_INR,
    SCAN_INR_GZ, SCAN_DICOM
} scan_format;

static scan_format format_of(const char *path, const struct stat *st)
{
    static const struct {
        const char *ending;
        scan_format format;
    } endings[] = {{".vdb", SCAN_VDB},       {".nii", SCAN_NIFTI}, {".nii.gz", SCAN_NIFTI}, {".raw", SCAN_RAW},
                   {".raw.gz", SCAN_RAW_GZ}, {".nrrd", SCAN_NRRD}, {".nhdr", SCAN_NRRD},    {".mha", SCAN_META},
                   {".mhd", SCAN_META},      {".inr", SCAN_INR},   {".inr.gz", SCAN_INR_GZ}, {".dcm", SCAN_DICOM}};
    if (S_ISDIR(st->st_mode)) return ohm_dicom_folder_has_dicom(path) ? SCAN_DICOM : SCAN_STACK;
    for (size_t i = 0; i < sizeof endings / sizeof *endings; ++i)
        if (ohm_scan_ends_with(path, endings[i].ending)) return endings[i].format;
    return S_ISREG(st->st_mode) && ohm_dicom_is_file(path) ? SCAN_DICOM : SCAN_UNKNOWN;
}

int ohm_scan_is_volume_path(const char *path)
{
    struct stat st;
    if (!path || stat(path, &st) != 0) return 0;
    return S_ISDIR(st.st_mode) || format_of(path, &st) != SCAN_UNKNOWN; /* a folder is a volume either way */
}

int ohm_scan_read(ohm_scan *out, const char *path, const ohm_scan_params *p, ohm_error *err)
{
    memset(out, 0, sizeof *out);
    out->background = NAN; /* stated by the reader (.vdb), else finish_values' lowest value */
    if (!path) return ohm_fail(err, OHM_ERR_USAGE, "scan read: no file name given");
    struct stat st;
    if (stat(path, &st) != 0) return ohm_fail(err, OHM_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    const scan_format format = format_of(path, &st);
    if (format != SCAN_STACK && format != SCAN_DICOM && !S_ISREG(st.st_mode))
        return ohm_fail(err, OHM_ERR_IO, "%s: not a regular file, expected a scan", path);
    int rc;
    switch (format) {
    case SCAN_STACK: rc = read_stack(out, path, p, err); break;
    case SCAN_VDB: rc = read_vdb(out, path, p, err); break;
    case SCAN_NIFTI: rc = read_nifti(out, path, p, err); break;
    case SCAN_RAW: rc = read_raw(out, path, 0, p, err); break;
    case SCAN_RAW_GZ: rc = read_raw(out, path, 1, p, err); break;
    case SCAN_NRRD: rc = ohm_scan_read_nrrd(out, path, p, err); break;
    case SCAN_META: rc = ohm_scan_read_meta(out, path, p, err); break;
    case SCAN_INR: rc = ohm_scan_read_inr(out, path, 0, p, err); break;
    case SCAN_INR_GZ: rc = ohm_scan_read_inr(out, path, 1, p, err); break;
    case SCAN_DICOM: rc = ohm_scan_read_dicom(out, path, p, err); break;
    default:
        return ohm_fail(err, OHM_ERR_USAGE,
                        "%s: unknown scan format, expected .vdb, .nii, .nii.gz, .nrrd, .nhdr, .mha, .mhd, .inr, "
                        ".inr.gz, .raw, .raw.gz, a DICOM file, a DICOMDIR or a folder of DICOM or .tif/.png slices",
                        path);
    }
    if (!rc) rc = finish_values(out, path, err);
    if (!rc) rc = check_placement(out, path, err);
    if (rc) ohm_scan_free(out);
    return ohm_error_name(err, rc, path);
}

void ohm_scan_free(ohm_scan *s)
{
    if (!s) return;
    free(s->values);
    memset(s, 0, sizeof *s);
}

/* ------------------------------------------------------------------------ */
/* Sampling                                                                  */

/* world -> index: the inverse of the 3x3 part and the offset.  0 if singular. */
static int world_to_index(const ohm_scan *s, const double w[3], double ijk[3])
{
    const double(*m)[4] = s->index_to_world;
    double a = m[0][0], b = m[0][1], c = m[0][2], d = m[1][0], e = m[1][1], f = m[1][2], g = m[2][0],
           h = m[2][1], k = m[2][2];
    double A = e * k - f * h, B = -(d * k - f * g), C = d * h - e * g;
    double det = a * A + b * B + c * C;
    if (det == 0 || !isfinite(det)) return 0;
    double inv[3][3] = {{A / det, -(b * k - c * h) / det, (b * f - c * e) / det},
                        {B / det, (a * k - c * g) / det, -(a * f - c * d) / det},
                        {C / det, -(a * h - b * g) / det, (a * e - b * d) / det}};
    double r[3] = {w[0] - m[0][3], w[1] - m[1][3], w[2] - m[2][3]};
    for (int i = 0; i < 3; ++i) ijk[i] = inv[i][0] * r[0] + inv[i][1] * r[1] + inv[i][2] * r[2];
    return 1;
}

static float voxel(const ohm_scan *s, int32_t i, int32_t j, int32_t k)
{
    return s->values[((size_t)k * (size_t)s->dims[1] + (size_t)j) * (size_t)s->dims[0] + (size_t)i];
}

/* NIfTI-1 stores the sform in float32: a point this far (in voxels) past
 * the outermost centres is still on them. */
#define BOX_SLACK 1e-5

static double sample_index(const ohm_scan *s, const double x[3])
{
    int32_t i0[3];
    double t[3];
    for (int a = 0; a < 3; ++a) {
        double n1 = (double)s->dims[a] - 1;
        if (!(x[a] >= -BOX_SLACK && x[a] <= n1 + BOX_SLACK)) return s->background; /* outside the box */
        double c = x[a] < 0 ? 0 : x[a] > n1 ? n1 : x[a];
        double fl = floor(c);
        if (fl >= n1) fl = n1 > 0 ? n1 - 1 : 0;
        i0[a] = (int32_t)fl;
        t[a] = s->dims[a] > 1 ? c - fl : 0;
    }
    double v = 0;
    for (int corner = 0; corner < 8; ++corner) {
        int32_t q[3];
        double wgt = 1;
        for (int a = 0; a < 3; ++a) {
            int up = (corner >> a) & 1;
            wgt *= up ? t[a] : 1 - t[a];
            q[a] = i0[a] + (up && s->dims[a] > 1 ? 1 : 0);
        }
        if (wgt != 0) v += wgt * voxel(s, q[0], q[1], q[2]);
    }
    return v;
}

double ohm_scan_sample(const ohm_scan *s, const double world[3])
{
    if (!s || !s->values) return 0;
    double x[3];
    if (!world_to_index(s, world, x)) return s->background;
    return sample_index(s, x);
}

double ohm_scan_sample_clamped(const ohm_scan *s, const double world[3])
{
    if (!s || !s->values) return 0;
    double x[3];
    if (!world_to_index(s, world, x)) return s->background;
    for (int a = 0; a < 3; ++a) x[a] = fmin(fmax(x[a], 0.0), (double)s->dims[a] - 1);
    return sample_index(s, x);
}

double ohm_scan_box_distance(const ohm_scan *s, const double world[3])
{
    double x[3], spacing[3];
    if (!s || !s->values || !world_to_index(s, world, x)) return INFINITY;
    ohm_scan_spacing(s, spacing);
    double d = -INFINITY;
    for (int a = 0; a < 3; ++a) {
        /* voxels past the nearer face of axis a, the slack counted inside
         * as sample_index counts it */
        double past = fmax(-x[a], x[a] - ((double)s->dims[a] - 1)) - BOX_SLACK;
        d = fmax(d, past * spacing[a]);
    }
    return d;
}

double ohm_scan_box_mean(const ohm_scan *s, const double lo[3], const double hi[3])
{
    if (!s || !s->values) return 0;
    /* index-space bounding box of the world box's corners */
    double ilo[3] = {INFINITY, INFINITY, INFINITY}, ihi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int c = 0; c < 8; ++c) {
        double w[3] = {c & 1 ? hi[0] : lo[0], c & 2 ? hi[1] : lo[1], c & 4 ? hi[2] : lo[2]}, x[3];
        if (!world_to_index(s, w, x)) return s->background;
        for (int a = 0; a < 3; ++a) {
            if (x[a] < ilo[a]) ilo[a] = x[a];
            if (x[a] > ihi[a]) ihi[a] = x[a];
        }
    }
    int32_t b0[3], b1[3];
    int empty = 0;
    for (int a = 0; a < 3; ++a) {
        double f0 = ceil(ilo[a] - 1e-9), f1 = floor(ihi[a] + 1e-9);
        if (f0 < 0) f0 = 0;
        if (f1 > s->dims[a] - 1) f1 = s->dims[a] - 1;
        if (f0 > f1) empty = 1;
        else {
            b0[a] = (int32_t)f0;
            b1[a] = (int32_t)f1;
        }
    }
    double sum = 0;
    size_t cnt = 0;
    if (!empty) {
        const double(*m)[4] = s->index_to_world;
        const double tol = 1e-9;
        for (int32_t k = b0[2]; k <= b1[2]; ++k)
            for (int32_t j = b0[1]; j <= b1[1]; ++j)
                for (int32_t i = b0[0]; i <= b1[0]; ++i) {
                    int inside = 1;
                    for (int a = 0; a < 3 && inside; ++a) {
                        double w = m[a][0] * i + m[a][1] * j + m[a][2] * k + m[a][3];
                        double slack = tol * (fabs(lo[a]) + fabs(hi[a]) + 1);
                        if (w < lo[a] - slack || w > hi[a] + slack) inside = 0;
                    }
                    if (inside) {
                        sum += voxel(s, i, j, k);
                        cnt++;
                    }
                }
    }
    if (cnt) return sum / (double)cnt;
    double centre[3] = {0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2])};
    return ohm_scan_sample(s, centre);
}

void ohm_scan_bounds(const ohm_scan *s, double lo[3], double hi[3]) { scan_bounds_of(s, lo, hi); }

void ohm_scan_spacing(const ohm_scan *s, double spacing[3])
{
    const double(*m)[4] = s->index_to_world;
    for (int a = 0; a < 3; ++a) spacing[a] = sqrt(m[0][a] * m[0][a] + m[1][a] * m[1][a] + m[2][a] * m[2][a]);
}

double ohm_scan_obliquity(const ohm_scan *s)
{
    double spacing[3], worst = 0;
    ohm_scan_spacing(s, spacing);
    for (int a = 0; a < 3; ++a) {
        double largest = 0; /* the cosine to the nearest world axis */
        for (int r = 0; r < 3; ++r) largest = fmax(largest, fabs(s->index_to_world[r][a]) / spacing[a]);
        worst = fmax(worst, acos(fmin(1.0, largest)) * 180.0 / M_PI);
    }
    return worst;
}

static void scan_bounds_of(const ohm_scan *s, double lo[3], double hi[3])
{
    for (int a = 0; a < 3; ++a) {
        lo[a] = INFINITY;
        hi[a] = -INFINITY;
    }
    if (!s || s->dims[0] <= 0 || s->dims[1] <= 0 || s->dims[2] <= 0) {
        for (int a = 0; a < 3; ++a) lo[a] = hi[a] = 0;
        return;
    }
    const double(*m)[4] = s->index_to_world;
    for (int c = 0; c < 8; ++c) {
        double x[3] = {c & 1 ? s->dims[0] - 1 : 0, c & 2 ? s->dims[1] - 1 : 0, c & 4 ? s->dims[2] - 1 : 0};
        for (int a = 0; a < 3; ++a) {
            double w = m[a][0] * x[0] + m[a][1] * x[1] + m[a][2] * x[2] + m[a][3];
            if (w < lo[a]) lo[a] = w;
            if (w > hi[a]) hi[a] = w;
        }
    }
}
