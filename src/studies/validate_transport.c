/* validate_transport.c — diffusion against ohm's own Monte Carlo transport
 * (mc.h) on the transport study's scenes (docs/transport.md; validate.h).
 *
 * The medium is the MCX benchmark's: sigma_a 0.005, sigma_s 1 /mm, g 0.01
 * (sigma_s' 0.99, one transport mean free path 1/sigma_t' = 1.005 mm,
 * diffusion length 8.2 mm).  Every scene is a quarter of a box, cut by
 * symmetry planes through the beam's axis (both solvers mirror there), lit by
 * a pencil beam entering the face z = 0 at the corner x = y = 0.  Scenes with
 * a clear region (a void, a rod, an index-1.0 layer, the head slab's CSF)
 * are solved at clear=off and clear=effective side by side (clear_regions.h),
 * their rows reported, not judged. */
#include "studies/validate.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "physics/mc_trace.h"
#include "physics/network.h"
#include "studies/block_error.h"
#include "studies/scene.h"
#include "solvers/solve.h"

static const double TR_SA = 0.005, TR_SS = 0.99, TR_G = 0.01;
/* Diffusion cannot be compared within this many transport mean free paths of
 * the source or of a face (docs/design.md §3); the Monte Carlo estimate is used
 * only where its own standard error is below this fraction. */
static const double NEAR_MFP = 2.0, MC_NOISE = 0.01;

/* What is embedded in the medium (every one on the beam's axis). */
typedef enum inclusion_shape {
    SHAPE_NONE = 0,
    SHAPE_SPHERE,   /* centre depth a, radius b                               */
    SHAPE_CYLINDER, /* a rod of radius b from the lit face down to depth a:
                       a clear one pipes the beam down                        */
    SHAPE_LAYER,    /* a layer from depth a, b thick                           */
    SHAPE_HEAD      /* the three-layer head slab (HEAD_* below), a and b unused */
} inclusion_shape;

typedef struct transport_scene {
    const char *name;
    int nx, ny, nz;           /* cells of the quarter box             */
    double eta;
    inclusion_shape shape;    /* another medium inside the box          */
    double a, b;              /* its place and size (mm; above)       */
    double inc_sa, inc_ss;    /* its medium                           */
    int report_only;          /* a scene diffusion cannot model: rows without tolerances */
    double inc_eta;           /* its index, 0: the scene's            */
    int clear;                /* it holds a clear region: solved at clear=off and
                                 clear=effective side by side (clear_regions.h) */
} transport_scene;

/* The inclusion: 4x absorption, 2x scattering; the void: almost clear
 * (1/sigma_t' 99 mm in a 20 mm sphere), where diffusion's D = 1/(3 sigma_t')
 * is a model of nothing. */
static const double INC_SA = 0.02, INC_SS = 2.0, VOID_SA = 0.0001, VOID_SS = 0.01;

/* A three-layer slab model of the adult head in the near infrared (the
 * kind Okada & Delpy study, Appl. Opt. 42:2906, 2003): scalp and skull
 * lumped, the cerebrospinal fluid, the brain; 1/mm and mm
 * (docs/transport.md, "Clear regions"). */
static const double HEAD_SCALP_SA = 0.019, HEAD_SCALP_SS = 0.86, HEAD_CSF_SA = 0.0004, HEAD_CSF_SS = 0.001,
                    HEAD_BRAIN_SA = 0.02, HEAD_BRAIN_SS = 1.0, HEAD_SCALP_MM = 10.0, HEAD_CSF_MM = 2.0;

/* The medium at the centre (x, y, z) of a cell: sigma_a, sigma_s', index. */
static void scene_medium_at(const transport_scene *sc, double x, double y, double z, double *sa, double *ss,
                            double *eta)
{
    int in = 0;
    switch (sc->shape) {
    case SHAPE_NONE: break;
    case SHAPE_SPHERE: in = x * x + y * y + (z - sc->a) * (z - sc->a) < sc->b * sc->b; break;
    case SHAPE_CYLINDER: in = x * x + y * y < sc->b * sc->b && z < sc->a; break;
    case SHAPE_LAYER: in = z >= sc->a && z < sc->a + sc->b; break;
    case SHAPE_HEAD:
        *eta = sc->eta;
        *sa = z < HEAD_SCALP_MM ? HEAD_SCALP_SA : z < HEAD_SCALP_MM + HEAD_CSF_MM ? HEAD_CSF_SA : HEAD_BRAIN_SA;
        *ss = z < HEAD_SCALP_MM ? HEAD_SCALP_SS : z < HEAD_SCALP_MM + HEAD_CSF_MM ? HEAD_CSF_SS : HEAD_BRAIN_SS;
        return;
    }
    *sa = in ? sc->inc_sa : TR_SA;
    *ss = in ? sc->inc_ss : TR_SS;
    *eta = in && sc->inc_eta > 0 ? sc->inc_eta : sc->eta;
}

