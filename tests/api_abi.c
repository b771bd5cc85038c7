/* api_abi.c — the sized structs of include/ohm.h (its ABI rule), against
 * the library as built: a caller built with 1.0's ohm_grid_info (a copy of
 * its layout here, as an old header had it) gets its fields and not a byte
 * past its size; a caller from a later 1.x, whose struct has grown, gets
 * every field this library knows and its new field untouched; a caller
 * that forgot the size is refused with a message naming *_INIT; and the
 * layouts the library describes to bindings (ohm_struct_members) are the
 * header's, member by member. */
#include <stdint.h>
#include <string.h>

#include "check.h"
#include "ohm.h"

/* ohm_grid_info as ohm 1.0's header lays it out */
typedef struct grid_info_1_0 {
    size_t size;
    int32_t dims[3];
    double origin[3];
    double voxel;
    int64_t cells;
    int64_t interior_cells;
} grid_info_1_0;

/* ... and as a later header might: one field more */
typedef struct grid_info_later {
    grid_info_1_0 known;
    double added_later;
} grid_info_later;

/* The library's description of a struct against this header's offsetof. */
static void members_match(const char *name, size_t size, const char *const *names, const size_t *offsets,
                          size_t count)
{
    size_t n = 0, described = 0;
    const ohm_struct_member *m = ohm_struct_members(name, &n, &described);
    CHECK_MSG(m && n == count && described == size, "%s: %zu members of %zu bytes described, the header has %zu of %zu",
              name, m ? n : 0, described, count, size);
    for (size_t k = 0; m && k < n && k < count; ++k)
        CHECK_MSG(strcmp(m[k].name, names[k]) == 0 && m[k].offset == offsets[k], "%s member %zu: %s at %zu, header: %s at %zu",
                  name, k, m[k].name, m[k].offset, names[k], offsets[k]);
}

static void described_layouts(void)
{
#define AT(type, member) offsetof(type, member)
    const char *grid[] = {"size", "dims", "origin", "voxel", "cells", "interior_cells"};
    const size_t grid_at[] = {AT(ohm_grid_info, size),  AT(ohm_grid_info, dims),  AT(ohm_grid_info, origin),
                              AT(ohm_grid_info, voxel), AT(ohm_grid_info, cells), AT(ohm_grid_info, interior_cells)};
    members_match("ohm_grid_info", sizeof(ohm_grid_info), grid, grid_at, 6);
    const char *result[] = {"size",           "channels",       "frames",   "unknowns",       "factorizations",
                            "solves",         "residual",       "power_incident", "power_entered", "power_in",
                            "power_absorbed", "power_out",      "seconds_setup", "seconds_solve"};
    const size_t result_at[] = {
        AT(ohm_result_info, size),           AT(ohm_result_info, channels),      AT(ohm_result_info, frames),
        AT(ohm_result_info, unknowns),       AT(ohm_result_info, factorizations), AT(ohm_result_info, solves),
        AT(ohm_result_info, residual),       AT(ohm_result_info, power_incident), AT(ohm_result_info, power_entered),
        AT(ohm_result_info, power_in),       AT(ohm_result_info, power_absorbed), AT(ohm_result_info, power_out),
        AT(ohm_result_info, seconds_setup),  AT(ohm_result_info, seconds_solve)};
    members_match("ohm_result_info", sizeof(ohm_result_info), result, result_at, 14);
    const char *estimate[] = {"size",        "interior_cells", "grid_cells",    "bytes_direct",   "bytes_cg",
                              "bytes_amg",   "bytes_mg",       "bytes_auto",    "bytes_allowed",  "margin",
                              "largest_dim", "largest_dim_mg", "solver",        "reason"};
    const size_t estimate_at[] = {
        AT(ohm_estimate_info, size),          AT(ohm_estimate_info, interior_cells), AT(ohm_estimate_info, grid_cells),
        AT(ohm_estimate_info, bytes_direct),  AT(ohm_estimate_info, bytes_cg),       AT(ohm_estimate_info, bytes_amg),
        AT(ohm_estimate_info, bytes_mg),      AT(ohm_estimate_info, bytes_auto),     AT(ohm_estimate_info, bytes_allowed),
        AT(ohm_estimate_info, margin),        AT(ohm_estimate_info, largest_dim),    AT(ohm_estimate_info, largest_dim_mg),
        AT(ohm_estimate_info, solver),        AT(ohm_estimate_info, reason)};
    members_match("ohm_estimate_info", sizeof(ohm_estimate_info), estimate, estimate_at, 14);
#undef AT
    size_t n = 7;
    CHECK(ohm_struct_members("ohm_scene", &n, NULL) == NULL && n == 7);
    CHECK_MSG(strstr(ohm_error_last(), "'ohm_scene' is no sized struct") != NULL, "%s", ohm_error_last());
}

