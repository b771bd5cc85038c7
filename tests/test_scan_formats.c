/* test_scan_formats.c — one volume, written here by independent code as raw,
 * NIfTI-1 (libnifti), NRRD (attached raw, gzip in LPS space, detached
 * big-endian .nhdr), MetaImage (.mha, zlib-compressed .mha, detached .mhd
 * with a header to skip), INRIMAGE-4 (.inr, .inr.gz, big-endian) and DICOM
 * series (written by tests/write_dicom.py with pydicom: files named out of
 * order, RescaleSlope 0.5 and intercept -1024, a DICOMDIR file-set, a
 * folder of two series, signed and unsigned pixels, RLE-compressed), reads
 * in ohm (src/input/scan.h) to identical values and the same world
 * transform: an oblique one (turned 20 degrees about z and 10 about x) for
 * every format that can state one, axis-aligned for INR.  LPS headers
 * (MetaImage; the NRRD that says so) carry the mirrored numbers and must
 * come out in ohm's RAS, as must DICOM's LPS.  Then bad headers and data
 * (DICOM: a missing slice, a duplicated position, a slice of another
 * orientation, a truncated file, two series and none chosen): each a
 * one-line error naming the file or folder. */
#include "check.h"
#include "tmp_files.h" /* zlib.h before cholmod.h, which defines _LARGEFILE64_SOURCE */
#include "run_chain.h"
#include "base/ohm_error.h"
#include "input/scan.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include <nifti2_io.h>

#ifndef OHM_TEST_PYTHON
#define OHM_TEST_PYTHON "/usr/bin/python3"
#endif

#define PI 3.14159265358979323846
enum { NX = 6, NY = 5, NZ = 4, NV = NX * NY * NZ };

static int16_t uniform; /* nonzero: every voxel holds it (test_uniform_extent) */
static int16_t value_at(int v) { return uniform ? uniform : (int16_t)((v * 37) % 211 - 90); }

static unsigned char le[2 * NV], be[2 * NV]; /* the voxels, little- and big-endian */
static double M[3][4];                       /* the index -> world (RAS) map: oblique, unless turned off */
static double SPACING[3] = {0.6, 0.7, 1.3};
static const double ORIGIN[3] = {-12.5, 30.25, 7.0};

static void make_volume(int turned)
{
    for (int v = 0; v < NV; ++v) {
        uint16_t u = (uint16_t)value_at(v);
        le[2 * v] = be[2 * v + 1] = (unsigned char)(u & 0xff);
        le[2 * v + 1] = be[2 * v] = (unsigned char)(u >> 8);
    }
    const double z = turned ? 20 * PI / 180 : 0, x = turned ? 10 * PI / 180 : 0;
    const double cz = cos(z), sz = sin(z), cx = cos(x), sx = sin(x);
    const double rz[3][3] = {{cz, -sz, 0}, {sz, cz, 0}, {0, 0, 1}}, rx[3][3] = {{1, 0, 0}, {0, cx, -sx}, {0, sx, cx}};
    for (int r = 0; r < 3; ++r) {
        for (int a = 0; a < 3; ++a) {
            double d = 0;
            for (int q = 0; q < 3; ++q) d += rz[r][q] * rx[q][a];
            M[r][a] = d * SPACING[a];
        }
        M[r][3] = ORIGIN[r];
    }
}

/* axis a's world vector (M's column), mirrored to LPS when lps. */
static void axis_vector(double out[3], int a, int lps)
{
    for (int r = 0; r < 3; ++r) out[r] = (lps && r < 2 ? -1 : 1) * M[r][a];
}

static const char *write_text_then(const char *name, const char *header, const void *data, size_t len, int gz)
{
    const char *p = write_tmp(name, header, strlen(header));
    if (gz && len > 0) { /* a gzip member appended after the text */
        gzFile f = gzopen(p, "ab");
        if (!f || gzwrite(f, data, (unsigned)len) != (int)len) fprintf(stderr, "cannot append to %s\n", p);
        if (f) gzclose(f);
    } else if (len > 0) {
        FILE *f = fopen(p, "ab");
        if (!f || fwrite(data, 1, len, f) != len) fprintf(stderr, "cannot append to %s\n", p);
        if (f) fclose(f);
    }
    return p;
}

