/* actions.c — the action table: every action, its options (type, default,
 * doc) and the function that runs it.  `ohm help` is generated from here. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

#include "base/vec3.h"
#include "steps/export_action.h"
#include "outputs/export_vdb.h"
#include "ohm_vdb.h"
#include "ohm_version.h"
#include "physics/light_kind.h"
#include "steps/pipeline.h"
#include "steps/render.h"
#include "steps/resolution.h"

/* ---- state --------------------------------------------------------------------- */

void ohm_state_init(ohm_state *s)
{
    memset(s, 0, sizeof *s);
    s->log.verbosity = 1;
    s->mesh_scale_mm = 1.0;
    s->model_error = -1;
    ohm_stats_set_str(&s->stats, "ohm_version", OHM_VERSION);
}

void ohm_state_free(ohm_state *s)
{
    ohm_mesh_free(&s->mesh);
    ohm_voxel_grid_free(&s->grid);
    ohm_solver_free(s->solver);
    free(s->solver_eta);
    free(s->solver_g);
    ohm_lights_free(s->lights, s->nlights);
    ohm_scan_free(&s->scan);
    ohm_transfer_free(&s->transfer);
}

/* A new mesh, grid, volume or material makes an earlier solve stale, its
 * setup with it. */
static void drop_solution(ohm_state *s)
{
    ohm_solver_free(s->solver);
    free(s->solver_eta);
    free(s->solver_g);
    s->solver = NULL;
    s->solver_eta = s->solver_g = NULL;
    s->have_solution = 0;
}

const ohm_solution *ohm_state_solution(const ohm_state *s)
{
    return s->have_solution && s->solver ? ohm_solver_solution(s->solver) : NULL;
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
    {"file", OHM_OPT_STRING, NULL,
     "mesh (.obj .ply .stl .off, optionally .gz) or density volume (.vdb .nii .nii.gz .nrrd .nhdr .mha .mhd .inr "
     ".inr.gz .raw .raw.gz), a DICOM series (a folder of slices, a DICOMDIR or one slice file) or a folder of "
     ".tif/.png slices", NULL, 0, 0, 1},
    {"grid", OHM_OPT_STRING, "density", "volume: the .vdb grid to read", NULL, 0, 0, 0},
    {"series", OHM_OPT_STRING, NULL, "DICOM: the SeriesInstanceUID to read when the folder holds several", NULL, 0,
     0, 0},
    {"dims", OHM_OPT_VEC3, NULL, "raw volume: voxels per axis nx,ny,nz (x fastest)", NULL, 0, 0, 0},
    {"type", OHM_OPT_ENUM, "u16", "raw volume: voxel type", "u8|u16|i16|f32", 0, 0, 0},
    {"endian", OHM_OPT_ENUM, "little", "raw volume: byte order", "little|big", 0, 0, 0},
    {"spacing", OHM_OPT_REAL13, "1", "raw volume: voxel size in mm (one value or x,y,z)", NULL, 1e-9, 1e9, 0},
    {"units", OHM_OPT_ENUM, "mm", "what one unit of the file is", "mm|cm|m|in", 0, 0, 0},
    {"size", OHM_OPT_REAL, NULL, "scale so the longest axis is this many mm (overrides units=)", NULL, 1e-9, 1e9, 0},
    {"max_expansion", OHM_OPT_REAL, OHM_SCAN_MAX_EXPANSION_TEXT,
     "volume: a scan needing over 256 MiB to read may hold at most this many voxels per byte of its files "
     "(more is a decompression bomb's mark: deflate's ceiling is 1032; scans hold 0.5-2, label masks 165-380)",
     NULL, 1, 1e12, 0},
    {0}};

/* A density volume: the material's source (transfer functions) and, alone,
 * the object itself (-voxelize threshold=). */
static int read_volume(ohm_state *s, const ohm_invocation *inv, const char *path, ohm_error *err)
{
    double t0 = ohm_now();
    ohm_scan_params p;
    memset(&p, 0, sizeof p);
    p.grid = ohm_opt_str(inv, "grid");
    p.series = ohm_opt_str(inv, "series");
    p.max_expansion = ohm_opt_real(inv, "max_expansion");
    p.log = &s->log;
    p.type = ohm_opt_str(inv, "type");
    p.endian = ohm_opt_str(inv, "endian");
    ohm_opt_real13(inv, "spacing", p.spacing);
    if (ohm_opt_given(inv, "dims")) {
        double d[3];
        ohm_opt_vec3(inv, "dims", d);
        for (int a = 0; a < 3; ++a) {
            if (d[a] < 1 || d[a] > 1e6 || d[a] != floor(d[a]))
                return ohm_fail(err, OHM_ERR_USAGE, "%s: -read dims=: expected three whole numbers >= 1", inv->where);
            p.dims[a] = (int32_t)d[a];
        }
    }
    ohm_scan scan;
    int rc = ohm_scan_read(&scan, path, &p, err);
    if (rc) return rc;
    ohm_state_set_scan(s, &scan, path, t0);
    return OHM_OK;
}

void ohm_state_set_scan(ohm_state *s, ohm_scan *scan_in, const char *name, double t0)
{
    ohm_scan scan = *scan_in;
    memset(scan_in, 0, sizeof *scan_in);
    ohm_scan_free(&s->scan);
    s->scan = scan;
    s->have_scan = 1;
    snprintf(s->scan_path, sizeof s->scan_path, "%s", name);
    drop_solution(s);
    double lo[3], hi[3];
    ohm_scan_bounds(&scan, lo, hi);
    double t = ohm_now() - t0;
    ohm_log_info(&s->log, "read %s: %d x %d x %d voxels, values %.6g .. %.6g, %.4g x %.4g x %.4g mm, %.2f s", name,
                 scan.dims[0], scan.dims[1], scan.dims[2], scan.min, scan.max, hi[0] - lo[0], hi[1] - lo[1],
                 hi[2] - lo[2], t);
    double spacing[3], tilt = ohm_scan_obliquity(&scan);
    ohm_scan_spacing(&scan, spacing);
    const double(*m)[4] = scan.index_to_world;
    char axes[128] = "axes along the world's";
    if (tilt > 1e-6)
        snprintf(axes, sizeof axes, "axes turned up to %.3g degrees from the world's: resampled through the scan's "
                                    "transform", tilt);
    ohm_log_info(&s->log, "read %s: voxels %.6g x %.6g x %.6g mm, the first one's centre at (%.6g, %.6g, %.6g) mm "
                          "(RAS); %s", name, spacing[0], spacing[1], spacing[2], m[0][3], m[1][3], m[2][3], axes);
    if (scan.detail[0]) ohm_log_info(&s->log, "read %s: %s", name, scan.detail);
    ohm_stats_set_str(&s->stats, "scan_file", name);
    ohm_stats_set_int(&s->stats, "scan_x", scan.dims[0]);
    ohm_stats_set_int(&s->stats, "scan_y", scan.dims[1]);
    ohm_stats_set_int(&s->stats, "scan_z", scan.dims[2]);
    ohm_stats_add(&s->stats, "t_read", t);
}

static int run_read(ohm_state *s, const ohm_invocation *inv, ohm_error *err)
{
    const char *path = ohm_opt_str(inv, "file");
    if (ohm_scan_is_volume_path(path)) return read_volume(s, inv, path, err);
    double t0 = ohm_now();
    ohm_mesh m;
    int rc = ohm_mesh_read(&m, path, err);
    if (rc) return rc;
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
    return ohm_state_set_mesh(s, &m, path, scale, t0, err);
}

int ohm_state_set_mesh(ohm_state *s, ohm_mesh *m_in, const char *name, double scale, double t0, ohm_error *err)
{
    ohm_mesh m = *m_in;
    memset(m_in, 0, sizeof *m_in);
    ohm_mesh_topology topo;
    int rc = ohm_mesh_topology_compute(&topo, &m, err);
    if (rc) {
        ohm_mesh_free(&m);
        return rc;
    }
    ohm_mesh_free(&s->mesh);
    drop_solution(s);
    ohm_voxel_grid_free(&s->grid); /* a new mesh makes the old grid stale */
    s->have_grid = 0;
    s->mesh = m;
    s->have_mesh = 1;
    s->mesh_scale_mm = scale;
    snprintf(s->mesh_path, sizeof s->mesh_path, "%s", name);

    double lo[3], hi[3];
    ohm_mesh_bounds(&m, lo, hi);
    double t = ohm_now() - t0;
    ohm_log_info(&s->log, "read %s: %zu vertices, %zu triangles, %.4g x %.4g x %.4g mm (%.6g mm per unit), %.2f s",
                 name, m.nverts, m.ntris, hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], scale, t);
    if (topo.boundary_edges || topo.nonmanifold_edges || topo.misoriented_edges)
        ohm_log_warn(&s->log,
                     "%s is not closed: %zu open (boundary) edges, %zu non-manifold edges, %zu flipped edges in %zu "
                     "piece(s); the inside is decided by the generalized winding number, which closes small holes",
                     name, topo.boundary_edges, topo.nonmanifold_edges, topo.misoriented_edges, topo.components);
    if (topo.degenerate_tris) ohm_log_info(&s->log, "%s: %zu degenerate triangles (ignored by the inside test)",
                                           name, topo.degenerate_tris);

    ohm_stats_set_str(&s->stats, "mesh_file", name);
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

/* A mesh replaces the grid made from the last one; a volume keeps the
 * grid (it may be the mesh's material); either makes a solution stale. */
static void read_io(const ohm_invocation *inv, ohm_step_io *io)
{
    if (ohm_scan_is_volume_path(ohm_opt_str(inv, "file"))) {
        io->provides = OHM_RES_VOLUME;
        io->drops = OHM_RES_SOLUTION;
    } else {
        io->provides = OHM_RES_MESH;
        io->drops = OHM_RES_GRID | OHM_RES_SOLUTION;
    }
}

/* ---- voxelize ------------------------------------------------------------------ */

