/* mesh_io.c — the OBJ / OFF / PLY / STL readers behind mesh.h.
 *
 * Every reader works on a (data, len) buffer that is NOT NUL-terminated and may
 * hold any bytes (the fuzz harnesses call the parse_* entry points directly), so:
 *  - no byte at or past data+len is ever read; numbers are parsed from a bounded
 *    NUL-terminated copy of their token (strtod for accuracy);
 *  - no count read from a file is trusted before the bytes it needs are there:
 *    allocations sized from a header are checked against what the rest of the
 *    buffer could hold, and everything else grows by doubling from what was
 *    actually parsed, so memory stays proportional to the input;
 *  - all size arithmetic is overflow-checked.
 * Messages: "name:line: what (expected what)" for text, "name: element N (byte
 * B): what" for binary.  Content errors are OHM_ERR_PARSE, files that cannot be
 * opened or read OHM_ERR_IO, an unsupported extension OHM_ERR_USAGE.
 *
 * Ownership: a builder (mb) owns the growing arrays until mb_finish hands them
 * to the caller's ohm_mesh; every failure path frees them and leaves the output
 * zeroed. */
#include "input/mesh.h"

#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <zlib.h>

/* Longest number token we accept (a %.17g double is ~25 characters). */
#define NUM_TOKEN_MAX 256
/* Largest decompressed .gz we read. */
#define GZ_MAX_BYTES ((uint64_t)4 << 30)

/* ------------------------------------------------------------------------ */
/* Mesh builder                                                              */

typedef struct mb {
    const char *name;
    ohm_error *err;
    double *v;      /* 3 per vertex */
    size_t nv, vcap;
    int64_t *t;     /* 3 per triangle */
    size_t nt, tcap;
} mb;

static void mb_init(mb *b, const char *name, ohm_error *err)
{
    memset(b, 0, sizeof *b);
    b->name = name ? name : "<buffer>";
    b->err = err;
}

static void mb_free(mb *b)
{
    free(b->v);
    free(b->t);
    b->v = NULL;
    b->t = NULL;
    b->nv = b->vcap = b->nt = b->tcap = 0;
}

static int mb_nomem(mb *b, const char *what, size_t n)
{
    return ohm_fail(b->err, OHM_ERR_NOMEM, "%s: out of memory allocating %zu %s", b->name, n, what);
}

/* Make room for `need` items of `elem` bytes in *p (capacity *cap). */
static int grow_to(mb *b, void **p, size_t *cap, size_t need, size_t elem, const char *what)
{
    if (need <= *cap) return 0;
    size_t nc = *cap ? *cap : 16;
    while (nc < need) nc = nc > SIZE_MAX / 2 ? need : nc * 2;
    if (nc > SIZE_MAX / elem) return mb_nomem(b, what, need);
    void *q = realloc(*p, nc * elem);
    if (!q) return mb_nomem(b, what, need);
    *p = q;
    *cap = nc;
    return 0;
}

static int mb_reserve_verts(mb *b, size_t n)
{
    if (n > SIZE_MAX - b->nv) return mb_nomem(b, "vertices", n);
    return grow_to(b, (void **)&b->v, &b->vcap, b->nv + n, 3 * sizeof(double), "vertices");
}

static int mb_reserve_tris(mb *b, size_t n)
{
    if (n > SIZE_MAX - b->nt) return mb_nomem(b, "triangles", n);
    return grow_to(b, (void **)&b->t, &b->tcap, b->nt + n, 3 * sizeof(int64_t), "triangles");
}

static int mb_vert(mb *b, const double c[3])
{
    if (b->nv == b->vcap) {
        int rc = mb_reserve_verts(b, 1);
        if (rc) return rc;
    }
    memcpy(b->v + 3 * b->nv, c, 3 * sizeof(double));
    b->nv++;
    return 0;
}

static int mb_tri(mb *b, int64_t i, int64_t j, int64_t k)
{
    if (b->nt == b->tcap) {
        int rc = mb_reserve_tris(b, 1);
        if (rc) return rc;
    }
    int64_t *t = b->t + 3 * b->nt;
    t[0] = i;
    t[1] = j;
    t[2] = k;
    b->nt++;
    return 0;
}

/* Polygons are fan-triangulated as their vertices arrive: (v0, prev, cur). */
typedef struct fan {
    int64_t first, prev;
    size_t n;
} fan;

static int fan_add(mb *b, fan *f, int64_t v)
{
    int rc = 0;
    if (f->n == 0) f->first = v;
    else if (f->n >= 2) rc = mb_tri(b, f->first, f->prev, v);
    f->prev = v;
    f->n++;
    return rc;
}

static int mb_finish(mb *b, ohm_mesh *out)
{
    if (b->nt == 0) {
        mb_free(b);
        return ohm_fail(b->err, OHM_ERR_PARSE, "%s: no faces, expected a closed triangle mesh", b->name);
    }
    /* Give back the doubling slack; a failed shrink keeps the larger block. */
    if (b->vcap > b->nv && b->nv > 0) {
        void *q = realloc(b->v, b->nv * 3 * sizeof(double));
        if (q) b->v = q;
    }
    if (b->tcap > b->nt) {
        void *q = realloc(b->t, b->nt * 3 * sizeof(int64_t));
        if (q) b->t = q;
    }
    out->verts = b->v;
    out->tris = b->t;
    out->nverts = b->nv;
    out->ntris = b->nt;
    b->v = NULL;
    b->t = NULL;
    return OHM_OK;
}

static uint64_t mix64(uint64_t x)
{
    /* splitmix64 finaliser */
    x ^= x >> 30;
    x *= 0xbf58476d1ce4e5b9ULL;
    x ^= x >> 27;
    x *= 0x94d049bb133111ebULL;
    x ^= x >> 31;
    return x;
}

/* Merge vertices with exactly equal coordinates (STL stores every triangle's
 * corners separately).  Open addressing, O(n); compacts b->v in place — the
 * unique vertex j is written at j <= i after vertex i has been read. */
static int mb_weld(mb *b)
{
    size_t n = b->nv;
    if (n == 0) return 0;
    size_t cap = 16;
    while (cap / 2 < n) {
        if (cap > SIZE_MAX / 4) return mb_nomem(b, "weld table entries", n);
        cap *= 2;
    }
    if (cap > SIZE_MAX / sizeof(size_t)) return mb_nomem(b, "weld table entries", cap);
    size_t *tab = malloc(cap * sizeof *tab);
    size_t *map = malloc(n * sizeof *map);
    if (!tab || !map) {
        free(tab);
        free(map);
        return mb_nomem(b, "weld table entries", cap);
    }
    for (size_t i = 0; i < cap; ++i) tab[i] = SIZE_MAX;
    size_t nu = 0, mask = cap - 1;
    for (size_t i = 0; i < n; ++i) {
        double c[3];
        uint64_t h = 0;
        for (int k = 0; k < 3; ++k) {
            c[k] = b->v[3 * i + k];
            if (c[k] == 0) c[k] = 0; /* -0 and +0 are the same point */
            uint64_t bits;
            memcpy(&bits, &c[k], sizeof bits);
            h = mix64(h ^ bits);
        }
        size_t s = (size_t)h & mask;
        for (;;) {
            size_t j = tab[s];
            if (j == SIZE_MAX) {
                memcpy(b->v + 3 * nu, c, sizeof c);
                tab[s] = nu;
                map[i] = nu++;
                break;
            }
            const double *q = b->v + 3 * j;
            if (q[0] == c[0] && q[1] == c[1] && q[2] == c[2]) {
                map[i] = j;
                break;
            }
            s = (s + 1) & mask;
        }
    }
    for (size_t i = 0; i < 3 * b->nt; ++i) b->t[i] = (int64_t)map[b->t[i]];
    b->nv = nu;
    free(tab);
    free(map);
    return 0;
}

