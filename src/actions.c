/* actions.c — the action table: every action, its options (type, default,
 * doc) and the function that runs it.  `ohm help` is generated from here. */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>

#include "export_vdb.h"
#include "ohm_vdb.h"
#include "ohm_version.h"
#include "pipeline.h"

/* ---- state --------------------------------------------------------------------- */

void ohm_state_init(ohm_state *s)
{
    memset(s, 0, sizeof *s);
    s->log.verbosity = 1;
    s->mesh_scale_mm = 1.0;
    ohm_stats_set_str(&s->stats, "ohm_version", OHM_VERSION);
}

void ohm_state_free(ohm_state *s)
{
    ohm_mesh_free(&s->mesh);
    ohm_voxel_grid_free(&s->grid);
}

/* millimetres per unit */
static double unit_mm(const char *u)
{
    if (strcmp(u, "cm") == 0) return 10.0;
    if (strcmp(u, "m") == 0) return 1000.0;
    if (strcmp(u, "in") == 0) return 25.4;
    return 1.0;
}

/* ---- read ---------------------------------------------------------------------- */

static const ohm_opt_spec read_opts[] = {
    {"file", OHM_OPT_STRING, NULL, "mesh to read: .obj .ply .stl .off, optionally .gz", NULL, 0, 0, 1},
    {"units", OHM_OPT_ENUM, "mm", "what one unit of the file is", "mm|cm|m|in", 0, 0, 0},
    {"size", OHM_OPT_REAL, NULL, "scale so the longest axis is this many mm (overrides units=)", NULL, 1e-9, 1e9, 0},
    {0}};

static int run_read(ohm_state *s, const ohm_invocation *inv, ohm_error *err)
{
    const char *path = ohm_opt_str(inv, "file");
    double t0 = ohm_now();
    ohm_mesh m;
    int rc = ohm_mesh_read(&m, path, err);
    if (rc) return rc;

    ohm_mesh_topology topo;
    rc = ohm_mesh_topology_compute(&topo, &m, err);
    if (rc) {
        ohm_mesh_free(&m);
        return rc;
    }
    double lo[3], hi[3];
    ohm_mesh_bounds(&m, lo, hi);
    double extent = fmax(hi[0] - lo[0], fmax(hi[1] - lo[1], hi[2] - lo[2]));
    double scale = unit_mm(ohm_opt_str(inv, "units"));
    if (ohm_opt_given(inv, "size")) {
        if (!(extent > 0)) {
            ohm_mesh_free(&m);
            return ohm_fail(err, OHM_ERR_INVALID, "%s: all vertices coincide, cannot scale to size=", path);
        }
        scale = ohm_opt_real(inv, "size") / extent;
    }
    ohm_mesh_scale(&m, scale);

    ohm_mesh_free(&s->mesh);
    ohm_voxel_grid_free(&s->grid); /* a new mesh makes the old grid stale */
    s->have_grid = 0;
    s->mesh = m;
    s->have_mesh = 1;
    s->mesh_scale_mm = scale;
    snprintf(s->mesh_path, sizeof s->mesh_path, "%s", path);

    double t = ohm_now() - t0;
    ohm_log_info(&s->log, "read %s: %zu vertices, %zu triangles, %.4g x %.4g x %.4g mm (%.6g mm per unit), %.2f s",
                 path, m.nverts, m.ntris, (hi[0] - lo[0]) * scale, (hi[1] - lo[1]) * scale, (hi[2] - lo[2]) * scale,
                 scale, t);
    if (topo.boundary_edges || topo.nonmanifold_edges || topo.misoriented_edges)
        ohm_log_warn(&s->log,
                     "%s is not closed: %zu open (boundary) edges, %zu non-manifold edges, %zu flipped edges in %zu "
                     "piece(s); the inside is decided by the generalized winding number, which closes small holes",
                     path, topo.boundary_edges, topo.nonmanifold_edges, topo.misoriented_edges, topo.components);
    if (topo.degenerate_tris) ohm_log_info(&s->log, "%s: %zu degenerate triangles (ignored by the inside test)",
                                           path, topo.degenerate_tris);

    ohm_stats_set_str(&s->stats, "mesh_file", path);
    ohm_stats_set_int(&s->stats, "mesh_vertices", (long long)m.nverts);
    ohm_stats_set_int(&s->stats, "mesh_triangles", (long long)m.ntris);
    ohm_stats_set_int(&s->stats, "mesh_boundary_edges", (long long)topo.boundary_edges);
    ohm_stats_set_int(&s->stats, "mesh_nonmanifold_edges", (long long)topo.nonmanifold_edges);
    ohm_stats_set_int(&s->stats, "mesh_components", (long long)topo.components);
    ohm_stats_set(&s->stats, "mesh_scale_mm", scale);
    ohm_stats_set(&s->stats, "mesh_volume_mm3", fabs(ohm_mesh_signed_volume(&s->mesh)));
    ohm_stats_add(&s->stats, "t_read", t);
    return OHM_OK;
}

