/* test_mesh_io.c — the mesh readers (mesh_io.c) and the mesh facts (mesh.c).
 *
 * Run from the repository root.  Checks:
 *  - every sample mesh: counts and topology as documented in samples/SOURCES
 *    (watertight ones: no boundary, no non-manifold edges), sphere volume;
 *  - a unit cube written in every format and flavour (OBJ quads / negative
 *    indices / v/vt/vn / CRLF / continuation, OFF with comments, COFF, PLY
 *    ascii and binary both endians with extra properties and elements, STL
 *    ascii and binary, .gz) reads back as 8 vertices, 12 triangles, volume 1;
 *  - bad inputs (tests/data/bad/ and generated ones) fail with the right code
 *    and a message naming the file and the line / element and byte;
 *  - the parse_* entry points read only [data, data+len): buffers are copied
 *    into exact-size heap blocks so AddressSanitizer sees any over-read;
 *  - topology counts on small hand-made meshes. */
#include "check.h"
#include "tmp_files.h"
#include "input/mesh.h"

#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <zlib.h>

#define PI 3.14159265358979323846

static void *read_all(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    char *p = NULL;
    *len = 0;
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    p = malloc(n > 0 ? (size_t)n : 1);
    *len = fread(p, 1, (size_t)(n > 0 ? n : 0), f);
    fclose(f);
    return p;
}

/* ---- growable byte buffer for writing test files ------------------------- */

typedef struct buf {
    char *d;
    size_t n, cap;
} buf;

static void put(buf *b, const void *p, size_t n)
{
    if (b->n + n > b->cap) {
        b->cap = (b->n + n) * 2 + 64;
        b->d = realloc(b->d, b->cap);
    }
    memcpy(b->d + b->n, p, n);
    b->n += n;
}

static void puts_(buf *b, const char *s) { put(b, s, strlen(s)); }

static void putf(buf *b, const char *fmt, double a, double c, double d)
{
    char tmp[256];
    int n = snprintf(tmp, sizeof tmp, fmt, a, c, d);
    put(b, tmp, (size_t)n);
}

/* big or little endian integers / floats */
static void put_uint(buf *b, uint64_t v, int bytes, int be)
{
    unsigned char t[8];
    for (int i = 0; i < bytes; ++i) t[be ? bytes - 1 - i : i] = (unsigned char)(v >> (8 * i));
    put(b, t, (size_t)bytes);
}

static void put_f32(buf *b, float f, int be)
{
    uint32_t w;
    memcpy(&w, &f, 4);
    put_uint(b, w, 4, be);
}

static void put_f64(buf *b, double d, int be)
{
    uint64_t w;
    memcpy(&w, &d, 8);
    put_uint(b, w, 8, be);
}

/* ---- the unit cube ------------------------------------------------------- */

/* vertex i = (i & 1, i >> 1 & 1, i >> 2 & 1); quads wound outward */
static const int cube_quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                     {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};

static double cube_coord(int v, int axis) { return (double)((v >> axis) & 1); }

/* the i-th of the 12 triangles, corner c */
static int cube_tri(int t, int c)
{
    const int *q = cube_quads[t / 2];
    static const int fan[2][3] = {{0, 1, 2}, {0, 2, 3}};
    return q[fan[t % 2][c]];
}

/* ---- checks --------------------------------------------------------------- */

static void check_cube(const ohm_mesh *m, int rc, const ohm_error *e, const char *what)
{
    CHECK_MSG(rc == 0, "%s: rc %d: %s", what, rc, e->msg);
    if (rc) return;
    CHECK_MSG(m->nverts == 8 && m->ntris == 12, "%s: %zu vertices, %zu triangles, expected 8 and 12", what,
              m->nverts, m->ntris);
    double vol = ohm_mesh_signed_volume(m);
    CHECK_MSG(fabs(vol - 1.0) < 1e-12, "%s: volume %.17g, expected 1", what, vol);
    double lo[3], hi[3];
    ohm_mesh_bounds(m, lo, hi);
    CHECK_MSG(lo[0] == 0 && lo[1] == 0 && lo[2] == 0 && hi[0] == 1 && hi[1] == 1 && hi[2] == 1,
              "%s: bounds %g %g %g .. %g %g %g", what, lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]);
    ohm_mesh_topology t;
    ohm_error te;
    ohm_error_clear(&te);
    CHECK(ohm_mesh_topology_compute(&t, m, &te) == 0);
    CHECK_MSG(t.boundary_edges == 0 && t.nonmanifold_edges == 0 && t.misoriented_edges == 0 &&
                  t.degenerate_tris == 0 && t.components == 1 && t.unused_verts == 0,
              "%s: topology b%zu n%zu m%zu d%zu c%zu u%zu", what, t.boundary_edges, t.nonmanifold_edges,
              t.misoriented_edges, t.degenerate_tris, t.components, t.unused_verts);
}

typedef int (*parse_fn)(ohm_mesh *, const char *, size_t, const char *, ohm_error *);

/* Parse from an exact-size heap copy (no terminator: ASan catches over-reads). */
static int parse_exact(parse_fn fn, ohm_mesh *m, const void *data, size_t len, const char *name, ohm_error *e)
{
    char *copy = malloc(len ? len : 1);
    if (len) memcpy(copy, data, len);
    ohm_error_clear(e);
    int rc = fn(m, len ? copy : NULL, len, name, e);
    free(copy);
    return rc;
}