static const char *write_nifti(void)
{
    const char *p = tmp_path("vol.nii");
    int64_t dims[8] = {3, NX, NY, NZ, 1, 1, 1, 1};
    nifti_image *nim = nifti_make_new_nim(dims, NIFTI_TYPE_INT16, 1);
    if (!nim) return p;
    for (int v = 0; v < NV; ++v) ((int16_t *)nim->data)[v] = value_at(v);
    memset(&nim->sto_xyz, 0, sizeof nim->sto_xyz);
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c) nim->sto_xyz.m[r][c] = M[r][c];
    nim->sto_xyz.m[3][3] = 1;
    nim->sto_ijk = nifti_dmat44_inverse(nim->sto_xyz);
    nim->sform_code = NIFTI_XFORM_SCANNER_ANAT;
    nim->dx = nim->pixdim[1] = SPACING[0];
    nim->dy = nim->pixdim[2] = SPACING[1];
    nim->dz = nim->pixdim[3] = SPACING[2];
    if (nifti_set_filenames(nim, p, 0, 1) == 0) nifti_image_write(nim);
    nifti_image_free(nim);
    return p;
}

/* NRRD: space directions and origin in RAS, or mirrored to LPS. */
static const char *write_nrrd(const char *name, int lps, const char *encoding, const char *endian,
                              const char *data_file, const void *data, size_t len, int gz)
{
    char h[2048], dirs[512] = "";
    for (int a = 0; a < 3; ++a) {
        double d[3];
        axis_vector(d, a, lps);
        size_t n = strlen(dirs);
        snprintf(dirs + n, sizeof dirs - n, " (%.17g,%.17g,%.17g)", d[0], d[1], d[2]);
    }
    double o[3] = {(lps ? -1 : 1) * ORIGIN[0], (lps ? -1 : 1) * ORIGIN[1], ORIGIN[2]};
    int n = snprintf(h, sizeof h,
                     "NRRD0004\n# written by test_scan_formats\ntype: short\ndimension: 3\nspace: %s\n"
                     "sizes: %d %d %d\nspace directions:%s\nspace origin: (%.17g,%.17g,%.17g)\nendian: %s\n"
                     "encoding: %s\n",
                     lps ? "left-posterior-superior" : "right-anterior-superior", NX, NY, NZ, dirs, o[0], o[1], o[2],
                     endian, encoding);
    if (data_file) snprintf(h + n, sizeof h - (size_t)n, "data file: %s\n", data_file);
    else snprintf(h + n, sizeof h - (size_t)n, "\n");
    return write_text_then(name, h, data, data_file ? 0 : len, gz);
}

/* MetaImage: always LPS (ITK's world). */
static const char *write_meta(const char *name, const char *extra, const char *data_file, const void *data,
                              size_t len)
{
    char h[2048], tm[512] = "";
    for (int a = 0; a < 3; ++a) {
        double d[3];
        axis_vector(d, a, 1);
        for (int c = 0; c < 3; ++c) {
            size_t n = strlen(tm);
            snprintf(tm + n, sizeof tm - n, " %.17g", d[c] / SPACING[a]);
        }
    }
    snprintf(h, sizeof h,
             "ObjectType = Image\nNDims = 3\nBinaryData = True\nDimSize = %d %d %d\nElementType = MET_SHORT\n"
             "ElementSpacing = %.17g %.17g %.17g\nOffset = %.17g %.17g %.17g\nTransformMatrix =%s\n"
             "AnatomicalOrientation = RAI\n%sElementDataFile = %s\n",
             NX, NY, NZ, SPACING[0], SPACING[1], SPACING[2], -ORIGIN[0], -ORIGIN[1], ORIGIN[2], tm, extra,
             data_file);
    return write_text_then(name, h, data, len, 0);
}

/* INRIMAGE-4: the header padded with newlines to 256 bytes, axis-aligned. */
static const char *write_inr(const char *name, const char *type, const char *cpu, const void *data, size_t len,
                             int gz, int end_header)
{
    char h[257];
    int n = snprintf(h, sizeof h,
                     "#INRIMAGE-4#{\nXDIM=%d\nYDIM=%d\nZDIM=%d\nVDIM=1\nTYPE=%s\nPIXSIZE=16 bits\nSCALE=2**0\n"
                     "CPU=%s\nVX=%g\nVY=%g\nVZ=%g\nXO=%g\nYO=%g\nZO=%g\n#GEOMETRY=CARTESIAN\n",
                     NX, NY, NZ, type, cpu, SPACING[0], SPACING[1], SPACING[2], ORIGIN[0], ORIGIN[1], ORIGIN[2]);
    memset(h + n, '\n', (size_t)(252 - n));
    memcpy(h + 252, end_header ? "##}\n" : "\n\n\n\n", 4);
    h[256] = 0;
    unsigned char *file = malloc(256 + len);
    memcpy(file, h, 256);
    memcpy(file + 256, data, len);
    const char *p = gz ? write_tmp_gz(name, file, 256 + len) : write_tmp(name, file, 256 + len);
    free(file);
    return p;
}

