/* fuzz_transfer.c — libFuzzer harness for transfer-function files
 * (ohm_transfer_parse).  Run with scripts/fuzz.sh transfer SECONDS.  Checks: no
 * crash or UB (sanitizers); a failure sets a one-line message whose code is the
 * return value; a success has >= 1 control point, 1 or 3 channels (1 in
 * resistance mode), strictly increasing finite densities, finite non-negative
 * coefficients (sigma_s' / ground > 0), a finite eta, and ohm_transfer_eval
 * gives finite values inside, between and outside the points. */
#include "input/transfer.h"
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    ohm_transfer t; ohm_error e;
    memset(&e, 0, sizeof e);
    char *copy = malloc(size ? size : 1); /* exact size, so over-reads are caught */
    if (size) memcpy(copy, data, size);
    int rc = ohm_transfer_parse(&t, size ? copy : NULL, size, "fuzz.transfer", &e);
    if (rc == 0) {
        int ch = t.channels;
        if (t.n < 1 || !t.density || !t.sigma_a || !t.sigma_s) abort();
        if (ch != 1 && ch != 3) abort();
        if (t.resistance_mode && ch != 1) abort();
        if (!isfinite(t.eta)) abort();
        for (size_t i = 0; i < t.n; ++i) {
            if (!isfinite(t.density[i])) abort();
            if (i && !(t.density[i] > t.density[i - 1])) abort();
            for (int c = 0; c < ch; ++c) {
                double a = t.sigma_a[i * (size_t)ch + c], s = t.sigma_s[i * (size_t)ch + c];
                if (!isfinite(a) || !isfinite(s) || a < 0 || !(s > 0)) abort();
            }
        }
        double probes[5] = {t.density[0] - 1.0, t.density[0], t.density[t.n - 1], t.density[t.n - 1] + 1.0,
                            0.5 * t.density[0] + 0.5 * t.density[t.n - 1]};
        for (int p = 0; p < 5; ++p) {
            double sa[3] = {0, 0, 0}, ss[3] = {0, 0, 0};
            if (!isfinite(probes[p])) continue;
            ohm_transfer_eval(&t, probes[p], sa, ss);
            for (int c = 0; c < ch; ++c) if (!isfinite(sa[c]) || !isfinite(ss[c])) abort();
        }
        ohm_transfer_free(&t);
    } else {
        if (e.code != rc || !memchr(e.msg, 0, sizeof e.msg) || strchr(e.msg, '\n')) abort();
        if (t.n || t.density || t.sigma_a || t.sigma_s) abort(); /* out zeroed on failure */
    }
    free(copy);
    return 0;
}