static void read_cube(const char *path, const char *what)
{
    ohm_mesh m;
    ohm_error e;
    ohm_error_clear(&e);
    int rc = ohm_mesh_read(&m, path, &e);
    check_cube(&m, rc, &e, what);
    ohm_mesh_free(&m);
}

static void parse_cube(parse_fn fn, const buf *b, const char *what)
{
    ohm_mesh m;
    ohm_error e;
    int rc = parse_exact(fn, &m, b->d, b->n, what, &e);
    check_cube(&m, rc, &e, what);
    ohm_mesh_free(&m);
}

static int zeroed(const ohm_mesh *m)
{
    return m->verts == NULL && m->tris == NULL && m->nverts == 0 && m->ntris == 0;
}

/* The call failed with `code`, the mesh is zeroed, and the message holds
 * every given needle (NULL-terminated list). */
static void check_fail(int rc, const ohm_mesh *m, const ohm_error *e, int code, const char *what, ...)
{
    CHECK_MSG(rc == code && e->code == code, "%s: rc %d (err %d), expected %d: %s", what, rc, e->code, code,
              e->msg);
    CHECK_MSG(zeroed(m), "%s: mesh not zeroed after failure", what);
    CHECK_MSG(strchr(e->msg, '\n') == NULL, "%s: message has a newline", what);
    va_list ap;
    va_start(ap, what);
    for (const char *n; (n = va_arg(ap, const char *));)
        CHECK_MSG(strstr(e->msg, n) != NULL, "%s: message '%s' lacks '%s'", what, e->msg, n);
    va_end(ap);
}

#define READ_FAILS(path, code, ...)                                                                \
    do {                                                                                            \
        ohm_mesh m_;                                                                                \
        ohm_error e_;                                                                               \
        ohm_error_clear(&e_);                                                                       \
        int rc_ = ohm_mesh_read(&m_, (path), &e_);                                                  \
        check_fail(rc_, &m_, &e_, (code), (path), (path), __VA_ARGS__, (const char *)NULL);         \
        if (rc_ == 0) ohm_mesh_free(&m_);                                                           \
    } while (0)

#define PARSE_FAILS(fn, text, len, name, code, ...)                                                 \
    do {                                                                                            \
        ohm_mesh m_;                                                                                \
        ohm_error e_;                                                                               \
        int rc_ = parse_exact((fn), &m_, (text), (len), (name), &e_);                               \
        check_fail(rc_, &m_, &e_, (code), (name), (name), __VA_ARGS__, (const char *)NULL);         \
        if (rc_ == 0) ohm_mesh_free(&m_);                                                           \
    } while (0)

#define PARSE_STR_FAILS(fn, text, name, code, ...) PARSE_FAILS(fn, text, strlen(text), name, code, __VA_ARGS__)

/* ---- samples -------------------------------------------------------------- */

static void test_samples(void)
{
    static const struct {
        const char *path;
        size_t nv, nt, boundary, nonmanifold, components, unused;
    } s[] = {
        {"samples/spot.obj", 2930, 5856, 0, 0, 1, 0},
        {"samples/cow.obj", 2903, 5804, 0, 0, 1, 0},
        {"samples/bunny00.off.gz", 37706, 75408, 0, 0, 1, 0},
        {"samples/knot1.off", 3200, 6400, 0, 0, 1, 0},
        {"samples/larger_sphere.off", 812, 1620, 0, 0, 1, 0},
        {"samples/head.off", 1487, 2918, 58, 0, 1, 0},
        {"samples/teapot.obj", 3644, 6320, 1036, 0, 4, 0},
        {"samples/stanford-bunny.obj.gz", 35947, 69451, 223, 0, 1, 1113},
        {"samples/ChineseDragon-10kv.off.gz", 10000, 19994, 6, 0, 1, 0},
    };
    for (size_t i = 0; i < sizeof s / sizeof s[0]; ++i) {
        ohm_mesh m;
        ohm_error e;
        ohm_error_clear(&e);
        int rc = ohm_mesh_read(&m, s[i].path, &e);
        CHECK_MSG(rc == 0, "%s: %s", s[i].path, e.msg);
        if (rc) continue;
        CHECK_MSG(m.nverts == s[i].nv && m.ntris == s[i].nt, "%s: %zu/%zu, expected %zu/%zu", s[i].path,
                  m.nverts, m.ntris, s[i].nv, s[i].nt);
        ohm_mesh_topology t;
        rc = ohm_mesh_topology_compute(&t, &m, &e);
        CHECK_MSG(rc == 0, "%s: topology: %s", s[i].path, e.msg);
        CHECK_MSG(t.boundary_edges == s[i].boundary && t.nonmanifold_edges == s[i].nonmanifold &&
                      t.components == s[i].components && t.unused_verts == s[i].unused &&
                      t.misoriented_edges == 0 && t.degenerate_tris == 0,
                  "%s: boundary %zu nonmanifold %zu components %zu unused %zu misoriented %zu degenerate %zu",
                  s[i].path, t.boundary_edges, t.nonmanifold_edges, t.components, t.unused_verts,
                  t.misoriented_edges, t.degenerate_tris);
        ohm_mesh_free(&m);
        CHECK(zeroed(&m));
    }

    /* sphere of radius ~1: the inscribed polyhedron is a little smaller */
    ohm_mesh m;
    ohm_error e;
    ohm_error_clear(&e);
    if (ohm_mesh_read(&m, "samples/larger_sphere.off", &e) == 0) {
        double v = ohm_mesh_signed_volume(&m);
        CHECK_REL(v, 4.0 / 3.0 * PI, 0.03);
        CHECK(v < 4.0 / 3.0 * PI);
        double lo[3], hi[3];
        ohm_mesh_bounds(&m, lo, hi);
        for (int k = 0; k < 3; ++k) {
            CHECK_REL(lo[k], -1.0, 0.02);
            CHECK_REL(hi[k], 1.0, 0.02);
        }
        ohm_mesh_scale(&m, 2.0);
        CHECK_REL(ohm_mesh_signed_volume(&m), 8 * v, 1e-12);
        /* shifting far from the origin must not cost accuracy */
        for (size_t i = 0; i < m.nverts; ++i) m.verts[3 * i] += 1e6;
        CHECK_REL(ohm_mesh_signed_volume(&m), 8 * v, 1e-9);
        /* inside out: negative */
        for (size_t t = 0; t < m.ntris; ++t) {
            int64_t tmp = m.tris[3 * t + 1];
            m.tris[3 * t + 1] = m.tris[3 * t + 2];
            m.tris[3 * t + 2] = tmp;
        }
        CHECK_REL(ohm_mesh_signed_volume(&m), -8 * v, 1e-9);
        ohm_mesh_free(&m);
    } else {
        CHECK_MSG(0, "%s", e.msg);
    }
    if (ohm_mesh_read(&m, "samples/spot.obj", &e) == 0) {
        CHECK(ohm_mesh_signed_volume(&m) > 0);
        ohm_mesh_free(&m);
    }
}

