/* test_transfer.c — transfer functions (transfer.h): parsing, every error with
 * its file:line, evaluation at and between control points and clamping, and
 * the sample files in samples/. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "input/transfer.h"

static int parse(ohm_transfer *t, const char *text, ohm_error *err)
{
    ohm_error_clear(err);
    return ohm_transfer_parse(t, text, strlen(text), "t.transfer", err);
}

/* text must fail with code and a message starting with "t.transfer:LINE:" and
 * containing what. */
static void expect_error(const char *text, int code, int line, const char *what)
{
    ohm_transfer t;
    ohm_error err;
    int rc = parse(&t, text, &err);
    char prefix[64];
    snprintf(prefix, sizeof prefix, "t.transfer:%d: ", line);
    CHECK_MSG(rc == code, "expected code %d, got %d (%s) for:\n%s", code, rc, err.msg, text);
    CHECK_MSG(strncmp(err.msg, prefix, strlen(prefix)) == 0, "message \"%s\" does not start with \"%s\"", err.msg,
              prefix);
    CHECK_MSG(strstr(err.msg, what) != NULL, "message \"%s\" does not say \"%s\"", err.msg, what);
    CHECK(t.n == 0 && t.density == NULL && t.sigma_a == NULL && t.sigma_s == NULL);
    ohm_transfer_free(&t);
}

static void test_parse_grey(void)
{
    ohm_transfer t;
    ohm_error err;
    int rc = parse(&t,
                   "# a leading comment\n"
                   "\n"
                   "ohm-transfer 1   # header comment\n"
                   "  # indented comment\n"
                   "-1000 0.001 0.01\n"
                   "\t\n"
                   "0 0.02 1.0   # soft\n"
                   "1000 0 25\n",
                   &err);
    CHECK_MSG(rc == 0, "%s", err.msg);
    if (rc) return;
    CHECK(t.resistance_mode == 0 && t.channels == 1 && t.eta == 1.3 && t.n == 3);
    CHECK(t.density[0] == -1000 && t.density[1] == 0 && t.density[2] == 1000);
    CHECK(t.sigma_a[1] == 0.02 && t.sigma_s[1] == 1.0 && t.sigma_a[2] == 0.0 && t.sigma_s[2] == 25.0);

    double a, s;
    /* at the points */
    for (size_t i = 0; i < t.n; ++i) {
        ohm_transfer_eval(&t, t.density[i], &a, &s);
        CHECK(a == t.sigma_a[i] && s == t.sigma_s[i]);
    }
    /* between them: linear */
    ohm_transfer_eval(&t, -500, &a, &s);
    CHECK_REL(a, 0.5 * (0.001 + 0.02), 1e-14);
    CHECK_REL(s, 0.5 * (0.01 + 1.0), 1e-14);
    ohm_transfer_eval(&t, 250, &a, &s);
    CHECK_REL(a, 0.75 * 0.02, 1e-14);
    CHECK_REL(s, 1.0 + 0.25 * 24.0, 1e-14);
    /* clamped outside */
    ohm_transfer_eval(&t, -1e9, &a, &s);
    CHECK(a == 0.001 && s == 0.01);
    ohm_transfer_eval(&t, 1e9, &a, &s);
    CHECK(a == 0.0 && s == 25.0);
    ohm_transfer_eval(&t, INFINITY, &a, &s);
    CHECK(a == 0.0 && s == 25.0);
    ohm_transfer_eval(&t, -INFINITY, &a, &s);
    CHECK(a == 0.001 && s == 0.01);
    ohm_transfer_eval(&t, NAN, &a, &s); /* NaN: the first point, never NaN out */
    CHECK(a == 0.001 && s == 0.01);
    ohm_transfer_free(&t);
    ohm_transfer_free(&t); /* twice is fine */
}