static void expect_volume_with(const char *path, const ohm_scan_params *p, const double (*want)[4], double tol)
{
    ohm_scan s;
    ohm_error e;
    ohm_error_clear(&e);
    int rc = ohm_scan_read(&s, path, p, &e);
    CHECK_MSG(rc == 0, "%s: %s", path, e.msg);
    if (rc) return;
    CHECK_MSG(s.dims[0] == NX && s.dims[1] == NY && s.dims[2] == NZ, "%s: %d x %d x %d", path, s.dims[0], s.dims[1],
              s.dims[2]);
    int same = 1;
    for (int v = 0; v < NV && same; ++v) same = s.values[v] == (float)value_at(v);
    CHECK_MSG(same, "%s: the voxels differ from the raw volume's", path);
    double worst = 0;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c) worst = fmax(worst, fabs(s.index_to_world[r][c] - want[r][c]));
    CHECK_MSG(worst <= tol, "%s: the index-to-world map is off by %.3g mm (tolerance %.1g)", path, worst, tol);
    ohm_scan_free(&s);
}

static void expect_volume(const char *path, const double (*want)[4], double tol)
{
    expect_volume_with(path, NULL, want, tol);
}

/* A DICOM series of the volume (vol.raw) in folder `name`, written by
 * tests/write_dicom.py (pydicom) with the options `extra`. */
static const char *write_dicom(const char *name, const char *extra)
{
    const char *dir = tmp_path(name);
    char matrix[640] = "", cmd[2048];
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c) {
            size_t n = strlen(matrix);
            snprintf(matrix + n, sizeof matrix - n, "%s%.17g", r + c ? "," : "", M[r][c]);
        }
    snprintf(cmd, sizeof cmd, "%s tests/write_dicom.py %s --raw %s/vol.raw --type i16 --dims %d,%d,%d --matrix=%s %s",
             OHM_TEST_PYTHON, dir, tmpdir, NX, NY, NZ, matrix, extra);
    int rc = system(cmd);
    CHECK_MSG(rc == 0, "tests/write_dicom.py failed (status %d): %s", rc, cmd);
    return dir;
}

static void test_dicom(void)
{
    /* DICOM keeps 16 significant digits per number (PS3.5 6.2) */
    const double(*m)[4] = (const double (*)[4])M, tol = 1e-9;
    const char *dicom = write_dicom("dicom", "--slope 0.5 --intercept -1024");
    char other[600];
    snprintf(other, sizeof other, "%s/notes.txt", dicom);
    FILE *f = fopen(other, "w"); /* a file that is not DICOM, as exports have */
    if (f) fputs("not a slice\n", f), fclose(f);
    expect_volume(dicom, m, tol);
    snprintf(other, sizeof other, "%s/IM0001.dcm", dicom); /* one file: its series */
    expect_volume(other, m, tol);
    expect_volume(write_dicom("rle", "--rle --stored i16"), m, tol); /* compressed: through GDCM's decoder */
    const char *set = write_dicom("fileset", "--dicomdir --slope 0.5 --intercept -1024");
    expect_volume(set, m, tol);
    snprintf(other, sizeof other, "%s/DICOMDIR", set);
    expect_volume(other, m, tol);

    /* two series in one folder: series= chooses; signed pixels, no rescale */
    const char *two = write_dicom("two", "--series-uid 1.2.826.0.1.3680043.2.1 --slope 0.5 --intercept -1024 --prefix A");
    write_dicom("two", "--series-uid 1.2.826.0.1.3680043.2.2 --stored i16 --prefix B");
    ohm_scan_params p = {.series = "1.2.826.0.1.3680043.2.2"};
    expect_volume_with(two, &p, m, tol);
    p.series = "1.2.826.0.1.3680043.2.1";
    expect_volume_with(two, &p, m, tol);
}