/* ---- round trips ---------------------------------------------------------- */

static void test_obj(void)
{
    buf b = {0};
    /* comments, groups and materials, vt/vn, a 4th coordinate and colours,
     * CRLF line ends, quads in every index form, negative indices, a line
     * continuation, and no newline at the end */
    puts_(&b, "# cube\r\nmtllib cube.mtl\r\no cube\r\ng all\r\n");
    for (int v = 0; v < 8; ++v) {
        putf(&b, "v %.1f %.1f %.1f", cube_coord(v, 0), cube_coord(v, 1), cube_coord(v, 2));
        puts_(&b, v % 2 ? " 1.0 0.5 0.25 0.125\r\n" : "\r\n");
    }
    puts_(&b, "vt 0 0\r\nvt 1 0\r\nvt 1 1\r\nvt 0 1\r\nvn 0 0 1\r\nvp 0.5\r\ns off\r\nusemtl red\r\n");
    static const char *const form[6] = {"%d/%d/1 ", "%d//1 ", "%d/%d ", "%d ", "%d/%d/1 ", "%d "};
    for (int f = 0; f < 6; ++f) {
        puts_(&b, "f ");
        for (int k = 0; k < 4; ++k) {
            char tmp[64];
            int idx = f % 2 ? cube_quads[f][k] - 8 : cube_quads[f][k] + 1; /* odd faces: relative */
            snprintf(tmp, sizeof tmp, form[f], idx, k + 1);
            puts_(&b, tmp);
            if (f == 3 && k == 1) puts_(&b, "\\\r\n  "); /* continued on the next line */
        }
        puts_(&b, f == 5 ? "# last face, no newline" : "\r\n");
    }
    parse_cube(ohm_mesh_parse_obj, &b, "cube.obj");
    read_cube(write_tmp("cube.OBJ", b.d, b.n), "cube.OBJ (upper-case extension)");
    read_cube(write_tmp_gz("cube.obj.gz", b.d, b.n), "cube.obj.gz");

    /* faces before vertices (forward references are legal OBJ) */
    b.n = 0;
    for (int t = 0; t < 12; ++t) {
        char tmp[64];
        snprintf(tmp, sizeof tmp, "f %d %d %d\n", cube_tri(t, 0) + 1, cube_tri(t, 1) + 1, cube_tri(t, 2) + 1);
        puts_(&b, tmp);
    }
    for (int v = 0; v < 8; ++v) putf(&b, "v %g %g %g\n", cube_coord(v, 0), cube_coord(v, 1), cube_coord(v, 2));
    parse_cube(ohm_mesh_parse_obj, &b, "forward.obj");
    free(b.d);

    /* finite huge coordinates are the next stage's problem, not the parser's */
    ohm_mesh m;
    ohm_error e;
    const char *big = "v 1e308 -1e308 0\nv 0 1 0\nv 0 0 1e-400\nf 1 2 3";
    CHECK_MSG(parse_exact(ohm_mesh_parse_obj, &m, big, strlen(big), "big.obj", &e) == 0, "%s", e.msg);
    CHECK(m.nverts == 3 && m.ntris == 1 && m.verts[0] == 1e308);
    ohm_mesh_free(&m);
}

