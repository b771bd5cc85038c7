/* clear_regions.c — finding the clear regions of a scene (clear_regions.h:
 * the rule; docs/transport.md, "Clear regions"). */
#include "physics/clear_regions.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const ohm_clear_mode_info ohm_clear_modes[OHM_CLEAR_MODES] = {
    {OHM_CLEAR_AUTO, "auto", "find clear regions and apply the best treatment there is (today: effective)"},
    {OHM_CLEAR_OFF, "off", "diffusion everywhere, as if no region were clear"},
    {OHM_CLEAR_EFFECTIVE, "effective",
     "an effective sigma_s' in each clear region, 1/L for its mean chord L (Custo et al. 2006)"},
    {OHM_CLEAR_RADIOSITY, "radiosity",
     "transport across each clear region: its walls exchange light by view factors (radiosity-diffusion, Firbank "
     "et al. 1996); solver=direct, cg or mg"},
};

const char *ohm_clear_mode_name(ohm_clear_mode m)
{
    for (int k = 0; k < OHM_CLEAR_MODES; ++k)
        if (ohm_clear_modes[k].mode == m) return ohm_clear_modes[k].name;
    return "?";
}

const char *ohm_clear_mode_choices(char *text, size_t size)
{
    size_t at = 0;
    text[0] = 0;
    for (int k = 0; k < OHM_CLEAR_MODES && at < size; ++k)
        at += (size_t)snprintf(text + at, size - at, "%s%s", k ? "|" : "", ohm_clear_modes[k].name);
    return text;
}

int ohm_clear_mode_parse(ohm_clear_mode *out, const char *word, ohm_error *err)
{
    for (int k = 0; k < OHM_CLEAR_MODES; ++k)
        if (strcmp(word, ohm_clear_modes[k].name) == 0) {
            *out = ohm_clear_modes[k].mode;
            return OHM_OK;
        }
    char choices[OHM_CLEAR_CHOICES_CHARS];
    return ohm_fail(err, OHM_ERR_USAGE, "clear=%s: expected %s", word,
                    ohm_clear_mode_choices(choices, sizeof choices));
}

ohm_clear_mode ohm_clear_mode_settle(ohm_clear_mode m)
{
    return m == OHM_CLEAR_AUTO ? OHM_CLEAR_EFFECTIVE : m;
}

ohm_clear_mode ohm_clear_region_action(ohm_clear_mode m, const ohm_clear_region *r)
{
    if (m == OHM_CLEAR_AUTO && 2 * r->surface_faces >= r->exposed_faces) return OHM_CLEAR_OFF;
    return ohm_clear_mode_settle(m);
}

double ohm_clear_effective_sigma_t(double thickness_mm)
{
    return 1.0 / thickness_mm;
}

double ohm_clear_reach(double thickness_mm)
{
    return OHM_CLEAR_REACH_CHORDS * thickness_mm;
}

void ohm_clear_regions_free(ohm_clear_regions *r)
{
    if (!r) return;
    free(r->region_of_cell);
    free(r->region);
    memset(r, 0, sizeof *r);
}

/* Unknown v's smallest sigma_t' over the channels (1/mm). */
static double smallest_sigma_t(const ohm_channel_medium *media, int channels, int64_t v)
{
    double st = INFINITY;
    for (int c = 0; c < channels; ++c) {
        double sa, ss;
        ohm_medium_coefficients(&media[c], v, &sa, &ss);
        st = fmin(st, sa + ss);
    }
    return st;
}

/* Labels while the regions are found: >= 0 a clear region found at an
 * earlier level (final); DIFFUSING no candidate at this level; UNSEEN a
 * candidate not yet reached; TENTATIVE - t the t-th candidate region of
 * this level, clear or not. */
enum { DIFFUSING = -1, UNSEEN = -2, TENTATIVE = -3 };

/* Each level halves the candidates' sigma_t' bound (clear_regions.h, step
 * 1); the first is 1/h.  LEVELS_MAX halvings reach 1/h 10^-12, below any
 * medium the material checks accept but a void. */
enum { LEVELS_MAX = 40 };

