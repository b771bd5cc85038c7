/* api/estimate.c — ohm_scene_estimate (include/ohm.h): the memory a solve of
 * the scene's mesh would take, and solver=auto's choice, predicted by
 * solvers/estimate.h before anything is built. */
#include "api/api.h"

#include <stddef.h>
#include <stdio.h>
#include <string.h>

#include "base/memory.h"
#include "solvers/estimate.h"
#include "steps/pipeline.h"

static const ohm_opt_spec estimate_opts[] = {
    {"dim", OHM_OPT_INT, NULL, "cells along the longest axis, as -voxelize dim=", NULL, 1, 4096, 1},
    {"solver", OHM_OPT_ENUM, "auto", "the solver whose largest dim is sought; auto: the one it would take",
     "auto|direct|cg|amg|mg", 0, 0, 0},
    {"channels", OHM_OPT_INT, NULL, "distinct channel materials (default the scene's material's, else 3)", NULL, 1, 3,
     0},
    {"solves", OHM_OPT_REAL, "1", "solves of each channel to come, relights included", NULL, 1, 1e9, 0},
    {"max_memory", OHM_OPT_REAL, NULL, "MB allowed (default what the machine has available)", NULL, 1e-3, 1e12, 0},
    {0}};

static const ohm_action estimate_action = {"estimate", "what a solve would take", NULL, estimate_opts,
                                           NULL,       0,                        NULL, NULL, NULL};

int ohm_scene_estimate(ohm_estimate_info *out, const ohm_scene *scene, const char *const *options)
{
    if (!out || !scene) return ohm_api_fail(OHM_ERR_USAGE, "ohm_scene_estimate: out or scene is NULL");
    const size_t size = out->size;
    /* the struct came in 1.2 with all of its present fields */
    int rc = ohm_api_sized_ok(size, offsetof(ohm_estimate_info, reason) + sizeof out->reason, "ohm_scene_estimate",
                              "OHM_ESTIMATE_INFO_INIT");
    if (rc) return rc;
    if (!scene->state.have_mesh)
        return ohm_api_fail(OHM_ERR_INVALID, "ohm_scene_estimate: the scene has no mesh (read one or set it first)");
    int argc = 0;
    while (options && options[argc]) ++argc;
    ohm_invocation inv;
    ohm_error err;
    ohm_error_clear(&err);
    rc = ohm_invocation_parse(&inv, &estimate_action, argc, options, &err);
    if (rc) return ohm_api_return(rc, &err);
    const ohm_state *s = &scene->state;
    int channels = ohm_opt_given(&inv, "channels") ? (int)ohm_opt_int(&inv, "channels")
                   : s->have_material                ? s->material.channels
                                                     : 3;
    double allowed = ohm_memory_limit(ohm_opt_given(&inv, "max_memory") ? ohm_opt_real(&inv, "max_memory") * 1048576.0
                                                                          : 0.0);
    ohm_solver_kind asked = OHM_SOLVER_AUTO;
    ohm_solver_kind_parse(&asked, ohm_opt_str(&inv, "solver"), NULL); /* an enum of the table: it parses */
    ohm_shape shape;
    ohm_shape_of(&shape, &s->mesh);
    ohm_solve_estimate e;
    ohm_estimate_solve(&e, &shape, (int)ohm_opt_int(&inv, "dim"), channels, ohm_opt_real(&inv, "solves"), allowed);
    ohm_solver_kind solver = asked == OHM_SOLVER_AUTO ? e.auto_choice : asked;

    ohm_estimate_info info = OHM_ESTIMATE_INFO_INIT;
    info.interior_cells = (int64_t)e.interior_cells;
    info.grid_cells = (int64_t)e.box_cells;
    info.bytes_direct = e.bytes[OHM_SOLVER_DIRECT];
    info.bytes_cg = e.bytes[OHM_SOLVER_CG];
    info.bytes_amg = e.bytes[OHM_SOLVER_AMG];
    info.bytes_mg = e.bytes[OHM_SOLVER_MG];
    info.bytes_auto = e.bytes[OHM_SOLVER_AUTO];
    info.bytes_allowed = allowed;
    info.margin = OHM_ESTIMATE_MARGIN;
    info.largest_dim = ohm_estimate_largest_dim(&shape, solver, channels, allowed);
    info.largest_dim_mg = ohm_estimate_largest_dim(&shape, OHM_SOLVER_MG, channels, allowed);
    snprintf(info.solver, sizeof info.solver, "%s", ohm_solver_kind_name(solver));
    snprintf(info.reason, sizeof info.reason, "%s", asked == OHM_SOLVER_AUTO ? e.auto_reason : "asked for");
    ohm_invocation_free(&inv);
    /* the fields this caller has; its size stays its own */
    memcpy((char *)out + sizeof info.size, (const char *)&info + sizeof info.size,
           (size < sizeof info ? size : sizeof info) - sizeof info.size);
    return OHM_OK;
}
