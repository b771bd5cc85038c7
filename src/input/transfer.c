/* transfer.c — transfer functions: density -> optical coefficients (transfer.h,
 * docs/transfer-functions.md).
 *
 * The parser reads the whole text, line by line (LF or CRLF), and stops at the
 * first problem with "name:line: what".  Numbers are read with strtod and must
 * be finite; every token is checked to be consumed entirely, so "1.0x" and
 * "nan" are errors, not silently truncated values. */
#include "input/transfer.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#define TRANSFER_LINE_MAX 4096 /* characters per line, terminator excluded */
#define TRANSFER_TOKENS_MAX 10 /* the widest row has 9 columns (RGB, eta, g) */

void ohm_transfer_free(ohm_transfer *t)
{
    if (!t) return;
    free(t->density);
    free(t->sigma_a);
    free(t->sigma_s);
    free(t->eta_points);
    free(t->g_points);
    memset(t, 0, sizeof *t);
}

/* Split line (NUL-terminated, modified in place) at blanks; drop a trailing
 * '#' comment.  Returns the number of tokens; only the first
 * TRANSFER_TOKENS_MAX are stored in tok. */
static int tokenize(char *line, char **tok)
{
    char *hash = strchr(line, '#');
    if (hash) *hash = '\0';
    int n = 0;
    char *p = line;
    for (;;) {
        while (*p == ' ' || *p == '\t' || *p == '\r' || *p == '\v' || *p == '\f') ++p;
        if (!*p) break;
        if (n < TRANSFER_TOKENS_MAX) tok[n] = p;
        ++n;
        while (*p && *p != ' ' && *p != '\t' && *p != '\r' && *p != '\v' && *p != '\f') ++p;
        if (*p) *p++ = '\0';
    }
    return n;
}

/* A finite number filling the whole token. */
static int parse_number(const char *s, double *v)
{
    char *end;
    errno = 0;
    double x = strtod(s, &end);
    if (end == s || *end != '\0') return -1;
    if (!isfinite(x)) return -1;
    if (errno == ERANGE && fabs(x) > 1.0) return -1; /* overflow; underflow to ~0 is fine */
    *v = x;
    return 0;
}