/* The dense-index step across face d. */
static int64_t face_step(const ohm_network *net, int d)
{
    const ohm_voxel_grid *g = net->grid;
    int axis = d >> 1;
    int64_t stride = axis == 0 ? 1 : axis == 1 ? (int64_t)g->dims[0] : (int64_t)g->dims[0] * g->dims[1];
    return (d & 1) ? stride : -stride;
}

/* The neighbour of cell ijk (dense index cell) across face d: its unknown;
 * -3 outside the object (the object's surface); -1 an interior cell that
 * is no unknown (below a depth band): both faces the region exposes; -2 on
 * a symmetry plane (the region goes on in its mirror image: no face). */
static int64_t neighbour(const ohm_network *net, const int32_t ijk[3], int64_t cell, int d)
{
    const ohm_voxel_grid *g = net->grid;
    int axis = d >> 1;
    int32_t x = ijk[axis];
    if (d & 1) {
        if (x == net->mirror.high[axis]) return -2;
        if (x + 1 >= g->dims[axis]) return -3;
    } else {
        if (x == net->mirror.low[axis]) return -2;
        if (x == 0) return -3;
    }
    int64_t nc = cell + face_step(net, d), w = ohm_network_unknown(net, (size_t)nc);
    return w < 0 && !g->inside[nc] ? -3 : w;
}

/* Grow the candidate regions' list to hold one more. */
static int reserve_region(ohm_clear_region **list, int64_t *cap, int64_t count)
{
    if (count < *cap) return 0;
    int64_t c = *cap ? 2 * *cap : 64;
    ohm_clear_region *l = realloc(*list, (size_t)c * sizeof *l);
    if (!l) return -1;
    *list = l;
    *cap = c;
    return 0;
}

/* One candidate region from unknown seed, labelled `label` in lab, by a
 * breadth-first walk over face neighbours (queue: room for every
 * candidate): its cells, exposed faces (to any cell not in it, or the
 * outside) and mean sigma_t'. */
static void grow_region(ohm_clear_region *r, int32_t *lab, int64_t *queue, int64_t seed, int32_t label,
                        const ohm_network *net, const ohm_channel_medium *media, int channels)
{
    double sum_st = 0;
    int64_t head = 0, tail = 0;
    memset(r, 0, sizeof *r);
    lab[seed] = label;
    queue[tail++] = seed;
    while (head < tail) {
        int64_t u = queue[head++];
        int64_t cell = ohm_network_cell(net, u);
        int32_t ijk[3];
        ohm_voxel_coords(net->grid, (size_t)cell, ijk);
        sum_st += smallest_sigma_t(media, channels, u);
        for (int d = 0; d < 6; ++d) {
            int64_t w = neighbour(net, ijk, cell, d);
            if (w == -2) continue;
            if (w >= 0 && lab[w] == UNSEEN) {
                lab[w] = label;
                queue[tail++] = w;
            } else if (w < 0 || lab[w] != label) {
                r->exposed_faces++;
                r->surface_faces += w == -3;
            }
        }
    }
    r->cells = tail;
    r->sigma_t = sum_st / (double)tail;
}

/* Thickness, volume and optical thickness of a grown region (cells h). */
static void measure_region(ohm_clear_region *r, double h)
{
    r->volume_mm3 = (double)r->cells * h * h * h;
    /* Cauchy: mean chord 4V/S; a region exposing no face (every side a
     * symmetry plane) is unbounded */
    r->thickness_mm = r->exposed_faces ? 4.0 * r->volume_mm3 / ((double)r->exposed_faces * h * h) : INFINITY;
    r->optical_thickness = r->sigma_t * r->thickness_mm;
}

/* The cells not yet found clear whose sigma_t' is below bound labelled
 * UNSEEN, the others not clear DIFFUSING; the count of candidates. */
static int64_t mark_candidates(int32_t *lab, const ohm_network *net, const ohm_channel_medium *media, int channels,
                               double bound)
{
    int64_t count = 0;
    for (int64_t v = 0; v < net->n; ++v) {
        if (lab[v] >= 0) continue;
        int cand = smallest_sigma_t(media, channels, v) < bound;
        lab[v] = cand ? UNSEEN : DIFFUSING;
        count += cand;
    }
    return count;
}