static void test_same_volume(void)
{
    const char *raw = write_tmp("vol.raw", le, sizeof le), *raw_be = write_tmp("vol_be.raw", be, sizeof be);
    (void)raw_be;
    /* the raw volume: its voxels, axis-aligned at the given spacing */
    ohm_scan r;
    ohm_error e;
    ohm_error_clear(&e);
    ohm_scan_params p = {.dims = {NX, NY, NZ}, .type = "i16", .spacing = {SPACING[0], SPACING[1], SPACING[2]}};
    CHECK_MSG(ohm_scan_read(&r, raw, &p, &e) == 0, "%s", e.msg);
    for (int v = 0; v < NV && r.values; ++v) CHECK(r.values[v] == (float)value_at(v));
    ohm_scan_free(&r);

    expect_volume(write_nifti(), (const double (*)[4])M, 1e-5); /* NIfTI-1 stores the sform in float32 */
    expect_volume(write_nrrd("vol.nrrd", 0, "raw", "little", NULL, le, sizeof le, 0), (const double (*)[4])M, 1e-12);
    expect_volume(write_nrrd("vol_lps.nrrd", 1, "gzip", "little", NULL, le, sizeof le, 1), (const double (*)[4])M,
                  1e-12);
    expect_volume(write_nrrd("vol.nhdr", 1, "raw", "big", "vol_be.raw", NULL, 0, 0), (const double (*)[4])M, 1e-12);
    expect_volume(write_meta("vol.mha", "ElementByteOrderMSB = False\n", "LOCAL", le, sizeof le),
                  (const double (*)[4])M, 1e-12);
    /* zlib-compressed, as ITK writes it */
    unsigned char z[4 * NV + 64];
    uLongf zlen = sizeof z;
    CHECK(compress2(z, &zlen, le, sizeof le, 9) == Z_OK);
    char extra[128];
    snprintf(extra, sizeof extra, "CompressedData = True\nCompressedDataSize = %lu\n", (unsigned long)zlen);
    expect_volume(write_meta("vol_z.mha", extra, "LOCAL", z, zlen), (const double (*)[4])M, 1e-12);
    /* detached big-endian data behind 16 bytes of its own header */
    unsigned char skipped[16 + sizeof be];
    memset(skipped, 0xAB, 16);
    memcpy(skipped + 16, be, sizeof be);
    write_tmp("vol_hdr16.raw", skipped, sizeof skipped);
    expect_volume(write_meta("vol.mhd", "ElementByteOrderMSB = True\nHeaderSize = 16\n", "vol_hdr16.raw", NULL, 0),
                  (const double (*)[4])M, 1e-12);
    /* INR: axis-aligned, with its origin */
    double aligned[3][4] = {{SPACING[0], 0, 0, ORIGIN[0]}, {0, SPACING[1], 0, ORIGIN[1]}, {0, 0, SPACING[2], ORIGIN[2]}};
    expect_volume(write_inr("vol.inr", "signed fixed", "decm", le, sizeof le, 0, 1), (const double (*)[4])aligned,
                  1e-12);
    expect_volume(write_inr("vol.inr.gz", "signed fixed", "pc", le, sizeof le, 1, 1), (const double (*)[4])aligned,
                  1e-12);
    expect_volume(write_inr("vol_be.inr", "signed fixed", "sun", be, sizeof be, 0, 1), (const double (*)[4])aligned,
                  1e-12);

    /* the obliquity the log reports: axis y is turned acos(cos 20 cos 10) */
    ohm_scan s;
    if (ohm_scan_read(&s, tmp_path("vol.nrrd"), NULL, &e) == 0) {
        double want = acos(cos(20 * PI / 180) * cos(10 * PI / 180)) * 180 / PI;
        CHECK_MSG(fabs(ohm_scan_obliquity(&s) - want) < 1e-9, "obliquity %.12g, expected %.12g",
                  ohm_scan_obliquity(&s), want);
        double sp[3];
        ohm_scan_spacing(&s, sp);
        for (int a = 0; a < 3; ++a) CHECK(fabs(sp[a] - SPACING[a]) < 1e-12);
        ohm_scan_free(&s);
    }
    if (ohm_scan_read(&s, tmp_path("vol.inr"), NULL, &e) == 0) {
        CHECK(ohm_scan_obliquity(&s) == 0);
        ohm_scan_free(&s);
    }
}