static const ohm_opt_spec voxelize_opts[] = {
    {"dim", OHM_OPT_INT, "64", "cells along the longest axis of the bounding box (unless voxel= is given)", NULL, 1,
     4096, 0},
    {"voxel", OHM_OPT_REAL, NULL, "voxel size, in units= (overrides dim=)", NULL, 1e-12, 1e12, 0},
    {"units", OHM_OPT_ENUM, "mm", "unit of voxel=", "mm|cm|m|in", 0, 0, 0},
    {"band", OHM_OPT_INT, "3", "half width of the surface level set's narrow band, in voxels", NULL, 1, 64, 0},
    {"error", OHM_OPT_REAL, NULL,
     "pick dim= from an accuracy target: the relative error of the surface exitance (e.g. 0.02); probes the scene "
     "at dim 16 and 32 and extrapolates (the probes solve the scene, so this -voxelize runs after the -material "
     "and -light steps that follow it, wherever they are written)",
     NULL, 1e-4, 0.9, 0},
    {"max_memory", OHM_OPT_REAL, NULL, "MB the grid may take (default: what the machine has available)", NULL, 1e-3,
     1e12, 0},
    {"max_dim", OHM_OPT_INT, NULL,
     "with error=: the most cells across the target may choose (what fits a caller's memory); a target that needs "
     "more is refused after the probes, naming the dim it needs",
     NULL, 4, 4096, 0},
    {"threshold", OHM_OPT_REAL, NULL,
     "with a volume and no mesh: the object is where the density is >= this (its iso-surface)", NULL, -1e300, 1e300,
     0},
    {0}};

/* -voxelize error= solves the scene: it waits for the material and lights */
static int voxelize_waits(const ohm_invocation *inv) { return ohm_opt_given(inv, "error"); }

static void voxelize_io(const ohm_invocation *inv, ohm_step_io *io)
{
    int i = 0;
    if (ohm_opt_given(inv, "error")) {
        io->needs[i++] = (ohm_need){OHM_RES_MESH, 0, "error= needs a mesh (a volume has no exitance to probe)"};
        static const char probes[] = "error= probes the scene: it needs -material (optical coefficients, not "
                                     "transfer= or resistance=) and -light, before it or right after it";
        io->needs[i++] = (ohm_need){OHM_RES_MATERIAL, 0, probes};
        io->needs[i++] = (ohm_need){OHM_RES_LIGHTS, 0, probes};
    } else if (ohm_opt_given(inv, "threshold")) {
        io->needs[i++] = (ohm_need){OHM_RES_MESH | OHM_RES_VOLUME, 0, "nothing to voxelize yet: put -read before it"};
    } else {
        io->needs[i++] = (ohm_need){OHM_RES_MESH, 0, "no mesh yet: put -read file=MESH before it (a volume alone "
                                                     "needs threshold=, the density of its surface)"};
    }
    io->provides = OHM_RES_GRID;
    io->drops = OHM_RES_SOLUTION;
}

/* A scan's object ends at its box (scan.h).  Where the scan's background is
 * below the threshold, the scan ends it there by itself: past the box its
 * values step down to the background, and the iso-surface estimate sees
 * that step.  Where it is not (a uniform or cropped scan, a .vdb whose
 * background passes), the scan is continued past its box without a step
 * and the box cuts it: the surface is the box's face. */
static double scan_value(void *user, const double world[3]) { return ohm_scan_sample(user, world); }
static double scan_value_clamped(void *user, const double world[3]) { return ohm_scan_sample_clamped(user, world); }
static double scan_domain(void *user, const double world[3]) { return ohm_scan_box_distance(user, world); }

static ohm_field scan_object_field(ohm_scan *scan, double threshold)
{
    if (scan->background < threshold) return (ohm_field){scan_value, NULL, scan};
    return (ohm_field){scan_value_clamped, scan_domain, scan};
}

