/* fuzz_scan.c — libFuzzer harness for the scan readers, which only read from a
 * path: the input goes to a temporary file and through ohm_scan_read.  KIND
 * (set with -DKIND=...) picks the reader:
 *   KIND_RAW    byte 0-2: dims (1 + b % 32 each), byte 3: bits 0-1 type
 *               u8|u16|i16|f32, bit 2 big-endian, bit 3 .raw.gz (the rest is
 *               gzip-compressed, so mutations hit the voxel decoder), bit 4 with
 *               bit 3: the rest written as-is under .raw.gz; byte 4: spacing
 *               (0 = default, else b / 16 mm); the rest is the file.
 *   KIND_NIFTI  byte 0: bit 0 .nii.gz (the rest gzip-compressed), bit 1 with
 *               bit 0: the rest written as-is under .nii.gz; the rest is the file.
 *   KIND_VDB    the whole input is the .vdb file (grid "density").
 *   KIND_NRRD   the whole input is the .nrrd file (Teem reads it).
 *   KIND_META   the whole input is the .mha file.
 *   KIND_INR    byte 0: bit 0 .inr.gz (the rest gzip-compressed); the rest is
 *               the file.
 *   KIND_DICOM  the whole input is one .dcm file, alone in a fresh folder, read
 *               as the series it belongs to (GDCM scans the folder, reads it).
 *   KIND_STACK  the whole input is one .png file, alone in a fresh folder,
 *               read as a slice stack (OpenImageIO decodes it).
 * Run with scripts/fuzz.sh raw|nifti|vdb|nrrd|meta|inr|dicom|stack SECONDS.  Checks: no crash or UB
 * (sanitizers); a failure leaves the scan zeroed with a one-line message whose
 * code is the return value; a success has positive dims (raw: exactly the ones
 * asked for), finite values with min <= max matching them, a finite affine, and
 * ohm_scan_sample / ohm_scan_box_mean / ohm_scan_bounds give finite results. */
#define _DEFAULT_SOURCE /* mkstemps */
#include "input/scan.h"
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <zlib.h>