/* ------------------------------------------------------------------------ */
/* Text: lines and tokens                                                    */

typedef struct tok {
    const char *s;
    size_t n;
} tok;

typedef struct lines {
    const char *p, *end;  /* start of the next line; end of the buffer        */
    const char *lp, *le;  /* token cursor in the current line; its end        */
    size_t line, next;    /* number of the current line; of the next one     */
    int cont;             /* a '\' before the newline continues the line     */
    int hash;             /* a token starting with '#' starts a comment      */
} lines;

static void lines_init(lines *L, const char *d, size_t n, int cont, int hash)
{
    /* a UTF-8 byte-order mark is not content */
    if (n >= 3 && memcmp(d, "\xEF\xBB\xBF", 3) == 0) {
        d += 3;
        n -= 3;
    }
    L->p = L->lp = L->le = d;
    L->end = d + n;
    L->line = L->next = 1;
    L->cont = cont;
    L->hash = hash;
}

static int is_ws(char c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f';
}

/* After a backslash at p: only '\r's, then a newline or the end of the line? */
static int is_cont(const char *p, const char *e)
{
    while (p < e && *p == '\r') ++p;
    return p == e || *p == '\n';
}

/* Advance to the next (logical) line; 0 at the end of the buffer. */
static int lines_next(lines *L)
{
    if (L->p >= L->end) return 0;
    const char *s = L->p, *from = s, *q;
    size_t extra = 0;
    for (;;) {
        q = memchr(from, '\n', (size_t)(L->end - from));
        if (!q || !L->cont) break;
        const char *c = q;
        while (c > s && c[-1] == '\r') --c;
        if (!(c > s && c[-1] == '\\')) break;
        ++extra;
        from = q + 1;
        if (from >= L->end) {
            q = NULL;
            break;
        }
    }
    L->lp = s;
    L->le = q ? q : L->end;
    L->p = q ? q + 1 : L->end;
    L->line = L->next;
    L->next += 1 + extra;
    return 1;
}

/* Next token of the current line; 0 when the line (or its comment) ends. */
static int line_tok(lines *L, tok *t)
{
    const char *p = L->lp, *e = L->le;
    for (;;) {
        while (p < e && is_ws(*p)) ++p;
        if (L->cont && p < e && *p == '\\' && is_cont(p + 1, e)) {
            ++p;
            continue;
        }
        break;
    }
    if (p >= e || (L->hash && *p == '#')) {
        L->lp = e;
        return 0;
    }
    const char *s = p;
    while (p < e && !is_ws(*p) && !(L->cont && *p == '\\' && is_cont(p + 1, e))) ++p;
    L->lp = p;
    t->s = s;
    t->n = (size_t)(p - s);
    return 1;
}

/* Next token, moving on to later lines as needed; 0 at the end of the buffer. */
static int stream_tok(lines *L, tok *t)
{
    for (;;) {
        if (line_tok(L, t)) return 1;
        if (!lines_next(L)) return 0;
    }
}

/* Next line that has a token; that token in *t.  0 at the end of the buffer. */
static int next_content_line(lines *L, tok *t)
{
    while (lines_next(L))
        if (line_tok(L, t)) return 1;
    return 0;
}

static int tok_eq(tok t, const char *s)
{
    size_t n = strlen(s);
    return t.n == n && memcmp(t.s, s, n) == 0;
}

/* ASCII case-insensitive comparison of n bytes. */
static int ieq_n(const char *a, const char *b, size_t n)
{
    for (size_t i = 0; i < n; ++i) {
        char x = a[i], y = b[i];
        if (x >= 'A' && x <= 'Z') x = (char)(x - 'A' + 'a');
        if (y >= 'A' && y <= 'Z') y = (char)(y - 'A' + 'a');
        if (x != y) return 0;
    }
    return 1;
}

static int tok_ieq(tok t, const char *s)
{
    return t.n == strlen(s) && ieq_n(t.s, s, t.n);
}

/* A printable, bounded copy of a token for messages. */
typedef struct shown {
    char s[64];
} shown;

static shown show(tok t)
{
    shown r;
    size_t n = t.n < 40 ? t.n : 40, i;
    for (i = 0; i < n; ++i) {
        unsigned char c = (unsigned char)t.s[i];
        r.s[i] = (c >= 0x20 && c < 0x7f) ? (char)c : '?';
    }
    if (t.n > n) {
        memcpy(r.s + i, "...", 3);
        i += 3;
    }
    r.s[i] = '\0';
    return r;
}

/* 0 ok, 1 not a number, 2 not finite (nan, inf, or overflows to inf). */
static int parse_double(tok t, double *out)
{
    char buf[NUM_TOKEN_MAX];
    if (t.n == 0 || t.n >= sizeof buf) return 1;
    memcpy(buf, t.s, t.n);
    buf[t.n] = '\0';
    char *e;
    double d = strtod(buf, &e);
    if (e != buf + t.n) return 1;
    if (!isfinite(d)) return 2;
    *out = d;
    return 0;
}

/* Optional sign and decimal digits at the start of s[0..n).  Returns the number
 * of characters used (0: no digits); *ovf set when |value| > INT64_MAX. */
static size_t parse_int_prefix(const char *s, size_t n, int64_t *out, int *ovf)
{
    size_t i = 0;
    int neg = 0;
    *ovf = 0;
    if (i < n && (s[i] == '+' || s[i] == '-')) neg = s[i++] == '-';
    size_t d0 = i;
    uint64_t v = 0;
    while (i < n && s[i] >= '0' && s[i] <= '9') {
        unsigned dig = (unsigned)(s[i] - '0');
        if (v > ((uint64_t)INT64_MAX - dig) / 10) *ovf = 1;
        else v = v * 10 + dig;
        ++i;
    }
    if (i == d0) return 0;
    *out = neg ? -(int64_t)v : (int64_t)v;
    return i;
}

/* 0 ok, 1 not an integer, 2 too large. */
static int parse_int(tok t, int64_t *out)
{
    int ovf;
    size_t used = parse_int_prefix(t.s, t.n, out, &ovf);
    if (used == 0 || used != t.n) return 1;
    return ovf ? 2 : 0;
}

static const char *const axis_name[3] = {"x", "y", "z"};

/* A coordinate token on line `line`; `what` names it ("x"). */
static int coord_tok(mb *b, size_t line, tok t, const char *what, double *out)
{
    int rc = parse_double(t, out);
    if (rc == 1)
        return ohm_fail(b->err, OHM_ERR_PARSE, "%s:%zu: expected a number for %s, got '%s'", b->name,
                        line, what, show(t).s);
    if (rc == 2)
        return ohm_fail(b->err, OHM_ERR_PARSE, "%s:%zu: coordinate '%s' is not a finite number",
                        b->name, line, show(t).s);
    return 0;
}

/* Three coordinates from the current line (extra tokens are left alone). */
static int coords_line(mb *b, lines *L, const char *what, double c[3])
{
    for (int k = 0; k < 3; ++k) {
        tok t;
        if (!line_tok(L, &t))
            return ohm_fail(b->err, OHM_ERR_PARSE, "%s:%zu: %s has %d coordinate%s, expected 3 (x y z)",
                            b->name, L->line, what, k, k == 1 ? "" : "s");
        int rc = coord_tok(b, L->line, t, axis_name[k], &c[k]);
        if (rc) return rc;
    }
    return 0;
}

