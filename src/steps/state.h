/* state.h — what a run's actions share, left to right (docs/design.md §8): the
 * current mesh, the voxel object, the statistics, the log.  One per run, owned
 * by the caller; no action keeps anything elsewhere. */
#ifndef OHM_STATE_H
#define OHM_STATE_H

#include "physics/light.h"
#include "base/log.h"
#include "physics/material.h"
#include "input/mesh.h"
#include "base/output.h"
#include "input/scan.h"
#include "input/transfer.h"
#include "solvers/solve.h"
#include "base/stats.h"
#include "grid/voxelize.h"

/* The set-up times a solve books (report_solve, actions.c). */
enum { OHM_SETUP_TIMES = 7 };

typedef struct ohm_state {
    ohm_log log;
    ohm_stats stats;

    int have_mesh;
    ohm_mesh mesh;                  /* in millimetres (scaled by -read)        */
    char mesh_path[OHM_PATH_MAX];
    double mesh_scale_mm;           /* millimetres per unit of the file        */

    int have_grid;
    ohm_voxel_grid grid;
    int mesh_flipped;               /* the voxelizer read the mesh inside-out  */

    int have_scan;                  /* a density volume (CT / MRI / .vdb)      */
    ohm_scan scan;
    char scan_path[OHM_PATH_MAX];

    int have_material;
    ohm_material material;
    int have_transfer;              /* the material maps the scan's density    */
    ohm_transfer transfer;
    char transfer_path[OHM_PATH_MAX];

    ohm_light *lights;              /* every -light so far, in order           */
    size_t nlights;

    /* -voxelize error=: the accuracy asked (0: none) and the lower bound on
     * diffusion's model error its probe measured (-1: not measured), which
     * -solve model=auto reads (steps/resolution.h); a grid made without
     * error= or a new material drops them */
    double error_target, model_error;

    /* The latest -solve: its network, media and solution, and with keep=1
     * every channel material's factor, for relighting (ohm_state_relight).
     * A new mesh, grid, volume or material frees it; a new light only makes
     * the solution stale (have_solution = 0). */
    ohm_solver *solver;
    double *solver_eta, *solver_g;  /* per-cell index and anisotropy it reads  */
    int have_solution;              /* the solver's solution is for these lights */
    char solve_options[160];        /* boundary=... fluence=...: for metadata  */
    char solution_desc[320];        /* those, the lights and the solver        */
    /* the solver's set-up seconds (network, assembly, factor, ...) booked
     * in the statistics so far: a relight books only what it added */
    double setup_booked[OHM_SETUP_TIMES];

    /* The running chain's outputs, staged until it has succeeded
     * (ohm_chain_run); NULL outside a run: writes then rename at once. */
    ohm_output_batch *outputs;
} ohm_state;

void ohm_state_init(ohm_state *s);
void ohm_state_free(ohm_state *s);

/* Take *m (millimetres, `scale` mm per unit of its source) or *scan as the
 * state's mesh or volume, as -read does with a file (logged, booked in the
 * statistics, later stages dropped); `name` stands for the file in messages
 * and metadata, t0 is when reading began.  *m / *scan is moved (zeroed),
 * and freed when set_mesh fails. */
int ohm_state_set_mesh(ohm_state *s, ohm_mesh *m, const char *name, double scale, double t0, ohm_error *err);
void ohm_state_set_scan(ohm_state *s, ohm_scan *scan, const char *name, double t0);

/* The current solution, or NULL when there is none (or it is stale). */
const ohm_solution *ohm_state_solution(const ohm_state *s);

/* Solve the state's lights again with the kept setup of the last -solve
 * (keep=1: no factorization), as -solve would log and book them. */
int ohm_state_relight(ohm_state *s, ohm_error *err);

#endif