static int parse_header(ohm_transfer *t, char **tok, int ntok, const char *name, size_t line, ohm_error *err)
{
    if (ntok < 2 || strcmp(tok[0], "ohm-transfer") != 0)
        return ohm_fail(err, OHM_ERR_PARSE,
                        "%s:%zu: bad header: expected \"ohm-transfer 1 [mode=optical|resistance] [eta=1.3]\"", name,
                        line);
    if (strcmp(tok[1], "1") != 0)
        return ohm_fail(err, OHM_ERR_PARSE, "%s:%zu: bad header: unsupported version \"%s\" (this ohm reads 1)", name,
                        line, tok[1]);
    int seen_mode = 0, seen_eta = 0, seen_g = 0, seen_scattering = 0;
    for (int i = 2; i < ntok; ++i) {
        if (strncmp(tok[i], "mode=", 5) == 0) {
            const char *m = tok[i] + 5;
            if (seen_mode)
                return ohm_fail(err, OHM_ERR_PARSE, "%s:%zu: bad header: mode given twice", name, line);
            seen_mode = 1;
            if (strcmp(m, "optical") == 0) t->resistance_mode = 0;
            else if (strcmp(m, "resistance") == 0) t->resistance_mode = 1;
            else
                return ohm_fail(err, OHM_ERR_PARSE,
                                "%s:%zu: bad header: unknown mode \"%s\" (expected optical or resistance)", name, line,
                                m);
        } else if (strncmp(tok[i], "eta=", 4) == 0) {
            double e;
            if (seen_eta) return ohm_fail(err, OHM_ERR_PARSE, "%s:%zu: bad header: eta given twice", name, line);
            seen_eta = 1;
            if (strcmp(tok[i] + 4, "column") == 0) {
                t->eta_column = 1;
                continue;
            }
            if (parse_number(tok[i] + 4, &e) || !(e >= 1.0 && e <= 3.0))
                return ohm_fail(err, OHM_ERR_PARSE,
                                "%s:%zu: bad header: eta must be a number in [1, 3] (as for materials) or column, "
                                "got \"%s\"",
                                name, line,
                                tok[i] + 4);
            t->eta = e;
        } else if (strncmp(tok[i], "g=", 2) == 0) {
            double g;
            if (seen_g) return ohm_fail(err, OHM_ERR_PARSE, "%s:%zu: bad header: g given twice", name, line);
            seen_g = 1;
            if (strcmp(tok[i] + 2, "column") == 0) {
                t->g_column = 1;
                continue;
            }
            if (parse_number(tok[i] + 2, &g) || !(g > -1.0 && g < 1.0))
                return ohm_fail(err, OHM_ERR_PARSE,
                                "%s:%zu: bad header: g (the anisotropy) must be a number in (-1, 1) or column, got \"%s\"", name,
                                line, tok[i] + 2);
            t->g = g;
        } else if (strncmp(tok[i], "scattering=", 11) == 0) {
            const char *k = tok[i] + 11;
            if (seen_scattering)
                return ohm_fail(err, OHM_ERR_PARSE, "%s:%zu: bad header: scattering given twice", name, line);
            seen_scattering = 1;
            if (strcmp(k, "reduced") == 0) t->scattering_full = 0;
            else if (strcmp(k, "full") == 0) t->scattering_full = 1;
            else
                return ohm_fail(err, OHM_ERR_PARSE,
                                "%s:%zu: bad header: scattering=%s, expected reduced (sigma_s') or full (sigma_s)",
                                name, line, k);
        } else {
            return ohm_fail(err, OHM_ERR_PARSE,
                            "%s:%zu: unknown header option \"%s\" (expected mode=optical|resistance, eta=VALUE|column, "
                            "g=VALUE|column or scattering=reduced|full)",
                            name, line, tok[i]);
        }
    }
    if (t->resistance_mode && (t->eta_column || t->g_column))
        return ohm_fail(err, OHM_ERR_PARSE, "%s:%zu: bad header: %s=column needs optical coefficients, not mode=resistance",
                        name, line, t->eta_column ? "eta" : "g");
    return OHM_OK;
}

/* Append one point; arrays grow geometrically. */
static int push_point(ohm_transfer *t, size_t *cap, const double *vals, ohm_error *err)
{
    int ch = t->channels;
    if (t->n == *cap) {
        size_t nc = *cap ? 2 * *cap : 16;
        double *d = realloc(t->density, nc * sizeof *d);
        if (!d) return ohm_fail(err, OHM_ERR_NOMEM, "transfer: out of memory");
        t->density = d;
        double *a = realloc(t->sigma_a, nc * (size_t)ch * sizeof *a);
        if (!a) return ohm_fail(err, OHM_ERR_NOMEM, "transfer: out of memory");
        t->sigma_a = a;
        double *s = realloc(t->sigma_s, nc * (size_t)ch * sizeof *s);
        if (!s) return ohm_fail(err, OHM_ERR_NOMEM, "transfer: out of memory");
        t->sigma_s = s;
        if (t->eta_column) {
            double *e = realloc(t->eta_points, nc * sizeof *e);
            if (!e) return ohm_fail(err, OHM_ERR_NOMEM, "transfer: out of memory");
            t->eta_points = e;
        }
        if (t->g_column) {
            double *g = realloc(t->g_points, nc * sizeof *g);
            if (!g) return ohm_fail(err, OHM_ERR_NOMEM, "transfer: out of memory");
            t->g_points = g;
        }
        *cap = nc;
    }
    t->density[t->n] = vals[0];
    for (int c = 0; c < ch; ++c) {
        t->sigma_a[t->n * (size_t)ch + (size_t)c] = vals[1 + c];
        t->sigma_s[t->n * (size_t)ch + (size_t)c] = vals[1 + ch + c];
    }
    if (t->eta_column) t->eta_points[t->n] = vals[1 + 2 * ch];
    if (t->g_column) t->g_points[t->n] = vals[1 + 2 * ch + t->eta_column];
    t->n++;
    return OHM_OK;
}