/* Per-cell media for the inclusion (unknown order = interior cells in cell
 * order: the box has no band); *eta_v only where the inclusion's index
 * differs (else NULL).  The coefficients are given to ohm_solve, the index
 * is the caller's to free. */
static int inclusion_media(ohm_coeff **sa, ohm_coeff **ss, double **eta_v, const ohm_voxel_grid *g,
                           const transport_scene *sc, ohm_error *err)
{
    size_t n = g->interior_cells;
    *sa = malloc(n * sizeof **sa);
    *ss = malloc(n * sizeof **ss);
    int own_eta = sc->inc_eta > 0 && sc->inc_eta != sc->eta;
    *eta_v = own_eta ? malloc(n * sizeof **eta_v) : NULL;
    if (!*sa || !*ss || (own_eta && !*eta_v)) {
        free(*sa), free(*ss), free(*eta_v);
        *sa = *ss = NULL;
        *eta_v = NULL;
        return ohm_fail(err, OHM_ERR_NOMEM, "validate: out of memory for the inclusion");
    }
    size_t u = 0;
    for (int k = 0; k < g->dims[2]; ++k)
        for (int j = 0; j < g->dims[1]; ++j)
            for (int i = 0; i < g->dims[0]; ++i) {
                if (!g->inside[ohm_voxel_index(g, i, j, k)]) continue;
                double x = (i - 0.5) * g->h, y = (j - 0.5) * g->h, z = (k - 0.5) * g->h;
                double a, s, e;
                scene_medium_at(sc, x, y, z, &a, &s, &e);
                (*sa)[u] = (ohm_coeff)a;
                (*ss)[u] = (ohm_coeff)s;
                if (*eta_v) (*eta_v)[u] = e;
                ++u;
            }
    return OHM_OK;
}

/* One solve of the scene: diffusion at the given settings with clear
 * regions treated as `clear` asks (clear_regions.h), or (mc != NULL) Monte
 * Carlo transport. */
static int scene_solve(ohm_solution *sol, const ohm_voxel_grid *g, const transport_scene *sc,
                       const ohm_transport_config *cfg, const ohm_mc_params *mc, ohm_clear_mode clear,
                       const ohm_log *log, ohm_error *err)
{
    ohm_material m = ohm_scene_grey(TR_SA, TR_SS);
    m.eta = sc->eta;
    m.g = TR_G;
    ohm_light beam = ohm_scene_pencil((const double[3]){0, 0, -1.0}, (const double[3]){0, 0, 1.0});
    ohm_mirrors mirror = {{1, 1, -1}, {-1, -1, -1}};
    ohm_solve_params p;
    memset(&p, 0, sizeof p);
    p.op.mirrors = &mirror;
    p.op.fresnel = cfg->fresnel;
    p.op.clear = clear;
    p.src.deposit = cfg->deposit;
    p.num.solver = mc ? OHM_SOLVER_MC : OHM_SOLVER_AUTO;
    if (mc) p.mc = *mc;
    if (!mc && cfg->hybrid > 0) { /* the hybrid: its transport part from another stream than the reference's */
        p.mc.photons = cfg->photons;
        p.mc.seed = cfg->seed + 1000003;
        p.mc.threads = cfg->threads;
        p.mc.handoff = cfg->hybrid;
        p.mc.device = cfg->device;
    }
    double *eta_v = NULL;
    if (sc->shape != SHAPE_NONE) {
        ohm_coeff *sa, *ss;
        int rc = inclusion_media(&sa, &ss, &eta_v, g, sc, err);
        if (rc) return rc;
        p.media.sigma_a[0] = sa;
        p.media.sigma_s[0] = ss;
        p.media.eta_v = eta_v;
        p.media.give_media = 1;
    }
    int rc = ohm_solve(sol, g, &m, &beam, 1, &p, log, err);
    free(eta_v); /* not taken by give_media (solve.h) */
    return rc;
}