static void test_parse_rgb_crlf(void)
{
    ohm_transfer t;
    ohm_error err;
    int rc = parse(&t,
                   "ohm-transfer 1 mode=optical eta=1.44\r\n"
                   "# density sa_r sa_g sa_b ss_r ss_g ss_b\r\n"
                   "\r\n"
                   "0 0.1 0.2 0.3 1 2 3\r\n"
                   "10 0.3 0.4 0.5 3 4 5", /* no final newline */
                   &err);
    CHECK_MSG(rc == 0, "%s", err.msg);
    if (rc) return;
    CHECK(t.channels == 3 && t.n == 2 && t.eta == 1.44 && !t.resistance_mode);
    double a[3], s[3];
    ohm_transfer_eval(&t, 5, a, s);
    for (int c = 0; c < 3; ++c) {
        CHECK_REL(a[c], 0.2 + 0.1 * c, 1e-14);
        CHECK_REL(s[c], 2.0 + c, 1e-14);
    }
    ohm_transfer_eval(&t, 7.5, a, s);
    CHECK_REL(a[2], 0.45, 1e-14);
    CHECK_REL(s[0], 2.5, 1e-14);
    ohm_transfer_eval(&t, -3, a, s);
    CHECK(a[0] == 0.1 && a[1] == 0.2 && a[2] == 0.3 && s[0] == 1 && s[1] == 2 && s[2] == 3);
    ohm_transfer_free(&t);
}

static void test_parse_single_and_resistance(void)
{
    ohm_transfer t;
    ohm_error err;
    /* one point: constant everywhere */
    int rc = parse(&t, "ohm-transfer 1\n5 0.05 2\n", &err);
    CHECK_MSG(rc == 0, "%s", err.msg);
    if (!rc) {
        double a, s;
        for (double d = -10; d <= 20; d += 7.5) {
            ohm_transfer_eval(&t, d, &a, &s);
            CHECK(a == 0.05 && s == 2.0);
        }
        ohm_transfer_free(&t);
    }
    rc = parse(&t, "ohm-transfer 1 mode=resistance\n0 1000 1e6\n100 500 2e5\n", &err);
    CHECK_MSG(rc == 0, "%s", err.msg);
    if (!rc) {
        CHECK(t.resistance_mode == 1 && t.channels == 1 && t.n == 2);
        double r, gnd;
        ohm_transfer_eval(&t, 50, &r, &gnd);
        CHECK_REL(r, 750, 1e-14);
        CHECK_REL(gnd, 6e5, 1e-14);
        ohm_transfer_free(&t);
    }
    /* mode=optical then eta in either order */
    rc = parse(&t, "ohm-transfer 1 eta=1.0 mode=optical\n0 0 1\n", &err);
    CHECK_MSG(rc == 0 && t.eta == 1.0, "%s", err.msg);
    ohm_transfer_free(&t);
    /* scattering=full with g: the columns hold sigma_s, kept as sigma_s' = sigma_s (1 - g),
     * whichever order the header words come in; reduced (the default) keeps them as they are */
    rc = parse(&t, "ohm-transfer 1 scattering=full g=0.9\n0 0.01 10\n1 0.02 20\n", &err);
    CHECK_MSG(rc == 0, "%s", err.msg);
    if (!rc) {
        double sa, ss;
        ohm_transfer_eval(&t, 0.5, &sa, &ss);
        CHECK(t.g == 0.9 && t.scattering_full == 1);
        CHECK_REL(ss, 1.5, 1e-14);
        CHECK_REL(sa, 0.015, 1e-14);
        ohm_transfer_free(&t);
    }
    rc = parse(&t, "ohm-transfer 1 g=0.9\n0 0.01 10\n", &err);
    CHECK_MSG(rc == 0 && t.g == 0.9 && t.scattering_full == 0 && t.sigma_s[0] == 10, "%s", err.msg);
    ohm_transfer_free(&t);
    /* eta=column: the last column is the index, interpolated like the rest;
     * the material's eta is the first point's; grey and RGB */
    rc = parse(&t, "ohm-transfer 1 eta=column\n0 0.01 1 1.3\n1 0.02 2 1.5\n", &err);
    CHECK_MSG(rc == 0, "%s", err.msg);
    if (!rc) {
        double sa, ss;
        ohm_transfer_eval(&t, 0.25, &sa, &ss);
        CHECK(t.eta_column == 1 && t.channels == 1 && t.eta == 1.3);
        CHECK_REL(ohm_transfer_eval_eta(&t, 0.25), 1.35, 1e-14);
        CHECK_REL(ss, 1.25, 1e-14);
        CHECK(ohm_transfer_eval_eta(&t, -5) == 1.3 && ohm_transfer_eval_eta(&t, 7) == 1.5); /* clamped */
        ohm_transfer_free(&t);
    }
    rc = parse(&t, "ohm-transfer 1 eta=column\n0  0.1 0.2 0.3  1 2 3  1.4\n", &err);
    CHECK_MSG(rc == 0 && t.channels == 3 && t.eta == 1.4 && ohm_transfer_eval_eta(&t, 0) == 1.4, "%s", err.msg);
    ohm_transfer_free(&t);
    /* g=column after eta: with scattering=full each point keeps sigma_s' = sigma_s (1 - its g) */
    rc = parse(&t, "ohm-transfer 1 eta=column g=column scattering=full\n0 0.01 10 1.3 0.9\n1 0.02 10 1.5 0.5\n", &err);
    CHECK_MSG(rc == 0, "%s", err.msg);
    if (!rc) {
        CHECK(t.g_column && t.eta_column && t.g == 0.9);
        CHECK_REL(t.sigma_s[0], 1.0, 1e-14);
        CHECK_REL(t.sigma_s[1], 5.0, 1e-14);
        CHECK_REL(ohm_transfer_eval_g(&t, 0.5), 0.7, 1e-14);
        CHECK_REL(ohm_transfer_eval_eta(&t, 0.5), 1.4, 1e-14);
        ohm_transfer_free(&t);
    }
    rc = parse(&t, "ohm-transfer 1 g=0.3\n0 0.01 1\n", &err);
    CHECK_MSG(rc == 0 && !t.g_column && ohm_transfer_eval_g(&t, 4) == 0.3, "%s", err.msg);
    ohm_transfer_free(&t);
    /* without the column every density has the header's index */
    rc = parse(&t, "ohm-transfer 1 eta=1.45\n0 0.01 1\n", &err);
    CHECK_MSG(rc == 0 && !t.eta_column && ohm_transfer_eval_eta(&t, 0.5) == 1.45, "%s", err.msg);
    ohm_transfer_free(&t);
}