static int empty_file(const char *name, const char *kind, ohm_error *err)
{
    return ohm_fail(err, OHM_ERR_PARSE, "%s: empty file, expected %s mesh", name ? name : "<buffer>",
                    kind);
}

/* ------------------------------------------------------------------------ */
/* OBJ                                                                       */

int ohm_mesh_parse_obj(ohm_mesh *out, const char *data, size_t len, const char *name, ohm_error *err)
{
    memset(out, 0, sizeof *out);
    if (!data || len == 0) return empty_file(name, "an OBJ", err);
    mb b;
    mb_init(&b, name, err);
    lines L;
    lines_init(&L, data, len, 1, 1);
    int rc = 0;
    int64_t maxref = 0; /* largest 1-based index seen: forward references are legal */
    size_t maxref_line = 0;
    tok kw, t;
    while (rc == 0 && next_content_line(&L, &kw)) {
        if (tok_eq(kw, "v")) {
            double c[3];
            rc = coords_line(&b, &L, "vertex", c);
            if (rc == 0) rc = mb_vert(&b, c);
        } else if (tok_eq(kw, "f")) {
            fan f = {0, 0, 0};
            while (rc == 0 && line_tok(&L, &t)) {
                int64_t idx = 0;
                int ovf;
                size_t used = parse_int_prefix(t.s, t.n, &idx, &ovf);
                if (used == 0 || (used < t.n && t.s[used] != '/')) {
                    rc = ohm_fail(err, OHM_ERR_PARSE,
                                  "%s:%zu: bad face vertex '%s' (expected i, i/t, i//n or i/t/n with an "
                                  "integer i)",
                                  b.name, L.line, show(t).s);
                } else if (ovf) {
                    rc = ohm_fail(err, OHM_ERR_PARSE, "%s:%zu: face vertex index '%s' is too large",
                                  b.name, L.line, show(t).s);
                } else if (idx == 0) {
                    rc = ohm_fail(err, OHM_ERR_PARSE,
                                  "%s:%zu: face vertex index 0 (OBJ indices start at 1, or are negative "
                                  "for relative)",
                                  b.name, L.line);
                } else if (idx < 0) {
                    if ((uint64_t)(-idx) > b.nv)
                        rc = ohm_fail(err, OHM_ERR_PARSE,
                                      "%s:%zu: face refers to vertex %" PRId64
                                      " (relative), only %zu vertices are defined before this line",
                                      b.name, L.line, idx, b.nv);
                    else
                        rc = fan_add(&b, &f, (int64_t)b.nv + idx);
                } else {
                    if (idx > maxref) {
                        maxref = idx;
                        maxref_line = L.line;
                    }
                    rc = fan_add(&b, &f, idx - 1);
                }
            }
            if (rc == 0 && f.n < 3)
                rc = ohm_fail(err, OHM_ERR_PARSE, "%s:%zu: face has %zu vertices, expected at least 3",
                              b.name, L.line, f.n);
        }
        /* vt vn vp g o s usemtl mtllib l p, and anything unknown: ignored */
    }
    if (rc == 0 && (uint64_t)maxref > b.nv)
        rc = ohm_fail(err, OHM_ERR_PARSE, "%s:%zu: face refers to vertex %" PRId64 ", file has %zu vertices",
                      b.name, maxref_line, maxref, b.nv);
    if (rc) {
        mb_free(&b);
        return rc;
    }
    return mb_finish(&b, out);
}

/* ------------------------------------------------------------------------ */
/* OFF                                                                       */

/* A count token: a non-negative integer. */
static int count_tok(mb *b, size_t line, tok t, const char *what, int64_t *out)
{
    int rc = parse_int(t, out);
    if (rc == 0 && *out >= 0) return 0;
    return ohm_fail(b->err, OHM_ERR_PARSE, "%s:%zu: bad %s '%s' (expected a non-negative integer)", b->name,
                    line, what, show(t).s);
}

int ohm_mesh_parse_off(ohm_mesh *out, const char *data, size_t len, const char *name, ohm_error *err)
{
    memset(out, 0, sizeof *out);
    if (!data || len == 0) return empty_file(name, "an OFF", err);
    mb b;
    mb_init(&b, name, err);
    lines L;
    lines_init(&L, data, len, 0, 1);
    int rc = 0;
    tok t;

    /* Header keyword: [ST][C][N]OFF; the extra per-vertex fields are skipped
     * because only the first three numbers of a vertex line are read. */
    if (!next_content_line(&L, &t)) {
        rc = ohm_fail(err, OHM_ERR_PARSE, "%s: no OFF header (the file holds only blank lines and comments)",
                      b.name);
        goto fail;
    }
    {
        size_t i = 0;
        if (t.n >= 2 && memcmp(t.s, "ST", 2) == 0) i += 2;
        if (i < t.n && t.s[i] == 'C') ++i;
        if (i < t.n && t.s[i] == 'N') ++i;
        if (i < t.n && (t.s[i] == '4' || t.s[i] == 'n')) {
            rc = ohm_fail(err, OHM_ERR_PARSE,
                          "%s:%zu: header '%s' is not supported (expected 3-D OFF: OFF, COFF, NOFF or CNOFF)",
                          b.name, L.line, show(t).s);
            goto fail;
        }
        if (t.n - i != 3 || memcmp(t.s + i, "OFF", 3) != 0) {
            rc = ohm_fail(err, OHM_ERR_PARSE,
                          "%s:%zu: expected an OFF header (OFF, COFF, NOFF or CNOFF), got '%s'", b.name,
                          L.line, show(t).s);
            goto fail;
        }
    }
    /* Counts: on the header line ("OFF 8 6 0") or the next line with content. */
    int64_t nv, nf;
    if (!line_tok(&L, &t) && !next_content_line(&L, &t)) {
        rc = ohm_fail(err, OHM_ERR_PARSE,
                      "%s:%zu: file ends after the header, expected the counts 'vertices faces edges'",
                      b.name, L.line);
        goto fail;
    }
    if ((rc = count_tok(&b, L.line, t, "vertex count", &nv))) goto fail;
    if (!line_tok(&L, &t)) {
        rc = ohm_fail(err, OHM_ERR_PARSE,
                      "%s:%zu: expected the counts 'vertices faces edges', the face count is missing",
                      b.name, L.line);
        goto fail;
    }
    if ((rc = count_tok(&b, L.line, t, "face count", &nf))) goto fail;
    /* the edge count, if any, is not needed */

    /* Never allocate more than the rest of the file can hold: a vertex needs at
     * least "0 0 0\n" (6 bytes), a face a count and a separator (2; a short
     * face then gets its own, more precise message). */
    {
        size_t rest = (size_t)(L.end - L.p) + 1;
        if ((uint64_t)nv > rest / 6 || (uint64_t)nf > rest / 2 ||
            (uint64_t)nv * 6 + (uint64_t)nf * 2 > rest) {
            rc = ohm_fail(err, OHM_ERR_PARSE,
                          "%s:%zu: header declares %" PRId64 " vertices and %" PRId64
                          " faces, more than the remaining %zu bytes can hold (at least 6 bytes per vertex, "
                          "2 per face)",
                          b.name, L.line, nv, nf, rest - 1);
            goto fail;
        }
    }
    if ((rc = mb_reserve_verts(&b, (size_t)nv))) goto fail;
    if ((rc = mb_reserve_tris(&b, (size_t)nf))) goto fail;

    for (int64_t i = 0; i < nv; ++i) {
        double c[3];
        if (!next_content_line(&L, &t)) {
            rc = ohm_fail(err, OHM_ERR_PARSE, "%s:%zu: file ends early, expected %" PRId64
                          " vertices, got %" PRId64, b.name, L.line, nv, i);
            goto fail;
        }
        L.lp = t.s; /* re-read the first token as x */
        if ((rc = coords_line(&b, &L, "vertex", c))) goto fail;
        if ((rc = mb_vert(&b, c))) goto fail;
    }
    for (int64_t i = 0; i < nf; ++i) {
        int64_t n;
        if (!next_content_line(&L, &t)) {
            rc = ohm_fail(err, OHM_ERR_PARSE, "%s:%zu: file ends early, expected %" PRId64
                          " faces, got %" PRId64, b.name, L.line, nf, i);
            goto fail;
        }
        if ((rc = count_tok(&b, L.line, t, "face vertex count", &n))) goto fail;
        if (n < 3) {
            rc = ohm_fail(err, OHM_ERR_PARSE, "%s:%zu: face has %" PRId64 " vertices, expected at least 3",
                          b.name, L.line, n);
            goto fail;
        }
        fan f = {0, 0, 0};
        for (int64_t k = 0; k < n; ++k) {
            int64_t v;
            if (!line_tok(&L, &t)) {
                rc = ohm_fail(err, OHM_ERR_PARSE,
                              "%s:%zu: face declares %" PRId64 " vertices, the line has only %" PRId64,
                              b.name, L.line, n, k);
                goto fail;
            }
            int prc = parse_int(t, &v);
            if (prc == 1) {
                rc = ohm_fail(err, OHM_ERR_PARSE, "%s:%zu: expected a vertex index, got '%s'", b.name,
                              L.line, show(t).s);
                goto fail;
            }
            if (prc == 2 || v < 0 || v >= nv) {
                rc = ohm_fail(err, OHM_ERR_PARSE,
                              "%s:%zu: face refers to vertex %s, file has %" PRId64
                              " vertices (indices 0..%" PRId64 ")",
                              b.name, L.line, show(t).s, nv, nv - 1);
                goto fail;
            }
            if ((rc = fan_add(&b, &f, v))) goto fail;
        }
        /* anything after the indices (a colour) is ignored */
    }
    return mb_finish(&b, out);
fail:
    mb_free(&b);
    return rc;
}

