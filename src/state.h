/* state.h — what a run's actions share, left to right (DESIGN.md §7): the
 * current mesh, the voxel object, the statistics, the log.  One per run, owned
 * by the caller; no action keeps anything elsewhere. */
#ifndef OHM_STATE_H
#define OHM_STATE_H

#include "log.h"
#include "mesh.h"
#include "output.h"
#include "stats.h"
#include "voxelize.h"

typedef struct ohm_state {
    ohm_log log;
    ohm_stats stats;

    int have_mesh;
    ohm_mesh mesh;                  /* in millimetres (scaled by -read)        */
    char mesh_path[OHM_PATH_MAX];
    double mesh_scale_mm;           /* millimetres per unit of the file        */

    int have_grid;
    ohm_voxel_grid grid;
} ohm_state;

void ohm_state_init(ohm_state *s);
void ohm_state_free(ohm_state *s);

#endif
