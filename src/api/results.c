/* api/results.c — what a scene holds, read back as arrays and figures
 * (include/ohm.h). */
#include "api/api.h"

#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "outputs/export_ply.h"

static int need_grid(const ohm_scene *scene, const char *fn)
{
    if (!scene) return ohm_api_fail(OHM_ERR_USAGE, "%s: scene is NULL", fn);
    if (!scene->state.have_grid) return ohm_api_fail(OHM_ERR_INVALID, "%s: no voxel grid yet: voxelize first", fn);
    return OHM_OK;
}

static size_t grid_cells(const ohm_voxel_grid *g)
{
    return (size_t)g->dims[0] * (size_t)g->dims[1] * (size_t)g->dims[2];
}

int ohm_scene_grid(ohm_grid_info *out, const ohm_scene *scene)
{
    if (!out) return ohm_api_fail(OHM_ERR_USAGE, "ohm_scene_grid: out is NULL");
    const size_t size = out->size;
    int rc = ohm_api_sized_ok(size, offsetof(ohm_grid_info, interior_cells) + sizeof out->interior_cells, "ohm_scene_grid",
                      "OHM_GRID_INFO_INIT");
    if (!rc) rc = need_grid(scene, "ohm_scene_grid");
    if (rc) return rc;
    const ohm_voxel_grid *g = &scene->state.grid;
    ohm_grid_info info = OHM_GRID_INFO_INIT;
    for (int a = 0; a < 3; ++a) {
        info.dims[a] = g->dims[a];
        info.origin[a] = g->origin[a];
    }
    info.voxel = g->h;
    info.cells = (int64_t)grid_cells(g);
    info.interior_cells = (int64_t)g->interior_cells;
    /* the fields this caller has; its size stays its own */
    memcpy((char *)out + sizeof info.size, (const char *)&info + sizeof info.size,
           (size < sizeof info ? size : sizeof info) - sizeof info.size);
    return OHM_OK;
}

#define MEMBER(type, member, kind, n) {#member, offsetof(type, member), kind, n}

static const ohm_struct_member grid_info_members[] = {
    MEMBER(ohm_grid_info, size, OHM_MEMBER_SIZE, 1),         MEMBER(ohm_grid_info, dims, OHM_MEMBER_INT32, 3),
    MEMBER(ohm_grid_info, origin, OHM_MEMBER_DOUBLE, 3),     MEMBER(ohm_grid_info, voxel, OHM_MEMBER_DOUBLE, 1),
    MEMBER(ohm_grid_info, cells, OHM_MEMBER_INT64, 1),       MEMBER(ohm_grid_info, interior_cells, OHM_MEMBER_INT64, 1),
};

static const ohm_struct_member result_info_members[] = {
    MEMBER(ohm_result_info, size, OHM_MEMBER_SIZE, 1),
    MEMBER(ohm_result_info, channels, OHM_MEMBER_INT, 1),
    MEMBER(ohm_result_info, frames, OHM_MEMBER_INT, 1),
    MEMBER(ohm_result_info, unknowns, OHM_MEMBER_INT64, 1),
    MEMBER(ohm_result_info, factorizations, OHM_MEMBER_INT, 1),
    MEMBER(ohm_result_info, solves, OHM_MEMBER_INT64, 1),
    MEMBER(ohm_result_info, residual, OHM_MEMBER_DOUBLE, 1),
    MEMBER(ohm_result_info, power_incident, OHM_MEMBER_DOUBLE, 1),
    MEMBER(ohm_result_info, power_entered, OHM_MEMBER_DOUBLE, 1),
    MEMBER(ohm_result_info, power_in, OHM_MEMBER_DOUBLE, 1),
    MEMBER(ohm_result_info, power_absorbed, OHM_MEMBER_DOUBLE, 1),
    MEMBER(ohm_result_info, power_out, OHM_MEMBER_DOUBLE, 1),
    MEMBER(ohm_result_info, seconds_setup, OHM_MEMBER_DOUBLE, 1),
    MEMBER(ohm_result_info, seconds_solve, OHM_MEMBER_DOUBLE, 1),
};

static const ohm_struct_member estimate_info_members[] = {
    MEMBER(ohm_estimate_info, size, OHM_MEMBER_SIZE, 1),
    MEMBER(ohm_estimate_info, interior_cells, OHM_MEMBER_INT64, 1),
    MEMBER(ohm_estimate_info, grid_cells, OHM_MEMBER_INT64, 1),
    MEMBER(ohm_estimate_info, bytes_direct, OHM_MEMBER_DOUBLE, 1),
    MEMBER(ohm_estimate_info, bytes_cg, OHM_MEMBER_DOUBLE, 1),
    MEMBER(ohm_estimate_info, bytes_amg, OHM_MEMBER_DOUBLE, 1),
    MEMBER(ohm_estimate_info, bytes_mg, OHM_MEMBER_DOUBLE, 1),
    MEMBER(ohm_estimate_info, bytes_auto, OHM_MEMBER_DOUBLE, 1),
    MEMBER(ohm_estimate_info, bytes_allowed, OHM_MEMBER_DOUBLE, 1),
    MEMBER(ohm_estimate_info, margin, OHM_MEMBER_DOUBLE, 1),
    MEMBER(ohm_estimate_info, largest_dim, OHM_MEMBER_INT, 1),
    MEMBER(ohm_estimate_info, largest_dim_mg, OHM_MEMBER_INT, 1),
    MEMBER(ohm_estimate_info, solver, OHM_MEMBER_CHAR, 16),
    MEMBER(ohm_estimate_info, reason, OHM_MEMBER_CHAR, 256),
};