/* path must fail with `code`, a one-line message naming it and saying why. */
static void expect_error(const char *path, int code, const char *why)
{
    ohm_scan s;
    ohm_error e;
    ohm_error_clear(&e);
    int rc = ohm_scan_read(&s, path, NULL, &e);
    CHECK_MSG(rc == code, "%s: returned %d, expected %d (%s)", path, rc, code, e.msg);
    CHECK_MSG(strstr(e.msg, path) && !strchr(e.msg, '\n'), "%s: the message does not name it on one line: %s", path,
              e.msg);
    CHECK_MSG(strstr(e.msg, why), "%s: the message does not say '%s': %s", path, why, e.msg);
    CHECK(s.values == NULL);
}

static void test_bad_dicom(void)
{
    expect_error(write_dicom("gap", "--case missing --stored i16"), OHM_ERR_PARSE, "missing slice");
    expect_error(write_dicom("twice", "--case duplicate --stored i16"), OHM_ERR_PARSE, "duplicated slice");
    expect_error(write_dicom("tilted", "--case tilted --stored i16"), OHM_ERR_PARSE, "one orientation");
    expect_error(write_dicom("cut", "--case truncated --stored i16"), OHM_ERR_PARSE, "truncated");
    const char *two = tmp_path("two");
    expect_error(two, OHM_ERR_USAGE, "choose one with series=");
    ohm_scan s;
    ohm_error e;
    ohm_error_clear(&e);
    ohm_scan_params p = {.series = "1.2.3"};
    CHECK(ohm_scan_read(&s, two, &p, &e) == OHM_ERR_USAGE && strstr(e.msg, "no series 1.2.3"));
}

/* A gzip stream far longer than the header says, cut off half way: a reader
 * that stops one byte past the expected size reports "too long"; one that
 * inflates the whole stream (a decompression bomb's cost) meets the cut and
 * reports something else. */
static const char *write_gz_bomb(const char *name, const char *header, size_t header_len)
{
    enum { BOMB = 4 << 20 };
    unsigned char *zeros = calloc(BOMB, 1), *z = malloc(BOMB);
    uLongf zlen = BOMB;
    const char *p = tmp_path(name);
    z_stream s;
    memset(&s, 0, sizeof s);
    if (zeros && z && deflateInit2(&s, 9, Z_DEFLATED, 15 + 16, 9, Z_DEFAULT_STRATEGY) == Z_OK) {
        unsigned char *whole = malloc(header_len + BOMB);
        if (whole) {
            memcpy(whole, header, header_len);
            memset(whole + header_len, 0, BOMB);
            s.next_in = whole;
            s.avail_in = (uInt)(header_len + BOMB);
            s.next_out = z;
            s.avail_out = (uInt)zlen;
            deflate(&s, Z_FINISH);
            zlen = zlen - s.avail_out;
            free(whole);
        }
        deflateEnd(&s);
        write_tmp(name, z, zlen / 2);
    }
    free(zeros);
    free(z);
    return p;
}

/* vol.nii with `len` bytes at `offset` of its header replaced (and the sform
 * switched off when no_sform), as name. */
static const char *patch_nifti(const char *name, size_t offset, const void *bytes, size_t len, int no_sform)
{
    const char *p = tmp_path(name);
    FILE *in = fopen(tmp_path("vol.nii"), "rb");
    unsigned char buf[4096];
    size_t n = in ? fread(buf, 1, sizeof buf, in) : 0;
    if (in) fclose(in);
    if (n < 352) return p;
    memcpy(buf + offset, bytes, len);
    if (no_sform) memset(buf + 252, 0, 4); /* qform_code and sform_code: the voxel size places the voxels */
    write_tmp(name, buf, n);
    return p;
}