/* The power leaving through the lit face z = 0, per unit incident. */
static double reflectance(const ohm_solution *s)
{
    const double area = s->net.grid->h * s->net.grid->h;
    double out = 0;
    for (int64_t f = 0; f < s->net.nfaces; ++f)
        if (s->net.face_dir[f] == 4) out += s->face_exitance[0][f] * area;
    return out / s->power_incident;
}

/* Absorbed per unit incident; diffusion books the first collision's
 * absorption (what entered but was not deposited) outside its solve. */
static double absorbed_fraction(const ohm_solution *s)
{
    return (s->power_absorbed + s->power_entered - s->power_in) / s->power_incident;
}

/* Cells are compared in blocks of about BLOCK_MM on a side (block_error.h:
 * diffusion varies on the scale of 1/sigma_tr = 8 mm, not of a cell). */
static const double BLOCK_MM = 3.0;

/* A cell away from the source and the faces (NEAR_MFP), where the Monte
 * Carlo block mean is precise (MC_NOISE). */
typedef struct scene_cells {
    const transport_scene *sc;
    double h;
} scene_cells;

static int away_from_source_and_faces(const void *user, int i, int j, int k, int64_t v)
{
    (void)v;
    const scene_cells *c = user;
    const double h = c->h, near = NEAR_MFP / (TR_SA + TR_SS);
    double x = (i - 0.5) * h, y = (j - 0.5) * h, z = (k - 0.5) * h;
    double to_face = fmin(fmin(c->sc->nx * h - x, c->sc->ny * h - y), fmin(z, c->sc->nz * h - z));
    return sqrt(x * x + y * y + z * z) > near && to_face > near;
}

static ohm_block_error compare_fluence(const ohm_solution *d, const ohm_solution *mc, const transport_scene *sc)
{
    const scene_cells cells = {sc, d->net.grid->h};
    const int dims[3] = {sc->nx, sc->ny, sc->nz};
    return ohm_block_error_of(d, mc, dims, (int)lround(BLOCK_MM / cells.h), MC_NOISE, away_from_source_and_faces,
                              &cells);
}

/* Reflectance against radius on the lit face in 1 mm rings from 2 mm out to
 * 2 mm short of the box's side, where the Monte Carlo ring's standard error
 * is below MC_NOISE: the worst relative difference, and where; *beyond is
 * the inner radius from which every such ring is within tol. */
static double compare_rings(const ohm_solution *d, const ohm_solution *mc, const transport_scene *sc, double tol,
                            double *at, int *rings, double *beyond)
{
    enum { MAX_RINGS = 512 };
    double sd[MAX_RINGS] = {0}, sm[MAX_RINGS] = {0}, var[MAX_RINGS] = {0};
    const ohm_voxel_grid *g = d->net.grid;
    const double h = g->h, rmax = fmin(sc->nx, sc->ny) * h - 2.0;
    for (int64_t f = 0; f < d->net.nfaces; ++f) {
        if (d->net.face_dir[f] != 4) continue;
        int64_t v = d->net.face_unknown[f];
        int32_t c[3];
        ohm_voxel_coords(g, d->net.face_cell[f], c);
        double x = (c[0] - 0.5) * h, y = (c[1] - 0.5) * h, r = sqrt(x * x + y * y);
        if (r < 2.0 || r >= rmax) continue;
        int k = (int)floor(r - 2.0);
        if (k >= MAX_RINGS) continue;
        sd[k] += d->face_exitance[0][f];
        sm[k] += mc->face_exitance[0][f];
        /* a lit-face cell has this one boundary face: its exitance's error is the face's */
        var[k] += mc->exitance_se[0][v] * mc->exitance_se[0][v];
    }
    double worst = 0;
    *rings = 0;
    *at = NAN;
    *beyond = 2.0;
    for (int k = 0; k < MAX_RINGS; ++k) {
        if (!(sm[k] > 0) || !(sqrt(var[k]) < MC_NOISE * sm[k])) continue;
        double e = fabs(sd[k] / sm[k] - 1.0);
        ++*rings;
        if (e > worst) worst = e, *at = 2.5 + k;
        if (!(e <= tol)) *beyond = 3.0 + k;
    }
    return *rings ? worst : NAN;
}

/* The scene's rows for diffusion solve d against mc; label names the scene
 * (and the clear= treatment, where it has a clear region). */
