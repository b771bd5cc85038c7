/* transfer.h — transfer functions: density -> optical coefficients.
 *
 * The file format (documented in docs/transfer-functions.md):
 *   ohm-transfer 1 [mode=optical|resistance] [eta=1.3|column] [g=0|column] [scattering=reduced|full]
 *   # comments; then one control point per line, increasing density:
 *   density  sigma_a  sigma_s'  [eta] [g]               (grey)
 *   density  sa_r sa_g sa_b  ss_r ss_g ss_b  [eta] [g]  (RGB)
 *   density  resistance  ground                     (mode=resistance, ohms)
 * eta=column: a column after the scattering ones holds the refractive index
 * at that density, in [1, 3], interpolated like the others (network.h's
 * interfaces where it changes between cells); g=column: the column after
 * that (or after the scattering ones) holds the anisotropy, in (-1, 1)
 * (transport: mc.h; with scattering=full each point's sigma_s' = sigma_s
 * (1 - its g)), whichever order the header words come in.
 * scattering=full: the third column is sigma_s, and sigma_s' = sigma_s (1 - g)
 * is kept (diffusion needs only that; g shapes Monte Carlo's phase function).
 * Piecewise linear between points, clamped outside them.  Validated on load:
 * increasing densities, values in the ranges below, consistent column
 * counts; errors say "file:line: what". */
#ifndef OHM_TRANSFER_H
#define OHM_TRANSFER_H

#include <stddef.h>

#include "base/curve.h"
#include "base/ohm_error.h"

/* The coefficients ohm accepts, in a transfer function and on -material:
 * the ranges tests/cli_extremes.sh solves stably (sigma_a 1e-6 against 1e6,
 * sigma_s' 1 against 1e12 in one object, 1/mm).  Beyond them the network's
 * conductances and the solve's power sums leave double's range (1e300 gave
 * an infinite sigma_a grid) or its precision; resistances likewise, ohms. */
#define OHM_SIGMA_A_MAX 1e6
#define OHM_SIGMA_S_MIN 1e-9
#define OHM_SIGMA_S_MAX 1e12
#define OHM_RESISTANCE_MIN 1e-12
#define OHM_RESISTANCE_MAX 1e12

typedef struct ohm_transfer {
    int resistance_mode;      /* points hold resistance, ground instead          */
    int channels;             /* 1 or 3 (resistance mode: 1)                     */
    double eta;               /* the header's, or with eta_column the first point's */
    int eta_column;           /* eta=column: every point gives its index          */
    double *eta_points;       /* n when eta_column, else NULL                     */
    int g_column;             /* g=column: every point gives its anisotropy       */
    double *g_points;         /* n when g_column, else NULL                       */
    double g;                 /* scattering anisotropy (header g=)               */
    int scattering_full;      /* the file gave sigma_s (converted to sigma_s')    */
    size_t n;                 /* control points                                  */
    double *density;          /* n                                              */
    double *sigma_a;          /* n * channels (resistance mode: resistance, ohm) */
    double *sigma_s;          /* n * channels (resistance mode: ground, ohm)     */
} ohm_transfer;

int ohm_transfer_read(ohm_transfer *out, const char *path, ohm_error *err);
int ohm_transfer_parse(ohm_transfer *out, const char *text, size_t len, const char *name, ohm_error *err);
void ohm_transfer_free(ohm_transfer *t);

/* Coefficients at a density (clamped at the ends): sa[c], ss[c] for c < channels. */
void ohm_transfer_eval(const ohm_transfer *t, double density, double *sa, double *ss);

/* Channel c's sigma_a (ss = 0) or sigma_s' (ss = 1) as a function of
 * density: ohm_curve_at gives ohm_transfer_eval's values; the curve points
 * into t (n > 0). */
ohm_curve ohm_transfer_curve(const ohm_transfer *t, int c, int ss);

/* The refractive index at a density: the column's (eta=column), else eta. */
double ohm_transfer_eval_eta(const ohm_transfer *t, double density);

/* The anisotropy at a density: the column's (g=column), else g. */
double ohm_transfer_eval_g(const ohm_transfer *t, double density);

#endif