static int parse_point(ohm_transfer *t, size_t *cap, char **tok, int ntok, const char *name, size_t line,
                       ohm_error *err)
{
    if (t->resistance_mode) {
        if (ntok != 3)
            return ohm_fail(err, OHM_ERR_PARSE,
                            "%s:%zu: expected 3 columns (density resistance ground) in mode=resistance, got %d", name,
                            line, ntok);
    } else if (t->n == 0) {
        int e = t->eta_column + t->g_column;
        const char *tail = t->eta_column && t->g_column ? " eta g" : t->eta_column ? " eta" : t->g_column ? " g" : "";
        if (ntok != 3 + e && ntok != 7 + e)
            return ohm_fail(err, OHM_ERR_PARSE,
                            "%s:%zu: expected %d columns (density sigma_a sigma_s'%s) or %d (density sa_r sa_g sa_b ss_r "
                            "ss_g ss_b%s), got %d",
                            name, line, 3 + e, tail, 7 + e, tail, ntok);
        t->channels = ntok == 3 + e ? 1 : 3;
    } else if (ntok != 1 + 2 * t->channels + t->eta_column + t->g_column) {
        return ohm_fail(err, OHM_ERR_PARSE, "%s:%zu: expected %d columns like the first point, got %d", name, line,
                        1 + 2 * t->channels + t->eta_column + t->g_column, ntok);
    }
    /* the extra columns' names: eta, then g (either may be absent) */
    const int eta_col = t->eta_column ? 1 + 2 * t->channels : -1;
    const int g_col = t->g_column ? 1 + 2 * t->channels + t->eta_column : -1;
    static const char *const optical_grey[] = {"density", "sigma_a", "sigma_s'", "", ""}; /* "": eta_col, g_col */
    static const char *const optical_rgb[] = {"density",      "sigma_a (R)",  "sigma_a (G)",  "sigma_a (B)", "sigma_s' (R)",
                                              "sigma_s' (G)", "sigma_s' (B)", "",             ""};
    static const char *const resist[] = {"density", "resistance", "ground"};
    const char *const *cols = t->resistance_mode ? resist : t->channels == 3 ? optical_rgb : optical_grey;

    double v[TRANSFER_TOKENS_MAX];
    for (int i = 0; i < ntok; ++i) {
        if (parse_number(tok[i], &v[i]))
            return ohm_fail(err, OHM_ERR_PARSE, "%s:%zu: column %d (%s): \"%s\" is not a finite number", name, line,
                            i + 1, i == eta_col ? "eta" : i == g_col ? "g" : cols[i], tok[i]);
        if (i == 0) continue;
        if (i == eta_col) {
            if (!(v[i] >= 1.0 && v[i] <= 3.0))
                return ohm_fail(err, OHM_ERR_INVALID, "%s:%zu: column %d (eta) must be in [1, 3], got %s", name, line,
                                i + 1, tok[i]);
            continue;
        }
        if (i == g_col) {
            if (!(v[i] > -1.0 && v[i] < 1.0))
                return ohm_fail(err, OHM_ERR_INVALID, "%s:%zu: column %d (g) must be in (-1, 1), got %s", name, line,
                                i + 1, tok[i]);
            continue;
        }
        const double lo = t->resistance_mode ? OHM_RESISTANCE_MIN : i > t->channels ? OHM_SIGMA_S_MIN : 0.0;
        const double hi = t->resistance_mode ? OHM_RESISTANCE_MAX : i > t->channels ? OHM_SIGMA_S_MAX : OHM_SIGMA_A_MAX;
        if (!(v[i] >= lo && v[i] <= hi))
            return ohm_fail(err, OHM_ERR_INVALID, "%s:%zu: column %d (%s) must be in [%g, %g], got %s", name, line,
                            i + 1, cols[i], lo, hi, tok[i]);
    }
    if (t->n > 0 && !(v[0] > t->density[t->n - 1]))
        return ohm_fail(err, OHM_ERR_INVALID,
                        "%s:%zu: densities must be strictly increasing: %s after %.17g", name, line, tok[0],
                        t->density[t->n - 1]);
    return push_point(t, cap, v, err);
}

