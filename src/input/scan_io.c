/* scan_io.c — what the scan readers share (scan_io.h). */
#include "input/scan_io.h"

#include "base/memory.h"

#include <ctype.h>
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

size_t ohm_sample_size(ohm_sample_type t)
{
    static const size_t size[] = {1, 1, 2, 2, 4, 4, 4, 8};
    return size[t];
}

const char *ohm_sample_name(ohm_sample_type t)
{
    static const char *const name[] = {"u8", "i8", "u16", "i16", "u32", "i32", "f32", "f64"};
    return name[t];
}

int ohm_scan_ends_with(const char *name, const char *suffix)
{
    size_t n = strlen(name), m = strlen(suffix);
    if (m > n) return 0;
    for (size_t i = 0; i < m; ++i)
        if (tolower((unsigned char)name[n - m + i]) != tolower((unsigned char)suffix[i])) return 0;
    return 1;
}

int ohm_scan_voxel_count(const char *path, const int64_t d[3], size_t *n, ohm_error *err)
{
    for (int k = 0; k < 3; ++k)
        if (d[k] <= 0)
            return ohm_fail(err, OHM_ERR_PARSE, "%s: dimension %d is %" PRId64 ", expected at least 1", path, k,
                            d[k]);
    uint64_t total = 1;
    for (int k = 0; k < 3; ++k) {
        if ((uint64_t)d[k] > OHM_SCAN_MAX_VOXELS || total * (uint64_t)d[k] > OHM_SCAN_MAX_VOXELS)
            return ohm_fail(err, OHM_ERR_PARSE,
                            "%s: %" PRId64 " x %" PRId64 " x %" PRId64 " voxels is more than the limit of %" PRIu64,
                            path, d[0], d[1], d[2], OHM_SCAN_MAX_VOXELS);
        total *= (uint64_t)d[k];
    }
    *n = (size_t)total;
    return 0;
}

int ohm_scan_check_budget(const char *path, const ohm_scan_params *p, size_t voxels, double buffer_bytes,
                          double stored_bytes, ohm_error *err)
{
    const double need = (double)voxels * sizeof(float) + buffer_bytes, limit = ohm_memory_limit(0);
    char nb[32], lb[32];
    if (need > limit)
        return ohm_fail(err, OHM_ERR_NOMEM, "%s: reading its %zu voxels needs %s, more than the %s available", path,
                        voxels, ohm_format_bytes(need, nb, 32), ohm_format_bytes(limit, lb, 32));
    const double max = p && p->max_expansion > 0 ? p->max_expansion : OHM_SCAN_MAX_EXPANSION;
    const double per_byte = stored_bytes > 0 ? (double)voxels / stored_bytes : 0;
    if (need > OHM_SCAN_BOMB_FLOOR && per_byte > max)
        return ohm_fail(err, OHM_ERR_PARSE,
                        "%s: %zu voxels from %s of file, %.0f per byte (more than max_expansion=%g): refused as a "
                        "likely decompression bomb; reading it would take %s (a real scan this compressible: "
                        "-read max_expansion=%.0f)",
                        path, voxels, ohm_format_bytes(stored_bytes, lb, 32), per_byte, max,
                        ohm_format_bytes(need, nb, 32), ceil(per_byte * 1.01));
    return 0;
}

int ohm_scan_alloc(ohm_scan *s, const char *path, const int64_t d[3], ohm_error *err)
{
    size_t n = 0;
    int rc = ohm_scan_voxel_count(path, d, &n, err);
    if (rc) return rc;
    s->values = malloc(n * sizeof(float));
    if (!s->values) return ohm_fail(err, OHM_ERR_NOMEM, "%s: out of memory allocating %zu voxels", path, n);
    for (int k = 0; k < 3; ++k) s->dims[k] = (int32_t)d[k];
    return 0;
}

void ohm_scan_convert(float *out, const unsigned char *in, size_t n, ohm_sample_type t, int big_endian)
{
    const size_t bpv = ohm_sample_size(t);
    for (size_t i = 0; i < n; ++i) {
        const unsigned char *b = in + i * bpv;
        uint64_t u = 0; /* the sample's bits, little-endian order assembled */
        for (size_t q = 0; q < bpv; ++q) u |= (uint64_t)b[big_endian ? bpv - 1 - q : q] << (8 * q);
        float v;
        switch (t) {
        case OHM_SAMPLE_U8: v = (float)(uint8_t)u; break;
        case OHM_SAMPLE_I8: v = (float)(int8_t)(uint8_t)u; break;
        case OHM_SAMPLE_U16: v = (float)(uint16_t)u; break;
        case OHM_SAMPLE_I16: v = (float)(int16_t)(uint16_t)u; break;
        case OHM_SAMPLE_U32: v = (float)(uint32_t)u; break;
        case OHM_SAMPLE_I32: v = (float)(int32_t)(uint32_t)u; break;
        case OHM_SAMPLE_F32: {
            uint32_t w = (uint32_t)u;
            memcpy(&v, &w, sizeof v);
            break;
        }
        default: {
            double d;
            memcpy(&d, &u, sizeof d);
            v = (float)d; /* out of float's range: inf, refused by the finite check */
            break;
        }
        }
        out[i] = v;
    }
}