#undef MEMBER

const ohm_struct_member *ohm_struct_members(const char *name, size_t *count, size_t *size)
{
    static const struct {
        const char *name;
        const ohm_struct_member *fields;
        size_t count, size;
    } known[] = {
        {"ohm_grid_info", grid_info_members, sizeof grid_info_members / sizeof grid_info_members[0], sizeof(ohm_grid_info)},
        {"ohm_result_info", result_info_members, sizeof result_info_members / sizeof result_info_members[0],
         sizeof(ohm_result_info)},
        {"ohm_estimate_info", estimate_info_members, sizeof estimate_info_members / sizeof estimate_info_members[0],
         sizeof(ohm_estimate_info)},
    };
    for (size_t k = 0; name && k < sizeof known / sizeof known[0]; ++k)
        if (strcmp(known[k].name, name) == 0) {
            if (count) *count = known[k].count;
            if (size) *size = known[k].size;
            return known[k].fields;
        }
    ohm_api_fail(OHM_ERR_USAGE, "ohm_struct_members: '%s' is no sized struct of ohm.h (ohm_grid_info, ohm_result_info, "
                 "ohm_estimate_info)",
                 name ? name : "(null)");
    return NULL;
}

int ohm_scene_inside(uint8_t *inside, size_t count, const ohm_scene *scene)
{
    int rc = need_grid(scene, "ohm_scene_inside");
    if (rc) return rc;
    const ohm_voxel_grid *g = &scene->state.grid;
    if (!inside || count != grid_cells(g))
        return ohm_api_fail(OHM_ERR_USAGE, "ohm_scene_inside: an array of %zu cells is needed, got %zu", grid_cells(g),
                            inside ? count : 0);
    memcpy(inside, g->inside, count);
    return OHM_OK;
}

/* The current solution, or NULL with the last error set. */
static const ohm_solution *need_solution(const ohm_scene *scene, const char *fn)
{
    if (!scene) {
        ohm_api_fail(OHM_ERR_USAGE, "%s: scene is NULL", fn);
        return NULL;
    }
    const ohm_solution *sol = ohm_state_solution(&scene->state);
    if (!sol)
        ohm_api_fail(OHM_ERR_INVALID, "%s: no current solution: %s", fn,
                     scene->state.solver ? "the lights changed since the last solve: relight" : "solve first");
    return sol;
}

static void result_of(ohm_result_info *out, const ohm_solution *sol)
{
    out->channels = sol->channels;
    out->frames = sol->frames;
    out->unknowns = sol->n;
    out->factorizations = sol->factors;
    out->solves = sol->solves;
    out->residual = sol->residual;
    out->power_incident = sol->power_incident;
    out->power_entered = sol->power_entered;
    out->power_in = sol->power_in;
    out->power_absorbed = sol->power_absorbed;
    out->power_out = sol->power_out;
    out->seconds_setup = sol->t_analyze + sol->t_factor + sol->t_cg_setup;
    out->seconds_solve = sol->t_source + sol->t_solve;
}

int ohm_scene_result(ohm_result_info *out, const ohm_scene *scene)
{
    if (!out) return ohm_api_fail(OHM_ERR_USAGE, "ohm_scene_result: out is NULL");
    const size_t size = out->size;
    int rc = ohm_api_sized_ok(size, offsetof(ohm_result_info, seconds_solve) + sizeof out->seconds_solve, "ohm_scene_result",
                      "OHM_RESULT_INFO_INIT");
    if (rc) return rc;
    const ohm_solution *sol = need_solution(scene, "ohm_scene_result");
    if (!sol) return ohm_error_last_code();
    ohm_result_info info = OHM_RESULT_INFO_INIT;
    result_of(&info, sol);
    memcpy((char *)out + sizeof info.size, (const char *)&info + sizeof info.size,
           (size < sizeof info ? size : sizeof info) - sizeof info.size);
    return OHM_OK;
}