static void add_rows(ohm_validation *v, const transport_scene *sc, const char *label, const ohm_solution *d,
                     const ohm_solution *mc, const ohm_transport_config *given)
{
    ohm_transport_config report = *given; /* a scene beyond the model: measured, not judged */
    report.tol_fluence_mean = report.tol_fluence_rms = report.tol_absorbed = report.tol_reflectance =
        report.tol_rings = -1;
    const ohm_transport_config *cfg = sc->report_only ? &report : given;
    char name[128], ref[64];
    snprintf(ref, sizeof ref, "ohm mc, %.3g photons", (double)mc->mc_photons);
    ohm_block_error fe = compare_fluence(d, mc, sc);
    snprintf(name, sizeof name, "%s: fluence >2 mfp, mean |err| (%lld blocks)", label, (long long)fe.blocks);
    ohm_validation_add(v, name, ref, fe.mean_abs, 0, fe.mean_abs, cfg->tol_fluence_mean);
    snprintf(name, sizeof name, "%s: fluence >2 mfp, rms err (bias %+.3f)", label, fe.bias);
    ohm_validation_add(v, name, ref, fe.rms, 0, fe.rms, cfg->tol_fluence_rms);
    snprintf(name, sizeof name, "%s: mc noise there, rms se/phi", label);
    ohm_validation_add(v, name, "a small part of the tolerance", fe.mc_noise, 0, fe.mc_noise, -1);
    double ad = absorbed_fraction(d), am = absorbed_fraction(mc);
    snprintf(name, sizeof name, "%s: absorbed fraction", label);
    ohm_validation_add(v, name, ref, ad, am, fabs(ad / am - 1.0), cfg->tol_absorbed);
    double rd = reflectance(d), rm = reflectance(mc);
    snprintf(name, sizeof name, "%s: total diffuse reflectance", label);
    ohm_validation_add(v, name, ref, rd, rm, fabs(rd / rm - 1.0), cfg->tol_reflectance);
    double at;
    int rings;
    double beyond;
    double worst = compare_rings(d, mc, sc, given->tol_rings, &at, &rings, &beyond);
    snprintf(name, sizeof name, "%s: R(r) beyond 2 mm, worst of %d (r=%.1f)", label, rings, at);
    ohm_validation_add(v, name, ref, worst, 0, worst, cfg->tol_rings);
    snprintf(name, sizeof name, "%s: R(r) within tolerance beyond r (mm)", label);
    ohm_validation_add(v, name, "report", beyond, 2.0, beyond, -1);
}

/* The head slab's rows (the acceptance of docs/transport.md's clear-region
 * study): reflectance R(r) in 5 mm rings from 20 to 40 mm of the beam, and
 * the fluence in the brain in 5 mm shells from 10 to 30 mm of where it
 * enters, each against the Monte Carlo (d / mc - 1; the Monte Carlo's own
 * standard error in the name).  A ring or shell outside the box, or within
 * 2 mm of its side, is left out. */
