/* test_scan.c — the density-volume readers (src/input/scan.h): NIfTI (.nii and
 * .nii.gz, written here with libnifti, non-identity sform, scl_slope/inter)
 * against the same data as raw (.raw and .raw.gz); one-line errors naming the
 * file for truncated / wrongly-sized raw, unsupported NIfTI datatypes and NaN
 * voxels; .vdb densify and the missing-grid message; trilinear sampling,
 * box means, bounds; PNG stacks (a directory, sorted by name); and the
 * walnut / head samples in samples/. */
#include "check.h"
#include "tmp_files.h"
#include "base/ohm_error.h"
#include "ohm_vdb.h"
#include "input/scan.h"
#include "input/scan_check.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <nifti2_io.h>

#define PI 3.14159265358979323846
#define NX 5
#define NY 4
#define NZ 3

/* ---- the test volume ------------------------------------------------------ */

static int16_t raw_value(int i, int j, int k)
{
    return (int16_t)(i * 7 + j * 13 + k * 29 - 50 + (i * j * k) % 5);
}

/* sform: rotation by 30 degrees about z, spacing (1.5, 2, 2.5), offset. */
static void test_sform(double m[3][4])
{
    const double c = cos(PI / 6), s = sin(PI / 6), sp[3] = {1.5, 2.0, 2.5};
    const double r[3][3] = {{c, -s, 0}, {s, c, 0}, {0, 0, 1}};
    const double t[3] = {10.0, -20.0, 30.0};
    for (int a = 0; a < 3; ++a) {
        for (int b = 0; b < 3; ++b) m[a][b] = r[a][b] * sp[b];
        m[a][3] = t[a];
    }
}

/* Writes a NIfTI-1 file with libnifti; data (nx*ny*nz of `datatype`) copied. */
static const char *write_nifti(const char *name, int datatype, const void *data, int nx, int ny, int nz,
                               double slope, double inter)
{
    const char *p = tmp_path(name);
    int64_t dims[8] = {3, nx, ny, nz, 1, 1, 1, 1};
    nifti_image *nim = nifti_make_new_nim(dims, datatype, 1);
    if (!nim) {
        fprintf(stderr, "nifti_make_new_nim failed\n");
        return p;
    }
    memcpy(nim->data, data, (size_t)nim->nvox * (size_t)nim->nbyper);
    double m[3][4];
    test_sform(m);
    memset(&nim->sto_xyz, 0, sizeof nim->sto_xyz);
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 4; ++b) nim->sto_xyz.m[a][b] = m[a][b];
    nim->sto_xyz.m[3][3] = 1;
    nim->sto_ijk = nifti_dmat44_inverse(nim->sto_xyz);
    nim->sform_code = NIFTI_XFORM_ALIGNED_ANAT;
    /* a different (identity-rotation) qform, which the sform must win over */
    nim->qform_code = NIFTI_XFORM_SCANNER_ANAT;
    nim->dx = nim->pixdim[1] = 1.5;
    nim->dy = nim->pixdim[2] = 2.0;
    nim->dz = nim->pixdim[3] = 2.5;
    nim->scl_slope = slope;
    nim->scl_inter = inter;
    if (nifti_set_filenames(nim, p, 0, 1) != 0) fprintf(stderr, "nifti_set_filenames %s failed\n", p);
    nifti_image_write(nim);
    nifti_image_free(nim);
    return p;
}

static int one_line_naming(const ohm_error *e, const char *path)
{
    return strstr(e->msg, path) != NULL && strchr(e->msg, '\n') == NULL;
}

static void print_err(const char *what, const ohm_error *e)
{
    printf("  %s -> %s\n", what, e->msg);
}

/* ---- tests ------------------------------------------------------------------ */

static int16_t vol[NZ][NY][NX];

