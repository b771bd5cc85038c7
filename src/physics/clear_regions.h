/* clear_regions.h — the regions of a scene where diffusion does not hold
 * because light crosses them without scattering enough to diffuse: the
 * cerebrospinal fluid, ventricles, sinuses and air cavities of a head, the
 * vitreous of an eye, a clear inclusion (docs/transport.md, "Clear regions").
 *
 * The rule, on the medium and the grid alone:
 *   1. a cell is a candidate when its transport mean free path exceeds the
 *      cell, 1/sigma_t' > h, with sigma_t' = sigma_a + sigma_s' the smallest
 *      over the channels (the most penetrating channel decides: a region
 *      clear in one channel is found, and a treatment leaves the channels
 *      that do diffuse there as they are);
 *   2. candidates are grouped into 6-connected regions (face neighbours;
 *      a symmetry plane continues a region, it is not its boundary);
 *   3. each region's thickness is its mean chord 4V/S (Cauchy's formula,
 *      exact for a convex body and for a layer, 2t for a layer of thickness
 *      t: the mean path of diffuse light across it), V its cells' volume and
 *      S its exposed faces' area (to any cell outside it, and to the
 *      outside); on a curved boundary the cells' staircase exposes up to
 *      3/2 of the true area, so a region reads up to 1/3 thinner;
 *   4. a region is clear when its optical thickness sigma_t' 4V/S (sigma_t'
 *      its cells' mean of the per-cell smallest) is below
 *      OHM_CLEAR_OPTICAL_THICKNESS: diffusion holds only beyond two transport
 *      mean free paths from a source or a boundary (docs/design.md §3; the
 *      transport study compares only there), so a region no thicker than
 *      that has no interior where diffusion holds;
 *   5. steps 1-4 repeat among the cells not yet found clear with the bound
 *      on sigma_t' halved (1/h, 1/(2h), 1/(4h), ...) until no cell is below
 *      it: a clear region inside a medium whose mean free path is only a
 *      little longer than a cell (the transport study's, 1.005 mm at h = 1;
 *      scalp at 1.14 mm; any tissue on a fine grid) is first one optically
 *      thick region with it, then found on its own.
 *
 * The result is a region per unknown (the network's unknown order,
 * network.h: interior cells in cell order, x fastest), -1 where diffusion
 * holds; ohm_clear_is_clear is the mask a treatment reads. */
#ifndef OHM_CLEAR_REGIONS_H
#define OHM_CLEAR_REGIONS_H

#include <stddef.h>
#include <stdint.h>

#include "base/ohm_error.h"
#include "physics/network.h"

/* Step 4's threshold on sigma_t' 4V/S (above). */
#define OHM_CLEAR_OPTICAL_THICKNESS 2.0

/* What -solve clear= does with the clear regions found.  A new treatment is
 * one enumerator here and one line in ohm_clear_modes (clear_regions.c). */
typedef enum ohm_clear_mode {
    OHM_CLEAR_OFF = 0,   /* diffusion everywhere, nothing looked for: what a
                            zeroed ohm_solve_params asks inside the library
                            (-solve, the API and Python default to auto)   */
    OHM_CLEAR_AUTO,      /* find them and apply the best treatment there is
                            (ohm_clear_mode_settle): today, effective      */
    OHM_CLEAR_EFFECTIVE, /* an effective sigma_s' in each clear region from
                            its thickness (ohm_clear_effective_sigma_t)     */
    OHM_CLEAR_RADIOSITY, /* transport across each clear region: its walls
                            exchange light by view factors (the
                            radiosity-diffusion coupling, clear_exchange.h),
                            face pairs within ohm_clear_reach of it         */
    OHM_CLEAR_MODES
} ohm_clear_mode;

/* The table of modes: the word -solve clear= takes, and what it does. */
typedef struct ohm_clear_mode_info {
    ohm_clear_mode mode;
    const char *name;
    const char *doc;
} ohm_clear_mode_info;
extern const ohm_clear_mode_info ohm_clear_modes[OHM_CLEAR_MODES];

