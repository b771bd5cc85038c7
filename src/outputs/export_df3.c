/* export_df3.c — see export_df3.h. */
#include "outputs/export_df3.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "base/vec3.h"
#include "physics/light_kind.h"

static const char *const channel_suffix[3] = {"_r", "_g", "_b"};

static int write_df3(const char *path, const ohm_voxel_grid *g, const ohm_solution *sol, const double *vals,
                     double scale, ohm_output_batch *batch, ohm_error *err)
{
    const int32_t nx = g->dims[0] + 2, ny = g->dims[1] + 2, nz = g->dims[2] + 2;
    ohm_output out;
    int rc = ohm_output_begin(&out, path, batch, err);
    if (rc) return rc;
    FILE *f = out.stream;
    unsigned char hdr[6] = {(unsigned char)(nx >> 8), (unsigned char)nx, (unsigned char)(ny >> 8),
                            (unsigned char)ny,        (unsigned char)(nz >> 8), (unsigned char)nz};
    fwrite(hdr, 1, 6, f);
    unsigned char *row = calloc((size_t)nx, 2);
    if (!row) {
        ohm_output_abort(&out);
        return ohm_fail(err, OHM_ERR_NOMEM, "%s: out of memory", path);
    }
    for (int32_t k = 0; k < nz; ++k)
        for (int32_t j = 0; j < ny; ++j) {
            memset(row, 0, (size_t)nx * 2);
            if (k > 0 && k < nz - 1 && j > 0 && j < ny - 1)
                for (int32_t i = 1; i < nx - 1; ++i) {
                    int64_t u = ohm_network_unknown(&sol->net, ohm_voxel_index(g, i - 1, j - 1, k - 1));
                    if (u < 0) continue;
                    double v = vals[u] * scale;
                    long q = (v > 0) ? lround(fmin(v, 65535.0)) : 0;
                    row[2 * i] = (unsigned char)(q >> 8);
                    row[2 * i + 1] = (unsigned char)q;
                }
            fwrite(row, 2, (size_t)nx, f);
        }
    free(row);
    if (ferror(f)) {
        ohm_output_abort(&out);
        return ohm_fail(err, OHM_ERR_IO, "cannot write '%s'", path);
    }
    return ohm_output_commit(&out, err);
}