static void test_nifti_vs_raw(void)
{
    for (int k = 0; k < NZ; ++k)
        for (int j = 0; j < NY; ++j)
            for (int i = 0; i < NX; ++i) vol[k][j][i] = raw_value(i, j, k);
    const char *nii = write_nifti("v.nii", NIFTI_TYPE_INT16, vol, NX, NY, NZ, 2.0, 5.0);
    const char *niigz = write_nifti("v.nii.gz", NIFTI_TYPE_INT16, vol, NX, NY, NZ, 2.0, 5.0);
    /* little-endian bytes for the raw file, whatever the host */
    unsigned char bytes[NX * NY * NZ * 2];
    for (int n = 0; n < NX * NY * NZ; ++n) {
        uint16_t u = (uint16_t)(&vol[0][0][0])[n];
        bytes[2 * n] = (unsigned char)(u & 0xff);
        bytes[2 * n + 1] = (unsigned char)(u >> 8);
    }
    const char *raw = write_tmp("v.raw", bytes, sizeof bytes);
    const char *rawgz = write_tmp_gz("v.raw.gz", bytes, sizeof bytes);

    ohm_scan_params rp;
    memset(&rp, 0, sizeof rp);
    rp.dims[0] = NX;
    rp.dims[1] = NY;
    rp.dims[2] = NZ;
    rp.type = "i16";
    ohm_scan a, b, c, d;
    ohm_error e = {0, ""};
    int rc = ohm_scan_read(&a, nii, NULL, &e);
    CHECK_MSG(rc == 0, "%s", e.msg);
    rc = ohm_scan_read(&b, niigz, NULL, &e);
    CHECK_MSG(rc == 0, "%s", e.msg);
    rc = ohm_scan_read(&c, raw, &rp, &e);
    CHECK_MSG(rc == 0, "%s", e.msg);
    rc = ohm_scan_read(&d, rawgz, &rp, &e);
    CHECK_MSG(rc == 0, "%s", e.msg);
    if (!a.values || !b.values || !c.values || !d.values) goto out;
    CHECK(a.dims[0] == NX && a.dims[1] == NY && a.dims[2] == NZ);
    CHECK(c.dims[0] == NX && c.dims[1] == NY && c.dims[2] == NZ);
    int same = 1;
    for (int n = 0; n < NX * NY * NZ; ++n) {
        if (a.values[n] != c.values[n] * 2 + 5) same = 0;
        if (b.values[n] != a.values[n]) same = 0;
        if (d.values[n] != c.values[n]) same = 0;
        if (c.values[n] != (&vol[0][0][0])[n]) same = 0;
    }
    CHECK_MSG(same, "nifti values != raw*2+5");
    CHECK(c.min == -50 && a.min == -95);
    /* world placement: expected from the sform, computed here */
    double m[3][4];
    test_sform(m);
    const int pts[4][3] = {{0, 0, 0}, {4, 3, 2}, {2, 1, 1}, {4, 0, 2}};
    for (int q = 0; q < 4; ++q) {
        double want[3], got[3];
        for (int r = 0; r < 3; ++r) {
            want[r] = m[r][0] * pts[q][0] + m[r][1] * pts[q][1] + m[r][2] * pts[q][2] + m[r][3];
            got[r] = a.index_to_world[r][0] * pts[q][0] + a.index_to_world[r][1] * pts[q][1] +
                     a.index_to_world[r][2] * pts[q][2] + a.index_to_world[r][3];
        }
        for (int r = 0; r < 3; ++r)
            CHECK_MSG(fabs(got[r] - want[r]) < 1e-4, "voxel (%d,%d,%d) axis %d: %g vs %g", pts[q][0], pts[q][1],
                      pts[q][2], r, got[r], want[r]);
        /* sampling at the voxel centre returns the voxel */
        double v = ohm_scan_sample(&a, want);
        double expect = raw_value(pts[q][0], pts[q][1], pts[q][2]) * 2.0 + 5.0;
        CHECK_MSG(fabs(v - expect) < 1e-3, "sample at voxel (%d,%d,%d) = %g, expected %g", pts[q][0], pts[q][1],
                  pts[q][2], v, expect);
    }
    /* linear between centres (in the rotated grid): a quarter of the way
     * from (1,2,1) to (2,2,1), and the centre of a cell */
    {
        double x[3] = {1.25, 2, 1}, w[3];
        for (int r = 0; r < 3; ++r) w[r] = m[r][0] * x[0] + m[r][1] * x[1] + m[r][2] * x[2] + m[r][3];
        double v0 = raw_value(1, 2, 1) * 2.0 + 5, v1 = raw_value(2, 2, 1) * 2.0 + 5;
        double v = ohm_scan_sample(&a, w);
        CHECK_MSG(fabs(v - (0.75 * v0 + 0.25 * v1)) < 1e-3, "sample %g, expected %g", v, 0.75 * v0 + 0.25 * v1);
        double y[3] = {2.5, 1.5, 0.5}, mean = 0;
        for (int r = 0; r < 3; ++r) w[r] = m[r][0] * y[0] + m[r][1] * y[1] + m[r][2] * y[2] + m[r][3];
        for (int cc = 0; cc < 8; ++cc) mean += raw_value(2 + (cc & 1), 1 + (cc >> 1 & 1), cc >> 2 & 1) * 2.0 + 5;
        mean /= 8;
        v = ohm_scan_sample(&a, w);
        CHECK_MSG(fabs(v - mean) < 1e-3, "cell centre %g, expected %g", v, mean);
        /* outside: the scan's background, its lowest value (here 5, the
         * smallest raw value 0 scaled by 2 and offset by 5) */
        double far[3] = {1e4, 0, 0};
        CHECK_MSG(ohm_scan_sample(&a, far) == a.min, "outside %g, the scan's minimum %g", ohm_scan_sample(&a, far),
                  a.min);
    }
    /* box mean on the axis-aligned raw scan (spacing 1 mm, origin 0): the box
     * around voxels (1..2, 1..2, 0..1) holds exactly those 8 centres */
    {
        double lo[3] = {0.9, 0.9, -0.1}, hi[3] = {2.1, 2.1, 1.1}, mean = 0;
        for (int cc = 0; cc < 8; ++cc) mean += raw_value(1 + (cc & 1), 1 + (cc >> 1 & 1), cc >> 2 & 1);
        mean /= 8;
        double v = ohm_scan_box_mean(&c, lo, hi);
        CHECK_MSG(fabs(v - mean) < 1e-4, "box mean %g, expected %g", v, mean);
        /* a box holding no centre: the trilinear value at its centre */
        double lo2[3] = {1.2, 1.2, 0.2}, hi2[3] = {1.4, 1.4, 0.4}, ctr[3] = {1.3, 1.3, 0.3};
        CHECK(fabs(ohm_scan_box_mean(&c, lo2, hi2) - ohm_scan_sample(&c, ctr)) < 1e-9);
        double blo[3], bhi[3];
        ohm_scan_bounds(&c, blo, bhi);
        CHECK(blo[0] == 0 && blo[1] == 0 && blo[2] == 0 && bhi[0] == NX - 1 && bhi[1] == NY - 1 &&
              bhi[2] == NZ - 1);
        /* bounds of the rotated scan contain every voxel centre */
        ohm_scan_bounds(&a, blo, bhi);
        double w[3] = {m[0][0] * 4 + m[0][3], m[1][0] * 4 + m[1][3], m[2][3]};
        CHECK(w[0] <= bhi[0] + 1e-4 && w[1] <= bhi[1] + 1e-4 && w[2] >= blo[2] - 1e-4);
        CHECK(fabs(bhi[2] - blo[2] - 2.5 * (NZ - 1)) < 1e-4);
    }
    /* wrong dims: one slice too many -> the file is too short */
    {
        rp.dims[2] = NZ + 1;
        ohm_scan z;
        rc = ohm_scan_read(&z, raw, &rp, &e);
        CHECK(rc == OHM_ERR_PARSE && one_line_naming(&e, raw) && strstr(e.msg, "160") && strstr(e.msg, "120"));
        print_err("wrong dims", &e);
        rc = ohm_scan_read(&z, rawgz, &rp, &e);
        CHECK(rc == OHM_ERR_PARSE && one_line_naming(&e, rawgz) && strstr(e.msg, "160") && strstr(e.msg, "120"));
        print_err("wrong dims .gz", &e);
        rp.dims[2] = NZ - 1; /* too long */
        rc = ohm_scan_read(&z, rawgz, &rp, &e);
        CHECK(rc == OHM_ERR_PARSE && one_line_naming(&e, rawgz) && strstr(e.msg, "too long"));
        print_err("too long .gz", &e);
        rp.dims[2] = 0;
        rc = ohm_scan_read(&z, raw, &rp, &e);
        CHECK(rc == OHM_ERR_USAGE && one_line_naming(&e, raw));
        print_err("dims 0", &e);
        rp.dims[2] = NZ;
        CHECK(z.values == NULL);
    }
    /* truncated raw */
    {
        const char *tr = write_tmp("trunc.raw", bytes, sizeof bytes - 1);
        ohm_scan z;
        rc = ohm_scan_read(&z, tr, &rp, &e);
        CHECK(rc == OHM_ERR_PARSE && one_line_naming(&e, tr) && strstr(e.msg, "truncated") &&
              strstr(e.msg, "120") && strstr(e.msg, "119"));
        print_err("truncated", &e);
    }
out:
    ohm_scan_free(&a);
    ohm_scan_free(&b);
    ohm_scan_free(&c);
    ohm_scan_free(&d);
}