/* ------------------------------------------------------------------------ */
/* PLY                                                                       */

enum { PT_NONE, PT_I8, PT_U8, PT_I16, PT_U16, PT_I32, PT_U32, PT_F32, PT_F64 };
static const unsigned char ply_tsize[] = {0, 1, 1, 2, 2, 4, 4, 4, 8};
static const struct {
    const char *name;
    unsigned char type;
} ply_types[] = {{"char", PT_I8},    {"int8", PT_I8},    {"uchar", PT_U8},   {"uint8", PT_U8},
                 {"short", PT_I16},  {"int16", PT_I16},  {"ushort", PT_U16}, {"uint16", PT_U16},
                 {"int", PT_I32},    {"int32", PT_I32},  {"uint", PT_U32},   {"uint32", PT_U32},
                 {"float", PT_F32},  {"float32", PT_F32}, {"double", PT_F64}, {"float64", PT_F64}};

static int ply_type(tok t)
{
    for (size_t i = 0; i < sizeof ply_types / sizeof ply_types[0]; ++i)
        if (tok_eq(t, ply_types[i].name)) return ply_types[i].type;
    return PT_NONE;
}

static int ply_is_int(int type) { return type >= PT_I8 && type <= PT_U32; }

typedef struct ply_prop {
    tok name;
    unsigned char type;  /* scalar type, or the item type of a list */
    unsigned char ctype; /* PT_NONE for a scalar; the count type of a list */
} ply_prop;

typedef struct ply_elem {
    tok name;
    int64_t count;
    size_t line; /* header line that declared it */
    ply_prop *props;
    size_t nprops, cap;
} ply_elem;

typedef struct ply {
    mb *b;
    int format; /* 0 ascii, 1 binary little endian, 2 binary big endian */
    ply_elem *elems;
    size_t nelems, cap;
    ply_elem *vert, *face;
    size_t ix[3];  /* property index of x, y, z in vert */
    size_t iface;  /* property index of the vertex index list in face */
} ply;

static void ply_free(ply *P)
{
    for (size_t i = 0; i < P->nelems; ++i) free(P->elems[i].props);
    free(P->elems);
}

/* 'format ascii|binary_little_endian|binary_big_endian VERSION'; the version is not read. */
static int ply_format_line(ply *P, lines *L)
{
    mb *b = P->b;
    tok t = {NULL, 0}; /* stays empty when the line ends here */
    line_tok(L, &t);
    if (tok_eq(t, "ascii")) P->format = 0;
    else if (tok_eq(t, "binary_little_endian")) P->format = 1;
    else if (tok_eq(t, "binary_big_endian")) P->format = 2;
    else
        return ohm_fail(b->err, OHM_ERR_PARSE,
                        "%s:%zu: unknown format '%s' (expected ascii, binary_little_endian or binary_big_endian)",
                        b->name, L->line, show(t).s);
    return 0;
}

/* 'element NAME COUNT': a new element, which the property lines after it describe. */
static int ply_element_line(ply *P, lines *L)
{
    mb *b = P->b;
    tok nm, cnt;
    int64_t count;
    if (!line_tok(L, &nm) || !line_tok(L, &cnt))
        return ohm_fail(b->err, OHM_ERR_PARSE, "%s:%zu: expected 'element NAME COUNT'", b->name, L->line);
    int rc = count_tok(b, L->line, cnt, "element count", &count);
    if (rc) return rc;
    if ((rc = grow_to(b, (void **)&P->elems, &P->cap, P->nelems + 1, sizeof(ply_elem), "PLY elements"))) return rc;
    ply_elem *e = &P->elems[P->nelems++];
    memset(e, 0, sizeof *e);
    e->name = nm;
    e->count = count;
    e->line = L->line;
    return 0;
}

/* The rest of 'property list COUNT_TYPE ITEM_TYPE NAME' into p. */
static int ply_list_property(const ply *P, lines *L, ply_prop *p)
{
    mb *b = P->b;
    tok ct, it;
    if (!line_tok(L, &ct) || !line_tok(L, &it) || !line_tok(L, &p->name))
        return ohm_fail(b->err, OHM_ERR_PARSE, "%s:%zu: expected 'property list COUNT_TYPE ITEM_TYPE NAME'", b->name,
                        L->line);
    p->ctype = (unsigned char)ply_type(ct);
    p->type = (unsigned char)ply_type(it);
    if (!ply_is_int(p->ctype))
        return ohm_fail(b->err, OHM_ERR_PARSE,
                        "%s:%zu: list count type '%s' is not an integer type (expected uchar, ushort, uint, ...)",
                        b->name, L->line, show(ct).s);
    if (p->type == PT_NONE)
        return ohm_fail(b->err, OHM_ERR_PARSE, "%s:%zu: unknown property type '%s'", b->name, L->line, show(it).s);
    return 0;
}

