/* solve.h — stage: material + lights + voxel object -> fluence and exitance.
 *
 * Lights belong to frames (ohm_light.frame: 0 = every frame, k = frame k); a
 * frame is one column of the right-hand side, its lights summed.  For each
 * distinct channel material: assemble A, factorize it once (one symbolic
 * analysis shared by all channels), and solve every frame as a column of
 * multi-column right-hand sides (in batches when memory asks for it) — the
 * paper's point: a change of light never refactors.  Power is booked per solve:
 * in (deposited) = absorbed (sum G_a phi) + out (sum G_b phi), exact in this
 * discretisation up to round-off (docs/design.md §3). */
#ifndef OHM_SOLVE_H
#define OHM_SOLVE_H

#include "solvers/solve_types.h"

/* The kind of that name (direct | cg | amg | mg | auto | mc), or
 * OHM_ERR_USAGE naming them; its name; its capabilities. */
int ohm_solver_kind_parse(ohm_solver_kind *out, const char *name, ohm_error *err);
const char *ohm_solver_kind_name(ohm_solver_kind kind);
unsigned ohm_solver_kind_caps(ohm_solver_kind kind);

/* One solve from scratch: a solver with keep = 0, its solution moved into
 * *sol (freed with ohm_solution_free). */
int ohm_solve(ohm_solution *sol, const ohm_voxel_grid *grid, const ohm_material *mat, const ohm_light *lights,
              size_t nlights, const ohm_solve_params *params, const ohm_log *log, ohm_error *err);

void ohm_solution_free(ohm_solution *sol);

/* A solver: the network, media and occluder of one grid and material, and
 * (keep = 1) every distinct channel material's assembled matrix and set-up
 * backend kept between solves, so a change of light never sets up again —
 * the paper's relighting (a factor-once direct solve: two triangular solves
 * per light).  The grid and every array and object params points to must
 * outlive the solver (it keeps a copy of params, and copies of its strings;
 * give_media arrays are taken as by ohm_solve, whether create succeeds or
 * fails).  keep = 0 sets
 * up each medium in turn and releases it after one solve: ohm_solve's
 * memory. */
int ohm_solver_create(ohm_solver **out, const ohm_voxel_grid *grid, const ohm_material *mat,
                      const ohm_solve_params *params, int keep, const ohm_log *log, ohm_error *err);

/* The set-up phase, timed by itself (the solution's t_assemble, t_analyze,
 * t_factor, t_cg_setup): every distinct channel material of these lights
 * (their channels and frames size the batches auto's choice weighs)
 * assembled and its backend set up — factorized, or its preconditioner
 * built — so that ohm_solver_solve only solves.  keep = 0 holds one set-up
 * at a time: the first medium's is made here, the others as the solve
 * reaches them.  Optional: a solve sets up what is not set up yet.
 * solver=mc sets up nothing.  Cancellable (OHM_ERR_CANCELLED, the log's
 * cancel flag); after a failure the solver is still usable. */
int ohm_solver_setup(ohm_solver *s, const ohm_light *lights, size_t nlights, ohm_error *err);

/* Solve for these lights (frames as for ohm_solve), replacing the solver's
 * solution: its results and per-solve statistics are this call's, its setup
 * statistics (factors, analyses, setup times) summed over the solver's life.
 * After a failure the solution holds no valid result until the next solve
 * succeeds. */
int ohm_solver_solve(ohm_solver *s, const ohm_light *lights, size_t nlights, ohm_error *err);

/* The latest solve's solution, owned by the solver. */
const ohm_solution *ohm_solver_solution(const ohm_solver *s);

/* *reaches = whether light lights any part of the object's surface (in
 * shadow or off the object it lights none), whatever its intensity.  The
 * -solve step warns about a light that does not, the same way for every
 * type of light. */
int ohm_solver_light_reaches(const ohm_solver *s, const ohm_light *light, int *reaches, ohm_error *err);

/* hybrid=auto, decided once the solver can trace the lights: the hybrid
 * (mc.handoff) turned off when no pencil beam among them reaches the
 * object, so a beam that misses costs no photons and labels nothing
 * "hybrid".  Changes only the solver's copy of the parameters. */
int ohm_solver_settle_auto_hybrid(ohm_solver *s, const ohm_light *lights, size_t nlights, ohm_error *err);

/* The parameters it solves with (the solver's copy: its strings and the
 * band's compacted arrays are the solver's own). */
const ohm_solve_params *ohm_solver_params(const ohm_solver *s);

void ohm_solver_free(ohm_solver *s); /* NULL is fine */

/* Every cell's exitance in one channel and frame, into out[n]: the power
 * leaving through its boundary faces per unit area, the mean of their
 * face_exitance; 0 for a cell with none.  It is derived when an output asks,
 * not stored: a stored copy was 8 B per cell per channel and frame, held
 * through the solve, for values that are nonzero only on the surface. */
void ohm_solution_exitance_frame(double *out, const ohm_solution *sol, int channel, int frame);

/* The power (W) leaving through boundary face f in one channel and frame:
 * its face_exitance times its area. */
double ohm_solution_face_power(const ohm_solution *sol, int channel, int frame, int64_t f);

/* Channel c's sigma_a (ss = 0) or reduced scattering sigma_s' (ss = 1), 1/mm,
 * per unknown into out[n], when it varies cell by cell (returns 1; for the
 * sigma_a / sigma_s output grids); 0, out untouched, when it is the
 * material's constant.  out NULL: only whether it varies. */
int ohm_solution_medium(double *out, const ohm_solution *sol, int c, int ss);

/* Whether any coefficient varies cell by cell (ohm_solution_medium). */
int ohm_solution_medium_varies(const ohm_solution *sol);

/* |in - absorbed - out| / in */
double ohm_solution_conservation_error(const ohm_solution *sol);

#endif