static void test_errors(void)
{
    /* header */
    expect_error("", OHM_ERR_PARSE, 1, "bad header");
    expect_error("# only a comment\n\n", OHM_ERR_PARSE, 2, "bad header");
    expect_error("0 0.1 1\n", OHM_ERR_PARSE, 1, "bad header");
    expect_error("\n# c\nohm-transfr 1\n0 0.1 1\n", OHM_ERR_PARSE, 3, "bad header");
    expect_error("ohm-transfer\n0 0.1 1\n", OHM_ERR_PARSE, 1, "bad header");
    expect_error("ohm-transfer 2\n0 0.1 1\n", OHM_ERR_PARSE, 1, "version");
    expect_error("ohm-transfer 1 colour=rgb\n0 0.1 1\n", OHM_ERR_PARSE, 1, "unknown header option \"colour=rgb\"");
    expect_error("ohm-transfer 1 mode=magic\n0 0.1 1\n", OHM_ERR_PARSE, 1, "unknown mode");
    expect_error("ohm-transfer 1 mode=resistance eta=column\n0 1 1\n", OHM_ERR_PARSE, 1, "eta=column needs optical");
    expect_error("ohm-transfer 1 eta=column\n0 0.1 1\n", OHM_ERR_PARSE, 2, "expected 4 columns (density sigma_a sigma_s' eta)");
    expect_error("ohm-transfer 1 eta=column\n0 0.1 1 1.3\n1 0.1 1\n", OHM_ERR_PARSE, 3, "expected 4 columns like the first");
    expect_error("ohm-transfer 1 eta=column\n0 0.1 1 0.9\n", OHM_ERR_INVALID, 2, "column 4 (eta) must be in [1, 3]");
    expect_error("ohm-transfer 1 eta=column\n0 0.1 1 nan\n", OHM_ERR_PARSE, 2, "column 4 (eta)");
    expect_error("ohm-transfer 1 g=column\n0 0.1 1 1\n", OHM_ERR_INVALID, 2, "column 4 (g) must be in (-1, 1)");
    expect_error("ohm-transfer 1 g=column eta=column\n0 0.1 1 1.3\n", OHM_ERR_PARSE, 2,
                 "expected 5 columns (density sigma_a sigma_s' eta g)");
    expect_error("ohm-transfer 1 mode=resistance g=column\n0 1 1\n", OHM_ERR_PARSE, 1, "g=column needs optical");
    expect_error("ohm-transfer 1 eta=0\n0 0.1 1\n", OHM_ERR_PARSE, 1, "eta");
    expect_error("ohm-transfer 1 eta=abc\n0 0.1 1\n", OHM_ERR_PARSE, 1, "eta");
    expect_error("ohm-transfer 1 eta=1.3 eta=1.4\n0 0.1 1\n", OHM_ERR_PARSE, 1, "twice");
    expect_error("ohm-transfer 1 g=1\n0 0.1 1\n", OHM_ERR_PARSE, 1, "anisotropy");
    expect_error("ohm-transfer 1 g=nan\n0 0.1 1\n", OHM_ERR_PARSE, 1, "anisotropy");
    expect_error("ohm-transfer 1 g=0.1 g=0.2\n0 0.1 1\n", OHM_ERR_PARSE, 1, "twice");
    expect_error("ohm-transfer 1 scattering=total\n0 0.1 1\n", OHM_ERR_PARSE, 1, "expected reduced");
    /* no points */
    expect_error("ohm-transfer 1\n", OHM_ERR_PARSE, 1, "no control points");
    expect_error("ohm-transfer 1\n# nothing\n\n", OHM_ERR_PARSE, 3, "no control points");
    /* column counts */
    expect_error("ohm-transfer 1\n0 0.1\n", OHM_ERR_PARSE, 2, "got 2");
    expect_error("ohm-transfer 1\n0 0.1 1 2\n", OHM_ERR_PARSE, 2, "got 4");
    expect_error("ohm-transfer 1\n0 0.1 1 1 1 1 1 1 1 1\n", OHM_ERR_PARSE, 2, "got 10");
    expect_error("ohm-transfer 1\n0 0.1 1\n1 0.1 0.2 0.3 1 2 3\n", OHM_ERR_PARSE, 3, "like the first point, got 7");
    expect_error("ohm-transfer 1\n0 .1 .2 .3 1 2 3\n# x\n1 0.1 1\n", OHM_ERR_PARSE, 4, "expected 7 columns");
    expect_error("ohm-transfer 1 mode=resistance\n0 .1 .2 .3 1 2 3\n", OHM_ERR_PARSE, 2, "mode=resistance");
    /* numbers */
    expect_error("ohm-transfer 1\n0 0.1x 1\n", OHM_ERR_PARSE, 2, "column 2 (sigma_a)");
    expect_error("ohm-transfer 1\n0 nan 1\n", OHM_ERR_PARSE, 2, "not a finite number");
    expect_error("ohm-transfer 1\n0 0.1 inf\n", OHM_ERR_PARSE, 2, "column 3 (sigma_s')");
    expect_error("ohm-transfer 1\n1e999 0.1 1\n", OHM_ERR_PARSE, 2, "column 1 (density)");
    /* each coefficient within transfer.h's ranges (sigma_a [0, 1e6], sigma_s' [1e-9, 1e12],
     * resistances [1e-12, 1e12]): beyond them the network's sums overflow */
    expect_error("ohm-transfer 1\n0 -0.1 1\n", OHM_ERR_INVALID, 2, "(sigma_a) must be in [0, 1e+06], got -0.1");
    expect_error("ohm-transfer 1\n0 .1 .2 .3 1 2 3\n1 .1 -.2 .3 1 2 3\n", OHM_ERR_INVALID, 3,
                 "column 3 (sigma_a (G)) must be in [0, 1e+06]");
    expect_error("ohm-transfer 1\n0 1e300 1\n", OHM_ERR_INVALID, 2, "(sigma_a) must be in [0, 1e+06], got 1e300");
    expect_error("ohm-transfer 1\n0 0.1 0\n", OHM_ERR_INVALID, 2, "sigma_s') must be in [1e-09, 1e+12], got 0");
    expect_error("ohm-transfer 1\n0 0.1 -1\n", OHM_ERR_INVALID, 2, "sigma_s') must be in [1e-09, 1e+12]");
    expect_error("ohm-transfer 1\n0 0.1 1e-300\n", OHM_ERR_INVALID, 2, "sigma_s') must be in [1e-09, 1e+12]");
    expect_error("ohm-transfer 1\n0 0.1 2e12\n", OHM_ERR_INVALID, 2, "sigma_s') must be in [1e-09, 1e+12]");
    expect_error("ohm-transfer 1\n0 .1 .2 .3 1 2 3\n1 .1 .2 .3 1 2 0\n", OHM_ERR_INVALID, 3,
                 "column 7 (sigma_s' (B)) must be in");
    expect_error("ohm-transfer 1 mode=resistance\n0 1000 0\n", OHM_ERR_INVALID, 2, "ground) must be in [1e-12, 1e+12]");
    expect_error("ohm-transfer 1 mode=resistance\n0 -5 10\n", OHM_ERR_INVALID, 2, "resistance) must be in");
    expect_error("ohm-transfer 1 mode=resistance\n0 1e200 10\n", OHM_ERR_INVALID, 2, "resistance) must be in");
    /* the ends of the ranges are accepted (tests/cli_extremes.sh solves them) */
    {
        ohm_transfer t;
        ohm_error e;
        ohm_error_clear(&e);
        const char *edge = "ohm-transfer 1\n0 0 1e-9\n1 1e6 1e12\n";
        CHECK_MSG(ohm_transfer_parse(&t, edge, strlen(edge), "edge.transfer", &e) == 0, "%s", e.msg);
        ohm_transfer_free(&t);
    }
    /* increasing densities */
    expect_error("ohm-transfer 1\n0 0.1 1\n1 0.1 1\n1 0.1 1\n", OHM_ERR_INVALID, 4, "strictly increasing");
    expect_error("ohm-transfer 1\n0 0.1 1\n\n# c\n-1 0.1 1\n", OHM_ERR_INVALID, 5, "strictly increasing");
    /* line length; CRLF line numbers */
    {
        size_t big = 5000;
        char *text = malloc(big + 64);
        CHECK(text != NULL);
        if (text) {
            strcpy(text, "ohm-transfer 1\r\n0 0.1 1\r\n");
            size_t at = strlen(text);
            memset(text + at, ' ', big);
            strcpy(text + at + big, "1 0.1 1\r\n");
            expect_error(text, OHM_ERR_PARSE, 3, "line too long");
            free(text);
        }
    }
    expect_error("ohm-transfer 1\r\n\r\n0 0.1 1\r\n0 0.1 1\r\n", OHM_ERR_INVALID, 4, "strictly increasing");
    /* a NUL byte inside the text */
    {
        static const char nul[] = "ohm-transfer 1\n0 0.1\0 1\n";
        ohm_transfer t;
        ohm_error err;
        ohm_error_clear(&err);
        int rc = ohm_transfer_parse(&t, nul, sizeof nul - 1, "t.transfer", &err);
        CHECK(rc == OHM_ERR_PARSE && strncmp(err.msg, "t.transfer:2: ", 14) == 0);
    }
}

