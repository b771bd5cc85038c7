/* scan_meta.c — MetaImage volumes (.mha: header and data in one file; .mhd:
 * the header, naming its data file), the format of ITK, 3D Slicer and
 * ITK-SNAP, read by ohm itself from the documented MetaIO format
 * (https://itk.org/Wiki/ITK/MetaIO/Documentation).  ITK's own reader was
 * weighed and not taken: Debian's libinsighttoolkit5-dev is 29 MB and pulls
 * in GDCM, DCMTK, HDF5 and MINC for one text header.
 *
 * Header lines "Key = Value", ElementDataFile last.  Keys read: ObjectType
 * (Image), NDims (2 or 3), DimSize, ElementType (MET_UCHAR MET_CHAR
 * MET_USHORT MET_SHORT MET_UINT MET_INT MET_FLOAT MET_DOUBLE),
 * ElementNumberOfChannels (1), ElementSpacing, Offset (or Position or
 * Origin), TransformMatrix (or Rotation or Orientation: axis i's direction
 * is entries 3i .. 3i+2, as ITK reads it), ElementByteOrderMSB (or
 * BinaryDataByteOrderMSB), CompressedData (a zlib stream), HeaderSize (bytes
 * before the data in a detached file; -1: the data ends the file),
 * ElementDataFile (LOCAL, or a file name relative to the header).  Other
 * keys are ignored.  MetaImage's world is ITK's LPS; ohm's is RAS
 * (scan_io.h). */
#include "input/scan_io.h"

#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

enum { META_HEADER_MAX = 65536 };

typedef struct meta_header {
    int ndims;
    int64_t dims[3];
    ohm_sample_type type;
    int have_type, big, compressed;
    double spacing[3], origin[3], dir[3][3];
    int64_t header_size;     /* detached data: bytes to skip; -1: data at the end */
    char data_file[4096];    /* "LOCAL" or a path                               */
    size_t data_offset;      /* LOCAL: where the data starts in the .mha        */
} meta_header;

static int meta_bool(const char *value, int *out)
{
    if (strcmp(value, "True") == 0 || strcmp(value, "true") == 0 || strcmp(value, "1") == 0) return *out = 1, 1;
    if (strcmp(value, "False") == 0 || strcmp(value, "false") == 0 || strcmp(value, "0") == 0) return *out = 0, 1;
    return 0;
}

static int meta_element_type(const char *value, ohm_sample_type *t)
{
    static const struct {
        const char *name;
        ohm_sample_type type;
    } types[] = {{"MET_UCHAR", OHM_SAMPLE_U8},  {"MET_CHAR", OHM_SAMPLE_I8},    {"MET_USHORT", OHM_SAMPLE_U16},
                 {"MET_SHORT", OHM_SAMPLE_I16}, {"MET_UINT", OHM_SAMPLE_U32},   {"MET_INT", OHM_SAMPLE_I32},
                 {"MET_FLOAT", OHM_SAMPLE_F32}, {"MET_DOUBLE", OHM_SAMPLE_F64}};
    for (size_t i = 0; i < sizeof types / sizeof types[0]; ++i)
        if (strcmp(value, types[i].name) == 0) return *t = types[i].type, 1;
    return 0;
}