static void test_off(void)
{
    buf b = {0};
    puts_(&b, "OFF # a cube\n# comment line\n\n   \n8 6 12 # counts\n");
    for (int v = 0; v < 8; ++v) {
        putf(&b, "%g %g %g", cube_coord(v, 0), cube_coord(v, 1), cube_coord(v, 2));
        puts_(&b, v == 3 ? "\n\n# between vertices\n" : "\n");
    }
    for (int f = 0; f < 6; ++f) {
        char tmp[64];
        snprintf(tmp, sizeof tmp, "4 %d %d %d %d%s\n", cube_quads[f][0], cube_quads[f][1], cube_quads[f][2],
                 cube_quads[f][3], f == 2 ? " 255 0 0" : "");
        puts_(&b, tmp);
    }
    parse_cube(ohm_mesh_parse_off, &b, "cube.off");
    read_cube(write_tmp_gz("cube.off.gz", b.d, b.n), "cube.off.gz");

    /* COFF with per-vertex colours, counts on the header line, triangles, no final newline */
    b.n = 0;
    puts_(&b, "COFF 8 12 0\r\n");
    for (int v = 0; v < 8; ++v)
        putf(&b, "%g %g %g 200 100 50 255\r\n", cube_coord(v, 0), cube_coord(v, 1), cube_coord(v, 2));
    for (int t = 0; t < 12; ++t) {
        char tmp[64];
        snprintf(tmp, sizeof tmp, "3 %d %d %d%s", cube_tri(t, 0), cube_tri(t, 1), cube_tri(t, 2),
                 t == 11 ? "" : "\r\n");
        puts_(&b, tmp);
    }
    parse_cube(ohm_mesh_parse_off, &b, "cube-coff.off");
    read_cube(write_tmp("cube.off", b.d, b.n), "cube.off (file)");

    /* NOFF: normals after the coordinates */
    b.n = 0;
    puts_(&b, "NOFF\n8 6 0\n");
    for (int v = 0; v < 8; ++v)
        putf(&b, "%g %g %g 0.577 0.577 0.577\n", cube_coord(v, 0), cube_coord(v, 1), cube_coord(v, 2));
    for (int f = 0; f < 6; ++f) {
        char tmp[64];
        snprintf(tmp, sizeof tmp, "4 %d %d %d %d\n", cube_quads[f][0], cube_quads[f][1], cube_quads[f][2],
                 cube_quads[f][3]);
        puts_(&b, tmp);
    }
    parse_cube(ohm_mesh_parse_off, &b, "cube-noff.off");
    free(b.d);
}

/* PLY header shared by the ascii and binary cubes: a 'material' element with
 * a list before 'vertex', extra vertex properties (including a list), z as a
 * double, an extra face property after the index list, an 'edge' element. */
static void ply_header(buf *b, const char *format)
{
    puts_(b, "ply\r\n");
    puts_(b, format);
    puts_(b, "comment a unit cube\r\nobj_info test\r\n"
             "element material 2\r\nproperty list uint16 float32 rgb\r\nproperty int8 id\r\n"
             "element vertex 8\r\nproperty uchar red\r\nproperty float x\r\nproperty float y\r\n"
             "property double z\r\nproperty list uchar short junk\r\nproperty ushort tag\r\n"
             "element face 6\r\nproperty uint8 kind\r\nproperty list uchar int vertex_indices\r\n"
             "property uint32 flags\r\n"
             "element edge 2\r\nproperty int vertex1\r\nproperty int32 vertex2\r\nend_header\r\n");
}

static void ply_binary_cube(buf *b, int be)
{
    b->n = 0;
    ply_header(b, be ? "format binary_big_endian 1.0\r\n" : "format binary_little_endian 1.0\r\n");
    for (int i = 0; i < 2; ++i) { /* material: rgb list of 3 floats, id */
        put_uint(b, 3, 2, be);
        for (int k = 0; k < 3; ++k) put_f32(b, 0.5f, be);
        put_uint(b, (uint64_t)i, 1, be);
    }
    for (int v = 0; v < 8; ++v) {
        put_uint(b, 255, 1, be);
        put_f32(b, (float)cube_coord(v, 0), be);
        put_f32(b, (float)cube_coord(v, 1), be);
        put_f64(b, cube_coord(v, 2), be);
        put_uint(b, (uint64_t)(v % 3), 1, be); /* junk: v % 3 shorts */
        for (int k = 0; k < v % 3; ++k) put_uint(b, 0xBEEF, 2, be);
        put_uint(b, 7, 2, be);
    }
    for (int f = 0; f < 6; ++f) {
        put_uint(b, 1, 1, be);
        put_uint(b, 4, 1, be);
        for (int k = 0; k < 4; ++k) put_uint(b, (uint64_t)cube_quads[f][k], 4, be);
        put_uint(b, 0xFFFFFFFFu, 4, be);
    }
    for (int i = 0; i < 2; ++i) {
        put_uint(b, 0, 4, be);
        put_uint(b, 1, 4, be);
    }
}

