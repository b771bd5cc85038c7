/* render.h — `-render`: a preview image of the solution (docs/outputs.md).
 *
 * An orthographic camera looks at the centre of the mesh's bounding box along
 * view= (default: the direction the frame's first light travels, or down -z
 * without lights) and frames the whole object.  Embree 3 casts one ray per
 * sample (2 x 2 per pixel) against the mesh; a hit is shaded by the exitance
 * of the solution around it (a tent filter over the surrounding boundary
 * cells, else the nearest one), times an exposure (auto: the 99th percentile
 * of the visible exitance maps to 1).  compare=1 puts beside it the same view
 * WITHOUT scattering: each surface point reflects the light it receives
 * (E = I n.l, with shadow rays) at once, scaled per channel so that the two
 * images carry the same total power out — light reaches the shadowed side
 * only in the scattering image.  .png (8-bit sRGB) or .exr (half, linear). */
#ifndef OHM_RENDER_H
#define OHM_RENDER_H

#include "steps/pipeline.h"

extern const ohm_opt_spec ohm_render_opts[];
int ohm_run_render(ohm_state *s, const ohm_invocation *inv, ohm_error *err);
void ohm_render_io(const ohm_invocation *inv, ohm_step_io *io);

#endif
