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
 * mesh distance) and the interior.  Where the inside test changes sign with no
 * mesh nearby — across a hole the winding number closed — the surface sits
 * between the two cells: half a voxel from each. */
static int collect(const ohm_voxel_grid *g, voxel_list *surface, voxel_list *density)
{
    const float band = (float)g->band, half = (float)(0.5 * g->h);
    for (int32_t k = 0; k < g->dims[2]; ++k)
        for (int32_t j = 0; j < g->dims[1]; ++j)
            for (int32_t i = 0; i < g->dims[0]; ++i) {
                size_t idx = ohm_voxel_index(g, i, j, k);
                int in = g->inside[idx];
                float d = (float)ohm_voxel_dist(g, idx);
                if (on_interface(g, i, j, k) && !(d <= (float)g->h)) d = half;
                if (d <= band) {
                    if (list_push(surface, i, j, k, in ? -d : d)) return -1;
                }
                if (in && list_push(density, i, j, k, 1.0f)) return -1;
            }
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

/* One solution grid: values per unknown, active where `where` is non-zero
 * (NULL: every unknown). */
static int solution_grid(ohm_vdb_grid **out, const char *name, const char *quantity, const ohm_voxel_grid *g,
                         const ohm_solution *sol, const double *values, const int *where,
                         const ohm_vdb_provenance *prov, ohm_error *err)
{
    voxel_list l = {0};
    const ohm_network *net = &sol->net;
    for (int64_t v = 0; v < net->n; ++v) {
        if (where && !where[v]) continue;
        int32_t ijk[3];
        ohm_voxel_coords(g, net->cell[v], ijk);
        int32_t i = ijk[0], j = ijk[1], k = ijk[2];
        if (list_push(&l, i, j, k, (float)values[v])) {
            list_free(&l);
            return ohm_fail(err, OHM_ERR_NOMEM, "write: out of memory collecting %s", name);
        }
    }
    int rc = ohm_vdb_grid_create(out, name, OHM_VDB_CLASS_FOG_VOLUME, 0.0f, g->h, g->origin, err);
    if (!rc) rc = ohm_vdb_grid_set_values(*out, l.ijk, l.val, l.n, err);
    if (!rc) rc = set_common_meta(*out, g, prov, err);
    if (!rc) rc = ohm_vdb_grid_set_meta_string(*out, "ohm_quantity", quantity, err);
    if (!rc && prov && prov->material) rc = ohm_vdb_grid_set_meta_string(*out, "ohm_material", prov->material, err);
    if (!rc && prov && prov->solve) rc = ohm_vdb_grid_set_meta_string(*out, "ohm_solve", prov->solve, err);
    /* Values are physical and unscaled (see docs/blender.md: EEVEE keeps half
     * floats, so values below ~6e-8 vanish there; scale intensity= instead). */
    if (!rc) rc = ohm_vdb_grid_set_meta_double(*out, "ohm_value_scale", 1.0, err);
    if (!rc)
        rc = ohm_vdb_grid_set_meta_string(*out, "ohm_scaling",
                                          "none: values are W/mm^2 for the lights' stated intensities; the solution "
                                          "is linear in intensity=",
                                          err);
    if (!rc) rc = ohm_vdb_grid_set_meta_double(*out, "ohm_power_in_W", sol->power_in, err);
    if (!rc) rc = ohm_vdb_grid_set_meta_double(*out, "ohm_power_out_W", sol->power_out, err);
    if (!rc) rc = ohm_vdb_grid_set_meta_double(*out, "ohm_residual", sol->residual, err);
    list_free(&l);
    return rc;
}

enum { MAX_GRIDS = 2 + 6 * OHM_MAX_CHANNELS };

int ohm_export_vdb(const char *path, const ohm_voxel_grid *g, const ohm_solution *sol, int frame,
                   const ohm_vdb_provenance *prov, ohm_output_batch *batch, ohm_error *err)
{
    if (!g || !g->inside) return ohm_fail(err, OHM_ERR_INVALID, "write: nothing to write: run -voxelize first");
    voxel_list surface = {0}, density = {0};
    ohm_vdb_grid *grids[MAX_GRIDS] = {NULL};
    size_t ngrids = 2;
    int *boundary_cell = NULL;
    double *cell_exitance = NULL; /* one channel's, in turn */
    ohm_output out;
    int out_open = 0;
    int rc = OHM_OK;

    if (collect(g, &surface, &density)) {
        rc = ohm_fail(err, OHM_ERR_NOMEM, "write: out of memory collecting voxels");
        goto done;
    }
    rc = ohm_vdb_grid_create(&grids[0], "surface", OHM_VDB_CLASS_LEVEL_SET, (float)g->band, g->h, g->origin, err);
    if (!rc) rc = ohm_vdb_grid_set_values(grids[0], surface.ijk, surface.val, surface.n, err);
    if (!rc) rc = ohm_vdb_grid_finish_level_set(grids[0], err);
    if (!rc) rc = set_common_meta(grids[0], g, prov, err);
    if (!rc) rc = ohm_vdb_grid_create(&grids[1], "density", OHM_VDB_CLASS_FOG_VOLUME, 0.0f, g->h, g->origin, err);
    if (!rc) rc = ohm_vdb_grid_set_values(grids[1], density.ijk, density.val, density.n, err);
    if (!rc) rc = ohm_vdb_grid_prune(grids[1], err);
    if (!rc) rc = set_common_meta(grids[1], g, prov, err);
    if (!rc && sol && (frame < 0 || frame >= sol->frames))
        rc = ohm_fail(err, OHM_ERR_INTERNAL, "write: frame %d of %d", frame, sol->frames);
    if (!rc && sol) {
        boundary_cell = calloc((size_t)(sol->n ? sol->n : 1), sizeof *boundary_cell);
        cell_exitance = malloc((size_t)(sol->n ? sol->n : 1) * sizeof *cell_exitance);
        if (!boundary_cell || !cell_exitance) rc = ohm_fail(err, OHM_ERR_NOMEM, "write: out of memory");
        for (int64_t f = 0; !rc && f < sol->net.nfaces; ++f) boundary_cell[sol->net.face_unknown[f]] = 1;
        static const char *suffix[3] = {"_r", "_g", "_b"};
        for (int c = 0; c < sol->channels && !rc; ++c) {
            char name[32];
            const char *sfx = sol->channels == 1 ? "" : suffix[c];
            snprintf(name, sizeof name, "fluence%s", sfx);
            size_t off = (size_t)frame * (size_t)sol->n;
            rc = solution_grid(&grids[ngrids++], name, "fluence rate phi, W/mm^2", g, sol, sol->fluence[c] + off,
                               NULL, prov, err);
            if (rc) break;
            snprintf(name, sizeof name, "exitance%s", sfx);
            ohm_solution_exitance_frame(cell_exitance, sol, c, frame);
            rc = solution_grid(&grids[ngrids++], name,
                               "exitance: power leaving through the cell's boundary faces per unit area, W/mm^2", g,
                               sol, cell_exitance, boundary_cell, prov, err);
            /* solver=mc: the standard errors beside the values */
            if (!rc && sol->fluence_se[c]) {
                snprintf(name, sizeof name, "fluence_se%s", sfx);
                rc = solution_grid(&grids[ngrids++], name, "Monte Carlo standard error of the fluence, W/mm^2", g, sol,
                                   sol->fluence_se[c] + off, NULL, prov, err);
            }
            if (!rc && sol->exitance_se[c]) {
                snprintf(name, sizeof name, "exitance_se%s", sfx);
                rc = solution_grid(&grids[ngrids++], name, "Monte Carlo standard error of the exitance, W/mm^2", g,
                                   sol, sol->exitance_se[c] + off, boundary_cell, prov, err);
            }
            /* the material, when it varies cell by cell (scans), in turn
             * through the exitance's buffer */
            if (!rc && ohm_solution_medium(cell_exitance, sol, c, 0)) {
                snprintf(name, sizeof name, "sigma_a%s", sfx);
                rc = solution_grid(&grids[ngrids++], name, "absorption coefficient sigma_a, 1/mm", g, sol,
                                   cell_exitance, NULL, prov, err);
            }
            if (!rc && ohm_solution_medium(cell_exitance, sol, c, 1)) {
                snprintf(name, sizeof name, "sigma_s%s", sfx);
                rc = solution_grid(&grids[ngrids++], name, "reduced scattering coefficient sigma_s', 1/mm", g, sol,
                                   cell_exitance, NULL, prov, err);
            }
        }
    }
    if (rc) goto done;

    rc = ohm_output_begin(&out, path, batch, err);
    if (rc) goto done;
    out_open = 1;
    rc = ohm_vdb_write(ohm_output_tmp_path(&out), grids, ngrids, err);
    if (rc) {
        /* The wrapper names the temporary file; name the user's file instead. */
        char why[OHM_ERROR_MSG_MAX];
        snprintf(why, sizeof why, "%s", err ? err->msg : "");
        rc = ohm_fail(err, rc, "cannot write '%s': %s", path, why);
        goto done;
    }
    rc = ohm_output_commit(&out, err);
    out_open = 0;

done:
    if (out_open) ohm_output_abort(&out);
    for (size_t i = 0; i < MAX_GRIDS; ++i) ohm_vdb_grid_free(grids[i]);
    free(boundary_cell);
    free(cell_exitance);
    list_free(&surface);
    list_free(&density);
    return rc;
}