/* One header line's key and value into h. */
static int meta_field(meta_header *h, const char *path, int line, const char *key, const char *value, ohm_error *err)
{
    double v[9];
    int nd = h->ndims > 0 ? h->ndims : 3;
#define META_BAD(what) ohm_fail(err, OHM_ERR_PARSE, "%s:%d: %s = %s, expected %s", path, line, key, value, what)
    if (strcmp(key, "ObjectType") == 0 && strcmp(value, "Image") != 0) return META_BAD("Image");
    if (strcmp(key, "NDims") == 0) {
        if (ohm_scan_numbers(value, v, 1) != 1 || (v[0] != 2 && v[0] != 3)) return META_BAD("2 or 3");
        h->ndims = (int)v[0];
    } else if (strcmp(key, "DimSize") == 0) {
        if (ohm_scan_numbers(value, v, nd) != nd) return META_BAD("one size per dimension");
        for (int a = 0; a < nd; ++a) {
            if (v[a] < 1 || v[a] != floor(v[a]) || v[a] > 9e18) return META_BAD("whole numbers, at least 1");
            h->dims[a] = (int64_t)v[a];
        }
    } else if (strcmp(key, "ElementType") == 0) {
        if (!meta_element_type(value, &h->type))
            return META_BAD("MET_UCHAR, MET_CHAR, MET_USHORT, MET_SHORT, MET_UINT, MET_INT, MET_FLOAT or MET_DOUBLE");
        h->have_type = 1;
    } else if (strcmp(key, "ElementNumberOfChannels") == 0) {
        if (ohm_scan_numbers(value, v, 1) != 1 || v[0] != 1) return META_BAD("1 (one value per voxel)");
    } else if (strcmp(key, "ElementSpacing") == 0) {
        if (ohm_scan_numbers(value, v, nd) != nd) return META_BAD("one spacing per dimension, in mm");
        for (int a = 0; a < nd; ++a) {
            if (!(v[a] > 0)) return META_BAD("positive spacings in mm");
            h->spacing[a] = v[a];
        }
    } else if (strcmp(key, "Offset") == 0 || strcmp(key, "Position") == 0 || strcmp(key, "Origin") == 0) {
        if (ohm_scan_numbers(value, v, nd) != nd) return META_BAD("one coordinate per dimension, in mm");
        for (int a = 0; a < nd; ++a) h->origin[a] = v[a];
    } else if (strcmp(key, "TransformMatrix") == 0 || strcmp(key, "Rotation") == 0 ||
               strcmp(key, "Orientation") == 0) {
        if (ohm_scan_numbers(value, v, nd * nd) != nd * nd) return META_BAD("NDims x NDims direction cosines");
        for (int a = 0; a < nd; ++a)
            for (int c = 0; c < nd; ++c) h->dir[a][c] = v[a * nd + c];
    } else if (strcmp(key, "ElementByteOrderMSB") == 0 || strcmp(key, "BinaryDataByteOrderMSB") == 0) {
        if (!meta_bool(value, &h->big)) return META_BAD("True or False");
    } else if (strcmp(key, "CompressedData") == 0) {
        if (!meta_bool(value, &h->compressed)) return META_BAD("True or False");
    } else if (strcmp(key, "HeaderSize") == 0) {
        if (ohm_scan_numbers(value, v, 1) != 1 || v[0] < -1 || v[0] > 1e18 || v[0] != floor(v[0]))
            return META_BAD("-1 or more bytes");
        h->header_size = (int64_t)v[0];
    } else if (strcmp(key, "ElementDataFile") == 0) {
        if (strcmp(value, "LIST") == 0 || strchr(value, '%'))
            return META_BAD("LOCAL or one data file (a list of slice files is not supported)");
        snprintf(h->data_file, sizeof h->data_file, "%s", value);
    }
#undef META_BAD
    return 0;
}

static int parse_meta_header(meta_header *h, const char *path, const char *head, size_t len, ohm_error *err)
{
    memset(h, 0, sizeof *h);
    for (int a = 0; a < 3; ++a) {
        h->spacing[a] = 1.0;
        h->dims[a] = 1;
        h->dir[a][a] = 1.0;
    }
    const char *p = head, *end = head + len;
    int line = 0;
    while (p < end && !h->data_file[0]) {
        const char *nl = memchr(p, '\n', (size_t)(end - p));
        if (!nl) break;
        ++line;
        size_t n = (size_t)(nl - p);
        if (n > 0 && p[n - 1] == '\r') --n;
        char key[64], value[4096];
        if (n > 0 && !ohm_scan_header_line(p, n, key, sizeof key, value, sizeof value))
            return ohm_fail(err, OHM_ERR_PARSE, "%s:%d: expected a 'Key = Value' header line", path, line);
        int rc = n > 0 ? meta_field(h, path, line, key, value, err) : 0;
        if (rc) return rc;
        p = nl + 1;
    }
    if (!h->data_file[0])
        return ohm_fail(err, OHM_ERR_PARSE, "%s: no ElementDataFile line (the header's last) in its first %d bytes, "
                                            "expected a MetaImage header", path, META_HEADER_MAX);
    h->data_offset = (size_t)(p - head);
    if (h->ndims == 0) return ohm_fail(err, OHM_ERR_PARSE, "%s: no NDims, expected NDims = 3", path);
    if (!h->have_type) return ohm_fail(err, OHM_ERR_PARSE, "%s: no ElementType, expected the voxels' type", path);
    return 0;
}