/* The mode named word, or OHM_ERR_USAGE "clear=WORD: expected auto|off|...". */
int ohm_clear_mode_parse(ohm_clear_mode *out, const char *word, ohm_error *err);
const char *ohm_clear_mode_name(ohm_clear_mode m);
/* "auto|off|effective" into text (size bytes; OHM_CLEAR_CHOICES_CHARS
 * holds them all): the choices, for help and messages; returns text. */
enum { OHM_CLEAR_CHOICES_CHARS = 128 };
const char *ohm_clear_mode_choices(char *text, size_t size);
/* auto's choice: the best treatment built (any other mode is itself). */
ohm_clear_mode ohm_clear_mode_settle(ohm_clear_mode m);

struct ohm_clear_region;
/* What mode m does with region r: auto treats a region inside the object
 * (less than half of its exposed area on the object's surface) and leaves
 * diffusion in one that is mostly the object's own surface layer or the
 * whole object (a clear object in air: its light leaves through the
 * surface, and an effective scattering from its thickness would only keep
 * it in; solver=mc models it); a mode asked by name treats every region. */
ohm_clear_mode ohm_clear_region_action(ohm_clear_mode m, const struct ohm_clear_region *r);

typedef struct ohm_clear_region {
    int64_t cells;            /* unknowns in it                                  */
    int64_t exposed_faces;    /* faces to diffusing cells or to the outside      */
    int64_t surface_faces;    /* of them, faces on the object's surface          */
    double volume_mm3;        /* cells h^3                                       */
    double thickness_mm;      /* mean chord 4V/S                                 */
    double sigma_t;           /* 1/mm: mean over its cells of the smallest sigma_t' */
    double optical_thickness; /* sigma_t thickness_mm                            */
    ohm_clear_mode action;    /* what is done with it (OHM_CLEAR_OFF: nothing)   */
} ohm_clear_region;

typedef struct ohm_clear_regions {
    int64_t n;                /* unknowns                                         */
    /* n: unknown v's clear region, or -1 where diffusion holds; NULL when no
     * cell is clear (no memory spent on a scene without clear regions) */
    int32_t *region_of_cell;
    int32_t count;            /* clear regions                                    */
    ohm_clear_region *region; /* count of them, level by level, each level's in
                                 the order of their first unknown */
    int64_t candidate_cells;  /* cells with 1/sigma_t' > h (clear or not): step 1 */
    int64_t clear_cells;      /* cells in clear regions                           */
    double clear_volume_mm3;
} ohm_clear_regions;

/* Find the clear regions of the network's unknowns under the channels'
 * media (network.h; channels >= 1; a resistance-mode medium has none). */
int ohm_clear_regions_find(ohm_clear_regions *out, const ohm_network *net, const ohm_channel_medium *media,
                           int channels, ohm_error *err);
void ohm_clear_regions_free(ohm_clear_regions *r);

/* Whether unknown v lies in a clear region (r may be NULL: none). */
static inline int ohm_clear_is_clear(const ohm_clear_regions *r, int64_t unknown)
{
    return r && r->region_of_cell && r->region_of_cell[unknown] >= 0;
}

/* The effective sigma_t' of a clear region of mean chord L (mm) under
 * clear=effective: 1 / L, the inverse line-of-sight distance up to which
 * Custo, Wells, Barnett, Hillman & Boas (Appl. Opt. 45:4747, 2006) find
 * that the CSF's scattering does not change what diffusion computes
 * (0.25 /mm for a 2 mm layer, their 0.3 /mm); the cells' own sigma_s' is
 * kept where it is larger (docs/transport.md). */
double ohm_clear_effective_sigma_t(double thickness_mm);

/* clear=radiosity: how far apart (mm) two wall faces of a region of this
 * mean chord may be and still be linked: OHM_CLEAR_REACH_CHORDS chords.  A
 * layer t thick has a mean chord of 2t, and a face's view factor to the far
 * wall beyond a distance r falls as (t/r)^2: ten thicknesses keep all but
 * about 1% of it, and the renormalisation hands that on to the pairs kept
 * (docs/transport.md measures 10, 15 and 20 mm on a 2 mm layer). */
#define OHM_CLEAR_REACH_CHORDS 5.0
double ohm_clear_reach(double thickness_mm);

#endif