/* ---- voxelize ------------------------------------------------------------------ */

static const ohm_opt_spec voxelize_opts[] = {
    {"dim", OHM_OPT_INT, "64", "cells along the longest axis of the bounding box (unless voxel= is given)", NULL, 1,
     4096, 0},
    {"voxel", OHM_OPT_REAL, NULL, "voxel size, in units= (overrides dim=)", NULL, 1e-12, 1e12, 0},
    {"units", OHM_OPT_ENUM, "mm", "unit of voxel=", "mm|cm|m|in", 0, 0, 0},
    {"band", OHM_OPT_INT, "3", "half width of the surface level set's narrow band, in voxels", NULL, 1, 64, 0},
    {0}};

static int run_voxelize(ohm_state *s, const ohm_invocation *inv, ohm_error *err)
{
    if (!s->have_mesh)
        return ohm_fail(err, OHM_ERR_INVALID, "%s: -voxelize: no mesh yet: put -read file=MESH before it", inv->where);
    ohm_voxelize_params p = {0};
    if (ohm_opt_given(inv, "voxel")) p.voxel = ohm_opt_real(inv, "voxel") * unit_mm(ohm_opt_str(inv, "units"));
    else p.dim = (int)ohm_opt_int(inv, "dim");
    p.band_voxels = (int)ohm_opt_int(inv, "band");

    double t0 = ohm_now();
    ohm_voxel_grid g;
    ohm_voxelize_report rep;
    int rc = ohm_voxelize(&g, &rep, &s->mesh, &p, &s->log, err);
    if (rc) return rc;
    double t = ohm_now() - t0;

    ohm_voxel_grid_free(&s->grid);
    s->grid = g;
    s->have_grid = 1;
    double cell_volume = g.h * g.h * g.h;
    double vol = (double)g.interior_cells * cell_volume;
    if (rep.flipped)
        ohm_log_warn(&s->log, "%s is wound inside-out (enclosed volume %.4g mm^3 < 0): reading it reversed",
                     s->mesh_path, rep.signed_volume);
    if (rep.ambiguous)
        ohm_log_info(&s->log, "%zu cells had a winding number between 0.4 and 0.6 (near holes or overlaps)",
                     rep.ambiguous);
    ohm_log_info(&s->log,
                 "voxelized: %d x %d x %d grid, voxel %.4g mm, %zu interior cells (%.6g mm^3; mesh encloses %.6g "
                 "mm^3), %.2f s",
                 g.dims[0], g.dims[1], g.dims[2], g.h, g.interior_cells, vol, fabs(rep.signed_volume), t);
    if (g.interior_cells == 0)
        ohm_log_warn(&s->log, "no cell centre lies inside the mesh: use a larger dim= or a smaller voxel=");

    ohm_stats_set(&s->stats, "voxel_mm", g.h);
    ohm_stats_set_int(&s->stats, "grid_x", g.dims[0]);
    ohm_stats_set_int(&s->stats, "grid_y", g.dims[1]);
    ohm_stats_set_int(&s->stats, "grid_z", g.dims[2]);
    ohm_stats_set_int(&s->stats, "cells", (long long)g.interior_cells);
    ohm_stats_set(&s->stats, "interior_volume_mm3", vol);
    ohm_stats_set_int(&s->stats, "mesh_flipped", rep.flipped);
    ohm_stats_set_int(&s->stats, "winding_evaluations", (long long)rep.winding_exact);
    ohm_stats_set_int(&s->stats, "winding_ambiguous_cells", (long long)rep.ambiguous);
    ohm_stats_add(&s->stats, "t_voxelize", t);
    return OHM_OK;
}