/* One level: the candidate regions below bound grown and measured; the
 * clear ones appended to out (their cells labelled with their number), the
 * others' cells DIFFUSING.  *found: candidates at this level. */
static int find_level(ohm_clear_regions *out, int32_t *lab, int64_t **queue, int64_t *queue_cap,
                      ohm_clear_region **tent, int64_t *tent_cap, int64_t *region_cap, const ohm_network *net,
                      const ohm_channel_medium *media, int channels, double bound, int64_t *found)
{
    *found = mark_candidates(lab, net, media, channels, bound);
    if (!*found) return 0;
    if (*found > *queue_cap) {
        int64_t *q = realloc(*queue, (size_t)*found * sizeof *q);
        if (!q) return -1;
        *queue = q;
        *queue_cap = *found;
    }
    int64_t nt = 0;
    for (int64_t v = 0; v < net->n; ++v) {
        if (lab[v] != UNSEEN) continue;
        if (nt >= INT32_MAX + (int64_t)TENTATIVE || reserve_region(tent, tent_cap, nt)) return -1;
        grow_region(&(*tent)[nt], lab, *queue, v, (int32_t)(TENTATIVE - nt), net, media, channels);
        measure_region(&(*tent)[nt], net->grid->h);
        ++nt;
    }
    /* the clear ones numbered on from the regions found before; the map
     * reuses the queue (nt <= candidates) */
    int64_t *final = *queue;
    for (int64_t t = 0; t < nt; ++t) {
        final[t] = DIFFUSING;
        if (!((*tent)[t].optical_thickness < OHM_CLEAR_OPTICAL_THICKNESS)) continue;
        if (out->count >= INT32_MAX || reserve_region(&out->region, region_cap, out->count)) return -1;
        final[t] = out->count;
        out->region[out->count++] = (*tent)[t];
        out->clear_cells += (*tent)[t].cells;
        out->clear_volume_mm3 += (*tent)[t].volume_mm3;
    }
    for (int64_t v = 0; v < net->n; ++v)
        if (lab[v] <= TENTATIVE) lab[v] = (int32_t)final[TENTATIVE - lab[v]];
    return 0;
}

int ohm_clear_regions_find(ohm_clear_regions *out, const ohm_network *net, const ohm_channel_medium *media,
                           int channels, ohm_error *err)
{
    memset(out, 0, sizeof *out);
    out->n = net->n;
    if (channels < 1 || media[0].resistance_mode || net->n == 0) return OHM_OK;
    int32_t *lab = malloc((size_t)net->n * sizeof *lab);
    if (!lab) return ohm_fail(err, OHM_ERR_NOMEM, "clear regions: out of memory for %lld cells", (long long)net->n);
    for (int64_t v = 0; v < net->n; ++v) lab[v] = DIFFUSING;
    int64_t *queue = NULL, queue_cap = 0, tent_cap = 0, region_cap = 0;
    ohm_clear_region *tent = NULL;
    double bound = 1.0 / net->grid->h;
    int failed = 0;
    for (int level = 0; level < LEVELS_MAX && !failed; ++level, bound *= 0.5) {
        int64_t found = 0;
        failed = find_level(out, lab, &queue, &queue_cap, &tent, &tent_cap, &region_cap, net, media, channels, bound,
                            &found);
        if (level == 0) out->candidate_cells = found;
        if (!found) break;
    }
    free(queue), free(tent);
    if (failed) {
        int64_t candidates = out->candidate_cells;
        free(lab);
        ohm_clear_regions_free(out);
        return ohm_fail(err, OHM_ERR_NOMEM, "clear regions: out of memory for %lld candidate cells",
                        (long long)candidates);
    }
    if (out->count == 0) {
        free(lab);
        free(out->region);
        out->region = NULL;
        return OHM_OK;
    }
    ohm_clear_region *kept = realloc(out->region, (size_t)out->count * sizeof *kept);
    if (kept) out->region = kept;
    out->region_of_cell = lab;
    for (int32_t k = 0; k < out->count; ++k) out->region[k].action = OHM_CLEAR_OFF;
    return OHM_OK;
}