/* Count the rest of a stream to its end (for "too long" messages). */
static uint64_t count_rest_plain(FILE *f)
{
    unsigned char scratch[4096];
    uint64_t total = 0;
    size_t more;
    while ((more = fread(scratch, 1, sizeof scratch, f)) > 0) total += more;
    return total;
}

/* path opened for reading at byte offset. */
static int open_at(FILE **out, const char *path, uint64_t offset, ohm_error *err)
{
    FILE *f = fopen(path, "rb");
    if (!f) return ohm_fail(err, OHM_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    if (offset > 0 && fseeko(f, (off_t)offset, SEEK_SET) != 0) {
        int e = errno;
        fclose(f);
        return ohm_fail(err, OHM_ERR_IO, "%s: cannot seek to byte %" PRIu64 ": %s", path, offset, strerror(e));
    }
    *out = f;
    return 0;
}

static int read_plain(const char *path, uint64_t offset, unsigned char *buf, size_t want, uint64_t *actual,
                      ohm_error *err)
{
    FILE *f = NULL;
    int rc = open_at(&f, path, offset, err);
    if (rc) return rc;
    size_t got = fread(buf, 1, want, f);
    uint64_t total = got + count_rest_plain(f);
    int bad = ferror(f);
    int e = errno;
    fclose(f);
    if (bad) return ohm_fail(err, OHM_ERR_IO, "%s: read error: %s", path, strerror(e));
    *actual = total;
    return 0;
}

static int gz_failure(gzFile f, const char *path, ohm_error *err)
{
    int zerr;
    const char *m = gzerror(f, &zerr);
    return zerr == Z_ERRNO ? ohm_fail(err, OHM_ERR_IO, "%s: read error: %s", path, strerror(errno))
                           : ohm_fail(err, OHM_ERR_PARSE, "%s: corrupt gzip stream: %s", path,
                                      m && *m ? m : "unexpected end of file");
}

static int read_gz(const char *path, uint64_t offset, unsigned char *buf, size_t want, uint64_t *actual,
                   ohm_error *err)
{
    errno = 0;
    gzFile f = gzopen(path, "rb");
    if (!f) return ohm_fail(err, OHM_ERR_IO, "%s: cannot open: %s", path, errno ? strerror(errno) : "zlib");
    gzbuffer(f, 1 << 17);
    uint64_t total = 0, skipped = 0;
    int rc = 0;
    unsigned char scratch[4096];
    for (;;) {
        unsigned char *dst;
        size_t room;
        if (skipped < offset) { /* the header before the data: read and dropped */
            dst = scratch;
            room = offset - skipped < sizeof scratch ? (size_t)(offset - skipped) : sizeof scratch;
        } else if (total < want) {
            dst = buf + total;
            room = want - (size_t)total;
        } else { /* one byte past what is expected says "too long": stop there (a bomb is not inflated) */
            dst = scratch;
            room = 1;
        }
        if (room > (1u << 30)) room = 1u << 30;
        int got = gzread(f, dst, (unsigned)room);
        if (got < 0) {
            rc = gz_failure(f, path, err);
            break;
        }
        if (total == 0 && skipped == 0 && got > 0 && gzdirect(f)) {
            rc = ohm_fail(err, OHM_ERR_PARSE, "%s: not a gzip file (expected the magic bytes 1f 8b)", path);
            break;
        }
        if (got == 0) {
            int zerr;
            gzerror(f, &zerr);
            if (zerr != Z_OK) rc = gz_failure(f, path, err);
            break;
        }
        if (skipped < offset) skipped += (uint64_t)got;
        else total += (uint64_t)got;
        if (total > want) break;
    }
    gzclose(f);
    *actual = total;
    return rc;
}

int ohm_scan_read_bytes(const char *path, int gz, uint64_t offset, unsigned char *buf, size_t want,
                        uint64_t *actual, ohm_error *err)
{
    return gz ? read_gz(path, offset, buf, want, actual, err) : read_plain(path, offset, buf, want, actual, err);
}

int ohm_scan_size_error(const char *path, uint64_t actual, size_t want, const int64_t d[3], ohm_sample_type t,
                        const char *where, ohm_error *err)
{
    if (actual > want)
        return ohm_fail(err, OHM_ERR_PARSE,
                        "%s: too long: %" PRId64 " x %" PRId64 " x %" PRId64 " %s voxels need %zu bytes, %s holds more",
                        path, d[0], d[1], d[2], ohm_sample_name(t), want, where);
    return ohm_fail(err, OHM_ERR_PARSE,
                    "%s: truncated: %" PRId64 " x %" PRId64 " x %" PRId64 " %s voxels need %zu bytes, %s holds %" PRIu64,
                    path, d[0], d[1], d[2], ohm_sample_name(t), want, where, actual);
}

int ohm_scan_inflate_bytes(const char *path, uint64_t offset, unsigned char *buf, size_t want, uint64_t *actual,
                           ohm_error *err)
{
    FILE *f = NULL;
    int opened = open_at(&f, path, offset, err);
    if (opened) return opened;
    z_stream z;
    memset(&z, 0, sizeof z);
    if (inflateInit2(&z, 15 + 32) != Z_OK) { /* zlib or gzip header, detected */
        fclose(f);
        return ohm_fail(err, OHM_ERR_NOMEM, "%s: zlib could not start", path);
    }
    unsigned char in[1 << 16], extra[1];
    uint64_t done = 0;
    int rc = 0, zr = Z_OK, too_long = 0;
    while (zr != Z_STREAM_END && !rc && !too_long) {
        if (z.avail_in == 0) {
            size_t got = fread(in, 1, sizeof in, f);
            if (got == 0) {
                rc = ferror(f) ? ohm_fail(err, OHM_ERR_IO, "%s: read error: %s", path, strerror(errno))
                               : ohm_fail(err, OHM_ERR_PARSE, "%s: the compressed data ends before its stream does",
                                          path);
                break;
            }
            z.next_in = in;
            z.avail_in = (uInt)got;
        }
        /* into buf while it has room; then into one spare byte: any
         * output there means the data is longer than the header says */
        int full = done >= want;
        size_t room = full ? 1 : (size_t)(want - done);
        z.next_out = full ? extra : buf + done;
        z.avail_out = (uInt)(room < (1u << 30) ? room : (1u << 30));
        uInt before = z.avail_out;
        zr = inflate(&z, Z_NO_FLUSH);
        if (zr != Z_OK && zr != Z_STREAM_END && zr != Z_BUF_ERROR)
            rc = ohm_fail(err, OHM_ERR_PARSE, "%s: corrupt compressed data: %s", path, z.msg ? z.msg : "zlib error");
        uint64_t produced = before - z.avail_out;
        if (full) too_long = produced > 0;
        else done += produced;
    }
    inflateEnd(&z);
    fclose(f);
    *actual = too_long ? (uint64_t)want + 1 : done;
    return rc;
}

int ohm_scan_read_head(const char *path, int gz, char *buf, size_t max, size_t *got, ohm_error *err)
{
    *got = 0;
    if (gz) {
        errno = 0;
        gzFile f = gzopen(path, "rb");
        if (!f) return ohm_fail(err, OHM_ERR_IO, "%s: cannot open: %s", path, errno ? strerror(errno) : "zlib");
        int n = gzread(f, buf, (unsigned)(max - 1));
        int rc = n < 0 ? gz_failure(f, path, err) : 0;
        gzclose(f);
        if (rc) return rc;
        *got = (size_t)n;
    } else {
        FILE *f = fopen(path, "rb");
        if (!f) return ohm_fail(err, OHM_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
        *got = fread(buf, 1, max - 1, f);
        int bad = ferror(f);
        fclose(f);
        if (bad) return ohm_fail(err, OHM_ERR_IO, "%s: read error: %s", path, strerror(errno));
    }
    buf[*got] = 0;
    return 0;
}

static size_t trimmed(const char *s, size_t len, const char **start)
{
    while (len > 0 && isspace((unsigned char)*s)) ++s, --len;
    while (len > 0 && isspace((unsigned char)s[len - 1])) --len;
    *start = s;
    return len;
}

int ohm_scan_header_line(const char *line, size_t len, char *key, size_t keymax, char *value, size_t valmax)
{
    const char *eq = memchr(line, '=', len);
    if (!eq) return 0;
    const char *k, *v;
    size_t kl = trimmed(line, (size_t)(eq - line), &k), vl = trimmed(eq + 1, len - (size_t)(eq - line) - 1, &v);
    if (kl == 0 || kl >= keymax || vl >= valmax) return 0;
    memcpy(key, k, kl);
    key[kl] = 0;
    memcpy(value, v, vl);
    value[vl] = 0;
    return 1;
}

int ohm_scan_numbers(const char *value, double *out, int count)
{
    const char *p = value;
    int n = 0;
    for (;;) {
        while (isspace((unsigned char)*p)) ++p;
        if (!*p) return n;
        if (n == count) return -1;
        char *end;
        errno = 0;
        double x = strtod(p, &end);
        if (end == p || errno == ERANGE || !isfinite(x)) return -1;
        out[n++] = x;
        p = end;
    }
}

void ohm_scan_set_geometry(ohm_scan *s, const double spacing[3], const double dir[3][3], const double origin[3])
{
    for (int r = 0; r < 3; ++r) {
        for (int a = 0; a < 3; ++a) s->index_to_world[r][a] = dir[a][r] * spacing[a];
        s->index_to_world[r][3] = origin[r];
    }
}

void ohm_scan_lps_to_ras(ohm_scan *s)
{
    for (int r = 0; r < 2; ++r)
        for (int c = 0; c < 4; ++c) s->index_to_world[r][c] = -s->index_to_world[r][c];
}