static void test_nifti_errors(void)
{
    ohm_scan z;
    ohm_error e = {0, ""};
    float cplx[2 * 8];
    for (int n = 0; n < 16; ++n) cplx[n] = (float)n;
    const char *cp = write_nifti("complex.nii", NIFTI_TYPE_COMPLEX64, cplx, 2, 2, 2, 0, 0);
    int rc = ohm_scan_read(&z, cp, NULL, &e);
    CHECK(rc == OHM_ERR_PARSE && one_line_naming(&e, cp) && strstr(e.msg, "datatype 32") &&
          strstr(e.msg, "COMPLEX64") && strstr(e.msg, "unsupported"));
    print_err("complex64", &e);

    float f[NX * NY * NZ];
    for (int n = 0; n < NX * NY * NZ; ++n) f[n] = (float)n * 0.5f;
    f[(1 * NY + 2) * NX + 3] = NAN; /* voxel (3, 2, 1) */
    const char *nanp = write_nifti("nan.nii.gz", NIFTI_TYPE_FLOAT32, f, NX, NY, NZ, 1, 0);
    rc = ohm_scan_read(&z, nanp, NULL, &e);
    CHECK(rc == OHM_ERR_PARSE && one_line_naming(&e, nanp) && strstr(e.msg, "(3, 2, 1)") && strstr(e.msg, "NaN"));
    print_err("NaN", &e);
    CHECK(z.values == NULL);

    /* a NIfTI whose voxel data is cut short */
    {
        int16_t small[NX * NY * NZ];
        for (int n = 0; n < NX * NY * NZ; ++n) small[n] = (int16_t)n;
        const char *full = write_nifti("full.nii", NIFTI_TYPE_INT16, small, NX, NY, NZ, 1, 0);
        FILE *fi = fopen(full, "rb");
        unsigned char buf[4096];
        size_t n = fi ? fread(buf, 1, sizeof buf, fi) : 0;
        if (fi) fclose(fi);
        const char *cut = write_tmp("cut.nii", buf, n > 10 ? n - 10 : 0);
        rc = ohm_scan_read(&z, cut, NULL, &e);
        CHECK(rc == OHM_ERR_PARSE && one_line_naming(&e, cut) && strstr(e.msg, "truncated"));
        print_err("truncated nifti", &e);
    }

    const char *junk = write_tmp("junk.nii", "not a nifti file at all", 23);
    rc = ohm_scan_read(&z, junk, NULL, &e);
    CHECK(rc != 0 && one_line_naming(&e, junk));
    print_err("junk", &e);

    const char *unk = write_tmp("v.xyz", "x", 1);
    rc = ohm_scan_read(&z, unk, NULL, &e);
    CHECK(rc == OHM_ERR_USAGE && one_line_naming(&e, unk));
    print_err("unknown extension", &e);
}

