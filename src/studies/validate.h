/* validate.h — `ohm validate`: the solver against references that do not
 * depend on ohm's own code (docs/design.md §3), on built-in scenes.  Each check is a
 * row: what was compared, measured, expected, error, tolerance, pass.  The
 * test suite runs the same functions and asserts every row passes. */
#ifndef OHM_VALIDATE_H
#define OHM_VALIDATE_H

#include <stdint.h>
#include <stdio.h>

#include "physics/fresnel.h"
#include "physics/light.h"
#include "base/log.h"
#include "base/ohm_error.h"
#include "device/request.h"

typedef struct ohm_check_row {
    char name[128];      /* the scene and quantity                         */
    char reference[64];  /* what it is compared with                       */
    double measured, expected;
    double error;        /* relative error (or the quantity, see kind)     */
    double tolerance;    /* pass when error <= tolerance; < 0: report only */
    int pass;
} ohm_check_row;

enum { OHM_VALIDATION_MAX_ROWS = 256 };

typedef struct ohm_validation {
    ohm_check_row rows[OHM_VALIDATION_MAX_ROWS];
    int n;
} ohm_validation;

/* Append a row (pass = error <= tolerance; tolerance < 0: reported only);
 * NULL when the table is full. */
ohm_check_row *ohm_validation_add(ohm_validation *v, const char *name, const char *reference, double measured,
                                  double expected, double error, double tolerance);

/* Each adds rows; returns non-zero only when a scene could not be run at all
 * (err says why).  A failed comparison is a row with pass = 0. */
int ohm_validate_infinite(ohm_validation *v, const ohm_log *log, ohm_error *err);
int ohm_validate_halfspace(ohm_validation *v, const ohm_log *log, ohm_error *err);
int ohm_validate_boundaries(ohm_validation *v, const ohm_log *log, ohm_error *err);
int ohm_validate_extremes(ohm_validation *v, const ohm_log *log, ohm_error *err);
int ohm_validate_layered(ohm_validation *v, const ohm_log *log, ohm_error *err);
/* A refractive index per cell (network.h's interfaces): a two-layer slab at
 * eta 1.3 over 1.6 on a 1-D column against ohm_ref_two_layer at h = 0.4 ..
 * 0.025 mm (within 1% at the finest; the convergence order), and a uniform
 * per-cell index against none. */
int ohm_validate_index_layers(ohm_validation *v, const ohm_log *log, ohm_error *err);

/* The half-space scene of ohm_validate_halfspace (sigma_a 0.05, sigma_s'
 * 0.95 /mm, a pencil beam's source at depth 1/sigma_t', Robin, eta 1.3) at
 * voxel size h, against the exact Robin half-space exitance J(r) over
 * 1/sigma_t' <= r <= 3/sigma_tr: worst relative error and the relative L1
 * error (sum |J - Jref| / sum Jref) over the surface faces there. */
typedef struct ohm_halfspace_result {
    double worst, mean, seconds, nnz_L;
    int64_t cells;
} ohm_halfspace_result;
int ohm_halfspace_accuracy(ohm_halfspace_result *out, double h, int use_cg, const ohm_log *log, ohm_error *err);

/* Diffusion against ohm's Monte Carlo transport (mc.h; validate_transport.c)
 * on the transport study's scenes (docs/transport.md) — a slab lit by a pencil beam at eta 1.0 and 1.4, a
 * cube at eta 1.37, the same cube with a sphere of another medium — in the
 * MCX benchmark's medium (sigma_a 0.005, sigma_s 1 /mm, g 0.01), cube side
 * `size` mm (slabs 2 size wide, size / 2 thick), voxel h: per scene the
 * fluence more than 2 transport mean free paths from the source and the
 * faces (mean |error|, rms), the absorbed fraction, the total diffuse
 * reflectance, and the reflectance against radius beyond 2 mm. */
typedef struct ohm_transport_config {
    double h, size;           /* mm                                        */
    int64_t photons;          /* per scene                                 */
    uint64_t seed;
    int threads;              /* 0: every core                             */
    ohm_fresnel fresnel;      /* the diffusion solve's settings            */
    ohm_deposit deposit;
    int hybrid;               /* > 0: -solve hybrid= (solve.h, mc.handoff)  */
    ohm_device_request device; /* where the photons run (mc.h; zero: the host) */
    double tol_fluence_mean, tol_fluence_rms, tol_absorbed, tol_reflectance, tol_rings;
} ohm_transport_config;
void ohm_transport_config_default(ohm_transport_config *cfg); /* the transport study's targets, h 1, size 60, 1e6 */
int ohm_validate_transport(ohm_validation *v, const ohm_transport_config *cfg, const ohm_log *log, ohm_error *err);

/* The Monte Carlo reference (mc.h) itself against published transport
 * values, `photons` each (random stream `seed`): van de Hulst's matched slab (MCML's check), MCML's
 * mismatched half-space, MCX's cube60 absorbed fraction; each row passes
 * within 4 combined standard errors; and its speed on cube60. */
int ohm_validate_mc(ohm_validation *v, int64_t photons, uint64_t seed, int threads, ohm_device_request device,
                    const ohm_log *log, ohm_error *err);

/* All of the above, in order. */
int ohm_validate_all(ohm_validation *v, const ohm_log *log, ohm_error *err);

/* The seed paper's Figure 1: a 15 x 15 single-layer grid (h = 1 mm), every
 * resistor 1 kOhm, Neumann boundary, a step source of 1.18 V behind 1 kOhm
 * (1.18 mA) into the middle 3 x 3 cells.  Writes the profile along the middle
 * row as CSV: the paper's network, a network whose resistors come from the
 * same milk coefficients (sigma_a 0.0041, sigma_s' 2.6 /mm: G = h D,
 * G_a = sigma_a h^3), and the Jensen dipole's exitance for that lit square —
 * each also normalised to its peak.  Adds rows comparing their widths. */
int ohm_paper_figure1(FILE *csv, ohm_validation *v, const ohm_log *log, ohm_error *err);

/* The table; returns the number of failed rows. */
int ohm_validation_print(FILE *f, const ohm_validation *v);

#endif