static void head_rows(ohm_validation *v, const transport_scene *sc, const char *label, const ohm_solution *d,
                      const ohm_solution *mc)
{
    enum { BINS = 4 };
    const double BIN_MM = 5.0, R_FROM = 20.0, PHI_FROM = 10.0;
    const ohm_voxel_grid *g = d->net.grid;
    const double h = g->h, side = fmin(sc->nx, sc->ny) * h - 2.0;
    double rd[BINS] = {0}, rm[BINS] = {0}, rv[BINS] = {0}, fd[BINS] = {0}, fm[BINS] = {0}, fv[BINS] = {0};
    for (int64_t f = 0; f < d->net.nfaces; ++f) {
        if (d->net.face_dir[f] != 4) continue;
        int32_t c[3];
        ohm_voxel_coords(g, (size_t)d->net.face_cell[f], c);
        double x = (c[0] - 0.5) * h, y = (c[1] - 0.5) * h;
        int b = (int)floor((sqrt(x * x + y * y) - R_FROM) / BIN_MM);
        if (b < 0 || b >= BINS) continue;
        int64_t u = d->net.face_unknown[f];
        rd[b] += d->face_exitance[0][f];
        rm[b] += mc->face_exitance[0][f];
        rv[b] += mc->exitance_se[0][u] * mc->exitance_se[0][u];
    }
    ohm_cell_cursor cur = ohm_network_cells(&d->net, 0);
    for (int64_t u = 0; u < d->n; ++u) {
        int32_t c[3];
        ohm_voxel_coords(g, (size_t)ohm_cell_cursor_next(&cur), c);
        double x = (c[0] - 0.5) * h, y = (c[1] - 0.5) * h, z = (c[2] - 0.5) * h;
        if (z < HEAD_SCALP_MM + HEAD_CSF_MM) continue; /* the brain only */
        int b = (int)floor((sqrt(x * x + y * y + z * z) - PHI_FROM) / BIN_MM);
        if (b < 0 || b >= BINS || sqrt(x * x + y * y) >= side) continue;
        fd[b] += d->fluence[0][u];
        fm[b] += mc->fluence[0][u];
        fv[b] += mc->fluence_se[0][u] * mc->fluence_se[0][u];
    }
    char name[128], ref[64];
    snprintf(ref, sizeof ref, "ohm mc, %.3g photons", (double)mc->mc_photons);
    for (int b = 0; b < BINS; ++b) {
        double lo = R_FROM + b * BIN_MM;
        if (lo + BIN_MM > side || !(rm[b] > 0)) continue;
        snprintf(name, sizeof name, "%s: R(r) %g-%g mm, d/mc - 1 (mc se %.3f)", label, lo, lo + BIN_MM,
                 sqrt(rv[b]) / rm[b]);
        ohm_validation_add(v, name, ref, rd[b] / rm[b] - 1.0, 0, fabs(rd[b] / rm[b] - 1.0), -1);
    }
    for (int b = 0; b < BINS; ++b) {
        double lo = PHI_FROM + b * BIN_MM;
        if (!(fm[b] > 0)) continue;
        snprintf(name, sizeof name, "%s: brain phi %g-%g mm, d/mc - 1 (mc se %.3f)", label, lo, lo + BIN_MM,
                 sqrt(fv[b]) / fm[b]);
        ohm_validation_add(v, name, ref, fd[b] / fm[b] - 1.0, 0, fabs(fd[b] / fm[b] - 1.0), -1);
    }
}

/* A scene's rows for one diffusion solve against the Monte Carlo. */
static void scene_rows(ohm_validation *v, const transport_scene *sc, const char *label, const ohm_solution *d,
                       const ohm_solution *mc, const ohm_transport_config *cfg)
{
    add_rows(v, sc, label, d, mc, cfg);
    if (sc->shape == SHAPE_HEAD) head_rows(v, sc, label, d, mc);
}

/* A scene with a clear region solved again at clear=effective, its rows
 * beside clear=off's (report only, as the scene is), and the iterations
 * the solver took at each (mg's, which solver=auto runs first). */
static int clear_rows(ohm_validation *v, const transport_scene *sc, const ohm_voxel_grid *g, const ohm_solution *off,
                      const ohm_solution *mc, const ohm_transport_config *cfg, const ohm_log *log, ohm_error *err)
{
    ohm_solution e;
    int rc = scene_solve(&e, g, sc, cfg, NULL, OHM_CLEAR_EFFECTIVE, log, err);
    if (rc) return rc;
    char label[96], name[128];
    snprintf(label, sizeof label, "%s [clear=effective]", sc->name);
    scene_rows(v, sc, label, &e, mc, cfg);
    snprintf(name, sizeof name, "%s: %s iterations, clear=off (effective: expected)", sc->name, off->solver);
    ohm_validation_add(v, name, "report", (double)off->cg_iterations, (double)e.cg_iterations,
                       (double)e.cg_iterations, -1);
    snprintf(name, sizeof name, "%s: clear regions found, cells (thickness %.3g mm)", sc->name,
             e.clear.count ? e.clear.region[0].thickness_mm : 0.0);
    ohm_validation_add(v, name, "report", (double)e.clear.clear_cells, (double)e.clear.count,
                       (double)e.clear.count, -1);
    ohm_solution_free(&e);
    return OHM_OK;
}

void ohm_transport_config_default(ohm_transport_config *cfg)
{
    memset(cfg, 0, sizeof *cfg);
    cfg->h = 1.0;
    cfg->size = 60.0;
    cfg->photons = 1000000;
    cfg->seed = 1;
    cfg->fresnel = OHM_FRESNEL_EXACT;
    cfg->deposit = OHM_DEPOSIT_EXPONENTIAL;
    cfg->hybrid = OHM_HYBRID_PENCIL; /* -solve's default for a pencil beam (hybrid=auto) */
    /* the transport study's targets (docs/transport.md) */
    cfg->tol_fluence_mean = 0.02;
    cfg->tol_fluence_rms = 0.04;
    cfg->tol_absorbed = 0.02;
    cfg->tol_reflectance = 0.02;
    cfg->tol_rings = 0.05;
}