static double dot3(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

/* POV-Ray vector from an ohm one: mirror z (right- to left-handed). */
static void pov_vec(FILE *f, const double v[3]) { fprintf(f, "<%.9g, %.9g, %.9g>", v[0], v[1], -v[2]); }

static int write_pov(const char *path, const char *const *df3_names, const ohm_voxel_grid *g,
                     const ohm_solution *sol, const ohm_df3_params *p, double max, double scale,
                     ohm_output_batch *batch, ohm_error *err)
{
    const double h = g->h;
    double lo[3], size[3], centre[3], radius = 0, extent = 0;
    for (int a = 0; a < 3; ++a) {
        lo[a] = g->origin[a] - 0.5 * h - h;
        size[a] = (g->dims[a] + 2) * h;
        centre[a] = lo[a] + 0.5 * size[a];
        radius += 0.25 * size[a] * size[a];
        if (size[a] > extent) extent = size[a];
    }
    radius = sqrt(radius);
    /* camera: halfway between the light's side and a side view, image up
     * towards the light */
    double L[3] = {p->toward_light[0], p->toward_light[1], p->toward_light[2]};
    if (!ohm_vec3_normalize(L)) L[0] = 0, L[1] = 1, L[2] = 0;
    static const int pref[3] = {2, 0, 1};
    int best = pref[0];
    for (int t = 1; t < 3; ++t)
        if (fabs(L[pref[t]]) < fabs(L[best]) - 1e-9) best = pref[t];
    double P[3] = {0, 0, 0};
    P[best] = 1;
    double lp = dot3(L, P);
    for (int a = 0; a < 3; ++a) P[a] -= lp * L[a];
    ohm_vec3_normalize(P);
    double D[3], S[3], cam[3];
    for (int a = 0; a < 3; ++a) D[a] = L[a] + P[a];
    ohm_vec3_normalize(D);
    double ld = dot3(L, D);
    for (int a = 0; a < 3; ++a) S[a] = L[a] - ld * D[a];
    ohm_vec3_normalize(S);
    const double half_angle = 20.0 * 3.14159265358979323846 / 180.0;
    double dist = 1.05 * radius / sin(half_angle);
    for (int a = 0; a < 3; ++a) cam[a] = centre[a] + dist * D[a];

    ohm_output out;
    int rc = ohm_output_begin(&out, path, batch, err);
    if (rc) return rc;
    FILE *f = out.stream;
    const char *what = p->exitance ? "exitance" : "fluence rate";
    fprintf(f, "// ohm: %s (W/mm^2) of frame %d as emitting media; POV-Ray 3.7 scene.\n", what, p->frame + 1);
    fprintf(f, "// Units: millimetres (ohm's right-handed coordinates with z mirrored into POV-Ray's).\n");
    fprintf(f, "// Voxel %.9g mm, grid %d x %d x %d padded by one zero voxel per side.\n", h, g->dims[0],
            g->dims[1], g->dims[2]);
    fprintf(f, "// df3 scale factor: sample = %s * %.9g (maximum %.9g W/mm^2 -> 65535);\n", what, scale, max);
    fprintf(f, "// POV-Ray reads samples as sample/65535, so 1.0 in a color_map = %.9g W/mm^2.\n", max);
    fprintf(f, "// Render from this directory, e.g.: povray +I<this file> +W640 +H480 +A0.3\n\n");
    fprintf(f, "#version 3.7;\nglobal_settings { assumed_gamma 1.0 }\nbackground { rgb 0 }\n\n");
    fprintf(f, "// emission per mm of a voxel at the maximum: about 3 over the box's longest side\n");
    fprintf(f, "#declare OhmGain = %.9g;\n\n", 3.0 / extent);
    fprintf(f, "camera {\n  perspective\n  location ");
    pov_vec(f, cam);
    fprintf(f, "\n  sky ");
    pov_vec(f, S);
    fprintf(f, "\n  up y\n  right x*image_width/image_height\n  angle %.9g\n  look_at ", 2 * 20.0);
    pov_vec(f, centre);
    fprintf(f, "\n}\n\n");
    fprintf(f, "box {\n  <0, 0, 0>, <1, 1, 1>\n  pigment { rgbt 1 }\n  hollow\n  interior {\n");
    static const char *const colour[3] = {"<1, 0, 0>", "<0, 1, 0>", "<0, 0, 1>"};
    for (int c = 0; c < sol->channels; ++c) {
        fprintf(f, "    media {\n      emission OhmGain\n      method 3\n      intervals 1\n      samples 20\n");
        fprintf(f, "      density {\n        density_file df3 \"%s\" interpolate 1\n", df3_names[c]);
        fprintf(f, "        color_map { [0 rgb 0] [1 rgb %s] }\n      }\n    }\n",
                sol->channels == 1 ? "1" : colour[c]);
    }
    fprintf(f, "  }\n  scale <%.9g, %.9g, %.9g>\n  translate <%.9g, %.9g, %.9g>\n  scale <1, 1, -1>\n}\n",
            size[0], size[1], size[2], lo[0], lo[1], lo[2]);
    fputs("\n// The lights of the frame, as each kind writes itself (the media above only emit: these\n"
          "// light what you add to the scene).  Colours are in ohm's units, as each line says.\n", f);
    for (size_t i = 0; i < p->nlights; ++i)
        if (ohm_light_in_frame(&p->lights[i], p->frame)) ohm_light_pov(f, &p->lights[i]);
    if (ferror(f)) {
        ohm_output_abort(&out);
        return ohm_fail(err, OHM_ERR_IO, "cannot write '%s'", path);
    }
    return ohm_output_commit(&out, err);
}

/* The .df3 files and the .pov scene of one value per unknown and channel. */
static int write_scene(const char *base, const ohm_voxel_grid *g, const ohm_solution *sol, const ohm_df3_params *p,
                       const double *const vals[], ohm_df3_report *rep, ohm_output_batch *batch, ohm_error *err)
{
    double max = 0;
    for (int c = 0; c < sol->channels; ++c) {
        for (int64_t u = 0; u < sol->n; ++u)
            if (vals[c][u] > max) max = vals[c][u];
    }
    double scale = max > 0 ? 65535.0 / max : 0;
    rep->max = max;
    rep->scale = scale;

    const char *slash = strrchr(base, '/');
    const char *stem = slash ? slash + 1 : base;
    char names[3][OHM_PATH_MAX];
    const char *namep[3];
    for (int c = 0; c < sol->channels; ++c) {
        char path[OHM_PATH_MAX];
        const char *suf = sol->channels == 1 ? "" : channel_suffix[c];
        snprintf(path, sizeof path, "%s%s.df3", base, suf);
        snprintf(names[c], sizeof names[c], "%s%s.df3", stem, suf);
        namep[c] = names[c];
        int rc = write_df3(path, g, sol, vals[c], scale, batch, err);
        if (rc) return rc;
        if (c == 0) snprintf(rep->first, sizeof rep->first, "%s", path);
    }
    snprintf(rep->pov, sizeof rep->pov, "%s.pov", base);
    return write_pov(rep->pov, namep, g, sol, p, max, scale, batch, err);
}

int ohm_export_df3(const char *base_in, const ohm_voxel_grid *g, const ohm_solution *sol, const ohm_df3_params *p,
                   ohm_df3_report *rep, ohm_output_batch *batch, ohm_error *err)
{
    memset(rep, 0, sizeof *rep);
    char base[OHM_PATH_MAX];
    size_t len = strlen(base_in);
    if (len + 8 >= sizeof base) return ohm_fail(err, OHM_ERR_IO, "%s: path is too long", base_in);
    memcpy(base, base_in, len + 1);
    if (len > 4 && (strcasecmp(base + len - 4, ".df3") == 0 || strcasecmp(base + len - 4, ".pov") == 0))
        base[len - 4] = '\0';
    if (p->frame < 0 || p->frame >= sol->frames)
        return ohm_fail(err, OHM_ERR_INVALID, "frame %d out of range: the solution has %d frame(s)", p->frame + 1,
                        sol->frames);
    for (int a = 0; a < 3; ++a)
        if (g->dims[a] + 2 > 65535)
            return ohm_fail(err, OHM_ERR_INVALID, "%s: grid of %d cells along an axis is too large for df3", base,
                            g->dims[a]);
    const char *slash = strrchr(base, '/');
    if (strpbrk(slash ? slash + 1 : base, "\"\\"))
        return ohm_fail(err, OHM_ERR_INVALID, "%s: a df3 name with a quote or backslash cannot go in a .pov string",
                        base_in);
    const double *vals[OHM_MAX_CHANNELS];
    double *cell_exitance[OHM_MAX_CHANNELS] = {NULL};
    int rc = OHM_OK;
    for (int c = 0; c < sol->channels && !rc; ++c) {
        vals[c] = sol->fluence[c] + (size_t)p->frame * (size_t)sol->n;
        if (!p->exitance) continue;
        cell_exitance[c] = malloc((size_t)(sol->n ? sol->n : 1) * sizeof *cell_exitance[c]);
        if (!cell_exitance[c]) {
            rc = ohm_fail(err, OHM_ERR_NOMEM, "%s: out of memory", base_in);
            break;
        }
        ohm_solution_exitance_frame(cell_exitance[c], sol, c, p->frame);
        vals[c] = cell_exitance[c];
    }
    if (!rc) rc = write_scene(base, g, sol, p, vals, rep, batch, err);
    for (int c = 0; c < OHM_MAX_CHANNELS; ++c) free(cell_exitance[c]);
    return rc;
}