static void test_vdb(void)
{
    ohm_error e = {0, ""};
    const double origin[3] = {1, 2, 3};
    ohm_vdb_grid *g = NULL;
    if (ohm_vdb_grid_create(&g, "density", OHM_VDB_CLASS_FOG_VOLUME, 0.0f, 0.5, origin, &e) != 0) {
        CHECK_MSG(0, "%s", e.msg);
        return;
    }
    int32_t ijk[3 * 3] = {2, 3, 4, 3, 3, 4, 2, 5, 6};
    float vals[3] = {1.0f, 2.0f, 3.0f};
    CHECK(ohm_vdb_grid_set_values(g, ijk, vals, 3, &e) == 0);
    const char *p = tmp_path("d.vdb");
    CHECK(ohm_vdb_write(p, &g, 1, &e) == 0);
    ohm_vdb_grid_free(g);
    ohm_scan s;
    int rc = ohm_scan_read(&s, p, NULL, &e);
    CHECK_MSG(rc == 0, "%s", e.msg);
    if (rc == 0) {
        CHECK(s.dims[0] == 2 && s.dims[1] == 3 && s.dims[2] == 3);
        CHECK(s.values[0] == 1.0f && s.values[1] == 2.0f && s.values[2 * 6 + 2 * 2 + 0] == 3.0f &&
              s.values[2] == 0.0f);
        CHECK(s.min == 0 && s.max == 3);
        /* voxel (2,3,4) sits at origin + 0.5 * (2,3,4) */
        double w[3] = {2.0, 3.5, 5.0};
        CHECK(fabs(ohm_scan_sample(&s, w) - 1.0) < 1e-6);
        CHECK(s.index_to_world[0][0] == 0.5 && s.index_to_world[0][3] == 2.0 && s.index_to_world[2][3] == 5.0);
    }
    ohm_scan_free(&s);
    ohm_scan_params pp;
    memset(&pp, 0, sizeof pp);
    pp.grid = "temperature";
    rc = ohm_scan_read(&s, p, &pp, &e);
    CHECK(rc == OHM_ERR_USAGE && one_line_naming(&e, p) && strstr(e.msg, "temperature") &&
          strstr(e.msg, "'density'"));
    print_err("missing grid", &e);
}

/* ---- NIfTI headers checked before libnifti2 sees them ---------------------- */

/* A 4 x 3 x 2 int16 NIfTI-1 (.nii) built by hand in either byte order, values
 * 0..23; `patch` may change the header before the data is appended. */
typedef void (*hdr_patch)(unsigned char *h, int big);

static void put_n(unsigned char *b, uint64_t v, int n, int big)
{
    for (int i = 0; i < n; ++i) b[big ? n - 1 - i : i] = (unsigned char)(v >> (8 * i));
}
static void put_f32(unsigned char *b, float f, int big)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    put_n(b, u, 4, big);
}
static void put_f64(unsigned char *b, double d, int big)
{
    uint64_t u;
    memcpy(&u, &d, 8);
    put_n(b, u, 8, big);
}

static size_t make_nifti1(unsigned char *out, int big, hdr_patch patch)
{
    memset(out, 0, 352);
    put_n(out, 348, 4, big);
    const int dims[8] = {3, 4, 3, 2, 1, 1, 1, 1};
    for (int k = 0; k < 8; ++k) put_n(out + 40 + 2 * k, (uint64_t)(uint16_t)dims[k], 2, big);
    put_n(out + 70, NIFTI_TYPE_INT16, 2, big);
    put_n(out + 72, 16, 2, big);
    for (int k = 0; k < 8; ++k) put_f32(out + 76 + 4 * k, 1.0f, big);
    put_f32(out + 108, 352.0f, big);
    memcpy(out + 344, "n+1\0", 4);
    if (patch) patch(out, big);
    for (int i = 0; i < 24; ++i) put_n(out + 352 + 2 * i, (uint64_t)i, 2, big);
    return 352 + 48;
}

