/* export_action.h — the -export action (docs/outputs.md): the solution as a coloured
 * PLY mesh (export_ply.h) and/or POV-Ray density files with a scene
 * (export_df3.h). */
#ifndef OHM_EXPORT_ACTION_H
#define OHM_EXPORT_ACTION_H

#include "steps/pipeline.h"

extern const ohm_opt_spec ohm_export_opts[];
int ohm_run_export(ohm_state *s, const ohm_invocation *inv, ohm_error *err);
void ohm_export_io(const ohm_invocation *inv, ohm_step_io *io);

#endif
