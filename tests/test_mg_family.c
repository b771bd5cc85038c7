/* test_mg_family.c — solver=mg on media of the held-in family
 * (studies/block_medium.h, docs/multigrid.md "Any medium") at 32^3 cells:
 * random blocks of nine levels over 1e6 in sigma_s' and 1e3 in sigma_a,
 * thin hard shells around a soft interior, and clear regions (sigma_s'
 * 1e-3 /mm) inside tissue.  On each, mg's solution is the Cholesky
 * factor's to 1e-6 of the peak, the power it sinks is the power put in to
 * 1e-10, and it takes at most its bound of iterations to 1e-10 (a count:
 * the family's table in docs/multigrid.md has the counts at larger sizes). */
#include <stdio.h>

#include "check.h"
#include "family.h"

enum { NX = 32 };

/* Iterations allowed at 32^3.  The shells and the clear regions took 25 and
 * 24 when this test was written, and are held to test_mg's 30 for the
 * scale study's block medium.  The nine-level blocks, whose faces cut the
 * hierarchy's 2x2x2 blocks at every level, took 49: piecewise-constant
 * aggregation over fixed blocks does not follow them (docs/multigrid.md,
 * "Any medium"); the bound keeps that from growing unseen. */
static const struct {
    ohm_family_medium medium;
    int64_t max_iterations;
} cases[] = {{OHM_FAMILY_BLOCKS9, 60}, {OHM_FAMILY_SHELLS, 30}, {OHM_FAMILY_CLEAR, 30}};

int main(void)
{
    for (size_t q = 0; q < sizeof cases / sizeof *cases; ++q) {
        const char *name = ohm_family_medium_name(cases[q].medium);
        family_result r;
        ohm_error err;
        ohm_error_clear(&err);
        int rc = family_solve(cases[q].medium, NX, 1e-10, 2, 1, &r, &err);
        CHECK_MSG(rc == 0, "%s at %d^3: %s", name, NX, err.msg);
        if (rc) continue;
        CHECK_MSG(r.vs_direct >= 0 && r.vs_direct <= 1e-6, "%s: mg vs direct %.3g of the peak", name, r.vs_direct);
        CHECK_MSG(r.conservation <= 1e-10, "%s: conservation error %.3g", name, r.conservation);
        CHECK_MSG(r.iterations > 0 && r.iterations <= cases[q].max_iterations, "%s: %lld iterations, more than %lld", name,
                  (long long)r.iterations, (long long)cases[q].max_iterations);
        fprintf(stderr, "mg: %-8s %d^3: %lld iterations, %d levels, %.1e off direct, conservation %.1e\n", name, NX,
                (long long)r.iterations, r.levels, r.vs_direct, r.conservation);
    }
    return check_summary();
}