static size_t make_nifti2(unsigned char *out, int big, hdr_patch patch)
{
    memset(out, 0, 544);
    put_n(out, 540, 4, big);
    memcpy(out + 4, "n+2\0\r\n\032\n", 8);
    put_n(out + 12, NIFTI_TYPE_INT16, 2, big);
    put_n(out + 14, 16, 2, big);
    const int dims[8] = {3, 4, 3, 2, 1, 1, 1, 1};
    for (int k = 0; k < 8; ++k) put_n(out + 16 + 8 * k, (uint64_t)dims[k], 8, big);
    for (int k = 0; k < 8; ++k) put_f64(out + 104 + 8 * k, 1.0, big);
    put_n(out + 168, 544, 8, big);
    if (patch) patch(out, big);
    for (int i = 0; i < 24; ++i) put_n(out + 544 + 2 * i, (uint64_t)i, 2, big);
    return 544 + 48;
}

static void p_magic(unsigned char *h, int big) { (void)big; memcpy(h + 344, "abc\0", 4); }
static void p_negdim(unsigned char *h, int big) { put_n(h + 40 + 2 * 2, (uint64_t)(uint16_t)-3, 2, big); }
static void p_zerodim(unsigned char *h, int big) { put_n(h + 40 + 2 * 3, 0, 2, big); }
static void p_ndim0(unsigned char *h, int big) { put_n(h + 40, 0, 2, big); }
static void p_ndim8(unsigned char *h, int big) { put_n(h + 40, 8, 2, big); }
static void p_dim4(unsigned char *h, int big)
{
    put_n(h + 40, 4, 2, big);
    put_n(h + 40 + 2 * 4, 2, 2, big);
}
static void p_voxoff0(unsigned char *h, int big) { put_f32(h + 108, 0.0f, big); }
static void p_voxoffnan(unsigned char *h, int big) { put_f32(h + 108, NAN, big); }
static void p_voxoffhuge(unsigned char *h, int big) { put_f32(h + 108, 1e30f, big); }
static void p_dtype(unsigned char *h, int big) { put_n(h + 70, 1234, 2, big); }
static void p_sizeof(unsigned char *h, int big) { put_n(h, 349, 4, big); }
static void p2_magic(unsigned char *h, int big) { (void)big; h[8] = 1; }
static void p2_dtype(unsigned char *h, int big) { put_n(h + 12, 40000, 2, big); }
static void p2_negdim(unsigned char *h, int big) { put_n(h + 16 + 8 * 1, (uint64_t)-5, 8, big); }
static void p2_voxoff(unsigned char *h, int big) { put_n(h + 168, 100, 8, big); }
static void p_sform_zero(unsigned char *h, int big) { put_n(h + 254, 1, 2, big); } /* sform_code 1, srows 0 */
static void p2_sform_huge(unsigned char *h, int big)
{
    put_n(h + 348, 1, 4, big); /* sform_code */
    for (int r = 0; r < 3; ++r) put_f64(h + 400 + 32 * r + 8 * r, 1e300, big);
}

