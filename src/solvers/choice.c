/* solvers/choice.c — the solver a solve asks for (solve.h's
 * ohm_solver_kind): its name, read once, what it can do, and the object
 * that solves it (a backend, or a transport), so that the layers that get
 * it ask its capabilities instead of comparing names, and the driver finds
 * its solver by kind. */
#include "solvers/solve.h"

#include <string.h>

#include "solvers/solver_impl.h"
#include "solvers/transport.h"

static const struct {
    const char *name;
    unsigned caps;
    const ohm_backend_ops *backend;     /* diffusion's linear solver, or NULL */
    const ohm_transport_ops *transport; /* OHM_SOLVES_TRANSPORT: the tracer   */
} kinds[] = {
    [OHM_SOLVER_DIRECT] = {"direct", 0, &ohm_backend_direct, NULL},
    [OHM_SOLVER_CG] = {"cg", 0, &ohm_backend_cg, NULL},
    [OHM_SOLVER_AMG] = {"amg", 0, &ohm_backend_amg, NULL},
    [OHM_SOLVER_MG] = {"mg", OHM_SOLVES_ON_DEVICE, &ohm_backend_mg, NULL},
    [OHM_SOLVER_AUTO] = {"auto", OHM_SOLVES_ON_DEVICE, &ohm_backend_auto, NULL}, /* its probe is mg (auto.c) */
    [OHM_SOLVER_MC] = {"mc", OHM_SOLVES_TRANSPORT | OHM_SOLVES_ON_DEVICE, NULL, &ohm_transport_mc},
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

const ohm_backend_ops *ohm_solver_kind_backend(ohm_solver_kind kind)
{
    return (int)kind >= 0 && (int)kind < NKINDS ? kinds[kind].backend : NULL;
}

const ohm_transport_ops *ohm_solver_kind_transport(ohm_solver_kind kind)
{
    return (int)kind >= 0 && (int)kind < NKINDS ? kinds[kind].transport : NULL;
}