static int run_voxelize(ohm_state *s, const ohm_invocation *inv, ohm_error *err)
{
    if (!s->have_mesh && !(s->have_scan && ohm_opt_given(inv, "threshold"))) {
        if (s->have_scan)
            return ohm_fail(err, OHM_ERR_USAGE,
                            "%s: -voxelize: a volume without a mesh needs threshold= (the density of its surface)",
                            inv->where);
        return ohm_fail(err, OHM_ERR_INVALID, "%s: -voxelize: no mesh yet: put -read file=MESH before it", inv->where);
    }
    ohm_voxelize_params p = {0};
    double model_target = 0, model_error = -1; /* what -solve model=auto reads */
    if (ohm_opt_given(inv, "voxel")) p.voxel = ohm_opt_real(inv, "voxel") * unit_mm(ohm_opt_str(inv, "units"));
    else p.dim = (int)ohm_opt_int(inv, "dim");
    if (ohm_opt_given(inv, "error")) {
        if (ohm_opt_given(inv, "voxel") || ohm_opt_given(inv, "dim"))
            return ohm_fail(err, OHM_ERR_USAGE, "%s: -voxelize: give error= or dim=/voxel=, not both", inv->where);
        if (!s->have_mesh)
            return ohm_fail(err, OHM_ERR_USAGE, "%s: -voxelize error= needs a mesh (a volume has no exitance to probe)",
                            inv->where);
        if (!s->have_material || s->nlights == 0 || s->have_transfer ||
            s->material.kind == OHM_MATERIAL_RESISTANCE)
            return ohm_fail(err, OHM_ERR_USAGE,
                            "%s: -voxelize error= probes the scene: it needs -material (optical coefficients, not "
                            "transfer= or resistance=) and -light, before it or right after it",
                            inv->where);
        ohm_resolution_pick pick;
        double target = ohm_opt_real(inv, "error");
        int rc = ohm_pick_resolution(&pick, &s->mesh, &s->material, s->lights, s->nlights, target,
                                     ohm_model_probe_photons(&s->material, target), &s->log, err);
        if (rc) return rc;
        if (ohm_opt_given(inv, "max_dim") && pick.dim > ohm_opt_int(inv, "max_dim"))
            return ohm_fail(err, OHM_ERR_NOMEM,
                            "%s: -voxelize error=%g needs dim=%d (predicted error %.3g there), more than max_dim=%lld "
                            "allows; use a larger error=",
                            inv->where, target, pick.dim, pick.predicted, (long long)ohm_opt_int(inv, "max_dim"));
        p.dim = pick.dim;
        ohm_stats_set(&s->stats, "error_target", target);
        ohm_stats_set(&s->stats, "error_predicted", pick.predicted);
        ohm_stats_set(&s->stats, "error_probe", pick.probe_error);
        ohm_stats_set_int(&s->stats, "dim_chosen", pick.dim);
        ohm_stats_add(&s->stats, "t_error_probe", pick.t_probe);
        model_target = target;
        if (pick.photons > 0) {
            ohm_stats_set(&s->stats, "model_error_probe", pick.model_error);
            ohm_stats_set(&s->stats, "model_diff_probe", pick.model_diff);
            ohm_stats_add(&s->stats, "t_model_probe", pick.t_model);
            model_error = pick.model_error;
        }
    }
    p.band_voxels = (int)ohm_opt_int(inv, "band");
    if (ohm_opt_given(inv, "max_memory")) p.max_memory = ohm_opt_real(inv, "max_memory") * 1048576.0;

    double t0 = ohm_now();
    ohm_voxel_grid g;
    ohm_voxelize_report rep;
    memset(&rep, 0, sizeof rep);
    int rc;
    if (s->have_mesh) {
        rc = ohm_voxelize(&g, &rep, &s->mesh, &p, &s->log, err);
    } else {
        double lo[3], hi[3];
        ohm_scan_bounds(&s->scan, lo, hi);
        const double threshold = ohm_opt_real(inv, "threshold");
        const ohm_field field = scan_object_field(&s->scan, threshold);
        rc = ohm_voxelize_field(&g, &field, lo, hi, threshold, &p, &s->log, err);
    }
    /* name the file the object came from (docs/design.md §11) */
    if (rc) return ohm_error_name(err, rc, s->have_mesh ? s->mesh_path : s->scan_path);
    double t = ohm_now() - t0;

    drop_solution(s);
    ohm_voxel_grid_free(&s->grid);
    s->grid = g;
    s->mesh_flipped = rep.flipped;
    s->have_grid = 1;
    s->error_target = model_target;
    s->model_error = model_error;
    double cell_volume = g.h * g.h * g.h;
    double vol = (double)g.interior_cells * cell_volume;
    if (rep.flipped)
        ohm_log_warn(&s->log, "%s is wound inside-out (enclosed volume %.4g mm^3 < 0): reading it reversed",
                     s->mesh_path, rep.signed_volume);
    if (rep.ambiguous)
        ohm_log_info(&s->log, "%zu cells had a winding number between 0.4 and 0.6 (near holes or overlaps)",
                     rep.ambiguous);
    if (s->have_mesh)
        ohm_log_info(&s->log,
                     "voxelized: %d x %d x %d grid, voxel %.4g mm, %zu interior cells (%.6g mm^3; mesh encloses "
                     "%.6g mm^3), %.2f s",
                     g.dims[0], g.dims[1], g.dims[2], g.h, g.interior_cells, vol, fabs(rep.signed_volume), t);
    else
        ohm_log_info(&s->log,
                     "voxelized %s at density >= %g: %d x %d x %d grid, voxel %.4g mm, %zu interior cells (%.6g "
                     "mm^3), %.2f s",
                     s->scan_path, ohm_opt_real(inv, "threshold"), g.dims[0], g.dims[1], g.dims[2], g.h,
                     g.interior_cells, vol, t);
    if (g.interior_cells == 0 && s->have_mesh)
        ohm_log_warn(&s->log, "no cell centre lies inside the mesh: use a larger dim= or a smaller voxel=");
    else if (g.interior_cells == 0)
        ohm_log_warn(&s->log, "%s: no cell reaches threshold=%g (the scan's values are %g .. %g): the object is "
                              "empty", s->scan_path, ohm_opt_real(inv, "threshold"), s->scan.min, s->scan.max);

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

/* ---- material ------------------------------------------------------------------ */

static const ohm_opt_spec material_opts[] = {
    {"preset", OHM_OPT_ENUM, NULL, "measured material (Jensen et al. 2001; eta 1.3)",
     "apple|chicken1|chicken2|cream|ketchup|marble|potato|skimmilk|skin1|skin2|spectralon|wholemilk", 0, 0, 0},
    {"sigma_a", OHM_OPT_REAL13, NULL, "absorption coefficient, 1/mm", NULL, 0, OHM_SIGMA_A_MAX, 0},
    {"sigma_s", OHM_OPT_REAL13, NULL, "reduced scattering coefficient sigma_s', 1/mm", NULL, OHM_SIGMA_S_MIN,
     OHM_SIGMA_S_MAX, 0},
    {"sigma_s_full", OHM_OPT_REAL13, NULL,
     "scattering coefficient sigma_s, 1/mm, instead of sigma_s': with g=, sigma_s' = sigma_s (1 - g)", NULL,
     OHM_SIGMA_S_MIN, OHM_SIGMA_S_MAX, 0},
    {"g", OHM_OPT_REAL, "0",
     "scattering anisotropy (mean cosine, Henyey-Greenstein): diffusion uses only sigma_s'; solver=mc traces "
     "sigma_s = sigma_s' / (1 - g) with this phase function",
     NULL, -0.99, 0.99, 0},
    {"eta", OHM_OPT_REAL, "1.3", "relative index of refraction", NULL, 1, 3, 0},
    {"resistance", OHM_OPT_REAL, NULL, "paper mode: ohms between neighbouring cells", NULL, OHM_RESISTANCE_MIN,
     OHM_RESISTANCE_MAX, 0},
    {"ground", OHM_OPT_REAL, NULL, "paper mode: ohms from each cell to ground", NULL, OHM_RESISTANCE_MIN,
     OHM_RESISTANCE_MAX, 0},
    {"transfer", OHM_OPT_STRING, NULL,
     "transfer function file: the volume's density -> coefficients per cell (see docs/transfer-functions.md)", NULL,
     0, 0, 0},
    {0}};

static void material_io(const ohm_invocation *inv, ohm_step_io *io)
{
    int transfer = ohm_opt_given(inv, "transfer");
    io->provides = OHM_RES_MATERIAL | (transfer ? OHM_RES_TRANSFER : 0u);
    io->drops = OHM_RES_SOLUTION | (transfer ? 0u : OHM_RES_TRANSFER);
}

static int run_material(ohm_state *s, const ohm_invocation *inv, ohm_error *err)
{
    ohm_material m;
    memset(&m, 0, sizeof m);
    int preset = ohm_opt_given(inv, "preset");
    int optical = ohm_opt_given(inv, "sigma_a") || ohm_opt_given(inv, "sigma_s") || ohm_opt_given(inv, "sigma_s_full");
    int paper = ohm_opt_given(inv, "resistance") || ohm_opt_given(inv, "ground");
    int transfer = ohm_opt_given(inv, "transfer");
    if (preset + optical + paper + transfer != 1)
        return ohm_fail(err, OHM_ERR_USAGE,
                        "%s: -material: give exactly one of preset=NAME, sigma_a= with sigma_s= (or sigma_s_full=), "
                        "resistance= with ground=, or transfer=FILE",
                        inv->where);
    int rc;
    ohm_transfer_free(&s->transfer);
    s->have_transfer = 0;
    if (transfer) {
        const char *tp = ohm_opt_str(inv, "transfer");
        ohm_transfer t;
        rc = ohm_transfer_read(&t, tp, err);
        if (rc) return rc;
        /* the material records the kind and channels; the coefficients come
         * per cell from the volume at -solve */
        m.kind = t.resistance_mode ? OHM_MATERIAL_RESISTANCE : OHM_MATERIAL_OPTICAL;
        m.channels = t.channels;
        m.eta = t.resistance_mode ? 1.0 : t.eta;
        m.g = t.resistance_mode ? 0.0 : t.g;
        ohm_transfer_eval(&t, t.density[0], m.sigma_a, m.sigma_s);
        if (t.resistance_mode) m.resistance = m.sigma_a[0], m.ground = m.sigma_s[0];
        const char *base = strrchr(tp, '/');
        snprintf(m.name, sizeof m.name, "transfer %s", base ? base + 1 : tp);
        drop_solution(s);
        s->material = m;
        s->have_material = 1;
        s->transfer = t;
        s->have_transfer = 1;
        snprintf(s->transfer_path, sizeof s->transfer_path, "%s", tp);
        ohm_stats_set_str(&s->stats, "material", m.name);
        ohm_stats_set_str(&s->stats, "transfer", tp);
        ohm_log_info(&s->log, "material: transfer function %s, %zu points, %d channel(s)%s%s", tp, t.n, t.channels,
                     t.resistance_mode ? ", resistances" : "",
                     t.eta_column && t.g_column ? ", an index and an anisotropy per density"
                     : t.eta_column             ? ", a refractive index per density"
                     : t.g_column               ? ", an anisotropy per density"
                                                : "");
        return OHM_OK;
    }
    if (preset) {
        rc = ohm_material_preset(&m, ohm_opt_str(inv, "preset"), err);
        if (rc) return rc;
        if (ohm_opt_given(inv, "eta")) m.eta = ohm_opt_real(inv, "eta");
        m.g = ohm_opt_real(inv, "g"); /* Jensen's table gives sigma_s' only: 0 unless told */
    } else if (optical) {
        int full = ohm_opt_given(inv, "sigma_s_full");
        if (full && ohm_opt_given(inv, "sigma_s"))
            return ohm_fail(err, OHM_ERR_USAGE,
                            "%s: -material: give sigma_s= (reduced, sigma_s') or sigma_s_full= (sigma_s, with g=), "
                            "not both",
                            inv->where);
        if (!ohm_opt_given(inv, "sigma_a") || !(full || ohm_opt_given(inv, "sigma_s")))
            return ohm_fail(err, OHM_ERR_USAGE, "%s: -material: sigma_a= and sigma_s= (or sigma_s_full=) go together",
                            inv->where);
        int ka = ohm_opt_real13(inv, "sigma_a", m.sigma_a);
        int ks = ohm_opt_real13(inv, full ? "sigma_s_full" : "sigma_s", m.sigma_s);
        m.g = ohm_opt_real(inv, "g");
        if (full) /* sigma_s' = sigma_s (1 - g): what diffusion needs (similarity) */
            for (int c = 0; c < 3; ++c) m.sigma_s[c] *= 1.0 - m.g;
        m.kind = OHM_MATERIAL_OPTICAL;
        m.channels = (ka == 3 || ks == 3) ? 3 : 1;
        m.eta = ohm_opt_real(inv, "eta");
        snprintf(m.name, sizeof m.name, "custom");
    } else {
        if (!ohm_opt_given(inv, "resistance") || !ohm_opt_given(inv, "ground"))
            return ohm_fail(err, OHM_ERR_USAGE, "%s: -material: resistance= and ground= go together", inv->where);
        m.kind = OHM_MATERIAL_RESISTANCE;
        m.channels = 1;
        m.resistance = ohm_opt_real(inv, "resistance");
        m.ground = ohm_opt_real(inv, "ground");
        m.eta = 1.0;
        snprintf(m.name, sizeof m.name, "resistances %g/%g ohm", m.resistance, m.ground);
    }
    rc = ohm_material_check(&m, err);
    if (rc) return rc;
    drop_solution(s);
    s->material = m;
    s->have_material = 1;
    s->model_error = -1; /* a probe of another material, if any */
    if (m.kind == OHM_MATERIAL_OPTICAL) {
        static const char *cn[3] = {"R", "G", "B"};
        for (int c = 0; c < m.channels; ++c) {
            double alb = ohm_material_albedo(&m, c);
            ohm_log_info(&s->log, "material %s%s%s: sigma_a %.4g, sigma_s' %.4g /mm, albedo %.4f, 1/sigma_t' %.4g mm, "
                         "1/sigma_tr %.4g mm",
                         m.name, m.channels == 1 ? "" : " ", m.channels == 1 ? "" : cn[c], m.sigma_a[c],
                         m.sigma_s[c], alb, 1.0 / (m.sigma_a[c] + m.sigma_s[c]),
                         m.sigma_a[c] > 0 ? 1.0 / ohm_material_sigma_tr(&m, c) : INFINITY);
            if (alb < 0.8)
                ohm_log_warn(&s->log,
                             "material %s%s%s has albedo %.3f < 0.8: the diffusion approximation is poor there "
                             "(light is absorbed before it scatters enough); expect errors of tens of percent "
                             "(-solve model=transport traces it instead; with -voxelize error=, model=auto "
                             "measures diffusion's error and chooses)",
                             m.name, m.channels == 1 ? "" : " ", m.channels == 1 ? "" : cn[c], alb);
        }
    }
    ohm_stats_set_str(&s->stats, "material", m.name);
    return OHM_OK;
}

/* ---- light --------------------------------------------------------------------- */

static void light_io(const ohm_invocation *inv, ohm_step_io *io)
{
    if (ohm_opt_int(inv, "orbit") > 0)
        io->needs[0] = (ohm_need){OHM_RES_MESH | OHM_RES_VOLUME | OHM_RES_GRID, 0,
                                  "orbit= turns about the object: -read it first"};
    io->provides = OHM_RES_LIGHTS;
    io->drops = OHM_RES_SOLUTION; /* stale until solved again */
}

/* type=, orbit= and sky= that do not go together: refused when parsed */
static int light_check(const ohm_invocation *inv, ohm_error *err)
{
    ohm_opt_reader reader = ohm_opt_reader_of(inv);
    return ohm_light_options_check(&reader, err);
}

/* Rotate v about the axis (0 x, 1 y, 2 z) by angle a (right-handed). */
static void rotate_axis(double v[3], int axis, double a)
{
    int p = (axis + 1) % 3, q = (axis + 2) % 3;
    double x = v[p], y = v[q];
    v[p] = x * cos(a) - y * sin(a);
    v[q] = x * sin(a) + y * cos(a);
}

/* Light l to the scene, or orbit= copies of it turned about the object. */
static int add_light(ohm_state *s, const ohm_light *l, const ohm_invocation *inv, ohm_error *err)
{
    int orbit = (int)ohm_opt_int(inv, "orbit");
    size_t add = orbit > 0 ? (size_t)orbit : 1;
    double centre[3] = {0, 0, 0};
    if (orbit > 0) {
        if (!s->have_mesh && !s->have_grid && !s->have_scan)
            return ohm_fail(err, OHM_ERR_USAGE, "%s: -light orbit=%d turns about the object: -read it first",
                            inv->where, orbit);
        for (size_t i = 0; i < s->nlights; ++i)
            if (s->lights[i].frame != 0)
                return ohm_fail(err, OHM_ERR_USAGE, "%s: -light orbit=: only one orbiting light per run", inv->where);
        double lo[3], hi[3];
        if (s->have_mesh) ohm_mesh_bounds(&s->mesh, lo, hi);
        else if (s->have_grid)
            for (int a = 0; a < 3; ++a) {
                lo[a] = s->grid.origin[a];
                hi[a] = s->grid.origin[a] + s->grid.h * (s->grid.dims[a] - 1);
            }
        else ohm_scan_bounds(&s->scan, lo, hi);
        for (int a = 0; a < 3; ++a) centre[a] = 0.5 * (lo[a] + hi[a]);
    }
    int axis = ohm_opt_str(inv, "axis")[0] - 'x';
    ohm_light *grown = realloc(s->lights, (s->nlights + add) * sizeof *grown);
    if (!grown) return ohm_fail(err, OHM_ERR_NOMEM, "out of memory");
    s->lights = grown;
    for (size_t k = 0; k < add; ++k) {
        ohm_light lk = *l;
        if (orbit > 0) {
            double angle = 2.0 * M_PI * (double)k / (double)orbit, rel[3];
            for (int a = 0; a < 3; ++a) rel[a] = l->pos[a] - centre[a];
            rotate_axis(rel, axis, angle);
            for (int a = 0; a < 3; ++a) lk.pos[a] = centre[a] + rel[a];
            rotate_axis(lk.dir, axis, angle);
            lk.frame = (int)k + 1;
        }
        s->lights[s->nlights++] = lk;
    }
    s->have_solution = 0; /* stale; the setup stays, for ohm_state_relight */
    return OHM_OK;
}

/* The light from its kind's options (the table, physics/light_kind.h); then
 * orbit=, which turns copies of it about the object. */
static int run_light(ohm_state *s, const ohm_invocation *inv, ohm_error *err)
{
    ohm_light l;
    ohm_opt_reader reader = ohm_opt_reader_of(inv);
    int rc = ohm_light_read(&l, &reader, err);
    if (rc) return rc;
    rc = add_light(s, &l, inv, err);
    if (rc) ohm_light_release(&l);
    return rc;
}

/* ---- solve --------------------------------------------------------------------- */

static const ohm_opt_spec solve_opts[] = {
    {"boundary", OHM_OPT_ENUM, "robin",
     "robin (partial current, as the dipole assumes) | neumann (zero flux, the paper's) | dirichlet (phi = 0)",
     "robin|neumann|dirichlet", 0, 0, 0},
    {"ordering", OHM_OPT_ENUM, "auto",
     "fill-reducing ordering of the Cholesky factor: metis, amd, nesdis (CHOLMOD's), grid (nested dissection by planes "
     "of cells, made for voxel grids: milliseconds); best tries metis, amd and grid; auto: grid, then metis too "
     "when it is predicted to pay for its analysis over the factorizations and solves to come (docs/ordering.md)",
     "auto|metis|amd|nesdis|grid|best", 0, 0, 0},
    {"fresnel", OHM_OPT_ENUM, "exact",
     "robin: the boundary constant A from eta by the exact Fresnel moments, A = (1 + 3 C2)/(1 - 2 C1) "
     "(Haskell et al. 1994) | polynomial: (1 + F_dr)/(1 - F_dr) with Egan & Hilgeman's fit (3.05 against 2.76 "
     "at eta 1.37)",
     "exact|polynomial", 0, 0, 0},
    {"deposit", OHM_OPT_ENUM, "exponential",
     "where entering light starts to diffuse: exponential (reduced-intensity profile) | point (at depth "
     "1/sigma_t', the dipole's) | surface (first cell, the paper's)",
     "exponential|point|surface", 0, 0, 0},
    {"fluence", OHM_OPT_ENUM, "diffuse",
     "what the fluence grid holds: diffuse (the scattered light, diffusion's phi) | total (plus the unscattered "
     "beam, attenuated by the full sigma_t, what transport codes report)",
     "diffuse|total", 0, 0, 0},
    {"shadows", OHM_OPT_ENUM, "auto",
     "shadow rays: mesh (Embree, against the triangles), grid (through the voxel cells), none; auto = mesh when "
     "there is one",
     "auto|mesh|grid|none", 0, 0, 0},
    {"solver", OHM_OPT_ENUM, "auto",
     "auto (the default: mg solves the first light, then the rest go to whichever of mg, direct and amg fits the "
     "memory and is predicted quickest; the statistics' solver_reason says why) | direct (Cholesky factor, reused by "
     "every light) | cg (MIC(0) conjugate gradients: memory O(cells), "
     "warm-started frame to frame) | amg (PETSc CG + hypre BoomerAMG: memory O(cells), iterations independent of "
     "the grid, distributed under mpirun) | mg (geometric multigrid on the voxel grid, matrix-free: memory and time "
     "O(cells), iterations independent of the grid and of contrasts, warm-started) | mc (Monte "
     "Carlo photon transport through the same cells and lights instead of diffusion: the reference for the "
     "model's error, with standard errors; photons= seed= threads=; -material g= for the phase function)",
     "direct|cg|amg|mg|auto|mc", 0, 0, 0},
    {"model", OHM_OPT_ENUM, "auto",
     "the light's model: diffusion (the resistor network, solved by solver=) | transport (Monte Carlo photons "
     "through the same cells: solver=mc) | auto (the default: diffusion, unless -voxelize error=E measured "
     "diffusion's own error against transport above E in this scene (it does for a material with an albedo "
     "below 0.9) and solver= is auto: then transport; docs/transport.md)",
     "auto|diffusion|transport", 0, 0, 0},
    {"device", OHM_OPT_DEVICE, "host",
     "where mg's solve and traced photons (solver=mc, and hybrid='s beside any solver) run: host (this "
     "machine's cores), gpu (the first GPU with double precision), cpu (an OpenCL CPU device, e.g. PoCL), "
     "opencl:N (as 'ohm devices' numbers them), auto (a GPU when there is one, for a grid of 2^16 cells or "
     "more and traces of 2^17 photons or more, else the host); mg's hierarchy stays on the device for relights",
     NULL, 0, 0, 0},
    {"photons", OHM_OPT_REAL, "1e6", "solver=mc and hybrid=: photons per frame and channel (the noise falls as 1/sqrt(photons))",
     NULL, 16, 1e12, 0},
    {"seed", OHM_OPT_INT, "1", "solver=mc and hybrid=: random seed; the same seed and threads= repeat a run bit for bit (on a "
     "device, the same seed repeats every photon's path, its sums to the order of the atomic additions)", NULL, 0,
     9.007199254740992e15, 0},
    {"threads", OHM_OPT_INT, "0", "solver=mc and hybrid=: threads (0: every core)", NULL, 0, 1024, 0},
    {"hybrid", OHM_OPT_STRING, "auto",
     "trace the light's first N reduced scatterings as Monte Carlo transport (photons= seed= threads=), then "
     "diffusion from where each photon is: right within a few mean free paths of a pencil beam, where diffusion "
     "alone is 15-22% off; 0: diffusion only; auto: 10 when a light is a pencil beam, else 0 (docs/transport.md)",
     NULL, 0, 0, 0},
    {"clear", OHM_OPT_STRING, "auto",
     "clear regions, where light crosses without diffusing (CSF, cavities, a clear inclusion: a connected region "
     "whose 1/sigma_t' exceeds the cell and whose optical thickness sigma_t' x mean chord is below 2): auto (find "
     "them and treat them as best ohm can: today effective) | off (diffusion everywhere) | effective (an effective "
     "sigma_s' of 1/thickness there, Custo et al. 2006) | radiosity (transport across them: their walls exchange "
     "light by view factors, Firbank et al. 1996; solver=direct, cg or mg); the log and the statistics name "
     "what is found (docs/transport.md)",
     NULL, 0, 0, 0},
    {"clear_reach", OHM_OPT_REAL, NULL,
     "clear=radiosity: link the clear regions' wall faces up to this far apart (mm); what farther pairs would "
     "carry goes to the pairs kept (default: 5 mean chords of the thickest region treated; the pairs and the "
     "set-up grow with the walls' area within reach)",
     NULL, 1e-6, 1e9, 0},
    {"petsc_options", OHM_OPT_STRING, NULL,
     "solver=amg: options for PETSc's database, e.g. \"-pc_type gamg\" or \"-ksp_type preonly -pc_type cholesky "
     "-pc_factor_mat_solver_type mumps\"; an option PETSc does not use is an error",
     NULL, 0, 0, 0},
    {"depth_band", OHM_OPT_REAL, "0",
     "solve only the cells within depth_band / sigma_tr of the surface (light there has decayed by e^-depth_band), "
     "the core closed as an absorbing half-space; 0 = every cell",
     NULL, 0, 1e6, 0},
    {"depth_band_error", OHM_OPT_REAL, NULL,
     "choose the depth band from an error target: depth_band = ln(1/depth_band_error) / 2, the round trip "
     "e^(-2 depth_band) of light "
     "to the band's floor and back bounds the exitance error (measured: docs/accuracy.md)",
     NULL, 1e-12, 0.5, 0},
    {"cg_tol", OHM_OPT_REAL, "1e-10", "solver=cg and amg stop when ||b - A x|| <= cg_tol ||b||", NULL, 1e-15, 1e-2, 0},
    {"batch_mb", OHM_OPT_REAL, "1024", "memory for right-hand sides solved together (frames beyond it: batches)",
     NULL, 1, 1e7, 0},
    {"max_memory", OHM_OPT_REAL, NULL,
     "MB the solver may take, estimated before it starts: the factor from its symbolic analysis, cg and amg "
     "per cell (amg: per rank), mc its tallies (default: what the machine has available)",
     NULL, 1e-3, 1e12, 0},
    {"keep", OHM_OPT_ENUM, "0",
     "1: keep every channel material's factor (or preconditioner) after the solve, so that new lights are solved "
     "without setting up again (the library's ohm_scene_relight, include/ohm.h); 0: release each once its "
     "channels are solved",
     "0|1", 0, 0, 0},
    {0}};

static void solve_io(const ohm_invocation *inv, ohm_step_io *io)
{
    (void)inv;
    io->needs[0] = (ohm_need){OHM_RES_GRID, 0, "no voxel object: -read and -voxelize first"};
    io->needs[1] = (ohm_need){OHM_RES_MATERIAL, 0, "no material: add -material (e.g. preset=marble) first"};
    io->needs[2] = (ohm_need){OHM_RES_LIGHTS, 0, "no lights: add -light first"};
    io->needs[3] = (ohm_need){OHM_RES_VOLUME, OHM_RES_TRANSFER, "transfer= maps a volume's density: -read one first"};
    io->provides = OHM_RES_SOLUTION;
}

/* The material from the volume through the transfer function: the density
 * at each interior cell (trilinear at its centre, or the mean over the cell
 * when the grid is coarser than the scan), in unknown order (interior cells,
 * x fastest), with the transfer function's curves of it (solve.h); paper
 * mode's resistances, and the index and anisotropy columns, per cell. */
static int material_from_scan(ohm_state *s, ohm_media_params *p, float **density, ohm_coeff **percell,
                              double **eta_cell, double **g_cell, ohm_error *err)
{
    const ohm_voxel_grid *g = &s->grid;
    const ohm_transfer *t = &s->transfer;
    size_t n = g->interior_cells;
    int nc = t->resistance_mode ? 1 : t->channels;
    *density = malloc((n ? n : 1) * sizeof **density);
    if (!*density) return ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory for the density");
    for (int q = 0; q < 2 * nc && t->resistance_mode; ++q) {
        percell[q] = malloc((n ? n : 1) * sizeof *percell[q]);
        if (!percell[q]) return ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory for the material");
    }
    if (t->eta_column) { /* the index per cell (transfer.h): network.h's interfaces */
        *eta_cell = malloc((n ? n : 1) * sizeof(double));
        if (!*eta_cell) return ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory for the refractive index");
    }
    if (t->g_column) { /* the anisotropy per cell: transport's phase function (mc.h) */
        *g_cell = malloc((n ? n : 1) * sizeof(double));
        if (!*g_cell) return ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory for the anisotropy");
    }
    /* the scan's finest spacing decides between sampling and averaging */
    double axis_spacing[3];
    ohm_scan_spacing(&s->scan, axis_spacing);
    double spacing = fmin(axis_spacing[0], fmin(axis_spacing[1], axis_spacing[2]));
    int average = g->h > 1.5 * spacing;
    size_t u = 0;
    for (int32_t k = 0; k < g->dims[2]; ++k)
        for (int32_t j = 0; j < g->dims[1]; ++j)
            for (int32_t i = 0; i < g->dims[0]; ++i) {
                if (!g->inside[ohm_voxel_index(g, i, j, k)]) continue;
                double c[3] = {g->origin[0] + g->h * i, g->origin[1] + g->h * j, g->origin[2] + g->h * k};
                if (average) {
                    double lo[3], hi[3];
                    for (int a = 0; a < 3; ++a) lo[a] = c[a] - 0.5 * g->h, hi[a] = c[a] + 0.5 * g->h;
                    (*density)[u++] = (float)ohm_scan_box_mean(&s->scan, lo, hi);
                } else {
                    (*density)[u++] = (float)ohm_scan_sample(&s->scan, c);
                }
            }
    /* the coefficients come from the density as it is kept (a float, like
     * the scan's values), wherever they are evaluated */
    for (u = 0; u < n; ++u) {
        double d = (*density)[u];
        if (*eta_cell) (*eta_cell)[u] = ohm_transfer_eval_eta(t, d);
        if (*g_cell) (*g_cell)[u] = ohm_transfer_eval_g(t, d);
        if (t->resistance_mode) {
            double r, ground;
            ohm_transfer_eval(t, d, &r, &ground);
            percell[0][u] = (ohm_coeff)r;
            percell[1][u] = (ohm_coeff)ground;
        }
    }
    p->give_media = 1; /* the solver keeps what it is given (solve.h): no copies */
    if (t->resistance_mode) {
        p->resistance_v = percell[0];
        p->ground_v = percell[1];
        free(*density); /* the resistances are all the network needs */
        *density = NULL;
    } else {
        /* the transfer function itself, not a coefficient per cell (solve.h) */
        p->density = *density;
        for (int ch = 0; ch < nc; ++ch) {
            p->density_sa[ch] = ohm_transfer_curve(t, ch, 0);
            p->density_ss[ch] = ohm_transfer_curve(t, ch, 1);
        }
        p->eta_v = *eta_cell;
        p->g_v = *g_cell;
    }
    ohm_log_info(&s->log, "material: %zu cells from %s through %s (%s)", n, s->scan_path, s->transfer_path,
                 average ? "box-averaged: the grid is coarser than the volume" : "trilinear");
    return OHM_OK;
}

/* device= names where mg's cycle and traced photons (solver=mc, and the
 * hybrid's beside any solver) run: asked of a solve with neither, once
 * hybrid=auto is settled, it would do nothing, and says so. */
static int device_has_work(const ohm_solve_params *p, const ohm_invocation *inv, ohm_error *err)
{
    ohm_device_kind dev = p->num.device.kind;
    if (dev == OHM_DEVICE_HOST || dev == OHM_DEVICE_AUTO) return OHM_OK;
    if ((ohm_solver_kind_caps(p->num.solver) & OHM_SOLVES_ON_DEVICE) || p->mc.handoff > 0) return OHM_OK;
    return ohm_fail(err, OHM_ERR_USAGE,
                    "%s: -solve: device=%s runs solver=mg's solve and traced photons (solver=mc, hybrid=); "
                    "solver=%s traces none here and runs on the host",
                    inv->where, ohm_opt_str(inv, "device"), ohm_solver_kind_name(p->num.solver));
}

/* -solve hybrid=auto|N (solve.h), after p's boundary, solver and band are
 * set: auto is OHM_HYBRID_PENCIL for a pencil beam where the hybrid applies
 * (optical media, the Fresnel boundary, every cell), else 0. */
static int hybrid_option(const ohm_state *s, const ohm_invocation *inv, const ohm_solve_params *p, int *handoff,
                         ohm_error *err)
{
    const char *h = ohm_opt_str(inv, "hybrid");
    if (strcmp(h, "auto") == 0) {
        *handoff = 0;
        for (size_t l = 0; l < s->nlights; ++l)
            if (ohm_light_at_a_point(&s->lights[l])) *handoff = OHM_HYBRID_PENCIL;
        if ((ohm_solver_kind_caps(p->num.solver) & OHM_SOLVES_TRANSPORT) || p->op.boundary != OHM_BOUNDARY_ROBIN ||
            p->op.band_k > 0 ||
            s->material.kind == OHM_MATERIAL_RESISTANCE)
            *handoff = 0; /* all transport already, or a scene the tracer does not model */
        return OHM_OK;
    }
    char *end;
    errno = 0;
    long k = strtol(h, &end, 10);
    if (end == h || *end || errno || k < 0 || k > 1000)
        return ohm_fail(err, OHM_ERR_USAGE, "%s: -solve: hybrid=%s: expected auto or a whole number 0..1000",
                        inv->where, h);
    *handoff = (int)k;
    return OHM_OK;
}

/* -solve model=auto|diffusion|transport (docs/transport.md, "Which model"),
 * after p's solver is read: transport is solver=mc; auto takes it where
 * -voxelize error='s probe measured diffusion's own error above the target
 * and the solver was left to ohm. */
static int model_option(const ohm_state *s, const ohm_invocation *inv, ohm_solve_params *p, ohm_error *err)
{
    const char *model = ohm_opt_str(inv, "model");
    int solver_given = ohm_opt_given(inv, "solver") && strcmp(ohm_opt_str(inv, "solver"), "auto") != 0;
    int transport = p->num.solver == OHM_SOLVER_MC;
    if (strcmp(model, "diffusion") == 0 && transport)
        return ohm_fail(err, OHM_ERR_USAGE, "%s: -solve: model=diffusion and solver=mc contradict (solver=mc is transport)",
                        inv->where);
    if (strcmp(model, "transport") == 0) {
        if (solver_given && !transport)
            return ohm_fail(err, OHM_ERR_USAGE,
                            "%s: -solve: model=transport is Monte Carlo (solver=mc); solver=%s solves diffusion",
                            inv->where, ohm_opt_str(inv, "solver"));
        p->num.solver = OHM_SOLVER_MC;
        return OHM_OK;
    }
    if (strcmp(model, "auto") != 0 || s->model_error < 0 || !(s->error_target > 0)) return OHM_OK;
    if (s->model_error > s->error_target && !solver_given) {
        p->num.solver = OHM_SOLVER_MC;
        ohm_log_info(&s->log,
                     "-solve model=auto: transport (solver=mc): diffusion's own error against transport in this "
                     "scene is at least %.3g (measured by -voxelize error=%g), more than the %g asked",
                     s->model_error, s->error_target, s->error_target);
    } else if (s->model_error > s->error_target) {
        ohm_log_warn(&s->log,
                     "-solve solver=%s is diffusion, whose own error against transport in this scene is at least "
                     "%.3g (measured by -voxelize error=%g): more than asked; model=transport traces it instead",
                     ohm_opt_str(inv, "solver"), s->model_error, s->error_target);
    } else {
        ohm_log_info(&s->log,
                     "-solve model=auto: diffusion: its own error against transport measured by -voxelize error=%g "
                     "is below the target (at least %.3g)",
                     s->error_target, s->model_error);
    }
    return OHM_OK;
}

/* -solve's options into p (strings point into inv). */
static int solve_params(ohm_solve_params *p, const ohm_state *s, const ohm_invocation *inv, ohm_error *err)
{
    const char *bname = ohm_opt_str(inv, "boundary"), *dname = ohm_opt_str(inv, "deposit");
    const char *fname = ohm_opt_str(inv, "fresnel");
    memset(p, 0, sizeof *p);
    p->op.boundary = strcmp(bname, "neumann") == 0     ? OHM_BOUNDARY_NEUMANN
                     : strcmp(bname, "dirichlet") == 0 ? OHM_BOUNDARY_DIRICHLET
                                                       : OHM_BOUNDARY_ROBIN;
    p->op.fresnel = strcmp(fname, "polynomial") == 0 ? OHM_FRESNEL_POLYNOMIAL : OHM_FRESNEL_EXACT;
    p->src.deposit = strcmp(dname, "point") == 0     ? OHM_DEPOSIT_POINT
                     : strcmp(dname, "surface") == 0 ? OHM_DEPOSIT_SURFACE
                                                     : OHM_DEPOSIT_EXPONENTIAL;
    p->num.ordering = ohm_opt_str(inv, "ordering");
    p->num.from_scan = s->have_scan && !s->have_mesh;
    p->src.total_fluence = strcmp(ohm_opt_str(inv, "fluence"), "total") == 0;
    /* the texts read once: the layers below get the typed choices */
    int rc_choice = ohm_solver_kind_parse(&p->num.solver, ohm_opt_str(inv, "solver"), err);
    if (!rc_choice) rc_choice = ohm_device_request_parse(&p->num.device, ohm_opt_str(inv, "device"), err);
    if (rc_choice) return rc_choice;
    if (ohm_opt_given(inv, "petsc_options")) p->num.petsc_options = ohm_opt_str(inv, "petsc_options");
    p->num.cg_tol = ohm_opt_real(inv, "cg_tol");
    p->mc.photons = (int64_t)ohm_opt_real(inv, "photons");
    p->mc.seed = (uint64_t)ohm_opt_int(inv, "seed");
    p->mc.threads = (int)ohm_opt_int(inv, "threads");
    p->mc.log = &s->log;
    p->mc.device = p->num.device; /* solver=mc's photons, and the hybrid's beside any solver */
    p->op.band_k = ohm_opt_real(inv, "depth_band");
    if (ohm_opt_given(inv, "depth_band_error")) {
        if (ohm_opt_given(inv, "depth_band"))
            return ohm_fail(err, OHM_ERR_USAGE, "%s: -solve: give depth_band= or depth_band_error=, not both",
                            inv->where);
        p->op.band_k = 0.5 * log(1.0 / ohm_opt_real(inv, "depth_band_error"));
    }
    int rc_m = model_option(s, inv, p, err);
    if (rc_m) return rc_m;
    if (ohm_clear_mode_parse(&p->op.clear, ohm_opt_str(inv, "clear"), NULL)) {
        char choices[OHM_CLEAR_CHOICES_CHARS];
        return ohm_fail(err, OHM_ERR_USAGE, "%s: -solve: clear=%s: expected %s", inv->where, ohm_opt_str(inv, "clear"),
                        ohm_clear_mode_choices(choices, sizeof choices));
    }
    if (ohm_opt_given(inv, "clear_reach")) {
        if (p->op.clear != OHM_CLEAR_RADIOSITY)
            return ohm_fail(err, OHM_ERR_USAGE, "%s: -solve: clear_reach= is the reach of clear=radiosity's coupling; "
                            "clear=%s has none", inv->where, ohm_opt_str(inv, "clear"));
        p->op.clear_reach = ohm_opt_real(inv, "clear_reach");
    }
    int rc_h = hybrid_option(s, inv, p, &p->mc.handoff, err);
    if (rc_h) return rc_h;
    const char *sh = ohm_opt_str(inv, "shadows");
    p->src.shadows = strcmp(sh, "none") == 0   ? OHM_SHADOWS_NONE
                     : strcmp(sh, "grid") == 0 ? OHM_SHADOWS_GRID
                     : strcmp(sh, "mesh") == 0 ? OHM_SHADOWS_MESH
                     : s->have_mesh            ? OHM_SHADOWS_MESH
                                               : OHM_SHADOWS_GRID;
    p->src.mesh = s->have_mesh ? &s->mesh : NULL;
    p->src.orientation = s->mesh_flipped ? -1 : 1;
    p->num.max_rhs_bytes = ohm_opt_real(inv, "batch_mb") * 1048576.0;
    if (ohm_opt_given(inv, "max_memory")) p->num.max_memory = ohm_opt_real(inv, "max_memory") * 1048576.0;
    return OHM_OK;
}

static const char *deposit_name(ohm_deposit d)
{
    return d == OHM_DEPOSIT_POINT ? "point" : d == OHM_DEPOSIT_SURFACE ? "surface" : "exponential";
}

/* One policy for a light that reaches nothing (off the object, behind it,
 * or only onto faces in shadow), whatever its type: it adds nothing, and
 * the log says which -light it is. */
static int warn_dark_lights(ohm_state *s, ohm_error *err)
{
    long long dark = 0;
    for (size_t l = 0; l < s->nlights; ++l) {
        int reaches = 1;
        int rc = ohm_solver_light_reaches(s->solver, &s->lights[l], &reaches, err);
        if (rc) return rc;
        dark += !reaches;
        if (!reaches)
            ohm_log_warn(&s->log, "%s: -light type=%s reaches no part of the object (it misses it, or what it "
                                  "faces is in shadow): it adds no light",
                         s->lights[l].where[0] ? s->lights[l].where : "a light", ohm_light_name(&s->lights[l]));
    }
    ohm_stats_set_int(&s->stats, "lights_reaching_nothing", dark);
    return OHM_OK;
}

/* A solve never succeeds with a number that is not one: the powers and the
 * backward error it reports must be finite (where: the step, for the message). */
static int check_solution_finite(const ohm_solution *sol, const char *where, ohm_error *err)
{
    const double v[4] = {sol->power_in, sol->power_absorbed, sol->power_out, sol->residual};
    static const char *const names[4] = {"power in", "power absorbed", "power out", "backward error"};
    for (int k = 0; k < 4; ++k)
        if (!isfinite(v[k]))
            return ohm_fail(err, OHM_ERR_NUMERIC, "%s: -solve: the %s is %g: the material or lights overflow double "
                                                  "precision", where, names[k], v[k]);
    return OHM_OK;
}

/* The clear regions found (physics/clear_regions.h) and what was done with
 * them, in the statistics (the log names each: solvers/clear.c). */
static void report_clear(ohm_stats *st, const ohm_solution *sol, const ohm_solve_params *p)
{
    const ohm_clear_regions *r = &sol->clear;
    double thickness = 0, optical = 0; /* the thinnest region's, optically */
    for (int32_t k = 0; k < r->count; ++k)
        if (k == 0 || r->region[k].optical_thickness < optical)
            optical = r->region[k].optical_thickness, thickness = r->region[k].thickness_mm;
    ohm_stats_set_str(st, "clear", ohm_clear_mode_name(p->op.clear));
    ohm_stats_set_str(st, "clear_action", ohm_clear_mode_name(sol->clear_action));
    ohm_stats_set_int(st, "clear_regions", r->count);
    ohm_stats_set_int(st, "clear_cells", (long long)r->clear_cells);
    ohm_stats_set(st, "clear_volume_mm3", r->clear_volume_mm3);
    ohm_stats_set(st, "clear_min_optical_thickness", optical);
    ohm_stats_set(st, "clear_thickness_mm", thickness);
    if (sol->clear_action == OHM_CLEAR_RADIOSITY) {
        ohm_stats_set_int(st, "clear_nodes", sol->clear_nodes);
        ohm_stats_set_int(st, "clear_pairs", sol->clear_pairs);
        ohm_stats_set(st, "clear_reach_mm", sol->clear_reach_mm);
    }
}

/* The solver's set-up seconds into the statistics: what it took since they
 * were last booked (a -solve books its solver's all; a relight, with the
 * set-up kept, what it added: nothing, unless a backend set up again). */
static void book_setup_times(ohm_state *s, const ohm_solution *sol, int relit)
{
    static const char *const key[OHM_SETUP_TIMES] = {"t_shadow_setup", "t_clear",    "t_cg_setup", "t_network",
                                                     "t_assemble",     "t_analyze", "t_factor"};
    const double t[OHM_SETUP_TIMES] = {sol->t_shadow_setup, sol->t_clear,    sol->t_cg_setup, sol->t_network,
                                       sol->t_assemble,     sol->t_analyze, sol->t_factor};
    for (int i = 0; i < OHM_SETUP_TIMES; ++i) {
        if (!relit) s->setup_booked[i] = 0;
        ohm_stats_add(&s->stats, key[i], t[i] - s->setup_booked[i]);
        s->setup_booked[i] = t[i];
    }
}

/* The solver's latest solve logged and booked in the statistics (-solve and
 * ohm_state_relight): t0 is when the solve began; a relight does not repeat
 * the notes about the grid and the boundary, which have not changed. */
static void report_solve(ohm_state *s, double t0, int relit)
{
    const ohm_solve_params *pp = ohm_solver_params(s->solver);
    const ohm_solve_params p = *pp;
    const ohm_solution *sol = ohm_solver_solution(s->solver);
    snprintf(s->solution_desc, sizeof s->solution_desc, "%s lights=%zu frames=%d solver=%s ordering=%s band=%g hybrid=%d",
             s->solve_options, s->nlights, sol->frames, sol->solver, sol->ordering, p.op.band_k, p.mc.handoff);
    double cons = ohm_solution_conservation_error(sol);
    ohm_log_info(&s->log,
                 "solved %lld cells x %d channel(s), %d factorization(s), %zu light(s) in %.2f s: backward error "
                 "%.2g, power in %.6g W = absorbed %.6g + out %.6g (conservation error %.2g)",
                 (long long)sol->n, sol->channels, sol->factors, s->nlights, ohm_now() - t0, sol->residual,
                 sol->power_in, sol->power_absorbed, sol->power_out, cons);
    const int transport = (ohm_solver_kind_caps(p.num.solver) & OHM_SOLVES_TRANSPORT) != 0;
    if (transport)
        ohm_log_info(&s->log,
                     "monte carlo: %lld photons (g=%g, seed=%llu, %d threads) at %.4g photons/ms, %.4g path "
                     "segments each%s",
                     (long long)sol->mc_photons, s->material.g, (unsigned long long)p.mc.seed, sol->mc_threads,
                     sol->t_solve > 0 ? 1e-3 * (double)sol->mc_photons / sol->t_solve : 0.0,
                     sol->mc_photons > 0 ? (double)sol->mc_events / (double)sol->mc_photons : 0.0,
                     sol->mc_truncated ? "; some photons hit the event cap (a medium that keeps light in)" : "");
    else if (sol->mc_photons > 0)
        ohm_log_info(&s->log,
                     "hybrid: the first %d reduced scatterings of %lld photons traced as transport (g=%g%s, seed=%llu), "
                     "diffusion from there",
                     p.mc.handoff, (long long)sol->mc_photons, s->material.g,
                     p.media.g_v ? " at the first point, per cell" : "",
                     (unsigned long long)p.mc.seed);
    if (p.op.boundary == OHM_BOUNDARY_NEUMANN && !relit)
        ohm_log_info(&s->log, "boundary=neumann lets no light out: all of it is absorbed inside (the paper's model)");
    if (sol->mode_corrections)
        ohm_log_info(&s->log,
                     "solve: %lld nearly singular piece(s) (almost no absorption or leak): their constant mode was "
                     "shifted by %.2g of the fluence to conserve power exactly",
                     (long long)sol->mode_corrections, sol->mode_shift);
    if (sol->band_depth > 0)
        ohm_log_info(&s->log, "solve: depth band %.4g mm: %lld interior cells below it not solved", sol->band_depth,
                     (long long)sol->band_dropped);
    /* a grid coarser than the diffusion length cannot resolve the spread of
     * light (the error grows like (h sigma_tr)^p: docs/accuracy.md) */
    if (s->material.kind != OHM_MATERIAL_RESISTANCE && !s->have_transfer && !relit)
        for (int c = 0; c < s->material.channels; ++c) {
            double sa = s->material.sigma_a[c], st = sa + s->material.sigma_s[c], str = sqrt(3.0 * sa * st);
            if (str * s->grid.h > 1.0)
                ohm_log_warn(&s->log,
                             "voxel %.4g mm is larger than the diffusion length 1/sigma_tr = %.4g mm%s%s: the grid "
                             "cannot resolve how light spreads, expect large errors (use a smaller voxel, or "
                             "-voxelize error=)",
                             s->grid.h, 1.0 / str, s->material.channels > 1 ? " of channel " : "",
                             s->material.channels > 1 ? (const char *[]){"R", "G", "B"}[c] : "");
        }
    ohm_stats *st = &s->stats;
    ohm_stats_set_int(st, "cells", (long long)sol->n);
    ohm_stats_set_int(st, "channels", sol->channels);
    /* the material's coefficients, for a client that draws the result (the
     * Blender add-on's volume object); where they vary from cell to cell
     * (medium_varies) the .vdb carries them per cell instead (export_vdb.c),
     * under the same names */
    ohm_stats_set_int(st, "medium_varies", ohm_solution_medium_varies(sol));
    if (s->material.kind == OHM_MATERIAL_OPTICAL)
        for (int c = 0; c < sol->channels; ++c) {
            const char *sfx = sol->channels == 1 ? "" : (const char *[]){"_r", "_g", "_b"}[c];
            char key[32];
            snprintf(key, sizeof key, "sigma_a%s", sfx);
            ohm_stats_set(st, key, s->material.sigma_a[c]);
            snprintf(key, sizeof key, "sigma_s%s", sfx);
            ohm_stats_set(st, key, s->material.sigma_s[c]);
        }
    ohm_stats_set_int(st, "factors", sol->factors);
    ohm_stats_set_int(st, "analyses", sol->analyses);
    ohm_stats_set_int(st, "lights", (long long)s->nlights);
    ohm_stats_set_int(st, "frames", sol->frames);
    ohm_stats_set_int(st, "solves", (long long)sol->solves);
    ohm_stats_set_int(st, "solves_skipped", (long long)sol->solves_skipped);
    ohm_stats_set_str(st, "shadows", ohm_shadows_name(p.src.shadows));
    ohm_stats_set(st, "t_update_per_frame", (sol->t_source + sol->t_solve) / sol->frames);
    ohm_stats_set_str(st, "boundary", ohm_boundary_name(p.op.boundary));
    ohm_stats_set_str(st, "deposit", deposit_name(p.src.deposit));
    ohm_stats_set_str(st, "fresnel", ohm_fresnel_name(p.op.fresnel));
    ohm_stats_set_str(st, "fluence", p.src.total_fluence ? "total" : "diffuse");
    ohm_stats_set_str(st, "ordering", sol->ordering);
    ohm_stats_set_str(st, "solver", sol->solver);
    ohm_stats_set_str(st, "solver_reason", sol->solver_reason);
    ohm_stats_set_str(st, "model", (ohm_solver_kind_caps(p.num.solver) & OHM_SOLVES_TRANSPORT) ? "transport" : "diffusion");
    ohm_stats_set_int(st, "cg_iterations", (long long)sol->cg_iterations);
    ohm_stats_set(st, "cg_relres", sol->cg_relres);
    ohm_stats_set_int(st, "cg_stalled", (long long)sol->cg_stalled);
    report_clear(st, sol, &p);
    ohm_stats_set_int(st, "ranks", sol->ranks);
    ohm_stats_set_int(st, "mg_levels", sol->mg_levels);
    ohm_stats_set_str(st, "device", sol->device[0] ? sol->device : "host");
    ohm_stats_set(st, "solver_bytes", sol->solver_bytes);
    ohm_stats_set(st, "depth_band", p.op.band_k);
    ohm_stats_set(st, "depth_band_mm", sol->band_depth);
    ohm_stats_set_int(st, "depth_band_dropped", (long long)sol->band_dropped);
    ohm_stats_set_int(st, "mode_corrections", (long long)sol->mode_corrections);
    ohm_stats_set(st, "mode_shift", sol->mode_shift);
    ohm_stats_set_int(st, "nnz_A", (long long)sol->nnz_A);
    ohm_stats_set_int(st, "nnz_L", (long long)sol->nnz_L);
    ohm_stats_set(st, "flops", sol->flops);
    book_setup_times(s, sol, relit);
    ohm_stats_add(st, "t_source", sol->t_source);
    ohm_stats_add(st, "t_solve", sol->t_solve);
    ohm_stats_set(st, "residual", sol->residual);
    ohm_stats_set(st, "power_incident", sol->power_incident);
    ohm_stats_set(st, "power_entered", sol->power_entered);
    ohm_stats_set(st, "power_in", sol->power_in);
    ohm_stats_set(st, "power_absorbed", sol->power_absorbed);
    ohm_stats_set(st, "power_out", sol->power_out);
    ohm_stats_set(st, "conservation_error", cons);
    if (transport) {
        ohm_stats_set_int(st, "mc_photons", (long long)sol->mc_photons);
        ohm_stats_set_int(st, "mc_seed", (long long)p.mc.seed);
        ohm_stats_set(st, "mc_g", s->material.g);
        ohm_stats_set_int(st, "mc_threads", sol->mc_threads);
        ohm_stats_set_int(st, "mc_truncated", (long long)sol->mc_truncated);
        ohm_stats_set(st, "mc_photons_per_ms", sol->t_solve > 0 ? 1e-3 * (double)sol->mc_photons / sol->t_solve : 0);
        ohm_stats_set(st, "mc_events_per_photon",
                      sol->mc_photons > 0 ? (double)sol->mc_events / (double)sol->mc_photons : 0);
    } else {
        ohm_stats_set_int(st, "hybrid", p.mc.handoff);
        ohm_stats_set_int(st, "solve_threads", sol->solve_threads);
        if (p.mc.handoff > 0) {
            ohm_stats_set_int(st, "mc_photons", (long long)sol->mc_photons);
            ohm_stats_set_int(st, "mc_seed", (long long)p.mc.seed);
            ohm_stats_set(st, "mc_events_per_photon",
                          sol->mc_photons > 0 ? (double)sol->mc_events / (double)sol->mc_photons : 0);
        }
    }
}

static int run_solve(ohm_state *s, const ohm_invocation *inv, ohm_error *err)
{
    if (!s->have_grid)
        return ohm_fail(err, OHM_ERR_INVALID, "%s: -solve: no voxel object: -read and -voxelize first", inv->where);
    if (s->grid.interior_cells == 0)
        return ohm_fail(err, OHM_ERR_INVALID, "%s: -solve: the voxel object from %s is empty: %s", inv->where,
                        s->have_mesh ? s->mesh_path : s->scan_path,
                        s->have_mesh ? "no cell centre lies inside the mesh (use a larger dim= or a smaller voxel=)"
                                     : "no cell reaches -voxelize threshold= (lower it)");
    if (!s->have_material)
        return ohm_fail(err, OHM_ERR_INVALID, "%s: -solve: no material: add -material (e.g. preset=marble) first",
                        inv->where);
    if (s->nlights == 0)
        return ohm_fail(err, OHM_ERR_INVALID, "%s: -solve: no lights: add -light first", inv->where);
    ohm_solve_params p;
    int rc = solve_params(&p, s, inv, err);
    if (rc) return rc;
    drop_solution(s);
    snprintf(s->solve_options, sizeof s->solve_options, "boundary=%s fresnel=%s deposit=%s fluence=%s shadows=%s",
             ohm_opt_str(inv, "boundary"), ohm_opt_str(inv, "fresnel"), ohm_opt_str(inv, "deposit"),
             ohm_opt_str(inv, "fluence"), ohm_shadows_name(p.src.shadows));
    double t0 = ohm_now();
    ohm_coeff *percell[2 * OHM_MAX_CHANNELS] = {NULL};
    float *density = NULL;
    if (s->have_transfer) {
        if (!s->have_scan)
            return ohm_fail(err, OHM_ERR_INVALID, "%s: -solve: transfer= maps a volume's density: -read one first",
                            inv->where);
        /* the index and anisotropy per cell stay the state's for the solver's life (solve.h) */
        rc = material_from_scan(s, &p.media, &density, percell, &s->solver_eta, &s->solver_g, err);
    }
    if (!rc) {
        int keep = strcmp(ohm_opt_str(inv, "keep"), "1") == 0;
        rc = ohm_solver_create(&s->solver, &s->grid, &s->material, &p, keep, &s->log, err);
        if (p.media.give_media) { /* the solver took them (solve.h) */
            density = NULL;
            memset(percell, 0, sizeof percell);
        }
    }
    for (int q = 0; q < 2 * OHM_MAX_CHANNELS; ++q) free(percell[q]);
    free(density);
    if (!rc && p.mc.handoff > 0 && strcmp(ohm_opt_str(inv, "hybrid"), "auto") == 0)
        rc = ohm_solver_settle_auto_hybrid(s->solver, s->lights, s->nlights, err);
    if (!rc) rc = device_has_work(ohm_solver_params(s->solver), inv, err);
    if (!rc) rc = ohm_solver_setup(s->solver, s->lights, s->nlights, err);
    if (!rc) rc = ohm_solver_solve(s->solver, s->lights, s->nlights, err);
    if (!rc) rc = check_solution_finite(ohm_solver_solution(s->solver), inv->where, err);
    if (rc) {
        drop_solution(s);
        return rc;
    }
    s->have_solution = 1;
    report_solve(s, t0, 0);
    return warn_dark_lights(s, err);
}

int ohm_state_relight(ohm_state *s, ohm_error *err)
{
    if (!s->solver)
        return ohm_fail(err, OHM_ERR_INVALID, "relight: nothing to relight: solve first (with keep=1 to keep its factor)");
    if (s->nlights == 0) return ohm_fail(err, OHM_ERR_INVALID, "relight: no lights: add one first");
    double t0 = ohm_now();
    s->have_solution = 0;
    int rc = ohm_solver_solve(s->solver, s->lights, s->nlights, err);
    if (!rc) rc = check_solution_finite(ohm_solver_solution(s->solver), "relight", err);
    if (rc) return rc;
    s->have_solution = 1;
    report_solve(s, t0, 1);
    return OHM_OK;
}

/* ---- place ---------------------------------------------------------------------- */

static const ohm_opt_spec place_opts[] = {
    {"fit", OHM_OPT_ENUM, "1", "1: stretch the volume's box onto the mesh's bounding box", "0|1", 0, 0, 0},
    {"scale", OHM_OPT_REAL, "1", "then scale the volume about its centre", NULL, 1e-9, 1e9, 0},
    {"offset", OHM_OPT_VEC3, "0,0,0", "then move it by this many mm", NULL, 0, 0, 0},
    {0}};

static void place_io(const ohm_invocation *inv, ohm_step_io *io)
{
    io->needs[0] = (ohm_need){OHM_RES_VOLUME, 0, "no volume to place: -read one first"};
    if (strcmp(ohm_opt_str(inv, "fit"), "1") == 0)
        io->needs[1] = (ohm_need){OHM_RES_MESH, 0, "fit=1: no mesh to fit the volume into"};
    io->drops = OHM_RES_SOLUTION;
}

static int run_place(ohm_state *s, const ohm_invocation *inv, ohm_error *err)
{
    if (!s->have_scan)
        return ohm_fail(err, OHM_ERR_INVALID, "%s: -place: no volume to place: -read one first", inv->where);
    double (*M)[4] = s->scan.index_to_world;
    double lo[3], hi[3];
    if (strcmp(ohm_opt_str(inv, "fit"), "1") == 0) {
        if (!s->have_mesh)
            return ohm_fail(err, OHM_ERR_INVALID, "%s: -place fit=1: no mesh to fit the volume into", inv->where);
        double mlo[3], mhi[3];
        ohm_mesh_bounds(&s->mesh, mlo, mhi);
        ohm_scan_bounds(&s->scan, lo, hi);
        for (int a = 0; a < 3; ++a) {
            double k = hi[a] > lo[a] ? (mhi[a] - mlo[a]) / (hi[a] - lo[a]) : 1.0;
            for (int b = 0; b < 3; ++b) M[a][b] *= k;
            M[a][3] = k * (M[a][3] - lo[a]) + mlo[a];
        }
    }
    double k = ohm_opt_real(inv, "scale"), off[3];
    ohm_opt_vec3(inv, "offset", off);
    ohm_scan_bounds(&s->scan, lo, hi);
    for (int a = 0; a < 3; ++a) {
        double c = 0.5 * (lo[a] + hi[a]);
        for (int b = 0; b < 3; ++b) M[a][b] *= k;
        M[a][3] = k * (M[a][3] - c) + c + off[a];
    }
    drop_solution(s);
    ohm_scan_bounds(&s->scan, lo, hi);
    ohm_log_info(&s->log, "placed %s at %.4g..%.4g, %.4g..%.4g, %.4g..%.4g mm", s->scan_path, lo[0], hi[0], lo[1],
                 hi[1], lo[2], hi[2]);
    return OHM_OK;
}

/* ---- write --------------------------------------------------------------------- */

static const ohm_opt_spec write_opts[] = {
    {"file", OHM_OPT_STRING, NULL, "output .vdb (written to a temporary file, then renamed)", NULL, 0, 0, 1},
    {0}};

static void write_io(const ohm_invocation *inv, ohm_step_io *io)
{
    (void)inv;
    io->needs[0] = (ohm_need){OHM_RES_GRID, 0, "nothing to write yet: put -voxelize before it"};
}

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
    ohm_vdb_provenance prov = {s->mesh_path, s->mesh_scale_mm, s->have_solution ? s->material.name : NULL,
                               s->have_solution ? s->solution_desc : NULL};
    const ohm_solution *sol = ohm_state_solution(s);
    int frames = sol ? sol->frames : 1;
    int rc = OHM_OK;
    /* Several frames: a numbered sequence NAME_0001.vdb ... (Blender's volume
     * sequences start at frame 1 and read trailing digits). */
    size_t stem = strlen(path) - 4;
    for (int f = 0; f < frames && !rc; ++f) {
        char framepath[OHM_PATH_MAX];
        if (frames == 1) snprintf(framepath, sizeof framepath, "%s", path);
        else snprintf(framepath, sizeof framepath, "%.*s_%04d.vdb", (int)stem, path, f + 1);
        rc = ohm_export_vdb(framepath, &s->grid, sol, f, &prov, s->outputs, err);
    }
    if (rc) return rc;
    double t = ohm_now() - t0;
    /* the grids ohm_export_vdb wrote, for the log */
    char grids[160] = "";
    if (sol) {
        const char *rgb = sol->channels == 1 ? "" : "_r/g/b";
        int varies = ohm_solution_medium_varies(sol);
        snprintf(grids, sizeof grids, ", fluence%s, exitance%s%s%s%s%s%s%s%s%s", rgb, rgb,
                 sol->fluence_se[0] ? ", fluence_se" : "", sol->fluence_se[0] ? rgb : "",
                 sol->fluence_se[0] ? ", exitance_se" : "", sol->fluence_se[0] ? rgb : "",
                 varies ? ", sigma_a" : "", varies ? rgb : "", varies ? ", sigma_s" : "", varies ? rgb : "");
    }
    if (frames == 1) ohm_log_info(&s->log, "wrote %s (grids: surface, density%s), %.2f s", path, grids, t);
    else
        ohm_log_info(&s->log, "wrote %.*s_0001.vdb .. _%04d.vdb (%d frames; grids: surface, density%s), %.2f s",
                     (int)stem, path, frames, frames, grids, t);
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
    int rc = ohm_output_begin(&out, path, s->outputs, err);
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
     read_opts, run_read, 0, NULL, read_io, NULL},
    {"voxelize", "find the cells inside the mesh (or above a volume's threshold) on a regular grid",
     "Classifies cell centres with the generalized winding number (robust to holes, open rims, overlapping\n"
     "pieces and inside-out winding) and measures the distance to the mesh in a narrow band.  The grid covers\n"
     "the bounding box plus a margin; dim=N puts N cells along its longest axis.",
     voxelize_opts, run_voxelize, 0, voxelize_waits, voxelize_io, NULL},
    {"place", "put a density volume where the mesh is (fit its box, scale, offset)",
     "For a mesh whose material comes from a scan: fit=1 stretches the volume's box onto the mesh's, then\n"
     "scale= and offset= adjust it.  A NIfTI volume already carries its world placement (sform/qform).",
     place_opts, run_place, 0, NULL, place_io, NULL},
    {"material", "set the optical material (preset, sigma_a/sigma_s/eta, or the paper's resistances)",
     "Presets are the measured materials of Jensen et al. 2001 (sigma_s', sigma_a per R,G,B in 1/mm, eta 1.3).\n"
     "sigma_a= and sigma_s= take one value (grey, one channel) or three (R,G,B).  resistance= and ground=\n"
     "give the paper's raw resistor values instead (use with boundary=neumann or dirichlet).",
     material_opts, run_material, OHM_ACTION_SETS_SCENE, NULL, material_io, NULL},
    {"light", "add a light (directional, point, spot, area, a pencil beam or the environment)",
     "Lights add up; every -light stays for later -solve actions.  Faces turned to the light receive\n"
     "E = I max(0, n.l) (point lights also 1/d^2); the part Fresnel transmits is deposited below the face.\n"
     "Shadow rays (-solve shadows=) decide which of those faces the light reaches.  type=environment is\n"
     "the sky all around (uniform radiance intensity=, or an equirectangular image sky=FILE.hdr|.exr):\n"
     "each face is lit by the part of the sky it sees past the object itself, through samples= fixed\n"
     "cosine-weighted directions (docs/lights.md).",
     ohm_light_opts, run_light, OHM_ACTION_SETS_SCENE, NULL, light_io, light_check},
    {"solve", "build the resistor network and solve every light (the solver chosen by size, or as asked)",
     "Assembles the diffusion network (harmonic-mean conductances, ground sigma_a h^3, the chosen boundary\n"
     "term), solves all lights as one multi-column right-hand side, checks the backward error and books the\n"
     "power: in = absorbed + out.  By default (solver=auto) geometric multigrid solves the first light and the\n"
     "rest go to the solver that fits the memory and is predicted quickest for them; the log and the\n"
     "statistics (solver, solver_reason) say which and why.  solver=direct factors the matrix with CHOLMOD\n"
     "(one analysis shared by every channel, the factor reused by every light); solver=cg solves by conjugate\n"
     "gradients (no factor: O(cells) memory); solver=amg by PETSc's CG with hypre's BoomerAMG (O(cells)\n"
     "memory, iterations that do not grow with the grid; under `mpirun -np N ohm ...` every rank solves a\n"
     "slab: docs/scale.md); solver=mg by geometric multigrid alone.  depth_band= / depth_band_error= solve\n"
     "only the cells light reaches.\n"
     "solver=mc traces Monte Carlo photon transport through the same cells, media and lights instead: the\n"
     "reference for diffusion's own error on this scene (same grids, plus fluence_se / exitance_se; `ohm\n"
     "validate transport`, docs/transport.md).",
     solve_opts, run_solve, 0, NULL, solve_io, NULL},
    {"export", "write the solution for other tools: a coloured PLY mesh, POV-Ray density files, CSV",
     "ply=FILE writes the input mesh (mm) as binary PLY with the exitance interpolated at each vertex\n"
     "(float exitance or exitance_r/_g/_b, W/mm^2) and 8-bit sRGB colours at a stated exposure (default:\n"
     "the 99th percentile maps to 1; recorded as 'comment ohm exposure').  df3=BASE writes one POV-Ray\n"
     "density file per channel (BASE_r.df3 ..., BASE.df3 for grey; the grid padded by one zero voxel,\n"
     "scaled so the maximum is 65535) and BASE.pov, a scene that renders them as emitting media.  csv=FILE\n"
     "writes one line per solved cell (i,j,k, centre in mm, fluence and exitance per channel) with 17\n"
     "significant digits: doubles read back exactly.",
     ohm_export_opts, ohm_run_export, OHM_ACTION_WRITES, NULL, ohm_export_io, NULL},
    {"write", "write the voxel object (and any solution) as a .vdb",
     "Grids: 'surface' (level set, signed distance in mm, negative inside) and 'density' (fog volume, 1 in\n"
     "interior cells, what Blender's Principled Volume reads); after -solve also 'fluence' and 'exitance'\n"
     "(W/mm^2; with suffixes _r _g _b for RGB).  World units are millimetres.",
     write_opts, run_write, OHM_ACTION_WRITES, NULL, write_io, NULL},
    {"render", "draw a preview image (.png or .exr) of the solution; compare=1 adds one without scattering",
     "An orthographic view of the mesh (along view=, default the first light's direction), each point shaded\n"
     "by the exitance of the solved frame around it; exposure= scales W/mm^2 to 1 (default: the 99th\n"
     "percentile of what is seen).  compare=1 puts the same view lit without scattering (n.l with shadow\n"
     "rays, the same total power out) beside it.  PNG is 8-bit sRGB, EXR half-float linear.",
     ohm_render_opts, ohm_run_render, OHM_ACTION_WRITES, NULL, ohm_render_io, NULL},
    {"stats", "write the run's figures as one JSON object",
     "Counts, sizes and per-stage times (t_read, t_voxelize, t_write, ...) recorded so far.", stats_opts, run_stats,
     OHM_ACTION_WRITES, NULL, NULL, NULL},
    {NULL, NULL, NULL, NULL, NULL, 0, NULL, NULL, NULL}};