static void test_nifti_headers(void)
{
    unsigned char buf[1024];
    ohm_scan s;
    ohm_error e = {0, ""};
    const char *p = tmp_path("h.nii"), *pgz = tmp_path("h.nii.gz");
    /* valid files in both byte orders and both versions, plain and gzip */
    for (int v2 = 0; v2 < 2; ++v2)
        for (int big = 0; big < 2; ++big)
            for (int gz = 0; gz < 2; ++gz) {
                size_t n = v2 ? make_nifti2(buf, big, NULL) : make_nifti1(buf, big, NULL);
                const char *f = gz ? pgz : p;
                if (gz) {
                    gzFile g = gzopen(f, "wb");
                    gzwrite(g, buf, (unsigned)n);
                    gzclose(g);
                } else {
                    FILE *fp = fopen(f, "wb");
                    fwrite(buf, 1, n, fp);
                    fclose(fp);
                }
                int rc = ohm_scan_read(&s, f, NULL, &e);
                CHECK_MSG(rc == 0, "NIfTI-%d %s-endian%s: %s", v2 + 1, big ? "big" : "little", gz ? " gz" : "",
                          e.msg);
                if (rc == 0) {
                    CHECK(s.dims[0] == 4 && s.dims[1] == 3 && s.dims[2] == 2);
                    CHECK(s.values[0] == 0.0f && s.values[1] == 1.0f && s.values[23] == 23.0f);
                }
                ohm_scan_free(&s);
            }
    /* each header field the check covers, with the message it gives */
    static const struct {
        int v2;
        hdr_patch patch;
        const char *want;
    } bad[] = {
        {0, p_magic, "NIfTI-1 magic is 'abc', expected 'n+1'"},
        {0, p_negdim, "NIfTI-1 dim[2] is -3, expected at least 1"},
        {0, p_zerodim, "NIfTI-1 dim[3] is 0, expected at least 1"},
        {0, p_ndim0, "dim[0] (the number of dimensions) is 0"},
        {0, p_ndim8, "dim[0] (the number of dimensions) is 8"},
        {0, p_dim4, "NIfTI-1 dim[4] is 2, expected 1"},
        {0, p_voxoff0, "vox_offset is 0"},
        {0, p_voxoffnan, "vox_offset is nan"},
        {0, p_voxoffhuge, "vox_offset is 1e+30"},
        {0, p_dtype, "datatype 1234"},
        {0, p_sizeof, "NIfTI sizeof_hdr is "},
        {1, p2_magic, "NIfTI-2 magic is 'n+2\\x00\\x01"},
        {1, p2_dtype, "NIfTI-2 datatype -25536"},
        {1, p2_negdim, "NIfTI-2 dim[1] is -5"},
        {1, p2_voxoff, "NIfTI-2 vox_offset is 100, expected a finite byte offset of at least 540"},
        {0, p_sform_zero, "transform is singular or overflows (determinant 0)"},
        {1, p2_sform_huge, "transform is singular or overflows (determinant inf)"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; ++i)
        for (int big = 0; big < 2; ++big) {
            size_t n = bad[i].v2 ? make_nifti2(buf, big, bad[i].patch) : make_nifti1(buf, big, bad[i].patch);
            FILE *fp = fopen(p, "wb");
            fwrite(buf, 1, n, fp);
            fclose(fp);
            int rc = ohm_scan_read(&s, p, NULL, &e);
            CHECK_MSG(rc == OHM_ERR_PARSE && one_line_naming(&e, p) && strstr(e.msg, bad[i].want),
                      "case %zu (%s-endian): rc %d, '%s', expected '%s'", i, big ? "big" : "little", rc, e.msg,
                      bad[i].want);
            CHECK(s.values == NULL);
        }
    /* every truncation of a valid header is refused, never read */
    size_t n = make_nifti2(buf, 0, NULL);
    for (size_t cut = 0; cut < 540; cut += 7) {
        (void)n;
        FILE *fp = fopen(p, "wb");
        fwrite(buf, 1, cut, fp);
        fclose(fp);
        int rc = ohm_scan_read(&s, p, NULL, &e);
        CHECK_MSG(rc == OHM_ERR_PARSE && one_line_naming(&e, p), "cut at %zu: rc %d %s", cut, rc, e.msg);
    }
    print_err("bad NIfTI-1 magic", &e);
}

/* ---- the .vdb checker ------------------------------------------------------ */

static unsigned char *slurp(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    long len = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *b = malloc(len > 0 ? (size_t)len : 1);
    *n = b ? fread(b, 1, (size_t)len, f) : 0;
    fclose(f);
    return b;
}

static void test_vdb_check(void)
{
    ohm_error e = {0, ""};
    const double origin[3] = {0, 0, 0};
    ohm_vdb_grid *g[2] = {NULL, NULL};
    /* two grids, values spread over several leaves and internal nodes */
    CHECK(ohm_vdb_grid_create(&g[0], "density", OHM_VDB_CLASS_FOG_VOLUME, 0.0f, 1.0, origin, &e) == 0);
    CHECK(ohm_vdb_grid_create(&g[1], "other", OHM_VDB_CLASS_FOG_VOLUME, 0.0f, 1.0, origin, &e) == 0);
    if (!g[0] || !g[1]) return;
    int32_t ijk[3 * 6] = {0, 0, 0, 9, 1, 2, 130, 5, 5, 4100, 3, 3, -20, -1, -7, 17, 33, 65};
    float vals[6] = {1, 2, 3, 4, 5, 6};
    CHECK(ohm_vdb_grid_set_values(g[0], ijk, vals, 6, &e) == 0);
    CHECK(ohm_vdb_grid_set_values(g[1], ijk, vals, 3, &e) == 0);
    ohm_vdb_grid_set_meta_string(g[0], "note", "hello", &e);
    ohm_vdb_grid_set_meta_double(g[0], "scale", 2.5, &e);
    ohm_vdb_grid_set_meta_int(g[0], "count", 7, &e);
    const char *p = tmp_path("c.vdb"), *q = tmp_path("m.vdb"), *nog = tmp_path("none.vdb");
    CHECK(ohm_vdb_write(p, g, 2, &e) == 0);
    ohm_vdb_grid_free(g[0]);
    ohm_vdb_grid_free(g[1]);
    CHECK_MSG(ohm_vdb_check(p, &e) == 0, "%s", e.msg);
    ohm_scan s;
    int rc = ohm_scan_read(&s, p, NULL, &e);
    CHECK_MSG(rc == 0, "%s", e.msg);
    CHECK(rc != 0 || (s.dims[0] == 4121 && s.dims[1] == 35 && s.dims[2] == 73));
    ohm_scan_free(&s);

    /* no grids: a data error (exit 1), not a usage error */
    CHECK(ohm_vdb_write(nog, NULL, 0, &e) == 0);
    rc = ohm_scan_read(&s, nog, NULL, &e);
    CHECK_MSG(rc == OHM_ERR_PARSE && one_line_naming(&e, nog) && strstr(e.msg, "no grids"), "rc %d %s", rc, e.msg);
    print_err("no grids", &e);

    /* every truncation and every single-byte change is either refused with one
     * line or passes the check; a sample of them also goes through OpenVDB */
    size_t n = 0;
    unsigned char *orig = slurp(p, &n);
    CHECK(orig != NULL && n > 1000);
    if (!orig) return;
    unsigned char *m = malloc(n);
    size_t refused = 0, total = 0;
    for (size_t k = 0; k < 2 * n; k += 3) {
        size_t len = n;
        memcpy(m, orig, n);
        if (k < n) len = k;           /* truncated at k */
        else m[k - n] ^= 0xA5;        /* byte k - n changed */
        FILE *f = fopen(q, "wb");
        fwrite(m, 1, len, f);
        fclose(f);
        rc = ohm_vdb_check(q, &e);
        total++;
        if (rc) {
            refused++;
            CHECK_MSG(rc == OHM_ERR_PARSE && one_line_naming(&e, q), "k=%zu rc %d %s", k, rc, e.msg);
        }
        if (k % 97 == 0) { /* through OpenVDB too: must not crash, leak or hang */
            rc = ohm_scan_read(&s, q, NULL, &e);
            CHECK(rc != 0 || s.values != NULL);
            ohm_scan_free(&s);
        }
    }
    CHECK_MSG(refused * 2 > total, "only %zu of %zu damaged files refused", refused, total);
    printf("  vdb check: %zu of %zu truncated or changed files refused\n", refused, total);
    free(m);
    free(orig);
}

/* A minimal 8-bit greyscale PNG (colour type 0), written with zlib. */
static void put32(unsigned char *b, uint32_t v)
{
    b[0] = (unsigned char)(v >> 24);
    b[1] = (unsigned char)(v >> 16);
    b[2] = (unsigned char)(v >> 8);
    b[3] = (unsigned char)v;
}

static void png_chunk(FILE *f, const char *type, const unsigned char *data, uint32_t len)
{
    unsigned char hdr[8];
    put32(hdr, len);
    memcpy(hdr + 4, type, 4);
    fwrite(hdr, 1, 8, f);
    if (len) fwrite(data, 1, len, f);
    uLong crc = crc32(0L, hdr + 4, 4);
    if (len) crc = crc32(crc, data, len);
    unsigned char c[4];
    put32(c, (uint32_t)crc);
    fwrite(c, 1, 4, f);
}

static void write_png_gray(const char *path, const unsigned char *px, int w, int h)
{
    FILE *f = fopen(path, "wb");
    if (!f) return;
    static const unsigned char sig[8] = {137, 80, 78, 71, 13, 10, 26, 10};
    fwrite(sig, 1, 8, f);
    unsigned char ihdr[13];
    put32(ihdr, (uint32_t)w);
    put32(ihdr + 4, (uint32_t)h);
    ihdr[8] = 8;  /* bit depth */
    ihdr[9] = 0;  /* greyscale */
    ihdr[10] = ihdr[11] = ihdr[12] = 0;
    png_chunk(f, "IHDR", ihdr, 13);
    size_t rawlen = (size_t)h * (size_t)(w + 1);
    unsigned char *raw = malloc(rawlen);
    for (int y = 0; y < h; ++y) {
        raw[(size_t)y * (size_t)(w + 1)] = 0; /* filter: none */
        memcpy(raw + (size_t)y * (size_t)(w + 1) + 1, px + (size_t)y * (size_t)w, (size_t)w);
    }
    uLongf zlen = compressBound((uLong)rawlen);
    unsigned char *z = malloc(zlen);
    compress(z, &zlen, raw, (uLong)rawlen);
    png_chunk(f, "IDAT", z, (uint32_t)zlen);
    png_chunk(f, "IEND", NULL, 0);
    fclose(f);
    free(raw);
    free(z);
}

static void test_stack(void)
{
    const char *dir = tmp_path("stack");
    if (mkdir(dir, 0700) != 0) {
        CHECK_MSG(0, "mkdir %s", dir);
        return;
    }
    /* three 4x3 slices, written out of order: names sort them */
    const char *names[3] = {"slice_002.png", "slice_000.png", "slice_001.png"};
    const int zs[3] = {2, 0, 1};
    char *paths[4];
    for (int q = 0; q < 3; ++q) {
        unsigned char px[12];
        for (int y = 0; y < 3; ++y)
            for (int x = 0; x < 4; ++x) px[y * 4 + x] = (unsigned char)(zs[q] * 100 + y * 10 + x);
        size_t len = strlen(dir) + strlen(names[q]) + 2;
        paths[q] = malloc(len);
        snprintf(paths[q], len, "%s/%s", dir, names[q]);
        write_png_gray(paths[q], px, 4, 3);
    }
    ohm_scan_params pp;
    memset(&pp, 0, sizeof pp);
    pp.spacing[0] = pp.spacing[1] = 0.5;
    pp.spacing[2] = 2;
    ohm_scan s;
    ohm_error e = {0, ""};
    int rc = ohm_scan_read(&s, dir, &pp, &e);
    CHECK_MSG(rc == 0, "%s", e.msg);
    if (rc == 0) {
        CHECK(s.dims[0] == 4 && s.dims[1] == 3 && s.dims[2] == 3);
        int ok = 1;
        for (int z = 0; z < 3; ++z)
            for (int y = 0; y < 3; ++y)
                for (int x = 0; x < 4; ++x)
                    if (fabsf(s.values[(z * 3 + y) * 4 + x] - (float)(z * 100 + y * 10 + x)) > 1e-3f) ok = 0;
        CHECK_MSG(ok, "stack values differ from the slices");
        CHECK(s.index_to_world[0][0] == 0.5 && s.index_to_world[2][2] == 2 && s.min == 0 && s.max == 223);
    }
    ohm_scan_free(&s);
    /* a slice of another size */
    {
        unsigned char px[4] = {1, 2, 3, 4};
        size_t len = strlen(dir) + 32;
        paths[3] = malloc(len);
        snprintf(paths[3], len, "%s/slice_003.png", dir);
        write_png_gray(paths[3], px, 2, 2);
        rc = ohm_scan_read(&s, dir, &pp, &e);
        CHECK(rc == OHM_ERR_PARSE && strstr(e.msg, "slice_003.png") && strstr(e.msg, "expected 4 x 3") &&
              !strchr(e.msg, '\n'));
        print_err("stack size mismatch", &e);
    }
    for (int q = 0; q < 4; ++q) {
        unlink(paths[q]);
        free(paths[q]);
    }
    rc = ohm_scan_read(&s, dir, &pp, &e);
    CHECK(rc == OHM_ERR_PARSE && one_line_naming(&e, dir));
    print_err("empty stack", &e);
}

static void test_samples(void)
{
    ohm_error e = {0, ""};
    ohm_scan s;
    ohm_scan_params pp;
    memset(&pp, 0, sizeof pp);
    pp.dims[0] = 64;
    pp.dims[1] = 48;
    pp.dims[2] = 57;
    pp.type = "u16";
    pp.spacing[0] = pp.spacing[1] = pp.spacing[2] = 0.625;
    int rc = ohm_scan_read(&s, "samples/walnut_64x48x57_uint16.raw.gz", &pp, &e);
    CHECK_MSG(rc == 0, "%s", e.msg);
    if (rc == 0) {
        double lo[3], hi[3];
        ohm_scan_bounds(&s, lo, hi);
        printf("  walnut: %dx%dx%d, range %g..%g, %.1f x %.1f x %.1f mm\n", s.dims[0], s.dims[1], s.dims[2], s.min,
               s.max, hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
        CHECK(s.min >= 0 && s.max <= 65535 && s.max > s.min + 1000);
        CHECK(hi[0] - lo[0] > 35 && hi[0] - lo[0] < 45); /* ~40 mm across */
    }
    ohm_scan_free(&s);
    rc = ohm_scan_read(&s, "samples/ch2_2mm.nii.gz", NULL, &e);
    CHECK_MSG(rc == 0, "%s", e.msg);
    if (rc == 0) {
        double lo[3], hi[3];
        ohm_scan_bounds(&s, lo, hi);
        printf("  ch2: %dx%dx%d, range %g..%g, bounds (%.1f %.1f %.1f)..(%.1f %.1f %.1f) mm\n", s.dims[0],
               s.dims[1], s.dims[2], s.min, s.max, lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]);
        CHECK(s.dims[0] == 90 && s.dims[1] == 108 && s.dims[2] == 90);
        CHECK(s.max > s.min);
        /* a head in MNI-like RAS mm: ~180 x 216 x 180 mm around the origin */
        CHECK(hi[0] - lo[0] > 150 && hi[0] - lo[0] < 200 && hi[1] - lo[1] > 180 && hi[1] - lo[1] < 240);
        CHECK(lo[0] < 0 && hi[0] > 0 && lo[1] < 0 && hi[1] > 0);
        /* the brain centre is brighter than air at a corner */
        double ctr[3] = {0, -18, 18}, corner[3] = {lo[0] + 1, lo[1] + 1, lo[2] + 1};
        CHECK(ohm_scan_sample(&s, ctr) > ohm_scan_sample(&s, corner));
    }
    ohm_scan_free(&s);
}

int main(void)
{
    if (tmp_begin("ohm_test_scan")) return 1;
    nifti_set_debug_level(0);
    test_nifti_vs_raw();
    test_nifti_errors();
    test_vdb();
    test_nifti_headers();
    test_vdb_check();
    test_stack();
    test_samples();
    cleanup_tmp();
    return check_summary();
}