static void test_files(void)
{
    ohm_transfer t;
    ohm_error err;
    ohm_error_clear(&err);
    int rc = ohm_transfer_read(&t, "samples/does-not-exist.transfer", &err);
    CHECK(rc == OHM_ERR_IO && strstr(err.msg, "does-not-exist.transfer") != NULL);

    static const struct {
        const char *path;
        int resistance, channels;
    } samples[] = {{"samples/ct-tissue.transfer", 0, 3},
                   {"samples/walnut.transfer", 0, 3},
                   {"samples/paper-mode.transfer", 1, 1}};
    for (size_t i = 0; i < sizeof samples / sizeof samples[0]; ++i) {
        ohm_error_clear(&err);
        rc = ohm_transfer_read(&t, samples[i].path, &err);
        CHECK_MSG(rc == 0, "%s", err.msg);
        if (rc) continue;
        CHECK_MSG(t.resistance_mode == samples[i].resistance && t.channels == samples[i].channels && t.n >= 2,
                  "%s: mode %d channels %d points %zu", samples[i].path, t.resistance_mode, t.channels, t.n);
        ohm_transfer_free(&t);
    }
    /* the walnut file covers the CT's uint16 range */
    rc = ohm_transfer_read(&t, "samples/walnut.transfer", &err);
    if (!rc) {
        CHECK(t.density[0] <= 0 && t.density[t.n - 1] >= 22526);
        ohm_transfer_free(&t);
    }
}

int main(void)
{
    test_parse_grey();
    test_parse_rgb_crlf();
    test_parse_single_and_resistance();
    test_errors();
    test_files();
    return check_summary();
}