static void test_ply(void)
{
    buf b = {0};
    ply_header(&b, "format ascii 1.0\r\n");
    puts_(&b, "3 0.5 0.5 0.5 0\r\n3 0.25 0.25 0.25 1\r\n");
    for (int v = 0; v < 8; ++v) {
        putf(&b, "255 %g %g %g ", cube_coord(v, 0), cube_coord(v, 1), cube_coord(v, 2));
        puts_(&b, v % 2 ? "2 -1 -2 7\r\n" : "0 7\r\n");
    }
    for (int f = 0; f < 6; ++f) {
        char tmp[64];
        snprintf(tmp, sizeof tmp, "1 4 %d %d %d %d 0\r\n", cube_quads[f][0], cube_quads[f][1], cube_quads[f][2],
                 cube_quads[f][3]);
        puts_(&b, tmp);
    }
    puts_(&b, "0 1\r\n1 2"); /* edges, no final newline */
    parse_cube(ohm_mesh_parse_ply, &b, "cube-ascii.ply");
    read_cube(write_tmp("cube-ascii.ply", b.d, b.n), "cube-ascii.ply (file)");

    ply_binary_cube(&b, 0);
    parse_cube(ohm_mesh_parse_ply, &b, "cube-le.ply");
    read_cube(write_tmp("cube-le.ply", b.d, b.n), "cube-le.ply (file)");
    ply_binary_cube(&b, 1);
    parse_cube(ohm_mesh_parse_ply, &b, "cube-be.ply");
    read_cube(write_tmp_gz("cube-be.ply.gz", b.d, b.n), "cube-be.ply.gz");

    /* truncated binary: cut inside face 4 */
    ply_binary_cube(&b, 0);
    /* a face is 22 bytes (kind, count, 4 ints, flags), the 2 edges 16 */
    size_t face4 = b.n - 16 - 2 * 22;
    const char *p = write_tmp("truncated-le.ply", b.d, face4 + 5);
    {
        char where[64];
        snprintf(where, sizeof where, "face 4 (byte %zu)", face4);
        READ_FAILS(p, OHM_ERR_PARSE, where, "file ends early", "expected 6 'face' elements");
    }

    /* NaN in a binary vertex */
    b.n = 0;
    puts_(&b, "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
              "property float z\nelement face 1\nproperty list uchar uint vertex_indices\nend_header\n");
    size_t v0 = b.n;
    for (int i = 0; i < 9; ++i) put_f32(&b, i == 4 ? NAN : (float)(i % 3 == i / 3), 0);
    put_uint(&b, 3, 1, 0);
    for (int i = 0; i < 3; ++i) put_uint(&b, (uint64_t)i, 4, 0);
    {
        char where[64];
        snprintf(where, sizeof where, "vertex 1 (byte %zu)", v0 + 12);
        PARSE_FAILS(ohm_mesh_parse_ply, b.d, b.n, "nan.ply", OHM_ERR_PARSE, where, "not a finite number");
    }
    /* index out of range in binary */
    float one = 1.0f;
    memcpy(b.d + v0 + 16, &one, 4);
    {
        ohm_mesh m;
        ohm_error e;
        CHECK_MSG(parse_exact(ohm_mesh_parse_ply, &m, b.d, b.n, "tri.ply", &e) == 0 && m.ntris == 1, "%s", e.msg);
        ohm_mesh_free(&m);
    }
    b.d[b.n - 1] = 0x7f;
    PARSE_FAILS(ohm_mesh_parse_ply, b.d, b.n, "range.ply", OHM_ERR_PARSE, "face 0 (byte ",
                "refers to vertex", "file has 3 vertices");

    /* binary header claiming 10^12 faces (big endian this time) */
    b.n = 0;
    puts_(&b, "ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
              "property float z\nelement face 1000000000000\nproperty list uchar int vertex_indices\n"
              "end_header\n");
    for (int i = 0; i < 9; ++i) put_f32(&b, (float)(i % 3 == i / 3), 1);
    put_uint(&b, 3, 1, 1);
    for (int i = 0; i < 3; ++i) put_uint(&b, (uint64_t)i, 4, 1);
    p = write_tmp("huge-faces-be.ply", b.d, b.n);
    READ_FAILS(p, OHM_ERR_PARSE, "(line 7)", "1000000000000", "file ends early");
    free(b.d);
}

static void stl_ascii_cube(buf *b)
{
    b->n = 0;
    puts_(b, "solid cube\n");
    for (int t = 0; t < 12; ++t) {
        puts_(b, "  facet normal 0 0 0\n    outer loop\n");
        for (int c = 0; c < 3; ++c) {
            int v = cube_tri(t, c);
            putf(b, "      vertex %e %e %e\n", cube_coord(v, 0), cube_coord(v, 1), cube_coord(v, 2));
        }
        puts_(b, "    endloop\n  endfacet\n");
    }
    puts_(b, "endsolid cube\n");
}

static void stl_binary_cube(buf *b, const char *header, uint32_t declared)
{
    char h[80];
    memset(h, 0, sizeof h);
    memcpy(h, header, strlen(header));
    b->n = 0;
    put(b, h, 80);
    put_uint(b, declared, 4, 0);
    for (int t = 0; t < 12; ++t) {
        for (int k = 0; k < 3; ++k) put_f32(b, 0.0f, 0);
        for (int c = 0; c < 3; ++c)
            for (int k = 0; k < 3; ++k) put_f32(b, (float)cube_coord(cube_tri(t, c), k), 0);
        put_uint(b, 0, 2, 0);
    }
}

