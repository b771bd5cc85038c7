#include "physics/material.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* Jensen, Marschner, Levoy, Hanrahan, "A Practical Model for Subsurface Light
 * Transport", SIGGRAPH 2001, Table / Fig. 5; the values pbrt-v3 tabulates. */
const ohm_preset ohm_presets[] = {
    {"apple", {2.29, 2.39, 1.97}, {0.0030, 0.0034, 0.046}},
    {"chicken1", {0.15, 0.21, 0.38}, {0.015, 0.077, 0.19}},
    {"chicken2", {0.19, 0.25, 0.32}, {0.018, 0.088, 0.20}},
    {"cream", {7.38, 5.47, 3.15}, {0.0002, 0.0028, 0.0163}},
    {"ketchup", {0.18, 0.07, 0.03}, {0.061, 0.97, 1.45}},
    {"marble", {2.19, 2.62, 3.00}, {0.0021, 0.0041, 0.0071}},
    {"potato", {0.68, 0.70, 0.55}, {0.0024, 0.0090, 0.12}},
    {"skimmilk", {0.70, 1.22, 1.90}, {0.0014, 0.0025, 0.0142}},
    {"skin1", {0.74, 0.88, 1.01}, {0.032, 0.17, 0.48}},
    {"skin2", {1.09, 1.59, 1.79}, {0.013, 0.070, 0.145}},
    {"spectralon", {11.6, 20.4, 14.9}, {0.00, 0.00, 0.00}},
    {"wholemilk", {2.55, 3.21, 3.77}, {0.0011, 0.0024, 0.014}},
    {NULL, {0, 0, 0}, {0, 0, 0}}};

const char *const ohm_preset_names =
    "apple|chicken1|chicken2|cream|ketchup|marble|potato|skimmilk|skin1|skin2|spectralon|wholemilk";

int ohm_material_preset(ohm_material *out, const char *name, ohm_error *err)
{
    memset(out, 0, sizeof *out);
    for (const ohm_preset *p = ohm_presets; p->name; ++p) {
        if (strcmp(p->name, name) != 0) continue;
        out->kind = OHM_MATERIAL_OPTICAL;
        out->channels = 3;
        for (int c = 0; c < 3; ++c) {
            out->sigma_a[c] = p->sigma_a[c];
            out->sigma_s[c] = p->sigma_s[c];
        }
        out->eta = 1.3;
        snprintf(out->name, sizeof out->name, "%s", p->name);
        return OHM_OK;
    }
    return ohm_fail(err, OHM_ERR_USAGE, "unknown material preset '%s' (presets: %s)", name, ohm_preset_names);
}

int ohm_material_check(const ohm_material *m, ohm_error *err)
{
    if (m->channels != 1 && m->channels != 3)
        return ohm_fail(err, OHM_ERR_INVALID, "material: %d channels, expected 1 (grey) or 3 (R,G,B)", m->channels);
    if (m->kind == OHM_MATERIAL_RESISTANCE) {
        if (!(m->resistance > 0) || !isfinite(m->resistance))
            return ohm_fail(err, OHM_ERR_INVALID, "material: resistance=%g ohm, expected a finite value > 0",
                            m->resistance);
        if (!(m->ground > 0) || !isfinite(m->ground))
            return ohm_fail(err, OHM_ERR_INVALID,
                            "material: ground=%g ohm, expected a finite value > 0 (an open circuit to ground is "
                            "no absorption: give a very large value)",
                            m->ground);
        return OHM_OK;
    }
    static const char *ch[3] = {"R", "G", "B"};
    for (int c = 0; c < m->channels; ++c) {
        const char *cn = m->channels == 1 ? "grey" : ch[c];
        if (!(m->sigma_a[c] >= 0) || !isfinite(m->sigma_a[c]))
            return ohm_fail(err, OHM_ERR_INVALID, "material: sigma_a=%g /mm (%s), expected a finite value >= 0",
                            m->sigma_a[c], cn);
        if (!(m->sigma_s[c] > 0) || !isfinite(m->sigma_s[c]))
            return ohm_fail(err, OHM_ERR_INVALID, "material: sigma_s=%g /mm (%s), expected a finite value > 0",
                            m->sigma_s[c], cn);
    }
    if (!(m->g > -1.0 && m->g < 1.0))
        return ohm_fail(err, OHM_ERR_INVALID, "material: g=%g, expected an anisotropy between -1 and 1", m->g);
    if (!(m->eta >= 1.0 && m->eta <= 3.0))
        return ohm_fail(err, OHM_ERR_INVALID, "material: eta=%g, expected a relative index from 1 to 3", m->eta);
    return OHM_OK;
}

double ohm_material_D(const ohm_material *m, int c) { return 1.0 / (3.0 * (m->sigma_a[c] + m->sigma_s[c])); }

double ohm_material_sigma_tr(const ohm_material *m, int c)
{
    return sqrt(3.0 * m->sigma_a[c] * (m->sigma_a[c] + m->sigma_s[c]));
}

double ohm_material_albedo(const ohm_material *m, int c) { return m->sigma_s[c] / (m->sigma_a[c] + m->sigma_s[c]); }

int ohm_material_channel_class(const ohm_material *m, int c)
{
    if (m->kind == OHM_MATERIAL_RESISTANCE) return 0;
    for (int e = 0; e < c; ++e)
        if (m->sigma_a[e] == m->sigma_a[c] && m->sigma_s[e] == m->sigma_s[c]) return e;
    return c;
}