int ohm_validate_transport(ohm_validation *v, const ohm_transport_config *cfg, const ohm_log *log, ohm_error *err)
{
    const double h = cfg->h, L = cfg->size;
    int half = (int)lround(0.5 * L / h), full = (int)lround(L / h);
    /* the head slab: its brain at least 18 mm deep, for the shells to 30 mm */
    int head_depth = (int)lround(fmax(0.5 * L, HEAD_SCALP_MM + HEAD_CSF_MM + 18.0) / h);
    const transport_scene scenes[] = {
        {"slab n1.0", full, full, half, 1.0, SHAPE_NONE, 0, 0, 0, 0, 0, 0, 0},
        {"slab n1.4", full, full, half, 1.4, SHAPE_NONE, 0, 0, 0, 0, 0, 0, 0},
        {"cube n1.37", half, half, full, 1.37, SHAPE_NONE, 0, 0, 0, 0, 0, 0, 0},
        {"cube n1.37 + sphere", half, half, full, 1.37, SHAPE_SPHERE, 0.35 * L, L / 6.0, INC_SA, INC_SS, 0, 0, 0},
        {"cube n1.37 + clear void", half, half, full, 1.37, SHAPE_SPHERE, 0.35 * L, L / 6.0, VOID_SA, VOID_SS, 1, 0,
         1},
        /* a clear rod down the beam's axis to half the depth: it pipes the beam */
        {"cube n1.37 + clear rod", half, half, full, 1.37, SHAPE_CYLINDER, 0.5 * L, L / 20.0, VOID_SA, VOID_SS, 1,
         0, 1},
        /* a 2 mm clear gap of index 1.0 (air) at a sixth of the size's depth */
        {"slab n1.37 + clear n1.0 layer", full, full, half, 1.37, SHAPE_LAYER, L / 6.0, 2.0, VOID_SA, VOID_SS, 1,
         1.0, 1},
        {"head slab", full, full, head_depth, 1.37, SHAPE_HEAD, 0, 0, 0, 0, 1, 0, 1},
    };
    ohm_mc_params mc = {
        .photons = cfg->photons, .seed = cfg->seed, .threads = cfg->threads, .log = log, .device = cfg->device};
    int rc = OHM_OK;
    for (size_t s = 0; s < sizeof scenes / sizeof scenes[0] && !rc; ++s) {
        const transport_scene *sc = &scenes[s];
        ohm_voxel_grid g;
        rc = ohm_scene_box(&g, sc->nx, sc->ny, sc->nz, h, err);
        if (rc) break;
        ohm_solution d, t;
        rc = scene_solve(&d, &g, sc, cfg, NULL, OHM_CLEAR_OFF, log, err);
        if (!rc) {
            rc = scene_solve(&t, &g, sc, cfg, &mc, OHM_CLEAR_OFF, log, err);
            if (!rc) {
                scene_rows(v, sc, sc->name, &d, &t, cfg);
                if (sc->clear) rc = clear_rows(v, sc, &g, &d, &t, cfg, log, err);
                char name[128];
                snprintf(name, sizeof name, "%s: mc speed, photons/ms (%d threads)", sc->name, t.mc_threads);
                double speed = t.t_solve > 0 ? 1e-3 * (double)t.mc_photons / t.t_solve : 0;
                ohm_validation_add(v, name, "report", speed, 0, speed, -1);
                ohm_solution_free(&t);
            }
            ohm_solution_free(&d);
        }
        ohm_voxel_grid_free(&g);
    }
    return rc;
}

/* ---- the Monte Carlo reference itself against published transport values ---- */

/* A box of cells h lit by a pencil beam of 1 W travelling -z onto its top face
 * at (x, y), traced directly (ohm_mc_trace: its power booking, including the
 * time gate, and the standard errors of the totals). */
typedef struct mc_box {
    ohm_voxel_grid grid;
    ohm_network net;
    ohm_light_entries in;
    double *fluence, *fluence_se, *face, *exit_se;
    ohm_coeff *sa, *ss; /* per cell (a clear top layer), or NULL */
    double *eta;
    ohm_mc_result res;
} mc_box;

static void mc_box_free(mc_box *b)
{
    ohm_light_entries_free(&b->in);
    ohm_network_free(&b->net);
    ohm_voxel_grid_free(&b->grid);
    free(b->fluence), free(b->fluence_se), free(b->exit_se), free(b->face);
    free(b->sa), free(b->ss), free(b->eta);
}