/* 'property TYPE NAME' or 'property list ...': one more property of the last element. */
static int ply_property_line(ply *P, lines *L)
{
    mb *b = P->b;
    if (P->nelems == 0)
        return ohm_fail(b->err, OHM_ERR_PARSE, "%s:%zu: property before any element", b->name, L->line);
    ply_elem *e = &P->elems[P->nelems - 1];
    ply_prop p = {{NULL, 0}, PT_NONE, PT_NONE};
    tok ty;
    if (!line_tok(L, &ty))
        return ohm_fail(b->err, OHM_ERR_PARSE, "%s:%zu: expected 'property TYPE NAME'", b->name, L->line);
    if (tok_eq(ty, "list")) {
        int rc = ply_list_property(P, L, &p);
        if (rc) return rc;
    } else {
        p.type = (unsigned char)ply_type(ty);
        if (p.type == PT_NONE)
            return ohm_fail(b->err, OHM_ERR_PARSE,
                            "%s:%zu: unknown property type '%s' (expected char uchar short ushort int uint float "
                            "double, or int8 ... float64)",
                            b->name, L->line, show(ty).s);
        if (!line_tok(L, &p.name))
            return ohm_fail(b->err, OHM_ERR_PARSE, "%s:%zu: expected 'property TYPE NAME'", b->name, L->line);
    }
    int rc = grow_to(b, (void **)&e->props, &e->cap, e->nprops + 1, sizeof(ply_prop), "PLY properties");
    if (rc) return rc;
    e->props[e->nprops++] = p;
    return 0;
}

/* The header's lines from 'ply' to 'end_header', into P's format and elements. */
static int ply_header_lines(ply *P, lines *L)
{
    mb *b = P->b;
    ohm_error *err = b->err;
    tok t;
    int have_format = 0;
    if (!lines_next(L) || !line_tok(L, &t) || !tok_eq(t, "ply"))
        return ohm_fail(err, OHM_ERR_PARSE, "%s:1: not a PLY file (expected 'ply' on the first line)", b->name);
    for (;;) {
        if (!lines_next(L))
            return ohm_fail(err, OHM_ERR_PARSE, "%s:%zu: file ends inside the header, expected 'end_header'",
                            b->name, L->line);
        if (!line_tok(L, &t)) continue; /* blank line */
        if (tok_eq(t, "comment") || tok_eq(t, "obj_info")) continue;
        if (tok_eq(t, "end_header")) break;
        int rc;
        if (tok_eq(t, "format")) {
            rc = ply_format_line(P, L);
            have_format = 1;
        } else if (tok_eq(t, "element"))
            rc = ply_element_line(P, L);
        else if (tok_eq(t, "property"))
            rc = ply_property_line(P, L);
        else
            rc = ohm_fail(err, OHM_ERR_PARSE,
                          "%s:%zu: unknown header line '%s' (expected format, element, property, comment or "
                          "end_header)",
                          b->name, L->line, show(t).s);
        if (rc) return rc;
    }
    if (!have_format)
        return ohm_fail(err, OHM_ERR_PARSE, "%s:%zu: header has no 'format' line", b->name, L->line);
    return 0;
}

/* The elements ohm reads: 'vertex' (required) and 'face', each at most once. */
static int ply_find_elements(ply *P, size_t end_line)
{
    mb *b = P->b;
    for (size_t i = 0; i < P->nelems; ++i) {
        ply_elem *e = &P->elems[i];
        ply_elem **slot = tok_eq(e->name, "vertex") ? &P->vert : tok_eq(e->name, "face") ? &P->face : NULL;
        if (!slot) continue;
        if (*slot)
            return ohm_fail(b->err, OHM_ERR_PARSE, "%s:%zu: a second '%s' element (the first is on line %zu)",
                            b->name, e->line, show(e->name).s, (*slot)->line);
        *slot = e;
    }
    if (!P->vert)
        return ohm_fail(b->err, OHM_ERR_PARSE, "%s:%zu: header has no 'vertex' element", b->name, end_line);
    return 0;
}

/* The scalar properties x, y and z of 'vertex', into P->ix. */
static int ply_vertex_xyz(ply *P)
{
    mb *b = P->b;
    const ply_elem *v = P->vert;
    for (int k = 0; k < 3; ++k) {
        size_t j;
        for (j = 0; j < v->nprops; ++j)
            if (tok_eq(v->props[j].name, axis_name[k])) break;
        if (j == v->nprops)
            return ohm_fail(b->err, OHM_ERR_PARSE, "%s:%zu: element 'vertex' has no property '%s'", b->name, v->line,
                            axis_name[k]);
        if (v->props[j].ctype != PT_NONE)
            return ohm_fail(b->err, OHM_ERR_PARSE, "%s:%zu: vertex property '%s' is a list, expected a scalar",
                            b->name, v->line, axis_name[k]);
        P->ix[k] = j;
    }
    return 0;
}

/* The list of vertex indices in 'face', into P->iface: the one named
 * vertex_indices or vertex_index, else the first list. */
static int ply_face_list(ply *P)
{
    mb *b = P->b;
    const ply_elem *f = P->face;
    size_t j, first_list = SIZE_MAX;
    for (j = 0; j < f->nprops; ++j) {
        const ply_prop *p = &f->props[j];
        if (p->ctype == PT_NONE) continue;
        if (first_list == SIZE_MAX) first_list = j;
        if (tok_eq(p->name, "vertex_indices") || tok_eq(p->name, "vertex_index")) break;
    }
    if (j == f->nprops) j = first_list;
    if (j == SIZE_MAX)
        return ohm_fail(b->err, OHM_ERR_PARSE,
                        "%s:%zu: element 'face' has no list property (expected 'property list uchar int "
                        "vertex_indices')",
                        b->name, f->line);
    if (!ply_is_int(f->props[j].type))
        return ohm_fail(b->err, OHM_ERR_PARSE, "%s:%zu: face list '%s' holds non-integer vertex indices", b->name,
                        f->line, show(f->props[j].name).s);
    P->iface = j;
    return 0;
}

/* The header, read and checked: what the body holds and where ohm finds x, y,
 * z and the faces' vertex indices in it. */
static int ply_header(ply *P, lines *L)
{
    int rc = ply_header_lines(P, L);
    if (!rc) rc = ply_find_elements(P, L->line);
    if (!rc) rc = ply_vertex_xyz(P);
    if (!rc && P->face) rc = ply_face_list(P);
    return rc;
}

/* Reserve storage for element e once its count is known to fit the data. */
static int ply_reserve(ply *P, const ply_elem *e)
{
    if (e == P->vert) return mb_reserve_verts(P->b, (size_t)e->count);
    if (e == P->face) return mb_reserve_tris(P->b, (size_t)e->count);
    return 0;
}

static int ply_index(ply *P, fan *f, int64_t v, const char *where, size_t line_or_item, size_t byte)
{
    mb *b = P->b;
    int64_t nv = P->vert->count;
    if (v < 0 || v >= nv) {
        if (byte == SIZE_MAX)
            return ohm_fail(b->err, OHM_ERR_PARSE,
                            "%s:%zu: face refers to vertex %" PRId64 ", file has %" PRId64 " vertices", b->name,
                            line_or_item, v, nv);
        return ohm_fail(b->err, OHM_ERR_PARSE,
                        "%s: %s %zu (byte %zu): refers to vertex %" PRId64 ", file has %" PRId64
                        " vertices",
                        b->name, where, line_or_item, byte, v, nv);
    }
    return fan_add(b, f, v);
}