int ohm_transfer_parse(ohm_transfer *out, const char *text, size_t len, const char *name, ohm_error *err)
{
    ohm_transfer t;
    memset(&t, 0, sizeof t);
    t.eta = 1.3;
    t.channels = 1;
    if (!name) name = "transfer";
    if (out) memset(out, 0, sizeof *out);
    if (!out || (!text && len))
        return ohm_fail(err, OHM_ERR_INTERNAL, "%s: ohm_transfer_parse: NULL argument", name);
    char buf[TRANSFER_LINE_MAX + 2];
    char *tok[TRANSFER_TOKENS_MAX];
    size_t cap = 0, line = 0, pos = 0;
    int have_header = 0, rc = OHM_OK;
    while (pos < len) {
        ++line;
        size_t end = pos;
        while (end < len && text[end] != '\n') ++end;
        size_t ll = end - pos;
        if (ll > 0 && text[pos + ll - 1] == '\r') --ll; /* CRLF */
        if (ll > TRANSFER_LINE_MAX) {
            rc = ohm_fail(err, OHM_ERR_PARSE, "%s:%zu: line too long (%zu characters; at most %d)", name, line, ll,
                          TRANSFER_LINE_MAX);
            goto fail;
        }
        memcpy(buf, text + pos, ll);
        buf[ll] = '\0';
        pos = end < len ? end + 1 : end;
        if (memchr(buf, '\0', ll)) {
            rc = ohm_fail(err, OHM_ERR_PARSE, "%s:%zu: NUL byte in a text file", name, line);
            goto fail;
        }
        int ntok = tokenize(buf, tok);
        if (ntok == 0) continue; /* blank or comment */
        if (!have_header) {
            rc = parse_header(&t, tok, ntok > TRANSFER_TOKENS_MAX ? TRANSFER_TOKENS_MAX : ntok, name, line, err);
            if (rc == OHM_OK && ntok > TRANSFER_TOKENS_MAX)
                rc = ohm_fail(err, OHM_ERR_PARSE, "%s:%zu: bad header: too many words", name, line);
            if (rc) goto fail;
            have_header = 1;
            continue;
        }
        rc = parse_point(&t, &cap, tok, ntok, name, line, err);
        if (rc) goto fail;
    }
    if (!have_header) {
        rc = ohm_fail(err, OHM_ERR_PARSE, "%s:%zu: bad header: empty file, expected \"ohm-transfer 1\"", name,
                      line ? line : 1);
        goto fail;
    }
    if (t.n < 1) {
        rc = ohm_fail(err, OHM_ERR_PARSE, "%s:%zu: no control points (at least 1 is needed)", name, line);
        goto fail;
    }
    if (t.resistance_mode) t.channels = 1;
    if (t.eta_column) t.eta = t.eta_points[0]; /* the material's: the scale of network.h's unknowns */
    if (t.scattering_full && !t.resistance_mode) /* sigma_s' = sigma_s (1 - g): what diffusion needs */
        for (size_t i = 0; i < t.n * (size_t)t.channels; ++i)
            t.sigma_s[i] *= 1.0 - (t.g_column ? t.g_points[i / (size_t)t.channels] : t.g);
    if (t.g_column) t.g = t.g_points[0]; /* the material's (reports) */
    *out = t;
    return OHM_OK;
fail:
    ohm_transfer_free(&t);
    return rc;
}