static void test_stl(void)
{
    buf b = {0};
    stl_ascii_cube(&b);
    parse_cube(ohm_mesh_parse_stl, &b, "cube-ascii.stl");
    read_cube(write_tmp("cube-ascii.stl", b.d, b.n), "cube-ascii.stl (file)");
    stl_binary_cube(&b, "solid cube, but binary", 12);
    parse_cube(ohm_mesh_parse_stl, &b, "cube-solid.stl");
    stl_binary_cube(&b, "binary cube", 12);
    read_cube(write_tmp("cube-binary.STL", b.d, b.n), "cube-binary.STL (file)");

    /* truncated binary, with and without a "solid" header */
    stl_binary_cube(&b, "solid looks like ascii", 12);
    const char *p = write_tmp("truncated-solid.stl", b.d, b.n - 60);
    READ_FAILS(p, OHM_ERR_PARSE, "triangle 10 (byte 584)", "file ends early", "expected 12 triangles (684 bytes)",
               "got 624 bytes");
    stl_binary_cube(&b, "plain header", 12);
    p = write_tmp("truncated.stl", b.d, b.n - 60);
    READ_FAILS(p, OHM_ERR_PARSE, "triangle 10 (byte 584)", "file ends early");

    /* the example from the design: 1000 triangles declared, 40700 bytes */
    {
        char *big = calloc(40700, 1);
        big[80] = (char)(1000 & 0xff);
        big[81] = (char)(1000 >> 8);
        ohm_mesh m;
        ohm_error e;
        int rc = parse_exact(ohm_mesh_parse_stl, &m, big, 40700, "x.stl", &e);
        CHECK(rc == OHM_ERR_PARSE);
        CHECK_MSG(strcmp(e.msg, "x.stl: triangle 812 (byte 40684): file ends early, expected 1000 triangles "
                                "(50084 bytes), got 40700 bytes") == 0,
                  "%s", e.msg);
        free(big);
    }
    /* more bytes than declared */
    stl_binary_cube(&b, "plain header", 11);
    PARSE_FAILS(ohm_mesh_parse_stl, b.d, b.n, "long.stl", OHM_ERR_PARSE, "declares 11 triangles (634 bytes)",
                "684 bytes");
    /* too short even for the header */
    PARSE_FAILS(ohm_mesh_parse_stl, "\x01\x02garbage", 9, "tiny.stl", OHM_ERR_PARSE, "9 bytes");
    /* NaN in a binary triangle */
    stl_binary_cube(&b, "nan", 12);
    float nanf_ = NAN;
    memcpy(b.d + 84 + 50 * 3 + 12 + 4, &nanf_, 4);
    PARSE_FAILS(ohm_mesh_parse_stl, b.d, b.n, "nan.stl", OHM_ERR_PARSE, "triangle 3 (byte 234)",
                "not a finite number");
    /* ascii errors */
    PARSE_STR_FAILS(ohm_mesh_parse_stl,
                    "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 inf 0\nvertex 0 1 0\n",
                    "inf.stl", OHM_ERR_PARSE, "inf.stl:5:", "'inf' is not a finite number");
    PARSE_STR_FAILS(ohm_mesh_parse_stl, "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n",
                    "early.stl", OHM_ERR_PARSE, "early.stl:5:", "file ends early");
    PARSE_STR_FAILS(ohm_mesh_parse_stl,
                    "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\nendfacet\n",
                    "two.stl", OHM_ERR_PARSE, "two.stl:6:", "facet has 2 vertices");
    PARSE_STR_FAILS(ohm_mesh_parse_stl, "solid empty\nendsolid empty\n", "nofaces.stl", OHM_ERR_PARSE,
                    "no faces");
    free(b.d);
}

/* ---- bad input -------------------------------------------------------------- */