static int ply_ascii(ply *P, lines *L)
{
    mb *b = P->b;
    ohm_error *err = b->err;
    tok t;
    for (size_t ei = 0; ei < P->nelems; ++ei) {
        ply_elem *e = &P->elems[ei];
        if (e->nprops == 0 || e->count == 0) continue;
        /* every property needs a token and a separator: 2 bytes */
        size_t rest = (size_t)(L->end - L->lp) + 1;
        if ((uint64_t)e->count > rest / 2 / e->nprops) {
            return ohm_fail(err, OHM_ERR_PARSE,
                            "%s:%zu: element '%s' declares %" PRId64
                            " items, more than the %zu bytes of data after line %zu can hold (at most %zu)",
                            b->name, e->line, show(e->name).s, e->count, rest - 1, L->line,
                            rest / 2 / e->nprops);
        }
        int rc = ply_reserve(P, e);
        if (rc) return rc;
        for (int64_t i = 0; i < e->count; ++i) {
            double c[3] = {0, 0, 0};
            for (size_t j = 0; j < e->nprops; ++j) {
                const ply_prop *p = &e->props[j];
                if (!stream_tok(L, &t))
                    return ohm_fail(err, OHM_ERR_PARSE,
                                    "%s:%zu: file ends early in %s %" PRId64 ", expected %" PRId64
                                    " '%s' elements",
                                    b->name, L->line, show(e->name).s, i, e->count, show(e->name).s);
                if (p->ctype == PT_NONE) {
                    if (e == P->vert) {
                        for (int k = 0; k < 3; ++k)
                            if (j == P->ix[k] && (rc = coord_tok(b, L->line, t, axis_name[k], &c[k])))
                                return rc;
                    }
                    continue;
                }
                int64_t n;
                if ((rc = count_tok(b, L->line, t, "list count", &n))) return rc;
                int is_idx = e == P->face && j == P->iface;
                if (is_idx && n < 3)
                    return ohm_fail(err, OHM_ERR_PARSE, "%s:%zu: face has %" PRId64
                                    " vertices, expected at least 3", b->name, L->line, n);
                fan f = {0, 0, 0};
                for (int64_t k = 0; k < n; ++k) {
                    if (!stream_tok(L, &t))
                        return ohm_fail(err, OHM_ERR_PARSE,
                                        "%s:%zu: file ends early in %s %" PRId64 ", a list of %" PRId64
                                        " values has only %" PRId64,
                                        b->name, L->line, show(e->name).s, i, n, k);
                    if (!is_idx) continue;
                    int64_t v;
                    int prc = parse_int(t, &v);
                    if (prc == 1)
                        return ohm_fail(err, OHM_ERR_PARSE, "%s:%zu: expected a vertex index, got '%s'",
                                        b->name, L->line, show(t).s);
                    if (prc == 2) v = -1;
                    if ((rc = ply_index(P, &f, v, NULL, L->line, SIZE_MAX))) return rc;
                }
            }
            if (e == P->vert && (rc = mb_vert(b, c))) return rc;
        }
    }
    return 0;
}

typedef struct bin {
    const unsigned char *d;
    size_t len, pos;
    int be;
} bin;

/* Read a value of `type` at r->pos (the caller checked it is there). */
static void bin_read(bin *r, int type, double *dv, int64_t *iv)
{
    size_t n = ply_tsize[type];
    const unsigned char *p = r->d + r->pos;
    uint64_t u = 0;
    for (size_t i = 0; i < n; ++i) u = (u << 8) | p[r->be ? i : n - 1 - i];
    r->pos += n;
    int64_t s = 0;
    switch (type) {
    case PT_I8: s = u >= 0x80 ? (int64_t)u - 0x100 : (int64_t)u; break;
    case PT_I16: s = u >= 0x8000 ? (int64_t)u - 0x10000 : (int64_t)u; break;
    case PT_I32: s = u >= 0x80000000u ? (int64_t)u - 0x100000000 : (int64_t)u; break;
    case PT_U8: case PT_U16: case PT_U32: s = (int64_t)u; break;
    case PT_F32: {
        uint32_t w = (uint32_t)u;
        float f;
        memcpy(&f, &w, sizeof f);
        *dv = f;
        *iv = 0;
        return;
    }
    default: {
        double d;
        memcpy(&d, &u, sizeof d);
        *dv = d;
        *iv = 0;
        return;
    }
    }
    *iv = s;
    *dv = (double)s;
}

static int ply_binary(ply *P, const char *data, size_t len, size_t start)
{
    mb *b = P->b;
    ohm_error *err = b->err;
    bin r = {(const unsigned char *)data, len, start, P->format == 2};
    for (size_t ei = 0; ei < P->nelems; ++ei) {
        ply_elem *e = &P->elems[ei];
        shown en = show(e->name);
        size_t minsz = 0; /* a list counts as its count field alone */
        int lists = 0;
        for (size_t j = 0; j < e->nprops; ++j) {
            const ply_prop *p = &e->props[j];
            minsz += ply_tsize[p->ctype != PT_NONE ? p->ctype : p->type];
            lists |= p->ctype != PT_NONE;
        }
        if (minsz == 0 || e->count == 0) continue;
        size_t rest = r.len - r.pos;
        if ((uint64_t)e->count > rest / minsz) {
            size_t k = rest / minsz;
            return ohm_fail(err, OHM_ERR_PARSE,
                            "%s: %s %zu (byte %zu): file ends early, the header (line %zu) declares %" PRId64
                            " '%s' elements of at least %zu byte%s each, %zu bytes remain",
                            b->name, en.s, k, r.pos + k * minsz, e->line, e->count, en.s, minsz,
                            minsz == 1 ? "" : "s", rest);
        }
        int rc = ply_reserve(P, e);
        if (rc) return rc;
        if (!lists && e != P->vert) {
            r.pos += (size_t)e->count * minsz;
            continue;
        }
        for (int64_t i = 0; i < e->count; ++i) {
            size_t at = r.pos;
            double c[3] = {0, 0, 0};
            for (size_t j = 0; j < e->nprops; ++j) {
                const ply_prop *p = &e->props[j];
                double dv;
                int64_t iv;
                size_t need = ply_tsize[p->ctype != PT_NONE ? p->ctype : p->type];
                if (r.len - r.pos < need) goto truncated;
                if (p->ctype == PT_NONE) {
                    bin_read(&r, p->type, &dv, &iv);
                    if (e == P->vert)
                        for (int k = 0; k < 3; ++k)
                            if (j == P->ix[k]) {
                                if (!isfinite(dv))
                                    return ohm_fail(err, OHM_ERR_PARSE,
                                                    "%s: vertex %" PRId64 " (byte %zu): coordinate %s = %g "
                                                    "is not a finite number",
                                                    b->name, i, at, axis_name[k], dv);
                                c[k] = dv;
                            }
                    continue;
                }
                bin_read(&r, p->ctype, &dv, &iv);
                if (iv < 0)
                    return ohm_fail(err, OHM_ERR_PARSE, "%s: %s %" PRId64 " (byte %zu): list count %" PRId64
                                    " is negative", b->name, en.s, i, at, iv);
                size_t isz = ply_tsize[p->type];
                if ((uint64_t)iv > (r.len - r.pos) / isz) goto truncated;
                int is_idx = e == P->face && j == P->iface;
                if (!is_idx) {
                    r.pos += (size_t)iv * isz;
                    continue;
                }
                if (iv < 3)
                    return ohm_fail(err, OHM_ERR_PARSE,
                                    "%s: face %" PRId64 " (byte %zu): face has %" PRId64
                                    " vertices, expected at least 3",
                                    b->name, i, at, iv);
                fan f = {0, 0, 0};
                for (int64_t k = 0; k < iv; ++k) {
                    int64_t v;
                    bin_read(&r, p->type, &dv, &v);
                    if ((rc = ply_index(P, &f, v, "face", (size_t)i, at))) return rc;
                }
            }
            if (e == P->vert && (rc = mb_vert(b, c))) return rc;
            continue;
        truncated:
            return ohm_fail(err, OHM_ERR_PARSE,
                            "%s: %s %" PRId64 " (byte %zu): file ends early, expected %" PRId64
                            " '%s' elements, got %zu bytes",
                            b->name, en.s, i, at, e->count, en.s, r.len);
        }
    }
    return 0;
}

