/* validate.h — `ohm validate`: the solver against references that do not
 * depend on ohm's own code (DESIGN.md §3), on built-in scenes.  Each check is a
 * row: what was compared, measured, expected, error, tolerance, pass.  The
 * test suite runs the same functions and asserts every row passes. */
#ifndef OHM_VALIDATE_H
#define OHM_VALIDATE_H

#include <stdint.h>
#include <stdio.h>

#include "log.h"
#include "ohm_error.h"

typedef struct ohm_check_row {
    char name[80];       /* the scene and quantity                         */
    char reference[64];  /* what it is compared with                       */
    double measured, expected;
    double error;        /* relative error (or the quantity, see kind)     */
    double tolerance;    /* pass when error <= tolerance; < 0: report only */
    int pass;
} ohm_check_row;

enum { OHM_VALIDATION_MAX_ROWS = 64 };

typedef struct ohm_validation {
    ohm_check_row rows[OHM_VALIDATION_MAX_ROWS];
    int n;
} ohm_validation;

/* Each adds rows; returns non-zero only when a scene could not be run at all
 * (err says why).  A failed comparison is a row with pass = 0. */
int ohm_validate_infinite(ohm_validation *v, const ohm_log *log, ohm_error *err);
int ohm_validate_halfspace(ohm_validation *v, const ohm_log *log, ohm_error *err);
int ohm_validate_boundaries(ohm_validation *v, const ohm_log *log, ohm_error *err);
int ohm_validate_extremes(ohm_validation *v, const ohm_log *log, ohm_error *err);
int ohm_validate_layered(ohm_validation *v, const ohm_log *log, ohm_error *err);

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