/* A box of one medium lit by a pencil beam from +z at (x, y), traced; with
 * clear_top > 0, its top clear_top cells are a clear (non-absorbing, barely
 * scattering) layer of index 1 above the medium (eta_v). */
static int mc_box_trace(mc_box *b, int nx, int ny, int nz, double h, double sa, double ss_reduced, double eta,
                        double g, double x, double y, int clear_top, const ohm_mc_params *p, ohm_error *err)
{
    memset(b, 0, sizeof *b);
    int rc = ohm_scene_box(&b->grid, nx, ny, nz, h, err);
    if (!rc) rc = ohm_network_build(&b->net, &b->grid, NULL, err);
    size_t n = (size_t)b->net.n, nf = (size_t)b->net.nfaces;
    if (!rc && clear_top > 0) {
        b->sa = malloc(n * sizeof *b->sa);
        b->ss = malloc(n * sizeof *b->ss);
        b->eta = malloc(n * sizeof(double));
        if (!b->sa || !b->ss || !b->eta) rc = ohm_fail(err, OHM_ERR_NOMEM, "validate: out of memory");
        for (size_t u = 0; u < n && !rc; ++u) { /* x-fastest: z index u / (nx ny) */
            int clear = (int)(u / ((size_t)nx * (size_t)ny)) >= nz - clear_top;
            b->sa[u] = (ohm_coeff)(clear ? 0.0 : sa);
            b->ss[u] = (ohm_coeff)(clear ? 1e-6 : ss_reduced); /* a scattering every 1e6 mm: clear */
            b->eta[u] = clear ? 1.0 : eta;
        }
    }
    ohm_light l = ohm_scene_pencil((const double[3]){x, y, nz * h + 1.0}, (const double[3]){0, 0, -1.0});
    if (!rc) rc = ohm_light_entries_add(&b->in, &b->net, &l, 1, eta, b->eta, NULL, err);
    if (rc) {
        mc_box_free(b);
        return rc;
    }
    b->fluence = calloc(n, sizeof(double));
    b->fluence_se = calloc(n, sizeof(double));
    b->exit_se = calloc(n, sizeof(double));
    b->face = calloc(nf, sizeof(double));
    if (!b->fluence || !b->fluence_se || !b->exit_se || !b->face) {
        mc_box_free(b);
        return ohm_fail(err, OHM_ERR_NOMEM, "validate: out of memory");
    }
    b->res = (ohm_mc_result){.fluence = b->fluence, .fluence_se = b->fluence_se, .face_exitance = b->face,
                             .exitance_se = b->exit_se};
    ohm_channel_medium med;
    memset(&med, 0, sizeof med);
    med.sigma_a0 = sa;
    med.sigma_s0 = ss_reduced;
    med.sigma_a = b->sa;
    med.sigma_s = b->ss;
    med.eta = eta;
    med.eta_v = b->eta;
    med.g = g;
    rc = ohm_mc_trace(&b->res, &b->net, &med, b->in.entry, b->in.count, 0, p, err);
    if (rc) mc_box_free(b);
    return rc;
}

/* Power leaving through faces of direction d (0..5: -x +x -y +y -z +z). */
static double mc_box_out(const mc_box *b, int d)
{
    double sum = 0, area = b->grid.h * b->grid.h;
    for (int64_t f = 0; f < b->net.nfaces; ++f)
        if (b->net.face_dir[f] == d) sum += b->face[f] * area;
    return sum;
}

/* A row against a published value: pass within 4 combined standard errors
 * (absolute: error and tolerance in the quantity's own units). */
static void published_row(ohm_validation *v, const char *name, const char *ref, double measured, double expected,
                          double se_ours, double se_theirs)
{
    double tol = 4.0 * sqrt(se_ours * se_ours + se_theirs * se_theirs);
    ohm_validation_add(v, name, ref, measured, expected, fabs(measured - expected), tol);
}