int ohm_transfer_read(ohm_transfer *out, const char *path, ohm_error *err)
{
    if (out) memset(out, 0, sizeof *out);
    /* FIFOs, devices, directories: opening or reading could block or never end */
    struct stat st;
    if (stat(path, &st) != 0) return ohm_fail(err, OHM_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    if (S_ISDIR(st.st_mode)) return ohm_fail(err, OHM_ERR_IO, "%s: is a directory, expected a transfer function", path);
    if (!S_ISREG(st.st_mode))
        return ohm_fail(err, OHM_ERR_IO, "%s: not a regular file, expected a transfer function", path);
    FILE *f = fopen(path, "rb");
    if (!f) return ohm_fail(err, OHM_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    size_t cap = 4096, len = 0;
    char *text = malloc(cap);
    if (!text) {
        fclose(f);
        return ohm_fail(err, OHM_ERR_NOMEM, "%s: out of memory", path);
    }
    for (;;) {
        if (len == cap) {
            if (cap > ((size_t)1 << 30)) {
                free(text);
                fclose(f);
                return ohm_fail(err, OHM_ERR_PARSE, "%s: larger than 1 GiB, not a transfer function", path);
            }
            char *p = realloc(text, 2 * cap);
            if (!p) {
                free(text);
                fclose(f);
                return ohm_fail(err, OHM_ERR_NOMEM, "%s: out of memory", path);
            }
            text = p;
            cap *= 2;
        }
        size_t got = fread(text + len, 1, cap - len, f);
        len += got;
        if (got == 0) break;
    }
    int bad = ferror(f);
    fclose(f);
    if (bad) {
        free(text);
        return ohm_fail(err, OHM_ERR_IO, "%s: read error", path);
    }
    int rc = ohm_transfer_parse(out, text, len, path, err);
    free(text);
    return rc;
}

/* The points around density: value = v[i0] + w (v[i1] - v[i0]); n > 0. */
static void bracket(const ohm_transfer *t, double density, size_t *pi0, size_t *pi1, double *pw)
{
    ohm_curve_bracket(t->density, t->n, density, pi0, pi1, pw);
}

/* One extra column (eta, g) at a density, or its header value when it is
 * not a column (points NULL). */
static double eval_column(const ohm_transfer *t, const double *points, double constant, double density)
{
    if (!points || t->n == 0) return constant;
    size_t i0, i1;
    double w;
    bracket(t, density, &i0, &i1, &w);
    return points[i0] + w * (points[i1] - points[i0]);
}

double ohm_transfer_eval_g(const ohm_transfer *t, double density)
{
    return eval_column(t, t->g_column ? t->g_points : NULL, t->g, density);
}

double ohm_transfer_eval_eta(const ohm_transfer *t, double density)
{
    return eval_column(t, t->eta_column ? t->eta_points : NULL, t->eta, density);
}

void ohm_transfer_eval(const ohm_transfer *t, double density, double *sa, double *ss)
{
    int ch = t->channels;
    if (t->n == 0) {
        for (int c = 0; c < ch; ++c) sa[c] = ss[c] = 0.0;
        return;
    }
    size_t i0, i1;
    double w;
    bracket(t, density, &i0, &i1, &w);
    for (int c = 0; c < ch; ++c) {
        double a0 = t->sigma_a[i0 * (size_t)ch + (size_t)c], a1 = t->sigma_a[i1 * (size_t)ch + (size_t)c];
        double s0 = t->sigma_s[i0 * (size_t)ch + (size_t)c], s1 = t->sigma_s[i1 * (size_t)ch + (size_t)c];
        sa[c] = a0 + w * (a1 - a0);
        ss[c] = s0 + w * (s1 - s0);
    }
}

ohm_curve ohm_transfer_curve(const ohm_transfer *t, int c, int ss)
{
    ohm_curve k = {t->n, t->density, (ss ? t->sigma_s : t->sigma_a) + c, (size_t)t->channels};
    return k;
}