static void test_bad_files(void)
{
    READ_FAILS("tests/data/bad/empty.obj", OHM_ERR_PARSE, ": empty file, expected an OBJ mesh");
    READ_FAILS("tests/data/bad", OHM_ERR_IO, ": is a directory, expected a mesh file");
    READ_FAILS("tests/data/bad/no-such-file.obj", OHM_ERR_IO, ": cannot open: No such file or directory");
    READ_FAILS("tests/data/bad/face-index-out-of-range.obj", OHM_ERR_PARSE, ":6: ",
               "face refers to vertex 9001, file has 4 vertices");
    READ_FAILS("tests/data/bad/face-index-zero.obj", OHM_ERR_PARSE, ":5: ", "index 0");
    READ_FAILS("tests/data/bad/nan-coordinate.obj", OHM_ERR_PARSE, ":3: ", "coordinate 'nan' is not a finite number");
    READ_FAILS("tests/data/bad/two-vertex-face.obj", OHM_ERR_PARSE, ":5: ", "face has 2 vertices");
    READ_FAILS("tests/data/bad/overflow-coordinate.off", OHM_ERR_PARSE, ":5: ", "'1e400' is not a finite number");
    READ_FAILS("tests/data/bad/huge-count.off", OHM_ERR_PARSE, ":3: ", "1000000000000 vertices");
    READ_FAILS("tests/data/bad/truncated.off", OHM_ERR_PARSE, ":13: ", "file ends early, expected 6 faces, got 2");
    READ_FAILS("tests/data/bad/truncated-ascii.ply", OHM_ERR_PARSE, ":16: ", "file ends early in face 1");
    READ_FAILS("tests/data/bad/huge-faces.ply", OHM_ERR_PARSE, ":8: ", "'face' declares 1000000000000 items");
    READ_FAILS("tests/data/bad/garbage-ascii.stl", OHM_ERR_PARSE, ":9: ", "expected 'facet' or 'endsolid', got 'this'");
    READ_FAILS("tests/data/bad/unknown-extension.xyz", OHM_ERR_USAGE, "unknown mesh format '.xyz'", ".obj .ply .stl",
               ".off");

    /* empty files of the other formats name their format */
    READ_FAILS(write_tmp("empty.ply", "", 0), OHM_ERR_PARSE, "empty file, expected a PLY mesh");
    READ_FAILS(write_tmp("empty.stl", "", 0), OHM_ERR_PARSE, "empty file, expected an STL mesh");
    READ_FAILS(write_tmp_gz("empty.off.gz", "", 0), OHM_ERR_PARSE, "empty file, expected an OFF mesh");
    READ_FAILS(write_tmp("noext", "v 0 0 0\n", 8), OHM_ERR_USAGE, "no file extension");

    /* corrupt .gz: truncated stream, flipped bytes, and not gzip at all */
    size_t len;
    char *gz = read_all("samples/ChineseDragon-10kv.off.gz", &len);
    CHECK(gz && len > 1000);
    if (gz) {
        READ_FAILS(write_tmp("cut.off.gz", gz, len / 2), OHM_ERR_PARSE, "corrupt gzip stream");
        for (size_t i = len / 3; i < len / 3 + 64; ++i) gz[i] = (char)~gz[i];
        READ_FAILS(write_tmp("flipped.off.gz", gz, len), OHM_ERR_PARSE, "corrupt gzip stream");
        free(gz);
    }
    const char *plain = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    READ_FAILS(write_tmp("plain.off.gz", plain, strlen(plain)), OHM_ERR_PARSE, "not a gzip file");
}

static void test_bad_buffers(void)
{
    /* OBJ */
    PARSE_STR_FAILS(ohm_mesh_parse_obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n", "rel.obj", OHM_ERR_PARSE,
                    "rel.obj:4:", "vertex -4 (relative)");
    PARSE_STR_FAILS(ohm_mesh_parse_obj, "v 0 0 0\nv 1 0\nf 1 2 3\n", "short.obj", OHM_ERR_PARSE, "short.obj:2:",
                    "vertex has 2 coordinates");
    PARSE_STR_FAILS(ohm_mesh_parse_obj, "v 0 0 0\nv 1 0 0\nv 0 1 0x\nf 1 2 3\n", "x.obj", OHM_ERR_PARSE, "x.obj:3:",
                    "expected a number for z, got '0x'");
    PARSE_STR_FAILS(ohm_mesh_parse_obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 a/3\n", "a.obj", OHM_ERR_PARSE, "a.obj:4:",
                    "bad face vertex 'a/3'");
    PARSE_STR_FAILS(ohm_mesh_parse_obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999\n", "ovf.obj",
                    OHM_ERR_PARSE, "ovf.obj:4:", "too large");
    PARSE_STR_FAILS(ohm_mesh_parse_obj, "v -inf 0 0\n", "inf.obj", OHM_ERR_PARSE, "inf.obj:1:",
                    "'-inf' is not a finite number");
    PARSE_STR_FAILS(ohm_mesh_parse_obj, "# only vertices\nv 0 0 0\nv 1 0 0\nv 0 1 0\n", "pts.obj", OHM_ERR_PARSE,
                    "pts.obj: no faces, expected a closed triangle mesh");
    PARSE_FAILS(ohm_mesh_parse_obj, "", 0, "empty.obj", OHM_ERR_PARSE, "empty file");
    /* OFF */
    PARSE_STR_FAILS(ohm_mesh_parse_off, "PLY\n3 1 0\n", "hdr.off", OHM_ERR_PARSE, "hdr.off:1:", "expected an OFF header");
    PARSE_STR_FAILS(ohm_mesh_parse_off, "4OFF\n3 1 0\n", "4d.off", OHM_ERR_PARSE, "4d.off:1:", "not supported");
    PARSE_STR_FAILS(ohm_mesh_parse_off, "OFF\n3 -1 0\n", "neg.off", OHM_ERR_PARSE, "neg.off:2:", "bad face count '-1'");
    PARSE_STR_FAILS(ohm_mesh_parse_off, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", "idx.off", OHM_ERR_PARSE,
                    "idx.off:6:", "face refers to vertex 3, file has 3 vertices");
    PARSE_STR_FAILS(ohm_mesh_parse_off, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n", "short.off", OHM_ERR_PARSE,
                    "short.off:6:", "face declares 4 vertices, the line has only 3");
    PARSE_STR_FAILS(ohm_mesh_parse_off, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n", "two.off", OHM_ERR_PARSE,
                    "two.off:6:", "face has 2 vertices");
    PARSE_STR_FAILS(ohm_mesh_parse_off, "OFF 99999999999999999999999 1 0\n", "ovf.off", OHM_ERR_PARSE, "ovf.off:1:",
                    "bad vertex count");
    PARSE_STR_FAILS(ohm_mesh_parse_off, "OFF\n", "nocount.off", OHM_ERR_PARSE, "nocount.off:1:", "counts");
    /* PLY */
    PARSE_STR_FAILS(ohm_mesh_parse_ply, "plx\n", "magic.ply", OHM_ERR_PARSE, "magic.ply:1:", "not a PLY file");
    PARSE_STR_FAILS(ohm_mesh_parse_ply, "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n", "eoh.ply",
                    OHM_ERR_PARSE, "eoh.ply:4:", "end_header");
    PARSE_STR_FAILS(ohm_mesh_parse_ply, "ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n",
                    "type.ply", OHM_ERR_PARSE, "type.ply:4:", "unknown property type 'quad'");
    PARSE_STR_FAILS(ohm_mesh_parse_ply,
                    "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n0 0\n",
                    "noz.ply", OHM_ERR_PARSE, "noz.ply:3:", "no property 'z'");
    PARSE_STR_FAILS(ohm_mesh_parse_ply,
                    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float "
                    "z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n",
                    "nan.ply", OHM_ERR_PARSE, "nan.ply:11:", "'nan' is not a finite number");
    PARSE_STR_FAILS(ohm_mesh_parse_ply,
                    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float "
                    "z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
                    "range.ply", OHM_ERR_PARSE, "range.ply:13:", "face refers to vertex 3, file has 3 vertices");
    PARSE_STR_FAILS(ohm_mesh_parse_ply,
                    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float "
                    "z\nend_header\n0 0 0\n1 0 0\n0 1 0\n",
                    "points.ply", OHM_ERR_PARSE, "points.ply: no faces");
}