/* The detached data file's path: relative to the header's folder. */
static int data_path(char *out, size_t max, const char *header, const char *name, ohm_error *err)
{
    const char *slash = strrchr(header, '/');
    int n = name[0] == '/' || !slash ? snprintf(out, max, "%s", name)
                                     : snprintf(out, max, "%.*s/%s", (int)(slash - header), header, name);
    if (n < 0 || (size_t)n >= max) return ohm_fail(err, OHM_ERR_USAGE, "%s: data file name too long", header);
    return 0;
}

int ohm_scan_read_meta(ohm_scan *s, const char *path, const ohm_scan_params *p, ohm_error *err)
{
    char *head = malloc(META_HEADER_MAX + 1);
    meta_header *h = malloc(sizeof *h);
    char *data = malloc(4096 + 1024);
    int rc = head && h && data ? 0 : ohm_fail(err, OHM_ERR_NOMEM, "%s: out of memory", path);
    size_t len = 0, n = 0;
    if (!rc) rc = ohm_scan_read_head(path, 0, head, META_HEADER_MAX + 1, &len, err);
    if (!rc) rc = parse_meta_header(h, path, head, len, err);
    if (!rc) rc = ohm_scan_voxel_count(path, h->dims, &n, err);
    int local = !rc && strcmp(h->data_file, "LOCAL") == 0;
    if (!rc && !local) rc = data_path(data, 4096 + 1024, path, h->data_file, err);
    const char *src = local ? path : data;
    size_t want = rc ? 0 : n * ohm_sample_size(h->type);
    uint64_t offset = local ? h->data_offset : (uint64_t)(h->header_size > 0 ? h->header_size : 0);
    struct stat st;
    if (!rc && stat(src, &st) != 0)
        rc = ohm_fail(err, OHM_ERR_IO, "%s: cannot open its data file %s: %s", path, src, strerror(errno));
    if (!rc && !local && h->header_size == -1 && !h->compressed) /* the data ends the file */
        offset = (uint64_t)st.st_size > want ? (uint64_t)st.st_size - want : 0;
    if (!rc) rc = ohm_scan_check_budget(path, p, n, (double)want, (double)st.st_size - (double)offset, err);
    unsigned char *buf = rc ? NULL : malloc(want ? want : 1);
    if (!rc && !buf) rc = ohm_fail(err, OHM_ERR_NOMEM, "%s: out of memory reading %zu bytes", path, want);
    uint64_t actual = 0;
    if (!rc)
        rc = h->compressed ? ohm_scan_inflate_bytes(src, offset, buf, want, &actual, err)
                           : ohm_scan_read_bytes(src, 0, offset, buf, want, &actual, err);
    if (!rc && actual != want)
        rc = ohm_scan_size_error(path, actual, want, h->dims, h->type,
                                 h->compressed ? "the decompressed data" : local ? "the data after the header" : src,
                                 err);
    if (!rc) rc = ohm_scan_alloc(s, path, h->dims, err);
    if (!rc) {
        ohm_scan_convert(s->values, buf, n, h->type, h->big);
        ohm_scan_set_geometry(s, h->spacing, h->dir, h->origin);
        ohm_scan_lps_to_ras(s);
    }
    free(buf);
    free(head);
    free(h);
    free(data);
    return rc;
}
