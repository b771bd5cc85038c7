/* light_pencil.c — a pencil beam: power `intensity` (W) along dir from pos,
 * entering the object at the one surface point where the beam meets it.  It
 * lights no faces (no rays: light.c places it through its entry face), and
 * the preview leaves it out (light_kind.h). */
#include "physics/light_kind.h"

static void rays(const ohm_light_setup *su, const double p[3], const double n[3], ohm_light_ray_fn emit, void *acc)
{
    (void)su, (void)p, (void)n, (void)emit, (void)acc;
}

static void pov(FILE *f, const ohm_light *l)
{
    ohm_light_pov_aimed(f, l, 1.0, "spotlight radius 0.1 falloff 0.2", "pencil beam, W");
}

const ohm_light_kind ohm_light_pencil = {OHM_LIGHT_PENCIL, "pencil", OHM_LIGHT_NEEDS_POS | OHM_LIGHT_NEEDS_DIR, 1, 0,
                                         NULL, NULL, rays, ohm_light_toward_position, pov, NULL};