/* ---- topology on hand-made meshes ----------------------------------------- */

static void test_topology(void)
{
    /* two tetrahedra, disjoint, one with a flipped face, plus an unused vertex,
     * a triangle with a repeated index and a zero-area one */
    double v[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1,   /* tet A: 0..3 */
                  5, 0, 0, 6, 0, 0, 5, 1, 0, 5, 0, 1,   /* tet B: 4..7 */
                  9, 9, 9,                              /* 8: unused */
                  2, 0, 0, 3, 0, 0, 4, 0, 0};           /* 9..11 collinear */
    int64_t t[] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3,  /* tet A, outward */
                   4, 6, 5, 4, 5, 7, 4, 7, 6, 5, 7, 6,  /* tet B, last face flipped */
                   9, 9, 10,                            /* repeated index */
                   9, 10, 11};                          /* zero area */
    ohm_mesh m = {v, t, 12, 10};
    ohm_mesh_topology top;
    ohm_error e;
    ohm_error_clear(&e);
    CHECK(ohm_mesh_topology_compute(&top, &m, &e) == 0);
    CHECK_MSG(top.boundary_edges == 3, "boundary %zu", top.boundary_edges); /* the zero-area triangle's */
    CHECK_MSG(top.misoriented_edges == 3, "misoriented %zu", top.misoriented_edges);
    CHECK_MSG(top.nonmanifold_edges == 0, "nonmanifold %zu", top.nonmanifold_edges);
    CHECK_MSG(top.degenerate_tris == 2, "degenerate %zu", top.degenerate_tris);
    CHECK_MSG(top.components == 3, "components %zu", top.components);
    CHECK_MSG(top.unused_verts == 1, "unused %zu", top.unused_verts);
    /* tet A alone has volume 1/6 */
    m.ntris = 4;
    CHECK_REL(ohm_mesh_signed_volume(&m), 1.0 / 6.0, 1e-14);

    /* three triangles on one edge: non-manifold */
    double w[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1};
    int64_t u[] = {0, 1, 2, 1, 0, 3, 0, 1, 4};
    ohm_mesh fin = {w, u, 5, 3};
    CHECK(ohm_mesh_topology_compute(&top, &fin, &e) == 0);
    CHECK_MSG(top.nonmanifold_edges == 1 && top.boundary_edges == 6, "nonmanifold %zu boundary %zu",
              top.nonmanifold_edges, top.boundary_edges);

    /* an index out of range is reported, not followed */
    u[2] = 5;
    CHECK(ohm_mesh_topology_compute(&top, &fin, &e) == OHM_ERR_INVALID);
    CHECK(strstr(e.msg, "vertex 5") != NULL);

    /* free accepts NULL and a zeroed mesh */
    ohm_mesh z = {0};
    ohm_mesh_free(&z);
    ohm_mesh_free(NULL);
    double lo[3], hi[3];
    ohm_mesh_bounds(&z, lo, hi);
    CHECK(lo[0] == 0 && hi[2] == 0);
    CHECK(ohm_mesh_signed_volume(&z) == 0);
}

int main(void)
{
    if (tmp_begin("ohm_test_mesh_io")) return 1;
    test_samples();
    test_obj();
    test_off();
    test_ply();
    test_stl();
    test_bad_files();
    test_bad_buffers();
    test_topology();
    cleanup_tmp();
    return check_summary();
}
