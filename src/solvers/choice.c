/* solvers/choice.c — the solver a solve asks for (solve.h's
 * ohm_solver_kind): its name, read once, and what it can do, so that the
 * layers that get it ask its capabilities instead of comparing names. */
#include "solvers/solve.h"

#include <string.h>

static const struct {
    const char *name;
    unsigned caps;
} kinds[] = {
    [OHM_SOLVER_DIRECT] = {"direct", 0},
    [OHM_SOLVER_CG] = {"cg", 0},
    [OHM_SOLVER_AMG] = {"amg", 0},
    [OHM_SOLVER_MG] = {"mg", OHM_SOLVES_ON_DEVICE},
    [OHM_SOLVER_AUTO] = {"auto", OHM_SOLVES_ON_DEVICE}, /* its probe is mg (auto.c) */
    [OHM_SOLVER_MC] = {"mc", OHM_SOLVES_TRANSPORT | OHM_SOLVES_ON_DEVICE},
};
enum { NKINDS = sizeof kinds / sizeof *kinds };

int ohm_solver_kind_parse(ohm_solver_kind *out, const char *name, ohm_error *err)
{
    for (int k = 0; name && k < NKINDS; ++k)
        if (strcmp(name, kinds[k].name) == 0) {
            *out = (ohm_solver_kind)k;
            return OHM_OK;
        }
    return ohm_fail(err, OHM_ERR_USAGE, "solve: unknown solver '%s': expected direct, cg, amg, mg, auto or mc",
                    name ? name : "");
}

const char *ohm_solver_kind_name(ohm_solver_kind kind)
{
    return (int)kind >= 0 && (int)kind < NKINDS ? kinds[kind].name : "?";
}

unsigned ohm_solver_kind_caps(ohm_solver_kind kind)
{
    return (int)kind >= 0 && (int)kind < NKINDS ? kinds[kind].caps : 0u;
}
