/* scan_inr.c — INRIMAGE-4 volumes (.inr, .inr.gz), the format of CGAL's
 * Mesh_3 sample images: a text header "#INRIMAGE-4#{" ... "##}" of
 * KEY=VALUE lines, padded with newlines to a multiple of 256 bytes, then the
 * voxels, x fastest.  Keys read: XDIM YDIM ZDIM VDIM (one value per voxel
 * only), TYPE (unsigned fixed | signed fixed | float), PIXSIZE (8 | 16 | 32
 * | 64 bits), SCALE (2**0 only: other fixed-point scales are refused), CPU
 * (decm alpha pc: little-endian; sun sgi: big), VX VY VZ (voxel size, mm),
 * XO YO ZO or TX TY TZ (origin, mm).  Lines starting with '#' are comments;
 * other keys are ignored.  The header has no orientation: the axes are the
 * world's. */
#include "input/scan_io.h"

#include <inttypes.h>
#include <sys/stat.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { INR_HEADER_MAX = 65536 };

typedef struct inr_header {
    int64_t dims[3], bits;
    char type[128], cpu[128];
    double voxel[3], origin[3];
    size_t size;             /* bytes, the data's offset */
} inr_header;

/* The header's fields from its text (head: the file's first bytes). */
static int parse_inr_header(inr_header *h, const char *path, const char *head, size_t len, ohm_error *err)
{
    static const char magic[] = "#INRIMAGE-4#{";
    if (len < sizeof magic - 1 || memcmp(head, magic, sizeof magic - 1) != 0)
        return ohm_fail(err, OHM_ERR_PARSE, "%s: not an INRIMAGE-4 file (expected it to begin with '%s')", path,
                        magic);
    memset(h, 0, sizeof *h);
    h->voxel[0] = h->voxel[1] = h->voxel[2] = 1.0;
    const char *p = head, *end = head + len;
    int line = 0;
    while (p < end) {
        const char *nl = memchr(p, '\n', (size_t)(end - p));
        if (!nl) break;
        ++line;
        size_t n = (size_t)(nl - p);
        if (n >= 3 && memcmp(p, "##}", 3) == 0) {
            h->size = (size_t)(nl + 1 - head);
            break;
        }
        char key[32], value[128];
        if (line > 1 && p[0] != '#' && ohm_scan_header_line(p, n, key, sizeof key, value, sizeof value)) {
            static const char *const dim_key[3] = {"XDIM", "YDIM", "ZDIM"};
            static const char *const vox_key[3] = {"VX", "VY", "VZ"};
            static const char *const org_key[3][2] = {{"XO", "TX"}, {"YO", "TY"}, {"ZO", "TZ"}};
            double x;
            int numeric = ohm_scan_numbers(value, &x, 1) == 1;
            for (int a = 0; a < 3; ++a) {
                int bad = 0;
                if (strcmp(key, dim_key[a]) == 0) {
                    bad = !numeric || !(x >= 1 && x <= 1e18) || x != floor(x); /* in range before the cast */
                    if (!bad) h->dims[a] = (int64_t)x;
                }
                else if (strcmp(key, vox_key[a]) == 0) bad = !numeric || !((h->voxel[a] = x) > 0);
                else if (strcmp(key, org_key[a][0]) == 0 || strcmp(key, org_key[a][1]) == 0)
                    bad = !numeric || !isfinite(h->origin[a] = x);
                if (bad)
                    return ohm_fail(err, OHM_ERR_PARSE, "%s:%d: %s=%s, expected a %s", path, line, key, value,
                                    key[1] == 'D' ? "whole number of voxels, at least 1"
                                    : key[0] == 'V' ? "positive voxel size in mm" : "finite origin in mm");
            }
            if (strcmp(key, "VDIM") == 0 && (!numeric || x != 1))
                return ohm_fail(err, OHM_ERR_PARSE,
                                "%s:%d: VDIM=%s: a vector of values per voxel, expected one value (VDIM=1)", path,
                                line, value);
            if (strcmp(key, "TYPE") == 0) snprintf(h->type, sizeof h->type, "%s", value);
            if (strcmp(key, "CPU") == 0) snprintf(h->cpu, sizeof h->cpu, "%s", value);
            char *unit = NULL;
            double bits = strcmp(key, "PIXSIZE") == 0 ? strtod(value, &unit) : 0;
            if (strcmp(key, "PIXSIZE") == 0 && (unit == value || !(bits >= 1 && bits <= 64) ||
                                                !strstr(unit, "bits") || (h->bits = (int64_t)bits) != bits))
                return ohm_fail(err, OHM_ERR_PARSE, "%s:%d: PIXSIZE=%s, expected '8 bits', '16 bits', '32 bits' or "
                                                    "'64 bits'", path, line, value);
            if (strcmp(key, "SCALE") == 0 && strcmp(value, "2**0") != 0)
                return ohm_fail(err, OHM_ERR_PARSE,
                                "%s:%d: SCALE=%s: fixed-point scaling is not supported, expected SCALE=2**0", path,
                                line, value);
        }
        p = nl + 1;
    }
    if (h->size == 0)
        return ohm_fail(err, OHM_ERR_PARSE, "%s: the INRIMAGE header does not end ('##}' missing in its first %d "
                                            "bytes)", path, INR_HEADER_MAX);
    for (int a = 0; a < 3; ++a)
        if (h->dims[a] < 1)
            return ohm_fail(err, OHM_ERR_PARSE, "%s: the header has no %cDIM, expected the volume's size", path,
                            'X' + a);
    return 0;
}

