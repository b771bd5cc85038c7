/* scan_check.c — ohm_vdb_check: walk a .vdb the way OpenVDB 10 will read it,
 * checking every size it declares against the bytes that hold it.
 *
 * The on-disk format, as OpenVDB 10.0 reads it (io::File::open, Archive::
 * readHeader, MetaMap::readMeta, GridDescriptor::read, Archive::readGrid,
 * Transform::read, Tree/RootNode/InternalNode/LeafNode::readTopology and
 * readBuffers, io::readCompressedValues, bloscFromStream, unzipFromStream),
 * all little-endian:
 *
 *   header     int64 magic 0x56444220, uint32 file version, uint32 library
 *              major, minor, uint8 has-grid-offsets, 36-char ASCII UUID
 *              (compression flags live per grid from version 222 on)
 *   MetaMap    uint32 count, then per entry: string name, string type,
 *              uint32 size, value (size bytes); string = uint32 length + bytes
 *   int32      grid count, then per grid a descriptor: string unique name,
 *              string type (suffix "_HalfFloat" = 16-bit values), string
 *              instance parent, int64 grid, block and end byte offsets;
 *              File::open then seeks to the end offset for the next one
 *   grid       at the grid offset: uint32 compression flags, MetaMap,
 *              transform (string map type + the map's doubles), and unless
 *              the grid is an instance: int32 buffer count, the root node
 *              (float background, uint32 tiles, uint32 children, 17 bytes per
 *              tile, per child its int32[3] origin and an internal node), and
 *              from the block offset the leaf buffers
 *   internal   child mask, value mask (NodeMask words), compressed values of
 *              every slot, then each child in index order (level 5 holds
 *              level-4 internal nodes, level 4 holds leaves; a leaf's
 *              topology is its 64-byte value mask)
 *   buffers    per leaf, children of the root in Coord order: 64-byte value
 *              mask (skipped: a File stream is seekable, so the topology's
 *              mask counts), compressed values
 *   values     int8 flag (0-6), 0-2 inactive floats, an optional selection
 *              mask, then active-or-all values as one chunk: blosc/zip =
 *              int64 size (<= 0: -size raw bytes) + bytes, none = raw
 *
 * ohm reads float grids only, so any other grid type is refused here, before
 * OpenVDB builds its tree.  Nothing the file declares is allocated: leaf
 * value-mask counts (2 bytes per leaf) and root-child entries are kept, at
 * most one per 64 and 17 bytes of the file. */
#include "input/scan_check.h"

#include <errno.h>
#include <inttypes.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#define VDB_MAGIC 0x56444220u
#define VDB_FILE_VERSION_MIN 222 /* OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION (OpenVDB 3.0) */
#define VDB_FILE_VERSION_MAX 224 /* OPENVDB_FILE_VERSION in OpenVDB 10 */
#define VDB_NAME_MAX 1024        /* grid names, types, parents */
#define COMPRESS_ZIP 0x1u
#define COMPRESS_ACTIVE_MASK 0x2u
#define COMPRESS_BLOSC 0x4u

typedef struct vr {
    FILE *f;
    const char *path;
    uint64_t size; /* file size */
    uint64_t pos;  /* where the next read starts */
    uint64_t lim;  /* end of the region being read */
    char limname[128];
    ohm_error *err;
    unsigned char *win; /* a window of the file: [wstart, wstart + wlen) */
    uint64_t wstart;
    size_t wlen;
} vr;
#define WINDOW (64 * 1024)

typedef struct root_entry {
    int32_t c[3];
    uint32_t child;   /* 0 tile, 1 child */
    uint32_t leaf0;   /* first leaf (index into the leaf counts; < file size / 64) */
    uint32_t nleaves;
} root_entry;

typedef struct grid_walk {
    uint32_t compression;
    int half;                 /* values stored as 16-bit halves */
    uint16_t *leaf_on;        /* active-value count of each leaf's topology mask */
    size_t nleaf, capleaf;
    root_entry *root;
    size_t nroot, caproot;
} grid_walk;