static void test_bad_input(void)
{
    /* what libnifti2 would repair without a word: refused, naming the field */
    const float nan_value = NAN, zero = 0;
    expect_error(patch_nifti("nan_slope.nii", 112, &nan_value, 4, 0), OHM_ERR_PARSE, "scl_slope nan");
    expect_error(patch_nifti("zero_voxel.nii", 80, &zero, 4, 1), OHM_ERR_PARSE,
                 "pixdim[1] (the voxel size along axis 0) is 0");
    expect_error(patch_nifti("nan_voxel.nii", 84, &nan_value, 4, 1), OHM_ERR_PARSE, "pixdim[2]");
    /* with an sform, pixdim places nothing: a zero there is harmless */
    expect_volume(patch_nifti("zero_voxel_sform.nii", 80, &zero, 4, 0), (const double (*)[4])M, 1e-5);
    /* decompression bombs: 4 MB of zeros behind a header that wants 64 bytes */
    static const char inr_head[] = "#INRIMAGE-4#{\nXDIM=4\nYDIM=4\nZDIM=4\nVDIM=1\nTYPE=unsigned fixed\nPIXSIZE=8 bits\n"
                                   "CPU=decm\n";
    char inr[256];
    memset(inr, '\n', sizeof inr);
    memcpy(inr, inr_head, strlen(inr_head));
    memcpy(inr + 252, "##}\n", 4);
    expect_error(write_gz_bomb("bomb.inr.gz", inr, sizeof inr), OHM_ERR_PARSE, "too long");
    {
        const char *raw = write_gz_bomb("bomb.raw.gz", "", 0);
        ohm_scan s;
        ohm_error e;
        ohm_error_clear(&e);
        ohm_scan_params p = {.dims = {4, 4, 4}, .type = "u8"};
        CHECK_MSG(ohm_scan_read(&s, raw, &p, &e) == OHM_ERR_PARSE && strstr(e.msg, "too long"), "raw.gz bomb: %s",
                  e.msg);
    }
    {
        /* an honest bomb (the corpus's: 57.6e6 zeros from 55 KB) is refused
         * by the budget, and read when max_expansion= lets it through */
        ohm_scan s;
        ohm_error e;
        ohm_error_clear(&e);
        ohm_scan_params p = {.dims = {480, 400, 300}, .type = "u8"};
        const char *bomb = "tests/data/corpus/bomb-honest.raw.gz";
        CHECK_MSG(ohm_scan_read(&s, bomb, &p, &e) == OHM_ERR_PARSE && strstr(e.msg, "decompression bomb") &&
                      strstr(e.msg, "max_expansion=1039"),
                  "honest raw.gz bomb: %s", e.msg);
        p.max_expansion = 1039;
        int rc = ohm_scan_read(&s, bomb, &p, &e);
        CHECK_MSG(rc == 0 && s.dims[0] == 480 && s.dims[2] == 300 && s.values[480 * 400 * 300 - 1] == 0,
                  "the same with max_expansion=1039: %s", rc ? e.msg : "wrong volume");
        if (!rc) ohm_scan_free(&s);
    }
    expect_error(write_nrrd("missing.nhdr", 0, "raw", "little", "no_such.raw", NULL, 0, 0), OHM_ERR_PARSE,
                 "couldn't open");
    expect_error(write_inr("complex.inr", "complex", "decm", le, sizeof le, 0, 1), OHM_ERR_PARSE, "TYPE=complex");
    expect_error(write_inr("short.inr", "signed fixed", "decm", le, sizeof le - 7, 0, 1), OHM_ERR_PARSE,
                 "truncated");
    expect_error(write_inr("open.inr", "signed fixed", "decm", le, sizeof le, 0, 0), OHM_ERR_PARSE,
                 "does not end");
    expect_error(write_inr("cpu.inr", "signed fixed", "vax", le, sizeof le, 0, 1), OHM_ERR_PARSE, "CPU=vax");
    expect_error(write_meta("short.mha", "", "LOCAL", le, sizeof le - 1), OHM_ERR_PARSE, "truncated");
    expect_error(write_meta("gone.mhd", "", "no_such.raw", NULL, 0), OHM_ERR_IO, "cannot open its data file");
    expect_error(write_meta("list.mhd", "", "LIST", NULL, 0), OHM_ERR_PARSE, "list of slice files");
    unsigned char junk[64];
    memset(junk, 0x5a, sizeof junk);
    expect_error(write_meta("junk_z.mha", "CompressedData = True\n", "LOCAL", junk, sizeof junk), OHM_ERR_PARSE,
                 "corrupt compressed data");
    expect_error(write_text_then("nodata.mha", "ObjectType = Image\nNDims = 3\nDimSize = 2 2 2\n", NULL, 0, 0),
                 OHM_ERR_PARSE, "no ElementDataFile");
    expect_error(write_text_then("ndims.mha", "NDims = 4\nElementDataFile = LOCAL\n", NULL, 0, 0), OHM_ERR_PARSE,
                 "2 or 3");
    static const unsigned char zeros[16] = {0};
    expect_error(write_text_then("four.nrrd", "NRRD0004\ntype: short\ndimension: 4\nsizes: 1 2 2 2\nendian: little\n"
                                              "encoding: raw\n\n", zeros, sizeof zeros, 0),
                 OHM_ERR_PARSE, "4 axes");
    expect_error(write_text_then("huge.nrrd", "NRRD0004\ntype: short\ndimension: 3\nsizes: 100000 100000 100000\n"
                                              "endian: little\nencoding: raw\n\n", zeros, sizeof zeros, 0),
                 OHM_ERR_PARSE, "more than the limit");
    /* a gigabyte declared, 16 bytes there: refused before Teem allocates it */
    expect_error(write_text_then("bomb.nrrd", "NRRD0004\ntype: short\ndimension: 3\nsizes: 1000 1000 500\n"
                                              "endian: little\nencoding: gzip\n\n", zeros, sizeof zeros, 0),
                 OHM_ERR_PARSE, "truncated");
    expect_error(write_text_then("magic.nrrd", "NRRD000-pi\n", NULL, 0, 0), OHM_ERR_PARSE, "not a NRRD file");
}