/* TYPE and PIXSIZE as a sample type. */
static int inr_sample(ohm_sample_type *t, const inr_header *h, const char *path, ohm_error *err)
{
    int b = (int)h->bits;
    if (strcmp(h->type, "unsigned fixed") == 0 && (b == 8 || b == 16 || b == 32))
        *t = b == 8 ? OHM_SAMPLE_U8 : b == 16 ? OHM_SAMPLE_U16 : OHM_SAMPLE_U32;
    else if (strcmp(h->type, "signed fixed") == 0 && (b == 8 || b == 16 || b == 32))
        *t = b == 8 ? OHM_SAMPLE_I8 : b == 16 ? OHM_SAMPLE_I16 : OHM_SAMPLE_I32;
    else if (strcmp(h->type, "float") == 0 && (b == 32 || b == 64))
        *t = b == 32 ? OHM_SAMPLE_F32 : OHM_SAMPLE_F64;
    else
        return ohm_fail(err, OHM_ERR_PARSE,
                        "%s: TYPE=%s with PIXSIZE=%d bits is not supported, expected unsigned fixed or signed fixed "
                        "(8, 16 or 32 bits) or float (32 or 64 bits)",
                        path, h->type[0] ? h->type : "(none)", b);
    return 0;
}

static int inr_big_endian(int *big, const inr_header *h, const char *path, ohm_error *err)
{
    static const char *const little[] = {"decm", "alpha", "pc"}, *const bigs[] = {"sun", "sgi"};
    for (int i = 0; i < 3; ++i)
        if (strcmp(h->cpu, little[i]) == 0) return *big = 0, 0;
    for (int i = 0; i < 2; ++i)
        if (strcmp(h->cpu, bigs[i]) == 0) return *big = 1, 0;
    if (!h->cpu[0] && h->bits == 8) return *big = 0, 0; /* bytes have no order */
    return ohm_fail(err, OHM_ERR_PARSE, "%s: CPU=%s, expected decm, alpha or pc (little-endian) or sun or sgi "
                                        "(big-endian)", path, h->cpu[0] ? h->cpu : "(none)");
}

int ohm_scan_read_inr(ohm_scan *s, const char *path, int gz, const ohm_scan_params *p, ohm_error *err)
{
    char *head = malloc(INR_HEADER_MAX + 1);
    if (!head) return ohm_fail(err, OHM_ERR_NOMEM, "%s: out of memory", path);
    size_t len = 0;
    inr_header h;
    int rc = ohm_scan_read_head(path, gz, head, INR_HEADER_MAX + 1, &len, err);
    if (!rc) rc = parse_inr_header(&h, path, head, len, err);
    free(head);
    ohm_sample_type t = OHM_SAMPLE_U8;
    int big = 0;
    if (!rc) rc = inr_sample(&t, &h, path, err);
    if (!rc) rc = inr_big_endian(&big, &h, path, err);
    size_t n = 0;
    if (!rc) rc = ohm_scan_voxel_count(path, h.dims, &n, err);
    if (rc) return rc;
    size_t want = n * ohm_sample_size(t);
    struct stat st;
    rc = ohm_scan_check_budget(path, p, n, (double)want, stat(path, &st) == 0 ? (double)st.st_size : 0, err);
    if (rc) return rc;
    unsigned char *buf = malloc(want ? want : 1);
    if (!buf) return ohm_fail(err, OHM_ERR_NOMEM, "%s: out of memory reading %zu bytes", path, want);
    uint64_t actual = 0;
    rc = ohm_scan_read_bytes(path, gz, h.size, buf, want, &actual, err);
    if (!rc && actual != want) {
        char where[96];
        snprintf(where, sizeof where, "the %s after its %zu-byte header", gz ? "decompressed data" : "file", h.size);
        rc = ohm_scan_size_error(path, actual, want, h.dims, t, where, err);
    }
    if (!rc) rc = ohm_scan_alloc(s, path, h.dims, err);
    if (!rc) {
        ohm_scan_convert(s->values, buf, n, t, big);
        const double axes[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
        ohm_scan_set_geometry(s, h.voxel, axes, h.origin);
    }
    free(buf);
    return rc;
}