#define KIND_RAW 1
#define KIND_NIFTI 2
#define KIND_VDB 3
#define KIND_NRRD 4
#define KIND_META 5
#define KIND_INR 6
#define KIND_DICOM 7
#define KIND_STACK 8

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static int write_file(const char *path, const uint8_t *d, size_t n, int gz)
{
    if (gz) {
        gzFile g = gzopen(path, "wb1");
        if (!g) return -1;
        int ok = n == 0 || gzwrite(g, d, (unsigned)n) == (int)n;
        return (gzclose(g) == Z_OK && ok) ? 0 : -1;
    }
    FILE *f = fopen(path, "wb");
    if (!f) return -1;
    int ok = n == 0 || fwrite(d, 1, n, f) == n;
    return (fclose(f) == 0 && ok) ? 0 : -1;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static const char *types[4] = {"u8", "u16", "i16", "f32"};
    ohm_scan_params p;
    memset(&p, 0, sizeof p);
    const char *suffix;
    int gz = 0;
#if KIND == KIND_RAW
    if (size < 5) return 0;
    for (int a = 0; a < 3; ++a) p.dims[a] = 1 + data[a] % 32;
    p.type = types[data[3] & 3];
    p.endian = (data[3] & 4) ? "big" : "little";
    suffix = (data[3] & 8) ? ".raw.gz" : ".raw";
    gz = (data[3] & 8) && !(data[3] & 16);
    if (data[4]) p.spacing[0] = p.spacing[1] = p.spacing[2] = data[4] / 16.0;
    data += 5; size -= 5;
#elif KIND == KIND_NIFTI
    if (size < 1) return 0;
    suffix = (data[0] & 1) ? ".nii.gz" : ".nii";
    gz = (data[0] & 1) && !(data[0] & 2);
    data += 1; size -= 1;
#elif KIND == KIND_VDB
    suffix = ".vdb";
    (void)types;
#elif KIND == KIND_NRRD
    suffix = ".nrrd";
    (void)types;
#elif KIND == KIND_META
    suffix = ".mha";
    (void)types;
#elif KIND == KIND_INR
    if (size < 1) return 0;
    suffix = (data[0] & 1) ? ".inr.gz" : ".inr";
    gz = data[0] & 1;
    data += 1; size -= 1;
    (void)types;
#elif KIND == KIND_DICOM
    suffix = ".dcm";
    (void)types;
#elif KIND == KIND_STACK
    suffix = ".png";
    (void)types;
#else
#error "set -DKIND=KIND_RAW, KIND_NIFTI, KIND_VDB, KIND_NRRD, KIND_META, KIND_INR, KIND_DICOM or KIND_STACK"
#endif
    char path[320];
    const char *dir = getenv("TMPDIR");
#if KIND == KIND_DICOM || KIND == KIND_STACK
    char folder[256];
    snprintf(folder, sizeof folder, "%s/ohm-fuzz-XXXXXX", dir && *dir ? dir : "/tmp");
    if (!mkdtemp(folder)) abort();
    snprintf(path, sizeof path, "%s/slice%s", folder, suffix);
#else
    snprintf(path, sizeof path, "%s/ohm-fuzz-XXXXXX%s", dir && *dir ? dir : "/tmp", suffix);
    int fd = mkstemps(path, (int)strlen(suffix));
    if (fd < 0) abort();
    close(fd);
#endif
    if (write_file(path, data, size, gz) != 0) abort();

    ohm_scan s; ohm_error e;
    memset(&e, 0, sizeof e);
    int rc = ohm_scan_read(&s, path, &p, &e);
    unlink(path);
#if KIND == KIND_DICOM || KIND == KIND_STACK
    rmdir(folder);
#endif
    if (rc == 0) {
        if (!s.values) abort();
        size_t n = 1;
        for (int a = 0; a < 3; ++a) {
            if (s.dims[a] < 1) abort();
            n *= (size_t)s.dims[a];
        }
#if KIND == KIND_RAW
        for (int a = 0; a < 3; ++a) if (s.dims[a] != p.dims[a]) abort();
#endif
        float lo = INFINITY, hi = -INFINITY;
        for (size_t i = 0; i < n; ++i) {
            if (!isfinite(s.values[i])) abort();
            if (s.values[i] < lo) lo = s.values[i];
            if (s.values[i] > hi) hi = s.values[i];
        }
        if (!(s.min <= s.max) || s.min != lo || s.max != hi) abort();
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 4; ++c) if (!isfinite(s.index_to_world[r][c])) abort();
        double blo[3], bhi[3], mid[3];
        ohm_scan_bounds(&s, blo, bhi);
        for (int a = 0; a < 3; ++a) {
            if (!isfinite(blo[a]) || !isfinite(bhi[a]) || blo[a] > bhi[a]) abort();
            mid[a] = 0.5 * (blo[a] + bhi[a]);
        }
        double v1 = ohm_scan_sample(&s, mid), v2 = ohm_scan_sample(&s, blo), v3 = ohm_scan_box_mean(&s, blo, bhi);
        if (!isfinite(v1) || !isfinite(v2) || !isfinite(v3)) abort();
        /* the extent (scan.h): a finite background, the box's middle inside it */
        const double far[3] = {bhi[0] + 1e3, bhi[1], bhi[2]};
        if (!isfinite(s.background) || ohm_scan_sample(&s, far) != s.background) abort();
        if (!(ohm_scan_box_distance(&s, mid) <= 0) || !isfinite(ohm_scan_sample_clamped(&s, far))) abort();
        ohm_scan_free(&s);
    } else {
        if (s.values || s.dims[0] || s.dims[1] || s.dims[2]) abort();
        if (e.code != rc || !memchr(e.msg, 0, sizeof e.msg) || strchr(e.msg, '\n')) abort();
    }
    return 0;
}
