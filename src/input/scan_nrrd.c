/* scan_nrrd.c — NRRD volumes (.nrrd; .nhdr with a detached data file), the
 * format of 3D Slicer and Teem, read through Debian's Teem (libteem-dev).
 * The header is read alone first (Teem's "skip data" mode), so the axes,
 * type and size are checked before any voxel is allocated.  Geometry: with a
 * space (space directions, space origin), each axis's direction and length
 * are its spacing and direction cosines; without one, the axes' spacings
 * (1 mm when absent) along the world axes.  An LPS space (DICOM's, Slicer's
 * default on disk) or scanner-xyz is made RAS (scan_io.h); RAS and an
 * unnamed space are kept as they are; LAS is mirrored in x.  Teem's errors
 * (its biff messages) become the message, after the file's name. */
#include "input/scan_io.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include <teem/nrrd.h>

/* Teem's accumulated error text, made one line, into err. */
static int teem_failure(const char *path, const char *doing, ohm_error *err)
{
    char *msg = biffGetDone(NRRD);
    char *line = msg ? msg : NULL;
    /* the innermost cause is Teem's last line: keep it, after the context */
    size_t len = line ? strlen(line) : 0;
    while (len > 0 && (line[len - 1] == '\n' || line[len - 1] == ' ')) line[--len] = 0;
    const char *last = line ? strrchr(line, '\n') : NULL;
    const char *cause = last ? last + 1 : line ? line : "unknown error";
    while (*cause == ' ' || *cause == '[') {
        const char *close = *cause == '[' ? strchr(cause, ']') : NULL;
        cause = close ? close + 1 : cause + 1;
    }
    int rc = ohm_fail(err, OHM_ERR_PARSE, "%s: %s: %s", path, doing, cause);
    free(msg);
    return rc;
}

static int nrrd_sample(ohm_sample_type *t, int type)
{
    switch (type) {
    case nrrdTypeChar: *t = OHM_SAMPLE_I8; return 1;
    case nrrdTypeUChar: *t = OHM_SAMPLE_U8; return 1;
    case nrrdTypeShort: *t = OHM_SAMPLE_I16; return 1;
    case nrrdTypeUShort: *t = OHM_SAMPLE_U16; return 1;
    case nrrdTypeInt: *t = OHM_SAMPLE_I32; return 1;
    case nrrdTypeUInt: *t = OHM_SAMPLE_U32; return 1;
    case nrrdTypeFloat: *t = OHM_SAMPLE_F32; return 1;
    case nrrdTypeDouble: *t = OHM_SAMPLE_F64; return 1;
    default: return 0;
    }
}