/* ---- write --------------------------------------------------------------------- */

static const ohm_opt_spec write_opts[] = {
    {"file", OHM_OPT_STRING, NULL, "output .vdb (written to a temporary file, then renamed)", NULL, 0, 0, 1},
    {0}};

static int has_suffix(const char *s, const char *suffix)
{
    size_t ls = strlen(s), lx = strlen(suffix);
    return ls >= lx && strcasecmp(s + ls - lx, suffix) == 0;
}

static int run_write(ohm_state *s, const ohm_invocation *inv, ohm_error *err)
{
    const char *path = ohm_opt_str(inv, "file");
    if (!has_suffix(path, ".vdb"))
        return ohm_fail(err, OHM_ERR_USAGE, "%s: -write file=%s: only .vdb is written here", inv->where, path);
    if (!s->have_grid)
        return ohm_fail(err, OHM_ERR_INVALID, "%s: -write: nothing to write yet: put -voxelize before it", inv->where);
    double t0 = ohm_now();
    ohm_vdb_provenance prov = {s->mesh_path, s->mesh_scale_mm};
    int rc = ohm_export_vdb(path, &s->grid, &prov, err);
    if (rc) return rc;
    double t = ohm_now() - t0;
    ohm_log_info(&s->log, "wrote %s (grids: surface, density), %.2f s", path, t);
    ohm_stats_add(&s->stats, "t_write", t);
    return OHM_OK;
}

/* ---- stats --------------------------------------------------------------------- */

static const ohm_opt_spec stats_opts[] = {
    {"file", OHM_OPT_STRING, NULL, "write the JSON here; without it, to stdout", NULL, 0, 0, 0},
    {0}};

static int run_stats(ohm_state *s, const ohm_invocation *inv, ohm_error *err)
{
    if (!ohm_opt_given(inv, "file")) {
        ohm_stats_write_json(&s->stats, stdout);
        fflush(stdout);
        return OHM_OK;
    }
    const char *path = ohm_opt_str(inv, "file");
    ohm_output out;
    int rc = ohm_output_begin(&out, path, err);
    if (rc) return rc;
    if (ohm_stats_write_json(&s->stats, out.stream) != 0) {
        ohm_output_abort(&out);
        return ohm_fail(err, OHM_ERR_IO, "cannot write '%s'", path);
    }
    rc = ohm_output_commit(&out, err);
    if (!rc) ohm_log_info(&s->log, "wrote %s", path);
    return rc;
}

/* ---- the table ----------------------------------------------------------------- */

const ohm_action ohm_actions[] = {
    {"read", "read a mesh (OBJ, PLY, STL, OFF; .gz too) and scale it to millimetres",
     "Reads a triangle mesh; polygons are split into triangles.  Reports open and non-manifold edges.\n"
     "Meshes come in arbitrary units: units= says what one unit is, size= scales the longest axis to a length.",
     read_opts, run_read},
    {"voxelize", "find the cells inside the mesh on a regular grid",
     "Classifies cell centres with the generalized winding number (robust to holes, open rims, overlapping\n"
     "pieces and inside-out winding) and measures the distance to the mesh in a narrow band.  The grid covers\n"
     "the bounding box plus a margin; dim=N puts N cells along its longest axis.",
     voxelize_opts, run_voxelize},
    {"write", "write the voxel object as a .vdb (grids surface and density)",
     "Grids: 'surface' (level set, signed distance in mm, negative inside) and 'density' (fog volume, 1 in\n"
     "interior cells, what Blender's Principled Volume reads).  World units are millimetres.",
     write_opts, run_write},
    {"stats", "write the run's figures as one JSON object",
     "Counts, sizes and per-stage times (t_read, t_voxelize, t_write, ...) recorded so far.", stats_opts, run_stats},
    {NULL, NULL, NULL, NULL, NULL}};