int ohm_validate_mc(ohm_validation *v, int64_t photons, uint64_t seed, int threads, ohm_device_request device,
                    const ohm_log *log, ohm_error *err)
{
    ohm_mc_params p = {.photons = photons, .seed = seed, .threads = threads, .log = log, .device = device};
    double N = (double)((photons + OHM_MC_BATCHES - 1) / OHM_MC_BATCHES * OHM_MC_BATCHES);
    mc_box b;
    /* van de Hulst's matched slab (mu_a 1, mu_s 9 /mm, g 0.75, 0.2 mm), the
     * check of MCML (Wang, Jacques & Zheng 1995): with n = 1 every photon
     * leaves whole, so each total's error is binomial */
    int rc = mc_box_trace(&b, 100, 100, 2, 0.1, 1.0, 9.0 * (1 - 0.75), 1.0, 0.75, 5.0, 5.0, 0, &p, err);
    if (rc) return rc;
    double Rd = mc_box_out(&b, 5), Tt = mc_box_out(&b, 4);
    published_row(v, "mc: matched slab, diffuse reflectance (abs)", "van de Hulst 0.09739 (MCML)", Rd, 0.09739,
                  sqrt(0.09739 * (1 - 0.09739) / N), 0);
    published_row(v, "mc: matched slab, total transmittance (abs)", "van de Hulst 0.66096 (MCML)", Tt, 0.66096,
                  sqrt(0.66096 * (1 - 0.66096) / N), 0);
    mc_box_free(&b);
    /* MCML 2.0's semi-infinite medium under air (sample1.mci, run 2: n 1.5,
     * mu_a 1, mu_s 9 /mm, g 0): Rd 0.220348 +- 0.000916, specular 0.04 apart */
    rc = mc_box_trace(&b, 40, 40, 40, 0.1, 1.0, 9.0, 1.5, 0.0, 2.0, 2.0, 0, &p, err);
    if (rc) return rc;
    double incident = b.in.entry[0].incident[0];
    published_row(v, "mc: half-space n1.5, diffuse reflectance (abs)", "MCML 0.220348 +- 0.000916",
                  mc_box_out(&b, 5) / incident, 0.220348, b.res.power_out_se / incident, 0.000916);
    mc_box_free(&b);
    /* The same half-space under 0.3 mm of a clear layer of index 1 (a per-cell
     * index): the air interface is now inside the object, between cells, so
     * the beam's specular 0.04 = ((1.5 - 1)/(1.5 + 1))^2 and every photon's
     * Fresnel reflection or refraction on its way out happen at an internal
     * change of index.  What leaves is the specular part plus MCML's diffuse
     * reflectance: through the top, and through the clear layer's sides (a
     * photon refracted out at a grazing angle crosses the 4 mm box's edge
     * before it rises 0.3 mm; the medium's own sides and bottom, 11 and 22
     * diffusion lengths away, lose nothing measurable). */
    rc = mc_box_trace(&b, 40, 40, 43, 0.1, 1.0, 9.0, 1.5, 0.0, 2.0, 2.0, 3, &p, err);
    if (rc) return rc;
    incident = b.in.entry[0].incident[0];
    published_row(v, "mc: half-space n1.5 under a clear n1.0 layer, out (abs)", "0.04 + MCML 0.220348 +- 0.000916",
                  b.res.power_out / incident, 0.04 + 0.220348, b.res.power_out_se / incident, 0.000916);
    mc_box_free(&b);
    /* MCX's cube60 (fangq/mcx src/mcx_bench.c): 60 mm of 1 mm voxels, mu_a
     * 0.005, mu_s 1 /mm, g 0.01, no reflection at the faces (DoMismatch 0),
     * the beam at grid point (29, 29), absorbed within 5 ns at c / 1.37:
     * 17.69708% (1e8 photons, mcx PR #267) */
    p.max_path = 5.0 * 299.792458 / 1.37;
    rc = mc_box_trace(&b, 60, 60, 60, 1.0, 0.005, 1.0 * (1 - 0.01), 1.0, 0.01, 29.0, 29.0, 0, &p, err);
    if (rc) return rc;
    published_row(v, "mc: cube60, absorbed fraction (abs)", "MCX 17.69708% (1e8 photons)",
                  b.res.power_absorbed / b.res.power_in, 0.1769708, b.res.power_absorbed_se / b.res.power_in, 0);
    double speed = 1e-3 * (double)b.res.photons / b.res.seconds;
    char name[80];
    if (b.res.device[0]) snprintf(name, sizeof name, "mc: cube60 speed, photons/ms (%.40s)", b.res.device);
    else snprintf(name, sizeof name, "mc: cube60 speed, photons/ms (%d threads)", b.res.threads);
    ohm_validation_add(v, name, b.res.device[0] ? "target: >= 100000 on a GPU" : "target: >= 100", speed,
                       b.res.device[0] ? 100000 : 100, speed, -1);
    mc_box_free(&b);
    return OHM_OK;
}