/* The header's axes, type and geometry into dims, *t and s's transform. */
static int nrrd_layout(ohm_scan *s, int64_t dims[3], ohm_sample_type *t, const Nrrd *nh, const char *path,
                       ohm_error *err)
{
    if (nh->dim != 2 && nh->dim != 3)
        return ohm_fail(err, OHM_ERR_PARSE, "%s: %u axes, expected a 2-D or 3-D volume of scalars", path, nh->dim);
    if (!nrrd_sample(t, nh->type))
        return ohm_fail(err, OHM_ERR_PARSE, "%s: type '%s', expected an 8-, 16- or 32-bit integer, float or double",
                        path, airEnumStr(nrrdType, nh->type));
    double spacing[3] = {1, 1, 1}, dir[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, origin[3] = {0, 0, 0};
    for (unsigned a = 0; a < 3; ++a) dims[a] = a < nh->dim ? (int64_t)nh->axis[a].size : 1;
    if (nh->spaceDim > 0) {
        if (nh->spaceDim != 3)
            return ohm_fail(err, OHM_ERR_PARSE, "%s: a %u-dimensional space, expected 3", path, nh->spaceDim);
        for (unsigned a = 0; a < nh->dim; ++a) {
            const double *d = nh->axis[a].spaceDirection;
            double len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            if (!(len > 0) || !isfinite(len))
                return ohm_fail(err, OHM_ERR_PARSE, "%s: axis %u's space direction is (%g, %g, %g), expected a "
                                                    "non-zero vector", path, a, d[0], d[1], d[2]);
            spacing[a] = len;
            for (int c = 0; c < 3; ++c) dir[a][c] = d[c] / len;
        }
        for (int c = 0; c < 3; ++c) origin[c] = isfinite(nh->spaceOrigin[c]) ? nh->spaceOrigin[c] : 0;
    } else {
        for (unsigned a = 0; a < nh->dim; ++a) {
            double sp = nh->axis[a].spacing;
            if (isfinite(sp) && !(sp > 0))
                return ohm_fail(err, OHM_ERR_PARSE, "%s: axis %u's spacing is %g, expected a positive size in mm",
                                path, a, sp);
            if (isfinite(sp)) spacing[a] = sp;
        }
    }
    ohm_scan_set_geometry(s, spacing, dir, origin);
    if (nh->space == nrrdSpaceLeftPosteriorSuperior || nh->space == nrrdSpaceScannerXYZ) ohm_scan_lps_to_ras(s);
    else if (nh->space == nrrdSpaceLeftAnteriorSuperior)
        for (int c = 0; c < 4; ++c) s->index_to_world[0][c] = -s->index_to_world[0][c];
    else if (nh->space != nrrdSpaceUnknown && nh->space != nrrdSpaceRightAnteriorSuperior)
        return ohm_fail(err, OHM_ERR_PARSE, "%s: space '%s', expected right-anterior-superior, "
                                            "left-posterior-superior, left-anterior-superior or scanner-xyz",
                        path, airEnumStr(nrrdSpace, nh->space));
    return 0;
}

/* The magic line "NRRD0001" .. "NRRD0005", checked before Teem sees the
 * file: on a file it cannot recognise, Teem 1.12's nrrdLoad loses an array
 * (found by tests/fuzz/fuzz_scan.c). */
static int nrrd_magic(const char *path, ohm_error *err)
{
    char head[16];
    size_t got = 0;
    int rc = ohm_scan_read_head(path, 0, head, sizeof head, &got, err);
    if (rc) return rc;
    if (got < 9 || memcmp(head, "NRRD000", 7) != 0 || head[7] < '1' || head[7] > '5' ||
        (head[8] != '\n' && head[8] != '\r'))
        return ohm_fail(err, OHM_ERR_PARSE, "%s: not a NRRD file (expected its first line to be NRRD0001 .. NRRD0005)",
                        path);
    return 0;
}

/* Bytes of the file's data that exist: the header file's size when the
 * data is attached (an upper bound), else the sum of its data files'. */
static double data_bytes(const NrrdIoState *nio, const char *path)
{
    struct stat st;
    unsigned nfiles = nio->dataFNArr ? nio->dataFNArr->len : 0;
    if (nfiles == 0) return stat(path, &st) == 0 ? (double)st.st_size : 0;
    double total = 0;
    for (unsigned i = 0; i < nfiles; ++i) {
        const char *name = nio->dataFN[i];
        char full[8192];
        if (name[0] == '/' || !nio->path) snprintf(full, sizeof full, "%s", name);
        else snprintf(full, sizeof full, "%s/%s", nio->path, name); /* header-relative, as Teem reads it */
        if (stat(full, &st) == 0) total += (double)st.st_size;
    }
    return total;
}

/* Teem allocates the whole volume before it reads a byte of it: a header
 * that declares more data than its files can hold is refused first.  Raw
 * data needs its bytes; deflate expands at most 1032:1 (zlib's technical
 * details), so gzip data needs a 1032th of them; text needs a character
 * per value.  Then the budget every reader keeps (memory, expansion). */
static int nrrd_data_fits(const NrrdIoState *nio, const char *path, const ohm_scan_params *p, size_t n, size_t want,
                          ohm_error *err)
{
    const char *enc = nio->encoding ? nio->encoding->name : "raw";
    double have = data_bytes(nio, path), need = (double)want;
    if (strcmp(enc, "gzip") == 0) need = (double)want / 1032.0;
    else if (strcmp(enc, "ascii") == 0 || strcmp(enc, "hex") == 0) need = (double)n;
    else if (strcmp(enc, "raw") != 0) need = 0; /* bzip2: no useful bound */
    if (have < need)
        return ohm_fail(err, OHM_ERR_PARSE,
                        "%s: truncated: its %zu voxels need %zu bytes (%s encoding), its data has at most %.0f", path,
                        n, want, enc, have);
    return ohm_scan_check_budget(path, p, n, (double)want, have, err);
}

int ohm_scan_read_nrrd(ohm_scan *s, const char *path, const ohm_scan_params *p, ohm_error *err)
{
    int magic = nrrd_magic(path, err);
    if (magic) return magic;
    Nrrd *nh = nrrdNew();
    NrrdIoState *nio = nrrdIoStateNew();
    if (!nh || !nio) {
        nrrdNix(nh);
        nrrdIoStateNix(nio);
        return ohm_fail(err, OHM_ERR_NOMEM, "%s: out of memory", path);
    }
    nrrdIoStateSet(nio, nrrdIoStateSkipData, AIR_TRUE);
    int rc = nrrdLoad(nh, path, nio) ? teem_failure(path, "reading the NRRD header", err) : 0;
    int64_t dims[3];
    ohm_sample_type t = OHM_SAMPLE_U8;
    size_t n = 0;
    if (!rc) rc = nrrd_layout(s, dims, &t, nh, path, err);
    if (!rc) rc = ohm_scan_voxel_count(path, dims, &n, err);
    if (!rc) rc = nrrd_data_fits(nio, path, p, n, n * ohm_sample_size(t), err);
    nrrdIoStateNix(nio);
    const int type = nh->type;
    const unsigned naxes = nh->dim;
    nrrdNuke(nh);
    if (rc) return rc;
    Nrrd *nd = nrrdNew();
    if (!nd) return ohm_fail(err, OHM_ERR_NOMEM, "%s: out of memory", path);
    rc = nrrdLoad(nd, path, NULL) ? teem_failure(path, "reading the NRRD data", err) : 0;
    int same = !rc && nd->type == type && nd->dim == naxes && nd->data;
    for (unsigned a = 0; a < naxes && same; ++a) same = (int64_t)nd->axis[a].size == dims[a];
    if (!rc && !same) rc = ohm_fail(err, OHM_ERR_PARSE, "%s: the file changed while it was read", path);
    if (!rc) rc = ohm_scan_alloc(s, path, dims, err);
    if (!rc) {
        const uint16_t one = 1;
        int big = *(const unsigned char *)&one == 0; /* Teem hands the data over in this machine's order */
        ohm_scan_convert(s->values, nd->data, n, t, big);
    }
    nrrdNuke(nd);
    return rc;
}
