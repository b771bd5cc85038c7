/* export_vdb.c — voxel object -> "surface" and "density" grids in one .vdb. */
#include "outputs/export_vdb.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ohm_vdb.h"
#include "ohm_version.h"
#include "base/output.h"

/* Growable list of (ijk, value) for one grid. */
typedef struct voxel_list {
    int32_t *ijk;
    float *val;
    size_t n, cap;
} voxel_list;

static int list_push(voxel_list *l, int32_t i, int32_t j, int32_t k, float v)
{
    if (l->n == l->cap) {
        size_t cap = l->cap ? 2 * l->cap : 4096;
        int32_t *ijk = realloc(l->ijk, 3 * cap * sizeof *ijk);
        if (!ijk) return -1;
        l->ijk = ijk;
        float *val = realloc(l->val, cap * sizeof *val);
        if (!val) return -1;
        l->val = val;
        l->cap = cap;
    }
    l->ijk[3 * l->n] = i;
    l->ijk[3 * l->n + 1] = j;
    l->ijk[3 * l->n + 2] = k;
    l->val[l->n++] = v;
    return 0;
}

static void list_free(voxel_list *l)
{
    free(l->ijk);
    free(l->val);
}

/* Does a face neighbour of (i,j,k) lie on the other side? */
static int on_interface(const ohm_voxel_grid *g, int32_t i, int32_t j, int32_t k)
{
    uint8_t self = g->inside[ohm_voxel_index(g, i, j, k)];
    static const int32_t off[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    for (int f = 0; f < 6; ++f) {
        int32_t a = i + off[f][0], b = j + off[f][1], c = k + off[f][2];
        if (a < 0 || b < 0 || c < 0 || a >= g->dims[0] || b >= g->dims[1] || c >= g->dims[2]) continue;
        if (g->inside[ohm_voxel_index(g, a, b, c)] != self) return 1;
    }
    return 0;
}

/* Collect the narrow band (sign from the inside test, magnitude from the exact
 * mesh distance).  Where the inside test changes sign with no mesh nearby —
 * across a hole the winding number closed — the surface sits between the
 * two cells: half a voxel from each. */
static int collect_surface(const ohm_voxel_grid *g, voxel_list *surface)
{
    const float band = (float)g->band, half = (float)(0.5 * g->h);
    for (int32_t k = 0; k < g->dims[2]; ++k)
        for (int32_t j = 0; j < g->dims[1]; ++j)
            for (int32_t i = 0; i < g->dims[0]; ++i) {
                size_t idx = ohm_voxel_index(g, i, j, k);
                float d = (float)ohm_voxel_dist(g, idx);
                if (on_interface(g, i, j, k) && !(d <= (float)g->h)) d = half;
                if (d <= band && list_push(surface, i, j, k, g->inside[idx] ? -d : d)) return -1;
            }
    return 0;
}

/* The interior, density 1. */
static int collect_density(const ohm_voxel_grid *g, voxel_list *density)
{
    for (int32_t k = 0; k < g->dims[2]; ++k)
        for (int32_t j = 0; j < g->dims[1]; ++j)
            for (int32_t i = 0; i < g->dims[0]; ++i)
                if (g->inside[ohm_voxel_index(g, i, j, k)] && list_push(density, i, j, k, 1.0f)) return -1;
    return 0;
}

static int set_common_meta(ohm_vdb_grid *grid, const ohm_voxel_grid *g, const ohm_vdb_provenance *prov,
                           ohm_error *err)
{
    int rc = ohm_vdb_grid_set_meta_string(grid, "ohm_units", "mm", err);
    if (!rc) rc = ohm_vdb_grid_set_meta_string(grid, "ohm_version", OHM_VERSION, err);
    if (!rc) rc = ohm_vdb_grid_set_meta_string(grid, "ohm_source", prov && prov->source ? prov->source : "", err);
    if (!rc) rc = ohm_vdb_grid_set_meta_double(grid, "ohm_mesh_scale_mm", prov ? prov->mesh_scale_mm : 1.0, err);
    if (!rc) rc = ohm_vdb_grid_set_meta_double(grid, "ohm_voxel_size_mm", g->h, err);
    if (!rc) rc = ohm_vdb_grid_set_meta_int(grid, "ohm_interior_cells", (int64_t)g->interior_cells, err);
    if (!rc)
        rc = ohm_vdb_grid_set_meta_string(grid, "ohm_inside_test",
                                          "generalized winding number > 1/2 at cell centres", err);
    return rc;
}

/* The solution grids' room: every unknown's voxel and the boundary cells'
 * (the exitance's), found once for all the grids, and one grid's values. */
typedef struct grid_room {
    int32_t *ijk;          /* n x 3, in unknown order                      */
    uint8_t *boundary;     /* n: the unknown has a boundary face            */
    int32_t *boundary_ijk; /* nboundary x 3, the boundary cells in order    */
    size_t nboundary;
    float *val; /* n at most: the grid being written                        */
} grid_room;

/* room's voxels for sol's unknowns (its boundary flags already set);
 * OHM_ERR_NOMEM */
static int room_fill(grid_room *room, const ohm_voxel_grid *g, const ohm_network *net, ohm_error *err)
{
    room->nboundary = 0;
    for (int64_t v = 0; v < net->n; ++v) room->nboundary += room->boundary[v];
    room->boundary_ijk = malloc(3 * (room->nboundary ? room->nboundary : 1) * sizeof *room->boundary_ijk);
    if (!room->boundary_ijk) return ohm_fail(err, OHM_ERR_NOMEM, "write: out of memory");
    ohm_cell_cursor cells = ohm_network_cells(net, 0);
    size_t b = 0;
    for (int64_t v = 0; v < net->n; ++v) {
        int32_t *at = room->ijk + 3 * v;
        ohm_voxel_coords(g, ohm_cell_cursor_next(&cells), at);
        if (room->boundary[v]) memcpy(room->boundary_ijk + 3 * b++, at, 3 * sizeof *at);
    }
    return OHM_OK;
}

/* One solution grid: values per unknown, active in every unknown or (on_boundary)
 * in the boundary cells only, written to w and freed. */
static int solution_grid(ohm_vdb_writer *w, grid_room *room, const char *name, const char *quantity,
                         const ohm_voxel_grid *g, const ohm_solution *sol, const double *values, int on_boundary,
                         const ohm_vdb_provenance *prov, ohm_error *err)
{
    size_t count = 0;
    for (int64_t v = 0; v < sol->n; ++v)
        if (!on_boundary || room->boundary[v]) room->val[count++] = (float)values[v];
    const int32_t *ijk = on_boundary ? room->boundary_ijk : room->ijk;
    ohm_vdb_grid *grid = NULL;
    int rc = ohm_vdb_grid_create(&grid, name, OHM_VDB_CLASS_FOG_VOLUME, 0.0f, g->h, g->origin, err);
    if (!rc) rc = ohm_vdb_grid_set_values(grid, ijk, room->val, count, err);
    if (!rc) rc = set_common_meta(grid, g, prov, err);
    if (!rc) rc = ohm_vdb_grid_set_meta_string(grid, "ohm_quantity", quantity, err);
    if (!rc && prov && prov->material) rc = ohm_vdb_grid_set_meta_string(grid, "ohm_material", prov->material, err);
    if (!rc && prov && prov->solve) rc = ohm_vdb_grid_set_meta_string(grid, "ohm_solve", prov->solve, err);
    /* Values are physical and unscaled (see docs/blender.md: EEVEE keeps half
     * floats, so values below ~6e-8 vanish there; scale intensity= instead). */
    if (!rc) rc = ohm_vdb_grid_set_meta_double(grid, "ohm_value_scale", 1.0, err);
    if (!rc)
        rc = ohm_vdb_grid_set_meta_string(grid, "ohm_scaling",
                                          "none: values are W/mm^2 for the lights' stated intensities; the solution "
                                          "is linear in intensity=",
                                          err);
    if (!rc) rc = ohm_vdb_grid_set_meta_double(grid, "ohm_power_in_W", sol->power_in, err);
    if (!rc) rc = ohm_vdb_grid_set_meta_double(grid, "ohm_power_out_W", sol->power_out, err);
    if (!rc) rc = ohm_vdb_grid_set_meta_double(grid, "ohm_residual", sol->residual, err);
    if (!rc) rc = ohm_vdb_writer_add(w, grid, err);
    ohm_vdb_grid_free(grid);
    return rc;
}

/* The object's grid from its voxels (surface: a level set; density: a fog
 * volume), written to w and freed with its list. */
static int object_grid(ohm_vdb_writer *w, const ohm_voxel_grid *g, int surface, const ohm_vdb_provenance *prov,
                       ohm_error *err)
{
    voxel_list l = {0};
    if (surface ? collect_surface(g, &l) : collect_density(g, &l)) {
        list_free(&l);
        return ohm_fail(err, OHM_ERR_NOMEM, "write: out of memory collecting voxels");
    }
    ohm_vdb_grid *grid = NULL;
    int rc = surface ? ohm_vdb_grid_create(&grid, "surface", OHM_VDB_CLASS_LEVEL_SET, (float)g->band, g->h, g->origin,
                                           err)
                     : ohm_vdb_grid_create(&grid, "density", OHM_VDB_CLASS_FOG_VOLUME, 0.0f, g->h, g->origin, err);
    if (!rc) rc = ohm_vdb_grid_set_values(grid, l.ijk, l.val, l.n, err);
    list_free(&l);
    if (!rc) rc = surface ? ohm_vdb_grid_finish_level_set(grid, err) : ohm_vdb_grid_prune(grid, err);
    if (!rc) rc = set_common_meta(grid, g, prov, err);
    if (!rc) rc = ohm_vdb_writer_add(w, grid, err);
    ohm_vdb_grid_free(grid);
    return rc;
}

/* The grids a solution adds for channel c (solution_grids' order). */
static size_t channel_grids(const ohm_solution *sol, int c)
{
    return 2 + (sol->fluence_se[c] != NULL) + (sol->exitance_se[c] != NULL) + ohm_solution_medium(NULL, sol, c, 0) +
           ohm_solution_medium(NULL, sol, c, 1);
}

/* Every channel's grids of frame `frame`, written to w one at a time. */
static int solution_grids(ohm_vdb_writer *w, const ohm_voxel_grid *g, const ohm_solution *sol, int frame,
                          const ohm_vdb_provenance *prov, ohm_error *err)
{
    size_t n = (size_t)(sol->n ? sol->n : 1);
    grid_room room = {
        .ijk = malloc(3 * n * sizeof *room.ijk), .boundary = calloc(n, 1), .val = malloc(n * sizeof *room.val)};
    double *cell_values = malloc(n * sizeof *cell_values); /* a channel's exitance or medium, in turn */
    int rc = !room.ijk || !room.boundary || !room.val || !cell_values
                 ? ohm_fail(err, OHM_ERR_NOMEM, "write: out of memory")
                 : OHM_OK;
    for (int64_t f = 0; !rc && f < sol->net.nfaces; ++f) room.boundary[sol->net.face_unknown[f]] = 1;
    if (!rc) rc = room_fill(&room, g, &sol->net, err);
    static const char *suffix[3] = {"_r", "_g", "_b"};
    size_t off = (size_t)frame * (size_t)sol->n;
    for (int c = 0; c < sol->channels && !rc; ++c) {
        char name[32];
        const char *sfx = sol->channels == 1 ? "" : suffix[c];
        snprintf(name, sizeof name, "fluence%s", sfx);
        rc = solution_grid(w, &room, name, "fluence rate phi, W/mm^2", g, sol, sol->fluence[c] + off, 0, prov, err);
        if (rc) break;
        snprintf(name, sizeof name, "exitance%s", sfx);
        ohm_solution_exitance_frame(cell_values, sol, c, frame);
        rc = solution_grid(w, &room, name,
                           "exitance: power leaving through the cell's boundary faces per unit area, W/mm^2", g, sol,
                           cell_values, 1, prov, err);
        /* solver=mc: the standard errors beside the values */
        if (!rc && sol->fluence_se[c]) {
            snprintf(name, sizeof name, "fluence_se%s", sfx);
            rc = solution_grid(w, &room, name, "Monte Carlo standard error of the fluence, W/mm^2", g, sol,
                               sol->fluence_se[c] + off, 0, prov, err);
        }
        if (!rc && sol->exitance_se[c]) {
            snprintf(name, sizeof name, "exitance_se%s", sfx);
            rc = solution_grid(w, &room, name, "Monte Carlo standard error of the exitance, W/mm^2", g, sol,
                               sol->exitance_se[c] + off, 1, prov, err);
        }
        /* the material, when it varies cell by cell (scans) */
        if (!rc && ohm_solution_medium(cell_values, sol, c, 0)) {
            snprintf(name, sizeof name, "sigma_a%s", sfx);
            rc = solution_grid(w, &room, name, "absorption coefficient sigma_a, 1/mm", g, sol, cell_values, 0, prov,
                               err);
        }
        if (!rc && ohm_solution_medium(cell_values, sol, c, 1)) {
            snprintf(name, sizeof name, "sigma_s%s", sfx);
            rc = solution_grid(w, &room, name, "reduced scattering coefficient sigma_s', 1/mm", g, sol, cell_values,
                               0, prov, err);
        }
    }
    free(room.ijk);
    free(room.boundary);
    free(room.boundary_ijk);
    free(room.val);
    free(cell_values);
    return rc;
}

/* The wrapper names the temporary file it was given: name the user's file
 * instead, in err's message. */
static void name_user_file(ohm_error *err, const char *tmp, const char *path)
{
    const char *at = err ? strstr(err->msg, tmp) : NULL;
    if (!at) return;
    char msg[OHM_ERROR_MSG_MAX];
    snprintf(msg, sizeof msg, "%.*s%s%s", (int)(at - err->msg), err->msg, path, at + strlen(tmp));
    snprintf(err->msg, sizeof err->msg, "%s", msg);
}

int ohm_export_vdb(const char *path, const ohm_voxel_grid *g, const ohm_solution *sol, int frame,
                   const ohm_vdb_provenance *prov, ohm_output_batch *batch, ohm_error *err)
{
    if (!g || !g->inside) return ohm_fail(err, OHM_ERR_INVALID, "write: nothing to write: run -voxelize first");
    if (sol && (frame < 0 || frame >= sol->frames))
        return ohm_fail(err, OHM_ERR_INTERNAL, "write: frame %d of %d", frame, sol->frames);
    size_t ngrids = 2;
    for (int c = 0; sol && c < sol->channels; ++c) ngrids += channel_grids(sol, c);
    /* one grid at a time (ohm_vdb_writer): its tree, not every grid's, held
     * beside the solution */
    ohm_output out;
    int rc = ohm_output_begin(&out, path, batch, err);
    if (rc) return rc;
    ohm_vdb_writer *w = NULL;
    rc = ohm_vdb_writer_open(&w, ohm_output_tmp_path(&out), ngrids, err);
    if (!rc) rc = object_grid(w, g, 1, prov, err);
    if (!rc) rc = object_grid(w, g, 0, prov, err);
    if (!rc && sol) rc = solution_grids(w, g, sol, frame, prov, err);
    if (rc) ohm_vdb_writer_abort(w);
    else rc = ohm_vdb_writer_close(w, err);
    if (rc) {
        name_user_file(err, ohm_output_tmp_path(&out), path);
        ohm_output_abort(&out);
        return rc;
    }
    return ohm_output_commit(&out, err);
}