int main(void)
{
    described_layouts();
    ohm_context *ctx = NULL;
    ohm_scene *scene = NULL;
    const char *read[] = {"file=samples/cow.obj", "size=20", NULL}, *vox[] = {"dim=10", NULL};
    CHECK(ohm_context_new(&ctx) == OHM_OK);
    ohm_context_set_verbosity(ctx, 0);
    CHECK(ohm_scene_new(&scene, ctx) == OHM_OK && ohm_scene_run(scene, "read", read) == OHM_OK &&
          ohm_scene_run(scene, "voxelize", vox) == OHM_OK);
    ohm_grid_info now = OHM_GRID_INFO_INIT;
    CHECK_MSG(ohm_scene_grid(&now, scene) == OHM_OK && now.interior_cells > 0, "%s", ohm_error_last());
    CHECK_MSG(sizeof(ohm_grid_info) >= sizeof(grid_info_1_0) &&
                  offsetof(ohm_grid_info, interior_cells) == offsetof(grid_info_1_0, interior_cells),
              "1.0's fields moved: the ABI rule says they never do within a major version");

    /* 1.0's caller, a guard after its struct */
    struct {
        grid_info_1_0 info;
        unsigned char guard[64];
    } old;
    memset(&old, 0xA5, sizeof old);
    old.info.size = sizeof old.info;
    CHECK_MSG(ohm_scene_grid((ohm_grid_info *)(void *)&old.info, scene) == OHM_OK, "%s", ohm_error_last());
    CHECK(old.info.size == sizeof old.info && old.info.cells == now.cells &&
          old.info.interior_cells == now.interior_cells && old.info.voxel == now.voxel);
    int untouched = 1;
    for (size_t i = 0; i < sizeof old.guard; ++i) untouched &= old.guard[i] == 0xA5;
    CHECK_MSG(untouched, "the library wrote past a 1.0 caller's struct");

    /* a later caller: its new field as it set it */
    grid_info_later later;
    memset(&later, 0, sizeof later);
    later.known.size = sizeof later;
    later.added_later = 42.5;
    CHECK(ohm_scene_grid((ohm_grid_info *)(void *)&later, scene) == OHM_OK);
    CHECK(later.known.interior_cells == now.interior_cells && later.added_later == 42.5);

    /* no size: refused, naming the initialiser */
    ohm_grid_info unset;
    memset(&unset, 0, sizeof unset);
    CHECK(ohm_scene_grid(&unset, scene) == OHM_ERR_USAGE);
    CHECK_MSG(strstr(ohm_error_last(), "OHM_GRID_INFO_INIT") != NULL, "%s", ohm_error_last());
    ohm_result_info r;
    memset(&r, 0, sizeof r);
    CHECK(ohm_scene_result(&r, scene) == OHM_ERR_USAGE && strstr(ohm_error_last(), "OHM_RESULT_INFO_INIT"));
    ohm_scene_free(scene);
    ohm_context_free(ctx);
    return check_summary();
}