int ohm_mesh_parse_ply(ohm_mesh *out, const char *data, size_t len, const char *name, ohm_error *err)
{
    memset(out, 0, sizeof *out);
    if (!data || len == 0) return empty_file(name, "a PLY", err);
    mb b;
    mb_init(&b, name, err);
    ply P;
    memset(&P, 0, sizeof P);
    P.b = &b;
    lines L;
    lines_init(&L, data, len, 0, 0);
    int rc = ply_header(&P, &L);
    if (rc == 0) {
        if (P.format == 0) rc = ply_ascii(&P, &L);
        else rc = ply_binary(&P, data, len, (size_t)(L.p - data));
    }
    ply_free(&P);
    if (rc) {
        mb_free(&b);
        return rc;
    }
    return mb_finish(&b, out);
}

/* ------------------------------------------------------------------------ */
/* STL                                                                       */

static int stl_expect(mb *b, lines *L, const char *word)
{
    tok t;
    if (!stream_tok(L, &t))
        return ohm_fail(b->err, OHM_ERR_PARSE, "%s:%zu: file ends early, expected '%s'", b->name, L->line,
                        word);
    if (!tok_ieq(t, word))
        return ohm_fail(b->err, OHM_ERR_PARSE, "%s:%zu: expected '%s', got '%s'", b->name, L->line, word,
                        show(t).s);
    return 0;
}

static int stl_ascii(mb *b, const char *data, size_t len)
{
    lines L;
    lines_init(&L, data, len, 0, 0);
    tok t;
    int rc;
    while (stream_tok(&L, &t)) {
        if (tok_ieq(t, "solid") || tok_ieq(t, "endsolid")) {
            L.lp = L.le; /* the solid's name */
            continue;
        }
        if (!tok_ieq(t, "facet"))
            return ohm_fail(b->err, OHM_ERR_PARSE, "%s:%zu: expected 'facet' or 'endsolid', got '%s'",
                            b->name, L.line, show(t).s);
        if ((rc = stl_expect(b, &L, "normal"))) return rc;
        for (int k = 0; k < 3; ++k) /* the normal is recomputed later; 'nan' is fine */
            if (!stream_tok(&L, &t))
                return ohm_fail(b->err, OHM_ERR_PARSE, "%s:%zu: file ends early in a facet normal", b->name,
                                L.line);
        if ((rc = stl_expect(b, &L, "outer"))) return rc;
        if ((rc = stl_expect(b, &L, "loop"))) return rc;
        fan f = {0, 0, 0};
        for (;;) {
            if (!stream_tok(&L, &t))
                return ohm_fail(b->err, OHM_ERR_PARSE, "%s:%zu: file ends early, expected 'vertex' or 'endloop'",
                                b->name, L.line);
            if (tok_ieq(t, "endloop")) break;
            if (!tok_ieq(t, "vertex"))
                return ohm_fail(b->err, OHM_ERR_PARSE, "%s:%zu: expected 'vertex' or 'endloop', got '%s'",
                                b->name, L.line, show(t).s);
            double c[3];
            for (int k = 0; k < 3; ++k) {
                if (!stream_tok(&L, &t))
                    return ohm_fail(b->err, OHM_ERR_PARSE, "%s:%zu: file ends early in a vertex", b->name,
                                    L.line);
                if ((rc = coord_tok(b, L.line, t, axis_name[k], &c[k]))) return rc;
            }
            if ((rc = mb_vert(b, c))) return rc;
            if ((rc = fan_add(b, &f, (int64_t)b->nv - 1))) return rc;
        }
        if (f.n < 3)
            return ohm_fail(b->err, OHM_ERR_PARSE, "%s:%zu: facet has %zu vertices, expected 3", b->name,
                            L.line, f.n);
        if ((rc = stl_expect(b, &L, "endfacet"))) return rc;
    }
    return 0;
}

static uint32_t le32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

/* Does the start of the file read as text (no control bytes but whitespace)? */
static int looks_text(const char *data, size_t len)
{
    size_t n = len < 1024 ? len : 1024;
    for (size_t i = 0; i < n; ++i) {
        unsigned char c = (unsigned char)data[i];
        if (c < 0x20 && !is_ws((char)c)) return 0;
    }
    return 1;
}

int ohm_mesh_parse_stl(ohm_mesh *out, const char *data, size_t len, const char *name, ohm_error *err)
{
    memset(out, 0, sizeof *out);
    if (!data || len == 0) return empty_file(name, "an STL", err);
    mb b;
    mb_init(&b, name, err);
    int rc;
    uint64_t ntri = 0, expect = 0;
    if (len >= 84) {
        ntri = le32((const unsigned char *)data + 80);
        expect = 84 + 50 * ntri;
    }
    size_t s = 0;
    while (s < len && is_ws(data[s])) ++s;
    int solid = len - s >= 5 && tok_ieq((tok){data + s, 5}, "solid");
    if (len >= 84 && expect == len) {
        /* binary (even when the 80-byte header begins with "solid") */
        const unsigned char *p = (const unsigned char *)data + 84;
        if ((rc = mb_reserve_verts(&b, 3 * (size_t)ntri)) || (rc = mb_reserve_tris(&b, (size_t)ntri)))
            goto fail;
        for (size_t i = 0; i < ntri; ++i, p += 50) {
            for (int k = 0; k < 3; ++k) {
                double c[3];
                for (int a = 0; a < 3; ++a) {
                    uint32_t w = le32(p + 12 + 12 * k + 4 * a);
                    float f;
                    memcpy(&f, &w, sizeof f);
                    if (!isfinite(f)) {
                        rc = ohm_fail(err, OHM_ERR_PARSE,
                                      "%s: triangle %zu (byte %zu): coordinate %s of corner %d is %g, not a "
                                      "finite number",
                                      b.name, i, (size_t)(p - (const unsigned char *)data), axis_name[a], k,
                                      (double)f);
                        goto fail;
                    }
                    c[a] = f;
                }
                if ((rc = mb_vert(&b, c))) goto fail;
            }
            if ((rc = mb_tri(&b, (int64_t)(3 * i), (int64_t)(3 * i + 1), (int64_t)(3 * i + 2)))) goto fail;
        }
    } else if (solid && looks_text(data, len)) {
        if ((rc = stl_ascii(&b, data, len))) goto fail;
    } else if (len < 84) {
        rc = ohm_fail(err, OHM_ERR_PARSE,
                      "%s: file is %zu bytes: too short for a binary STL (84-byte header) and not an ASCII STL "
                      "(does not start with 'solid')",
                      b.name, len);
        goto fail;
    } else if (len < expect) {
        uint64_t k = (len - 84) / 50;
        rc = ohm_fail(err, OHM_ERR_PARSE,
                      "%s: triangle %" PRIu64 " (byte %" PRIu64 "): file ends early, expected %" PRIu64
                      " triangles (%" PRIu64 " bytes), got %zu bytes",
                      b.name, k, 84 + 50 * k, ntri, expect, len);
        goto fail;
    } else {
        rc = ohm_fail(err, OHM_ERR_PARSE,
                      "%s: binary STL header declares %" PRIu64 " triangles (%" PRIu64
                      " bytes), but the file has %zu bytes",
                      b.name, ntri, expect, len);
        goto fail;
    }
    if ((rc = mb_weld(&b))) goto fail;
    return mb_finish(&b, out);
fail:
    mb_free(&b);
    return rc;
}

/* ------------------------------------------------------------------------ */
/* Files                                                                     */

typedef int (*parse_fn)(ohm_mesh *, const char *, size_t, const char *, ohm_error *);