static int vfail(vr *v, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
static int vfail(vr *v, const char *fmt, ...)
{
    char msg[OHM_ERROR_MSG_MAX];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return ohm_fail(v->err, OHM_ERR_PARSE, "%s: %s", v->path, msg);
}

static void set_limit(vr *v, uint64_t lim, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;
static void set_limit(vr *v, uint64_t lim, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(v->limname, sizeof v->limname, fmt, ap);
    va_end(ap);
    v->lim = lim;
}

static uint64_t left(const vr *v) { return v->pos <= v->lim ? v->lim - v->pos : 0; }

/* n more bytes must lie before the limit. */
static int need(vr *v, uint64_t n, const char *what)
{
    if (n > left(v))
        return vfail(v, "%s needs %" PRIu64 " bytes at byte %" PRIu64 ", but only %" PRIu64 " are left in %s", what,
                     n, v->pos, left(v), v->limname);
    return 0;
}

/* Positions only move; bytes are fetched (through the window) when read. */
static int seek_to(vr *v, uint64_t pos)
{
    v->pos = pos;
    return 0;
}

static int rd(vr *v, void *dst, size_t n, const char *what)
{
    int rc = need(v, n, what);
    if (rc) return rc;
    unsigned char *d = dst;
    while (n > 0) {
        if (v->pos >= v->wstart && v->pos - v->wstart < v->wlen) {
            size_t off = (size_t)(v->pos - v->wstart), k = v->wlen - off;
            if (k > n) k = n;
            memcpy(d, v->win + off, k);
            d += k;
            n -= k;
            v->pos += k;
            continue;
        }
        if (fseeko(v->f, (off_t)v->pos, SEEK_SET) != 0)
            return ohm_fail(v->err, OHM_ERR_IO, "%s: cannot seek to byte %" PRIu64 ": %s", v->path, v->pos,
                            strerror(errno));
        v->wstart = v->pos;
        v->wlen = fread(v->win, 1, WINDOW, v->f);
        if (v->wlen == 0)
            return ferror(v->f) ? ohm_fail(v->err, OHM_ERR_IO, "%s: read error at byte %" PRIu64, v->path, v->pos)
                                : vfail(v, "%s at byte %" PRIu64 ": unexpected end of file", what, v->pos);
    }
    return 0;
}

static int skip(vr *v, uint64_t n, const char *what)
{
    int rc = need(v, n, what);
    return rc ? rc : seek_to(v, v->pos + n);
}

static uint32_t le32(const unsigned char *b)
{
    return (uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 | (uint32_t)b[3] << 24;
}
static uint64_t le64(const unsigned char *b) { return (uint64_t)le32(b) | (uint64_t)le32(b + 4) << 32; }

static int rd_u32(vr *v, uint32_t *out, const char *what)
{
    unsigned char b[4];
    int rc = rd(v, b, 4, what);
    if (!rc) *out = le32(b);
    return rc;
}

static int rd_i64(vr *v, int64_t *out, const char *what)
{
    unsigned char b[8];
    int rc = rd(v, b, 8, what);
    if (!rc) *out = (int64_t)le64(b);
    return rc;
}

/* A length-prefixed string.  Up to cap-1 bytes are kept in out (NUL-ended;
 * *truncated says if more were skipped); the length must fit in the region. */
static int rd_string(vr *v, char *out, size_t cap, int *truncated, const char *what)
{
    uint32_t len;
    int rc = rd_u32(v, &len, what);
    if (rc) return rc;
    if (len > left(v))
        return vfail(v, "%s length %" PRIu32 " at byte %" PRIu64 " exceeds the %" PRIu64 " bytes left in %s", what,
                     len, v->pos - 4, left(v), v->limname);
    size_t keep = len < cap ? len : cap - 1;
    rc = rd(v, out, keep, what);
    if (rc) return rc;
    out[keep] = 0;
    if (truncated) *truncated = keep < len;
    return keep < len ? skip(v, len - keep, what) : 0;
}

/* Printable form of a name for messages (control bytes as '?'). */
static const char *shown(const char *s, char *buf, size_t cap)
{
    size_t i = 0;
    for (; s[i] && i + 1 < cap && i < 64; ++i) buf[i] = (s[i] >= 0x20 && s[i] < 0x7f) ? s[i] : '?';
    buf[i] = 0;
    return buf;
}

/* ---- metadata ------------------------------------------------------------ */

/* Fixed-size metadata types OpenVDB 10 registers: TypedMetadata<T>::readValue
 * reads sizeof(T) whatever the stored size says, so the two must agree or
 * OpenVDB's reading would drift out of step with ours. */
static long fixed_meta_size(const char *type)
{
    static const struct {
        const char *name;
        long size;
    } t[] = {{"bool", 1},   {"double", 8}, {"float", 4},  {"int32", 4},   {"int64", 8},        {"vec2i", 8},
             {"vec2s", 8},  {"vec2d", 16}, {"vec3i", 12}, {"vec3s", 12},  {"vec3d", 24},       {"vec4i", 16},
             {"vec4s", 16}, {"vec4d", 32}, {"mat4s", 64}, {"mat4d", 128}, {"ptdataidx32", 4}, {"ptdataidx64", 8},
             {"ptidx32", 4}, {"ptidx64", 8}};
    for (size_t i = 0; i < sizeof t / sizeof t[0]; ++i)
        if (strcmp(type, t[i].name) == 0) return t[i].size;
    return -1;
}

/* One blosc-or-raw array of io::DelayedLoadMetadata ("__delayedload"):
 * uint32 bytes, then bytes of blosc data (whose header must not promise much
 * more than count * elem bytes: OpenVDB reserves what it promises) or, when
 * bytes is 0, count * elem raw bytes. */
static int delayed_array(vr *v, uint64_t count, unsigned elem, uint32_t bytes, const char *what)
{
    if (bytes == 0) return skip(v, count * elem, what);
    unsigned char h[16];
    if (bytes < 16) return vfail(v, "%s: a %" PRIu32 "-byte blosc chunk is shorter than its 16-byte header", what, bytes);
    int rc = rd(v, h, 16, what);
    if (rc) return rc;
    /* OpenVDB pads short arrays (to 128 bytes) before compressing them */
    if (le32(h + 4) > count * elem + 256 || le32(h + 12) != bytes)
        return vfail(v, "%s: blosc header says %" PRIu32 " bytes from %" PRIu32 ", expected at most %" PRIu64
                        " from %" PRIu32,
                     what, le32(h + 4), le32(h + 12), count * elem + 256, bytes);
    return skip(v, bytes - 16u, what);
}

static int delayed_load_meta(vr *v, uint32_t nbytes, const char *what)
{
    if (nbytes == 0) return 0;
    uint64_t start = v->pos, saved_lim = v->lim;
    char saved_name[sizeof v->limname];
    memcpy(saved_name, v->limname, sizeof saved_name);
    set_limit(v, v->pos + nbytes, "%s (%" PRIu32 " bytes)", what, nbytes);
    uint32_t count, bytes;
    int rc = rd_u32(v, &count, what);
    if (!rc) rc = rd_u32(v, &bytes, what);
    /* count leaves, each of which takes far more than a byte of the file */
    if (!rc && count > v->size)
        rc = vfail(v, "%s declares %" PRIu32 " leaves, more than the %" PRIu64 "-byte file can hold", what, count,
                   v->size);
    if (!rc) rc = delayed_array(v, count, 1, bytes, what);
    if (!rc) rc = rd_u32(v, &bytes, what);
    if (!rc && bytes != UINT32_MAX) rc = delayed_array(v, count, 8, bytes, what);
    memcpy(v->limname, saved_name, sizeof saved_name);
    v->lim = saved_lim;
    return rc ? rc : seek_to(v, start + nbytes);
}

static int meta_map(vr *v, const char *owner)
{
    char what[256];
    uint32_t count;
    snprintf(what, sizeof what, "%s metadata count", owner);
    int rc = rd_u32(v, &count, what);
    if (rc) return rc;
    if ((uint64_t)count * 12 > left(v))
        return vfail(v, "%s declares %" PRIu32 " metadata entries, more than the %" PRIu64 " bytes left in %s can hold",
                     owner, count, left(v), v->limname);
    for (uint32_t i = 0; i < count; ++i) {
        char name[128], type[64], sh[80];
        int trunc_type = 0;
        snprintf(what, sizeof what, "%s metadata %" PRIu32 " name", owner, i);
        if ((rc = rd_string(v, name, sizeof name, NULL, what))) return rc;
        snprintf(what, sizeof what, "%s metadata '%s' type", owner, shown(name, sh, sizeof sh));
        if ((rc = rd_string(v, type, sizeof type, &trunc_type, what))) return rc;
        uint32_t nbytes;
        snprintf(what, sizeof what, "%s metadata '%s' size", owner, sh);
        if ((rc = rd_u32(v, &nbytes, what))) return rc;
        snprintf(what, sizeof what, "%s metadata '%s' value", owner, sh);
        if (nbytes > left(v))
            return vfail(v, "%s length %" PRIu32 " at byte %" PRIu64 " exceeds the %" PRIu64 " bytes left in %s", what,
                         nbytes, v->pos - 4, left(v), v->limname);
        long fixed = trunc_type ? -1 : fixed_meta_size(type);
        if (fixed >= 0 && nbytes != (uint32_t)fixed) {
            char st[80];
            return vfail(v, "%s of type %s is %" PRIu32 " bytes, expected %ld", what, shown(type, st, sizeof st),
                         nbytes, fixed);
        }
        if (!trunc_type && strcmp(type, "__delayedload") == 0) rc = delayed_load_meta(v, nbytes, what);
        else rc = skip(v, nbytes, what); /* string, or a type OpenVDB keeps as an opaque blob */
        if (rc) return rc;
    }
    return 0;
}

/* ---- transform ------------------------------------------------------------- */

static int transform(vr *v, const char *owner)
{
    static const struct {
        const char *name;
        unsigned bytes;
    } maps[] = {{"AffineMap", 128},         {"UnitaryMap", 128},        {"ScaleMap", 120},
                {"UniformScaleMap", 120},   {"TranslationMap", 24},     {"ScaleTranslateMap", 144},
                {"UniformScaleTranslateMap", 144}};
    char type[64], what[256], sh[80];
    int trunc = 0;
    snprintf(what, sizeof what, "%s transform type", owner);
    int rc = rd_string(v, type, sizeof type, &trunc, what);
    if (rc) return rc;
    for (size_t i = 0; !trunc && i < sizeof maps / sizeof maps[0]; ++i)
        if (strcmp(type, maps[i].name) == 0) {
            snprintf(what, sizeof what, "%s %s", owner, maps[i].name);
            return skip(v, maps[i].bytes, what);
        }
    return vfail(v, "%s has a transform of type '%s', expected a linear map (AffineMap, ScaleMap, "
                    "ScaleTranslateMap, TranslationMap, UniformScale[Translate]Map or UnitaryMap)",
                 owner, shown(type, sh, sizeof sh));
}

/* ---- tree ---------------------------------------------------------------- */

static unsigned popcount_bytes(const unsigned char *m, size_t n)
{
    unsigned c = 0;
    for (size_t i = 0; i < n; ++i) {
        unsigned b = m[i];
        while (b) {
            b &= b - 1;
            c++;
        }
    }
    return c;
}

/* io::readCompressedValues for `dest_count` values under a value mask with
 * `mask_on` bits set (mask_bytes long). */
static int compressed_values(vr *v, const grid_walk *g, uint64_t dest_count, uint64_t mask_on, uint64_t mask_bytes,
                             const char *what)
{
    unsigned char flag;
    int rc = rd(v, &flag, 1, what);
    if (rc) return rc;
    int8_t meta = (int8_t)flag;
    if (meta == 2 || meta == 4 || meta == 5) rc = skip(v, meta == 5 ? 8 : 4, what); /* inactive float(s) */
    if (!rc && (meta == 3 || meta == 4 || meta == 5)) rc = skip(v, mask_bytes, what); /* selection mask */
    if (rc) return rc;
    uint64_t count = (g->compression & COMPRESS_ACTIVE_MASK) && meta != 6 ? mask_on : dest_count;
    if (g->half && count < 1) return 0; /* HalfReader reads nothing for no values */
    uint64_t nbytes = count * (g->half ? 2u : 4u);
    if (!(g->compression & (COMPRESS_BLOSC | COMPRESS_ZIP))) return skip(v, nbytes, what);
    int64_t n;
    if ((rc = rd_i64(v, &n, what))) return rc;
    const char *kind = g->compression & COMPRESS_BLOSC ? "blosc" : "zip";
    if (n <= 0) {
        if (n == INT64_MIN || (uint64_t)(-n) != nbytes)
            return vfail(v, "%s: a raw %s chunk of %" PRId64 " bytes at byte %" PRIu64 ", expected %" PRIu64, what,
                         kind, n == INT64_MIN ? n : -n, v->pos - 8, nbytes);
        return skip(v, nbytes, what);
    }
    if ((uint64_t)n > left(v))
        return vfail(v, "%s: %s chunk size %" PRId64 " at byte %" PRIu64 " exceeds the %" PRIu64 " bytes left in %s",
                     what, kind, n, v->pos - 8, left(v), v->limname);
    if (g->compression & COMPRESS_BLOSC) {
        unsigned char h[16];
        if (n < 16)
            return vfail(v, "%s: a %" PRId64 "-byte blosc chunk at byte %" PRIu64 " is shorter than its 16-byte header",
                         what, n, v->pos - 8);
        if ((rc = rd(v, h, 16, what))) return rc;
        if (le32(h + 4) != nbytes || le32(h + 12) != (uint64_t)n)
            return vfail(v, "%s: blosc header at byte %" PRIu64 " says %" PRIu32 " bytes from %" PRIu32
                            ", expected %" PRIu64 " from %" PRId64,
                         what, v->pos - 16, le32(h + 4), le32(h + 12), nbytes, n);
        return skip(v, (uint64_t)n - 16, what);
    }
    return skip(v, (uint64_t)n, what);
}

static int push_leaf(vr *v, grid_walk *g, unsigned on)
{
    if (g->nleaf == g->capleaf) {
        size_t nc = g->capleaf ? g->capleaf * 2 : 256;
        uint16_t *q = realloc(g->leaf_on, nc * sizeof *q);
        if (!q) return ohm_fail(v->err, OHM_ERR_NOMEM, "%s: out of memory checking the tree", v->path);
        g->leaf_on = q;
        g->capleaf = nc;
    }
    g->leaf_on[g->nleaf++] = (uint16_t)on;
    return 0;
}

/* InternalNode<..., log2dim>::readTopology (5: 32^3 slots, 4: 16^3). */
static int internal_node(vr *v, grid_walk *g, int log2dim, const char *owner)
{
    const size_t nslots = (size_t)1 << (3 * log2dim), mbytes = nslots / 8;
    unsigned char child[4096], value[4096];
    char what[256];
    snprintf(what, sizeof what, "%s internal node (level %d) masks", owner, log2dim == 5 ? 2 : 1);
    int rc = rd(v, child, mbytes, what);
    if (!rc) rc = rd(v, value, mbytes, what);
    if (rc) return rc;
    unsigned nchild = popcount_bytes(child, mbytes);
    /* every child takes at least its masks: fail before walking them */
    uint64_t least = log2dim == 5 ? 2 * 512 + 1 : 64;
    if ((uint64_t)nchild * least > left(v))
        return vfail(v, "%s internal node (level %d) at byte %" PRIu64 " has %u children, more than the %" PRIu64
                        " bytes left in %s can hold",
                     owner, log2dim == 5 ? 2 : 1, v->pos - 2 * mbytes, nchild, left(v), v->limname);
    snprintf(what, sizeof what, "%s internal node (level %d) values", owner, log2dim == 5 ? 2 : 1);
    if ((rc = compressed_values(v, g, nslots, popcount_bytes(value, mbytes), mbytes, what))) return rc;
    /* children in index order */
    for (size_t i = 0; i < nslots; ++i) {
        if (!(child[i >> 3] & (1u << (i & 7)))) continue;
        if (log2dim == 5) {
            if ((rc = internal_node(v, g, 4, owner))) return rc;
        } else {
            unsigned char leaf[64];
            snprintf(what, sizeof what, "%s leaf value mask", owner);
            if ((rc = rd(v, leaf, 64, what))) return rc;
            if ((rc = push_leaf(v, g, popcount_bytes(leaf, 64)))) return rc;
        }
    }
    return 0;
}

static int cmp_coord(const int32_t a[3], const int32_t b[3])
{
    for (int k = 0; k < 3; ++k)
        if (a[k] != b[k]) return a[k] < b[k] ? -1 : 1;
    return 0;
}

static int cmp_root(const void *pa, const void *pb)
{
    return cmp_coord(((const root_entry *)pa)->c, ((const root_entry *)pb)->c);
}

static int root_node(vr *v, grid_walk *g, const char *owner)
{
    char what[256];
    unsigned char b[12];
    snprintf(what, sizeof what, "%s root node", owner);
    int rc = rd(v, b, 8, what); /* int32 buffer count, float background */
    if (!rc) rc = rd(v, b, 8, what);
    if (rc) return rc;
    uint32_t ntiles = le32(b), nchildren = le32(b + 4);
    /* a tile is 17 bytes, a child at least 12 + two 4096-byte masks + 1 */
    if ((uint64_t)ntiles * 17 + (uint64_t)nchildren * (12 + 8192 + 1) > left(v))
        return vfail(v, "%s root node declares %" PRIu32 " tiles and %" PRIu32
                        " children, more than the %" PRIu64 " bytes left in %s can hold",
                     owner, ntiles, nchildren, left(v), v->limname);
    g->nroot = (size_t)ntiles + nchildren;
    g->root = g->nroot ? calloc(g->nroot, sizeof *g->root) : NULL;
    if (g->nroot && !g->root) return ohm_fail(v->err, OHM_ERR_NOMEM, "%s: out of memory checking the tree", v->path);
    for (size_t i = 0; i < g->nroot; ++i) {
        root_entry *e = &g->root[i];
        e->child = i >= ntiles;
        snprintf(what, sizeof what, "%s root %s %zu", owner, e->child ? "child" : "tile", e->child ? i - ntiles : i);
        if ((rc = rd(v, b, 12, what))) return rc;
        for (int k = 0; k < 3; ++k) {
            e->c[k] = (int32_t)le32(b + 4 * k);
            if (e->c[k] % 4096 != 0)
                return vfail(v, "%s at byte %" PRIu64 " has origin (%" PRId32 ", %" PRId32 ", %" PRId32
                                "), expected multiples of 4096",
                             what, v->pos - 12, (int32_t)le32(b), (int32_t)le32(b + 4), (int32_t)le32(b + 8));
        }
        if (!e->child) {
            if ((rc = skip(v, 5, what))) return rc; /* float value, bool active */
            continue;
        }
        e->leaf0 = (uint32_t)g->nleaf;
        if ((rc = internal_node(v, g, 5, owner))) return rc;
        e->nleaves = (uint32_t)(g->nleaf - e->leaf0);
    }
    /* RootNode keeps a std::map by origin: duplicates would be dropped (and
     * leaked), and the buffers are read back in sorted order. */
    if (g->nroot > 1) qsort(g->root, g->nroot, sizeof *g->root, cmp_root);
    for (size_t i = 1; i < g->nroot; ++i)
        if (cmp_coord(g->root[i - 1].c, g->root[i].c) == 0)
            return vfail(v, "%s root node has two entries at (%" PRId32 ", %" PRId32 ", %" PRId32 ")", owner,
                         g->root[i].c[0], g->root[i].c[1], g->root[i].c[2]);
    return 0;
}

static int leaf_buffers(vr *v, grid_walk *g, const char *owner)
{
    char what[256];
    snprintf(what, sizeof what, "%s leaf buffer", owner);
    for (size_t i = 0; i < g->nroot; ++i) {
        const root_entry *e = &g->root[i];
        if (!e->child) continue;
        for (size_t l = 0; l < e->nleaves; ++l) {
            int rc = skip(v, 64, what);
            if (!rc) rc = compressed_values(v, g, 512, g->leaf_on[e->leaf0 + l], 64, what);
            if (rc) return rc;
        }
    }
    return 0;
}

/* ---- grids ----------------------------------------------------------------- */

typedef struct desc {
    char *name, *parent; /* malloc'd; parent "" unless an instance */
    int half;
    int64_t grid_pos, block_pos, end_pos;
} desc;

static int cmp_desc_name(const void *a, const void *b)
{
    return strcmp((*(const desc *const *)a)->name, (*(const desc *const *)b)->name);
}

static int grid_body(vr *v, const desc *d, size_t index)
{
    char owner[120], sh[80];
    snprintf(owner, sizeof owner, "grid %zu ('%s')", index, shown(d->name, sh, sizeof sh));
    int rc = seek_to(v, (uint64_t)d->grid_pos);
    if (rc) return rc;
    set_limit(v, (uint64_t)d->block_pos, "%s before its data blocks (byte %" PRId64 ")", owner, d->block_pos);
    grid_walk g;
    memset(&g, 0, sizeof g);
    g.half = d->half;
    char what[256];
    snprintf(what, sizeof what, "%s compression flags", owner);
    if ((rc = rd_u32(v, &g.compression, what))) goto done;
    if (g.compression & ~(COMPRESS_ZIP | COMPRESS_ACTIVE_MASK | COMPRESS_BLOSC)) {
        rc = vfail(v, "%s compression flags are 0x%" PRIx32 ", expected a combination of 0x1 (zip), 0x2 (active "
                      "mask) and 0x4 (blosc)",
                   owner, g.compression);
        goto done;
    }
    if ((rc = meta_map(v, owner))) goto done;
    if ((rc = transform(v, owner))) goto done;
    if (d->parent[0]) goto done; /* an instance: its tree is its parent's */
    if ((rc = root_node(v, &g, owner))) goto done;
    if (v->pos != (uint64_t)d->block_pos) {
        rc = vfail(v, "%s topology ends at byte %" PRIu64 ", but its descriptor puts the data blocks at byte %" PRId64,
                   owner, v->pos, d->block_pos);
        goto done;
    }
    set_limit(v, (uint64_t)d->end_pos, "%s (it ends at byte %" PRId64 ")", owner, d->end_pos);
    if ((rc = leaf_buffers(v, &g, owner))) goto done;
    if (v->pos != (uint64_t)d->end_pos)
        rc = vfail(v, "%s data blocks end at byte %" PRIu64 ", but its descriptor says byte %" PRId64, owner, v->pos,
                   d->end_pos);
done:
    free(g.leaf_on);
    free(g.root);
    return rc;
}

static int check_file(vr *v)
{
    unsigned char h[8 + 4 + 4 + 4 + 1 + 36];
    set_limit(v, v->size, "the %" PRIu64 "-byte file", v->size);
    if (v->size < 8) return vfail(v, "%" PRIu64 " bytes is too short for a .vdb header (magic 0x56444220)", v->size);
    int rc = rd(v, h, 8, "the magic number");
    if (rc) return rc;
    if (le64(h) != VDB_MAGIC) return vfail(v, "not an OpenVDB file (magic 0x%016" PRIx64 ", expected 0x56444220)", le64(h));
    if ((rc = rd(v, h + 8, sizeof h - 8, "the file header"))) return rc;
    uint32_t version = le32(h + 8);
    if (version < VDB_FILE_VERSION_MIN || version > VDB_FILE_VERSION_MAX)
        return vfail(v, "file format version %" PRIu32 ", expected %d to %d (OpenVDB 3.0 to 10)", version,
                     VDB_FILE_VERSION_MIN, VDB_FILE_VERSION_MAX);
    if (h[20] == 0)
        return vfail(v, "has no grid offsets (written to a stream, not a file); ohm reads only seekable .vdb files");
    const unsigned char *u = h + 21;
    for (int i = 0; i < 36; ++i) {
        int hy = i == 8 || i == 13 || i == 18 || i == 23;
        int ok = hy ? u[i] == '-'
                    : (u[i] >= '0' && u[i] <= '9') || (u[i] >= 'a' && u[i] <= 'f') || (u[i] >= 'A' && u[i] <= 'F');
        if (!ok) return vfail(v, "the file UUID at byte 21 is not 36 characters of the form 8-4-4-4-12 hex digits");
    }
    if ((rc = meta_map(v, "the file"))) return rc;
    unsigned char c[4];
    if ((rc = rd(v, c, 4, "the grid count"))) return rc;
    int32_t ngrids = (int32_t)le32(c);
    if (ngrids < 0) return vfail(v, "grid count %" PRId32 " is negative", ngrids);
    if (ngrids == 0) return vfail(v, "the file holds no grids");
    if ((uint64_t)ngrids * 36 > left(v))
        return vfail(v, "declares %" PRId32 " grids, more than the %" PRIu64 " bytes left in %s can hold", ngrids,
                     left(v), v->limname);
    /* every descriptor takes at least 36 bytes, so ngrids < file size / 36 */
    desc *d = calloc((size_t)ngrids, sizeof *d);
    desc **byname = calloc((size_t)ngrids, sizeof *byname);
    char *name = malloc(VDB_NAME_MAX + 1), *parent = malloc(VDB_NAME_MAX + 1);
    if (!d || !byname || !name || !parent) {
        rc = ohm_fail(v->err, OHM_ERR_NOMEM, "%s: out of memory for %" PRId32 " grid descriptors", v->path, ngrids);
        goto done;
    }
    for (int32_t i = 0; i < ngrids && !rc; ++i) {
        char what[96], type[64], sh[80], st[80];
        int trunc = 0;
        snprintf(what, sizeof what, "grid descriptor %" PRId32 " name", i);
        if ((rc = rd_string(v, name, VDB_NAME_MAX + 1, &trunc, what))) break;
        if (trunc) {
            rc = vfail(v, "grid descriptor %" PRId32 " name is longer than %d bytes", i, VDB_NAME_MAX);
            break;
        }
        snprintf(what, sizeof what, "grid descriptor %" PRId32 " type", i);
        if ((rc = rd_string(v, type, sizeof type, &trunc, what))) break;
        const char *suffix = "_HalfFloat";
        size_t tl = strlen(type), sl = strlen(suffix);
        if (!trunc && tl > sl && strcmp(type + tl - sl, suffix) == 0) {
            d[i].half = 1;
            type[tl - sl] = 0;
        }
        if (trunc || strcmp(type, "Tree_float_5_4_3") != 0) {
            rc = vfail(v, "grid '%s' is of type %s%s, expected a float grid (Tree_float_5_4_3)",
                       shown(name, sh, sizeof sh), shown(type, st, sizeof st), trunc ? "..." : "");
            break;
        }
        snprintf(what, sizeof what, "grid descriptor %" PRId32 " instance parent", i);
        if ((rc = rd_string(v, parent, VDB_NAME_MAX + 1, &trunc, what))) break;
        if (trunc) {
            rc = vfail(v, "grid descriptor %" PRId32 " instance parent name is longer than %d bytes", i, VDB_NAME_MAX);
            break;
        }
        d[i].name = malloc(strlen(name) + 1);
        d[i].parent = malloc(strlen(parent) + 1);
        if (!d[i].name || !d[i].parent) {
            rc = ohm_fail(v->err, OHM_ERR_NOMEM, "%s: out of memory for grid names", v->path);
            break;
        }
        strcpy(d[i].name, name);
        strcpy(d[i].parent, parent);
        byname[i] = &d[i];
        snprintf(what, sizeof what, "grid descriptor %" PRId32 " offsets", i);
        if ((rc = rd_i64(v, &d[i].grid_pos, what)) || (rc = rd_i64(v, &d[i].block_pos, what)) ||
            (rc = rd_i64(v, &d[i].end_pos, what)))
            break;
        /* an instance has no data blocks: OpenVDB leaves its block offset 0 */
        if (d[i].parent[0]) d[i].block_pos = d[i].end_pos;
        if (d[i].grid_pos < (int64_t)v->pos || d[i].block_pos < d[i].grid_pos || d[i].end_pos < d[i].block_pos ||
            (uint64_t)d[i].end_pos > v->size) {
            rc = vfail(v, "grid '%s' offsets %" PRId64 ", %" PRId64 ", %" PRId64
                          " are out of order or outside the %" PRIu64 "-byte file (expected %" PRIu64
                          " <= grid <= blocks <= end <= %" PRIu64 ")",
                       shown(d[i].name, sh, sizeof sh), d[i].grid_pos, d[i].block_pos, d[i].end_pos, v->size, v->pos,
                       v->size);
            break;
        }
        rc = seek_to(v, (uint64_t)d[i].end_pos); /* File::readGridDescriptors: gd.seekToEnd */
    }
    if (rc) goto done;
    /* unique names; instance parents among them */
    qsort(byname, (size_t)ngrids, sizeof *byname, cmp_desc_name);
    for (int32_t i = 1; i < ngrids && !rc; ++i)
        if (strcmp(byname[i - 1]->name, byname[i]->name) == 0) {
            char sh[80];
            rc = vfail(v, "grid descriptors %td and %td have the same name '%s'", byname[i - 1] - d, byname[i] - d,
                       shown(byname[i]->name, sh, sizeof sh));
        }
    for (int32_t i = 0; i < ngrids && !rc; ++i) {
        if (d[i].parent[0]) {
            desc key = {d[i].parent, NULL, 0, 0, 0, 0}, *kp = &key;
            desc **hit = bsearch(&kp, byname, (size_t)ngrids, sizeof *byname, cmp_desc_name);
            if (!hit || *hit == &d[i]) {
                char sh[80], sp[80];
                rc = vfail(v, "grid '%s' is an instance of '%s', which is not another grid in the file",
                           shown(d[i].name, sh, sizeof sh), shown(d[i].parent, sp, sizeof sp));
                break;
            }
        }
        rc = grid_body(v, &d[i], (size_t)i);
    }
done:
    for (int32_t i = 0; d && i < ngrids; ++i) {
        free(d[i].name);
        free(d[i].parent);
    }
    free(d);
    free(byname);
    free(name);
    free(parent);
    return rc;
}

int ohm_vdb_check(const char *path, ohm_error *err)
{
    vr v;
    memset(&v, 0, sizeof v);
    v.path = path;
    v.err = err;
    v.f = fopen(path, "rb");
    if (!v.f) return ohm_fail(err, OHM_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    struct stat st;
    if (fstat(fileno(v.f), &st) != 0 || !S_ISREG(st.st_mode)) {
        fclose(v.f);
        return ohm_fail(err, OHM_ERR_IO, "%s: not a regular file, expected a .vdb", path);
    }
    v.size = (uint64_t)st.st_size;
    v.win = malloc(WINDOW);
    int rc = v.win ? check_file(&v) : ohm_fail(err, OHM_ERR_NOMEM, "%s: out of memory", path);
    free(v.win);
    fclose(v.f);
    return rc;
}