/* A per-cell array of one channel and frame: arguments checked. */
static const ohm_solution *cell_array(const ohm_scene *scene, const char *fn, const double *out, size_t count,
                                      int channel, int frame)
{
    const ohm_solution *sol = need_solution(scene, fn);
    if (!sol) return NULL;
    size_t cells = grid_cells(&scene->state.grid);
    if (!out || count != cells) {
        ohm_api_fail(OHM_ERR_USAGE, "%s: an array of %zu cells is needed, got %zu", fn, cells, out ? count : 0);
        return NULL;
    }
    if (channel < 0 || channel >= sol->channels || frame < 0 || frame >= sol->frames) {
        ohm_api_fail(OHM_ERR_USAGE, "%s: channel %d, frame %d: the solution has %d channel(s) and %d frame(s)", fn,
                     channel, frame, sol->channels, sol->frames);
        return NULL;
    }
    return sol;
}

/* per-unknown values into the dense grid array (0 elsewhere) */
static void scatter(double *out, size_t count, const ohm_solution *sol, const double *per_unknown)
{
    memset(out, 0, count * sizeof *out);
    ohm_cell_cursor cells = ohm_network_cells(&sol->net, 0);
    for (int64_t u = 0; u < sol->n; ++u) out[ohm_cell_cursor_next(&cells)] = per_unknown[u];
}

int ohm_scene_fluence(double *out, size_t count, const ohm_scene *scene, int channel, int frame)
{
    const ohm_solution *sol = cell_array(scene, "ohm_scene_fluence", out, count, channel, frame);
    if (!sol) return ohm_error_last_code();
    scatter(out, count, sol, sol->fluence[channel] + (size_t)frame * (size_t)sol->n);
    return OHM_OK;
}

int ohm_scene_exitance(double *out, size_t count, const ohm_scene *scene, int channel, int frame)
{
    const ohm_solution *sol = cell_array(scene, "ohm_scene_exitance", out, count, channel, frame);
    if (!sol) return ohm_error_last_code();
    double *per_unknown = malloc((size_t)(sol->n ? sol->n : 1) * sizeof *per_unknown);
    if (!per_unknown) return ohm_api_fail(OHM_ERR_NOMEM, "ohm_scene_exitance: out of memory");
    ohm_solution_exitance_frame(per_unknown, sol, channel, frame);
    scatter(out, count, sol, per_unknown);
    free(per_unknown);
    return OHM_OK;
}

int ohm_scene_vertex_exitance(float *out, size_t count, const ohm_scene *scene, int frame)
{
    const ohm_solution *sol = need_solution(scene, "ohm_scene_vertex_exitance");
    if (!sol) return ohm_error_last_code();
    const ohm_state *s = &scene->state;
    if (!s->have_mesh) return ohm_api_fail(OHM_ERR_INVALID, "ohm_scene_vertex_exitance: the scene has no mesh");
    size_t need = s->mesh.nverts * (size_t)sol->channels;
    if (!out || count != need)
        return ohm_api_fail(OHM_ERR_USAGE, "ohm_scene_vertex_exitance: an array of %zu values (%zu vertices x %d "
                            "channels) is needed, got %zu", need, s->mesh.nverts, sol->channels, out ? count : 0);
    if (frame < 0 || frame >= sol->frames)
        return ohm_api_fail(OHM_ERR_USAGE, "ohm_scene_vertex_exitance: frame %d: the solution has %d", frame,
                            sol->frames);
    float *ex = NULL;
    ohm_error err;
    ohm_error_clear(&err);
    int rc = ohm_vertex_exitance(&ex, &s->mesh, &s->grid, sol, frame, &err);
    if (rc) return ohm_api_return(rc, &err);
    memcpy(out, ex, need * sizeof *out);
    free(ex);
    return OHM_OK;
}

static const ohm_stat *find_stat(const ohm_scene *scene, const char *key, const char *fn)
{
    if (!scene || !key) {
        ohm_api_fail(OHM_ERR_USAGE, "%s: scene or key is NULL", fn);
        return NULL;
    }
    const ohm_stat *st = ohm_stats_find(&scene->state.stats, key);
    if (!st) ohm_api_fail(OHM_ERR_INVALID, "%s: the scene has no figure '%s' (yet)", fn, key);
    return st;
}

int ohm_scene_stat(double *out, const ohm_scene *scene, const char *key)
{
    const ohm_stat *st = find_stat(scene, key, "ohm_scene_stat");
    if (!st) return ohm_error_last_code();
    if (st->is_string) return ohm_api_fail(OHM_ERR_INVALID, "ohm_scene_stat: '%s' is a text: ohm_scene_stat_text", key);
    if (out) *out = st->num;
    return OHM_OK;
}

int ohm_scene_stat_text(const char **text, const ohm_scene *scene, const char *key)
{
    const ohm_stat *st = find_stat(scene, key, "ohm_scene_stat_text");
    if (!st) return ohm_error_last_code();
    if (!st->is_string) return ohm_api_fail(OHM_ERR_INVALID, "ohm_scene_stat_text: '%s' is a number: ohm_scene_stat", key);
    if (text) *text = st->str;
    return OHM_OK;
}