static const struct {
    const char *ext;
    const char *kind;
    parse_fn parse;
} formats[] = {{"obj", "an OBJ", ohm_mesh_parse_obj},
               {"ply", "a PLY", ohm_mesh_parse_ply},
               {"stl", "an STL", ohm_mesh_parse_stl},
               {"off", "an OFF", ohm_mesh_parse_off}};

/* The format index for path (-1: unknown) and whether it is gzip-compressed. */
static int format_of(const char *path, int *gz, const char **ext, size_t *extn)
{
    const char *base = strrchr(path, '/');
    base = base ? base + 1 : path;
    size_t n = strlen(base);
    *gz = n > 3 && ieq_n(base + n - 3, ".gz", 3);
    if (*gz) n -= 3;
    size_t dot = n;
    while (dot > 0 && base[dot - 1] != '.') --dot;
    *ext = dot > 0 ? base + dot : base + n;
    *extn = dot > 0 ? n - dot : 0;
    for (size_t i = 0; i < sizeof formats / sizeof formats[0]; ++i)
        if (*extn == strlen(formats[i].ext) && ieq_n(*ext, formats[i].ext, *extn)) return (int)i;
    return -1;
}

static int read_plain(const char *path, off_t size, char **buf, size_t *len, ohm_error *err)
{
    FILE *f = fopen(path, "rb");
    if (!f) return ohm_fail(err, OHM_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    size_t cap = size > 0 && (uint64_t)size < SIZE_MAX ? (size_t)size + 1 : 1 << 16, n = 0;
    char *p = malloc(cap);
    if (!p) {
        fclose(f);
        return ohm_fail(err, OHM_ERR_NOMEM, "%s: out of memory reading %zu bytes", path, cap);
    }
    for (;;) {
        if (n == cap) { /* the file grew, or its size was unknown */
            size_t nc = cap > SIZE_MAX / 2 ? SIZE_MAX : cap * 2;
            char *q = nc > cap ? realloc(p, nc) : NULL;
            if (!q) {
                free(p);
                fclose(f);
                return ohm_fail(err, OHM_ERR_NOMEM, "%s: out of memory reading %zu bytes", path, nc);
            }
            p = q;
            cap = nc;
        }
        size_t got = fread(p + n, 1, cap - n, f);
        n += got;
        if (got == 0) break;
    }
    if (ferror(f)) {
        int e = errno;
        free(p);
        fclose(f);
        return ohm_fail(err, OHM_ERR_IO, "%s: read error: %s", path, strerror(e));
    }
    fclose(f);
    *buf = p;
    *len = n;
    return 0;
}

/* gzerror's text without the "path: " zlib puts in front. */
static const char *gz_reason(const char *path, const char *m)
{
    size_t n = strlen(path);
    if (!m || !*m) return "unexpected end of file";
    if (strncmp(m, path, n) == 0 && m[n] == ':' && m[n + 1] == ' ') return m + n + 2;
    return m;
}

static int read_gz(const char *path, off_t size, char **buf, size_t *len, ohm_error *err)
{
    errno = 0;
    gzFile f = gzopen(path, "rb");
    if (!f) return ohm_fail(err, OHM_ERR_IO, "%s: cannot open: %s", path, errno ? strerror(errno) : "zlib");
    gzbuffer(f, 1 << 17);
    uint64_t want = size > 0 ? (uint64_t)size * 4 : 1 << 20;
    size_t cap = want < (1 << 20) ? 1 << 20 : want > GZ_MAX_BYTES ? (size_t)GZ_MAX_BYTES : (size_t)want;
    size_t n = 0;
    char *p = malloc(cap);
    int rc = 0;
    if (!p) {
        gzclose(f);
        return ohm_fail(err, OHM_ERR_NOMEM, "%s: out of memory decompressing (%zu bytes)", path, cap);
    }
    for (;;) {
        if (n == cap) {
            if ((uint64_t)cap >= GZ_MAX_BYTES) {
                rc = ohm_fail(err, OHM_ERR_PARSE,
                              "%s: decompresses to more than %" PRIu64 " bytes, the limit for a .gz mesh", path,
                              GZ_MAX_BYTES);
                break;
            }
            size_t nc = (uint64_t)cap * 2 > GZ_MAX_BYTES ? (size_t)GZ_MAX_BYTES : cap * 2;
            char *q = realloc(p, nc);
            if (!q) {
                rc = ohm_fail(err, OHM_ERR_NOMEM, "%s: out of memory decompressing (%zu bytes)", path, nc);
                break;
            }
            p = q;
            cap = nc;
        }
        size_t chunk = cap - n < (1u << 30) ? cap - n : (1u << 30);
        int got = gzread(f, p + n, (unsigned)chunk);
        if (got < 0) {
            int zerr;
            const char *m = gzerror(f, &zerr);
            if (zerr == Z_ERRNO)
                rc = ohm_fail(err, OHM_ERR_IO, "%s: read error: %s", path, strerror(errno));
            else
                rc = ohm_fail(err, OHM_ERR_PARSE, "%s: corrupt gzip stream: %s", path, gz_reason(path, m));
            break;
        }
        if (n == 0 && got > 0 && gzdirect(f)) {
            rc = ohm_fail(err, OHM_ERR_PARSE, "%s: not a gzip file (expected the magic bytes 1f 8b)", path);
            break;
        }
        if (got == 0) {
            /* gzread reports a stream cut short only through gzerror */
            int zerr;
            const char *m = gzerror(f, &zerr);
            if (zerr != Z_OK)
                rc = ohm_fail(err, OHM_ERR_PARSE, "%s: corrupt gzip stream: %s", path, gz_reason(path, m));
            break;
        }
        n += (size_t)got;
    }
    gzclose(f);
    if (rc) {
        free(p);
        return rc;
    }
    *buf = p;
    *len = n;
    return 0;
}

int ohm_mesh_read(ohm_mesh *out, const char *path, ohm_error *err)
{
    memset(out, 0, sizeof *out);
    if (!path) return ohm_fail(err, OHM_ERR_USAGE, "mesh read: no file name given");
    struct stat st;
    if (stat(path, &st) != 0) return ohm_fail(err, OHM_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    if (S_ISDIR(st.st_mode)) return ohm_fail(err, OHM_ERR_IO, "%s: is a directory, expected a mesh file", path);
    /* FIFOs, devices, sockets: reading could block forever or never end. */
    if (!S_ISREG(st.st_mode)) return ohm_fail(err, OHM_ERR_IO, "%s: not a regular file, expected a mesh file", path);
    int gz;
    const char *ext;
    size_t extn;
    int fi = format_of(path, &gz, &ext, &extn);
    if (fi < 0) {
        if (extn == 0)
            return ohm_fail(err, OHM_ERR_USAGE,
                            "%s: no file extension, expected a mesh file ending in .obj .ply .stl or .off "
                            "(optionally .gz)",
                            path);
        return ohm_fail(err, OHM_ERR_USAGE,
                        "%s: unknown mesh format '.%.*s', expected .obj .ply .stl or .off (optionally .gz)",
                        path, (int)(extn > 16 ? 16 : extn), ext);
    }
    if (S_ISREG(st.st_mode) && st.st_size == 0)
        return ohm_fail(err, OHM_ERR_PARSE, "%s: empty file, expected %s mesh", path, formats[fi].kind);
    char *buf = NULL;
    size_t len = 0;
    int rc = gz ? read_gz(path, st.st_size, &buf, &len, err) : read_plain(path, st.st_size, &buf, &len, err);
    if (rc) return rc;
    rc = formats[fi].parse(out, buf, len, path, err);
    free(buf);
    return ohm_error_name(err, rc, path);
}
