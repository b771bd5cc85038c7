/* export_action.c — see export_action.h. */
#include "steps/export_action.h"

#include <math.h>
#include <string.h>

#include "base/vec3.h"
#include "outputs/export_csv.h"
#include "outputs/export_df3.h"
#include "outputs/export_ply.h"
#include "physics/light_kind.h"

const ohm_opt_spec ohm_export_opts[] = {
    {"ply", OHM_OPT_STRING, NULL, "write the mesh with per-vertex exitance and sRGB colours (binary PLY)", NULL, 0,
     0, 0},
    {"df3", OHM_OPT_STRING, NULL,
     "write POV-Ray density files BASE_r/_g/_b.df3 (BASE.df3 for grey) and the scene BASE.pov", NULL, 0, 0, 0},
    {"csv", OHM_OPT_STRING, NULL,
     "write every solved cell as a line: i,j,k, its centre x,y,z (mm), fluence and exitance per channel, 17 digits",
     NULL, 0, 0, 0},
    {"quantity", OHM_OPT_ENUM, "fluence", "df3: what the density files hold", "fluence|exitance", 0, 0, 0},
    {"exposure", OHM_OPT_REAL, NULL,
     "ply: colour = sRGB(exitance * exposure); default: the 99th percentile of the vertex exitance maps to 1",
     NULL, 1e-300, 1e300, 0},
    {"frame", OHM_OPT_INT, "1", "which frame of an orbit sequence (1 = the first)", NULL, 1, 1000000, 0},
    {0}};

/* Direction from the object towards the lights of a frame (unit sum), each
 * as its kind sees it (physics/light_kind.h; an environment has none). */
static void toward_light(const ohm_state *s, int frame, double out[3])
{
    double centre[3] = {0, 0, 0};
    const ohm_voxel_grid *g = &s->grid;
    for (int a = 0; a < 3; ++a) centre[a] = g->origin[a] + 0.5 * (g->dims[a] - 1) * g->h;
    out[0] = out[1] = out[2] = 0;
    for (size_t i = 0; i < s->nlights; ++i) {
        const ohm_light *l = &s->lights[i];
        double v[3];
        if (!ohm_light_in_frame(l, frame)) continue;
        if (!ohm_light_toward(l, centre, v)) continue;
        for (int a = 0; a < 3; ++a) out[a] += v[a];
    }
}

void ohm_export_io(const ohm_invocation *inv, ohm_step_io *io)
{
    io->needs[0] = (ohm_need){OHM_RES_SOLUTION, 0, "nothing to export: run -solve first"};
    if (ohm_opt_given(inv, "ply")) io->needs[1] = (ohm_need){OHM_RES_MESH, 0, "ply=: no mesh to export"};
}

int ohm_run_export(ohm_state *s, const ohm_invocation *inv, ohm_error *err)
{
    int want_ply = ohm_opt_given(inv, "ply"), want_df3 = ohm_opt_given(inv, "df3");
    int want_csv = ohm_opt_given(inv, "csv");
    if (!want_ply && !want_df3 && !want_csv)
        return ohm_fail(err, OHM_ERR_USAGE, "%s: -export: give ply=FILE, df3=BASE and/or csv=FILE", inv->where);
    if (!s->have_solution || !s->have_grid)
        return ohm_fail(err, OHM_ERR_INVALID, "%s: -export: nothing to export: run -solve first", inv->where);
    int frame = (int)ohm_opt_int(inv, "frame") - 1;
    if (frame >= ohm_state_solution(s)->frames)
        return ohm_fail(err, OHM_ERR_INVALID, "%s: -export frame=%d: the solution has %d frame(s)", inv->where,
                        frame + 1, ohm_state_solution(s)->frames);
    double t0 = ohm_now();
    int rc;
    if (want_ply) {
        const char *path = ohm_opt_str(inv, "ply");
        if (!s->have_mesh)
            return ohm_fail(err, OHM_ERR_INVALID, "%s: -export ply=: no mesh to export", inv->where);
        double exposure = ohm_opt_given(inv, "exposure") ? ohm_opt_real(inv, "exposure") : 0, used = 0;
        rc = ohm_export_ply(path, &s->mesh, &s->grid, ohm_state_solution(s), frame, exposure, &used, s->outputs,
                            err);
        if (rc) return rc;
        ohm_log_info(&s->log, "wrote %s (%zu vertices with exitance, frame %d, exposure %.6g%s)", path,
                     s->mesh.nverts, frame + 1, used, ohm_opt_given(inv, "exposure") ? "" : ", auto");
        ohm_stats_set(&s->stats, "export_ply_exposure", used);
    }
    if (want_df3) {
        ohm_df3_params p;
        memset(&p, 0, sizeof p);
        p.frame = frame;
        p.exitance = strcmp(ohm_opt_str(inv, "quantity"), "exitance") == 0;
        toward_light(s, frame, p.toward_light);
        p.lights = s->lights;
        p.nlights = s->nlights;
        ohm_df3_report rep;
        rc = ohm_export_df3(ohm_opt_str(inv, "df3"), &s->grid, ohm_state_solution(s), &p, &rep, s->outputs, err);
        if (rc) return rc;
        ohm_log_info(&s->log, "wrote %s and %d density file(s) from %s (%s, frame %d, scale %.6g per W/mm^2)",
                     rep.pov, ohm_state_solution(s)->channels, rep.first, p.exitance ? "exitance" : "fluence", frame + 1,
                     rep.scale);
        ohm_stats_set(&s->stats, "export_df3_scale", rep.scale);
    }
    if (want_csv) {
        const char *path = ohm_opt_str(inv, "csv");
        rc = ohm_export_csv(path, &s->grid, ohm_state_solution(s), frame, s->outputs, err);
        if (rc) return rc;
        ohm_log_info(&s->log, "wrote %s (%lld cells, frame %d)", path, (long long)ohm_state_solution(s)->n, frame + 1);
    }
    ohm_stats_add(&s->stats, "t_export", ohm_now() - t0);
    return OHM_OK;
}
