/* test_validate.c — every `ohm validate` row must pass: convergence to the
 * infinite-medium solution at second order, the exact Robin half-space,
 * conservation, Neumann vs Robin, singular and ill-conditioned systems. */
#include <string.h>

#include "check.h"
#include "studies/validate.h"

int main(void)
{
    ohm_log quiet = {.verbosity = 0};
    ohm_validation v;
    memset(&v, 0, sizeof v);
    ohm_error err;
    ohm_error_clear(&err);
    int rc = ohm_validate_all(&v, &quiet, &err);
    CHECK_MSG(rc == 0, "validate: %s", err.msg);
    ohm_validation_print(stdout, &v);
    int asserted = 0;
    for (int i = 0; i < v.n; ++i) {
        if (v.rows[i].tolerance < 0) continue; /* reported beside, not a pass mark */
        ++asserted;
        CHECK_MSG(v.rows[i].pass, "%s: measured %g, expected %g, error %g > %g", v.rows[i].name, v.rows[i].measured,
                  v.rows[i].expected, v.rows[i].error, v.rows[i].tolerance);
    }
    /* the suite must actually compare something in each family */
    const char *families[] = {"infinite medium convergence order", "half-space J(r), worst", "half-space escaped",
                              "neumann: power out", "sigma_a=0, neumann: refused", "contrast 1e+12",
                              "sigma_a=1e-9, neumann: backward", "two layers: conservation"};
    for (size_t f = 0; f < sizeof families / sizeof *families; ++f) {
        int found = 0;
        for (int i = 0; i < v.n; ++i) found |= strncmp(v.rows[i].name, families[f], strlen(families[f])) == 0;
        CHECK_MSG(found, "no row for '%s'", families[f]);
    }
    CHECK(asserted >= 20);
    return check_summary();
}