/* Slices of the volume (8-bit: every voxel's value must fit) as .tif or .png
 * files in folder `name`, written by Pillow. */
static const char *write_slices(const char *name, const char *ext)
{
    const char *dir = tmp_path(name);
    char cmd[1024];
    snprintf(cmd, sizeof cmd,
             "%s -c \"import os, sys; from PIL import Image; os.makedirs(sys.argv[1]); "
             "[Image.new('L', (%d, %d), %d).save('%%s/s%%02d.%%s' %% (sys.argv[1], z, sys.argv[2])) "
             "for z in range(%d)]\" %s %s",
             OHM_TEST_PYTHON, NX, NY, (int)uniform, NZ, dir, ext);
    int rc = system(cmd);
    CHECK_MSG(rc == 0, "writing slices failed (status %d): %s", rc, cmd);
    return dir;
}

/* A scan's object ends where the scan ends (docs/scans.md, scan.h): a uniform
 * volume in every format, axis-aligned at 0.5 mm, is exactly the cells of
 * 0.5 mm between its outermost voxel centres, (NX-1)(NY-1)(NZ-1), at any
 * threshold up to its value (the grid's margin used to fill with it too). */
static void test_uniform_extent(void)
{
    uniform = 200;
    for (int a = 0; a < 3; ++a) SPACING[a] = 0.5;
    make_volume(0);
    const char *raw = write_tmp("vol.raw", le, sizeof le); /* the DICOM writer's source too */
    const char *const path[] = {
        raw,
        write_nifti(),
        write_nrrd("u.nrrd", 0, "raw", "little", NULL, le, sizeof le, 0),
        write_meta("u.mha", "ElementByteOrderMSB = False\n", "LOCAL", le, sizeof le),
        write_inr("u.inr.gz", "signed fixed", "pc", le, sizeof le, 1, 1),
        write_dicom("u_dicom", "--slope 0.5 --intercept -1024"),
        write_slices("u_tif", "tif"),
        write_slices("u_png", "png"),
    };
    /* DICOM's rescale: every stored 200 reads as 0.5 * 200 - 1024 */
    const double value[] = {200, 200, 200, 200, 200, -924, 200, 200};
    const long long box = (NX - 1LL) * (NY - 1) * (NZ - 1);
    for (size_t f = 0; f < sizeof path / sizeof *path; ++f)
        for (int t = 0; t < 3; ++t) {
            const double threshold = t == 0 ? value[f] : t == 1 ? value[f] - 1 : -1e6;
            char lines[1024];
            snprintf(lines, sizeof lines, "read file=%s%s\nvoxelize voxel=0.5 threshold=%.17g\n", path[f],
                     f == 0 ? " dims=6,5,4 type=i16 spacing=0.5" : f >= 6 ? " spacing=0.5" : "", threshold);
            long long cells = object_cells(lines);
            CHECK_MSG(cells == box, "%s, uniform %g, threshold %g: %lld cells, expected its box's %lld", path[f],
                      value[f], threshold, cells, box);
        }
}

int main(void)
{
    if (tmp_begin("ohm_test_scan_formats")) return 1;
    nifti_set_debug_level(0);
    make_volume(1);
    test_same_volume();
    test_dicom();
    test_bad_input();
    test_bad_dicom();
    test_uniform_extent(); /* last: it rewrites the volume */
    cleanup_tmp();
    return check_summary();
}
