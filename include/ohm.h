/* ohm.h — ohm's public C API: subsurface light scattering in voxel volumes.
 *
 * This header is the manual.  ohm turns a closed mesh (or a density volume
 * from a CT/MRI scan) into a grid of voxel cells, gives them a material,
 * lights them, and solves the diffusion of light inside as a resistor
 * network whose matrix is factored once and reused for every light (Sharp &
 * Machiraju, "Accelerating Subsurface Scattering Using Cholesky
 * Factorization").  The results are fluence and exitance per cell, exitance
 * per mesh vertex, the power balance, and files: .vdb volumes for Blender,
 * PLY meshes, POV-Ray df3, preview images, JSON statistics.
 *
 * Objects (opaque handles, after Embree and libgit2):
 *
 *   ohm_context  what a caller's runs share: verbosity, the log and progress
 *                callbacks.  A context may serve many scenes; it must outlive
 *                them.  Use one context per thread, or serialise calls.
 *   ohm_scene    one object and its light: the mesh or volume, the voxel
 *                grid, the material, the lights, and the solver set up for
 *                them (the factor, kept for relighting), plus the scene's
 *                statistics.  Not thread-safe: one thread at a time.
 *
 * Conventions:
 *   - Every call that can fail returns int: OHM_OK (0) or a negative
 *     OHM_ERR_* (ohm/common.h).  The message of the calling thread's latest
 *     failure is ohm_error_last(), which never returns NULL (libgit2's
 *     git_error_last).  Messages name the file, line, action or option that
 *     is wrong and what was expected.
 *   - Output parameters come first; a handle's free function accepts NULL.
 *   - No hidden global state: everything lives in the context and the
 *     scene.  What is per process or per thread, and why: the last-error
 *     message (per thread); the list of output files being written, for
 *     ohm_cleanup_outputs_on_signal (ohm/cli.h; updated with atomic
 *     operations, safe from any thread); while a thread factorizes, a
 *     thread-local pointer through which CHOLMOD's BLAS calls report
 *     progress and see cancellation (libohm defines dsyrk_, dgemm_, dtrsm_
 *     and dpotrf_ in front of the BLAS: other callers pass straight
 *     through); MPI and PETSc's start (ohm/cli.h).  No C++ exception crosses
 *     this API.
 *   - The ABI only grows within a major version (the SONAME is
 *     libohm.so.MAJOR; CMake's package accepts any MINOR.PATCH of the
 *     MAJOR asked for): functions are added, never changed or removed, and
 *     a struct the caller allocates begins with its size (set it with the
 *     struct's *_INIT), so that fields added at its end later are neither
 *     written past an older caller's struct nor expected from an older
 *     library (it fills the fields it knows and leaves the rest as
 *     initialised).
 *   - Lengths are in millimetres, powers in watts, fluence and exitance in
 *     W/mm^2.  Arrays over the grid are x fastest: cell (i, j, k) is at
 *     i + dims[0] * (j + dims[1] * k), its centre at origin + voxel * (i, j, k).
 *
 * The steps of a scene are ohm's pipeline actions (`ohm help` lists them,
 * `ohm help ACTION` gives every option): read, voxelize, material, light,
 * solve, place, write, export, render, stats.  ohm_scene_run runs one with
 * "key=value" options, exactly as the command line's `-ACTION key=value`;
 * the typed calls below hand over and read back arrays.  A minimal program:
 *
 *     ohm_context *ctx = NULL;
 *     ohm_scene *scene = NULL;
 *     const char *read[] = {"file=bunny.obj", "size=50", NULL};
 *     const char *vox[] = {"dim=64", NULL}, *mat[] = {"preset=marble", NULL};
 *     const char *light[] = {"type=directional", "dir=0,-1,0", NULL};
 *     if (ohm_context_new(&ctx) || ohm_scene_new(&scene, ctx) ||
 *         ohm_scene_run(scene, "read", read) || ohm_scene_run(scene, "voxelize", vox) ||
 *         ohm_scene_run(scene, "material", mat) || ohm_scene_add_light(scene, light) ||
 *         ohm_scene_solve(scene, NULL))
 *         fprintf(stderr, "%s\n", ohm_error_last());
 *     ohm_scene_free(scene);
 *     ohm_context_free(ctx);
 *
 * Relighting: ohm_scene_solve keeps its solver's setup; ohm_scene_clear_lights,
 * ohm_scene_add_light and ohm_scene_relight then solve new lights without
 * setting up again: with solver=direct, two triangular solves each, never
 * factoring again.  The default, solver=auto, solves the first light by
 * multigrid and chooses for the relights once it has timed one (the
 * statistics' solver and solver_reason say what it took and why);
 * ohm_scene_estimate predicts that choice and the memory before any solve.
 *
 * Linking: pkg-config --cflags --libs ohm, or CMake's find_package(ohm)
 * and target ohm::ohm. */
#ifndef OHM_H
#define OHM_H

#include <stddef.h>
#include <stdint.h>

#include "ohm/common.h"

/* The version of this header; ohm_version() gives the library's. */
#define OHM_VERSION_MAJOR 1
#define OHM_VERSION_MINOR 2
#define OHM_VERSION_PATCH 0

#if defined(__GNUC__) || defined(__clang__)
#define OHM_API __attribute__((visibility("default")))
#else
#define OHM_API
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* ---- version and errors -------------------------------------------------- */

/* "MAJOR.MINOR.PATCH" of the library linked; major, minor, patch (each may
 * be NULL) get its numbers. */
OHM_API const char *ohm_version(int *major, int *minor, int *patch);

/* The message of this thread's latest failed call ("" when none failed);
 * never NULL.  Valid until this thread's next failing call. */
OHM_API const char *ohm_error_last(void);

/* The status of this thread's latest failed call, OHM_OK when none. */
OHM_API int ohm_error_last_code(void);

/* ---- context ------------------------------------------------------------- */

typedef struct ohm_context ohm_context;

/* A message: level OHM_LOG_WARNING or OHM_LOG_INFO, one line of text with
 * no trailing newline. */
typedef void (*ohm_log_callback)(void *user, int level, const char *text);

/* Progress of a long step: what it is ("voxelize", "solve", ...) and the
 * fraction done, in [0, 1]; 1 when it ends.  Called from the thread that
 * called into ohm (or, for some steps, a thread of ohm's own), at least about
 * ten times a second while a long step runs; it should return quickly.  It
 * may call ohm_context_cancel to stop the call. */
typedef void (*ohm_progress_callback)(void *user, const char *what, double fraction);

/* A new context into *out: verbosity 1, messages and progress on stderr.
 * OHM_ERR_NOMEM when out of memory (*out is then NULL). */
OHM_API int ohm_context_new(ohm_context **out);

/* Release a context; NULL is accepted.  Free its scenes first. */
OHM_API void ohm_context_free(ohm_context *ctx);

/* 0: warnings only, 1: normal (the default), 2: verbose. */
OHM_API void ohm_context_set_verbosity(ohm_context *ctx, int verbosity);

/* Where messages go; fn NULL: stderr, as "ohm: TEXT" lines (the default). */
OHM_API void ohm_context_set_log(ohm_context *ctx, ohm_log_callback fn, void *user);

/* fn NULL: progress lines on stderr for steps longer than a second. */
OHM_API void ohm_context_set_progress(ohm_context *ctx, ohm_progress_callback fn, void *user);

/* Progress for polling instead of a callback (since 1.1): the context keeps
 * each report, calls nothing and prints nothing, and any thread reads the
 * latest with ohm_context_progress.  For a caller whose callback would have
 * to take a lock the calling thread does not hold (Python's, in Blender: a
 * callback ten times a second waits on the main thread each time).
 * ohm_context_set_progress ends it. */
OHM_API void ohm_context_poll_progress(ohm_context *ctx);

/* The latest progress report of a polling context: what ("" before the
 * first, truncated to size - 1 bytes) and the fraction done. */
OHM_API int ohm_context_progress(ohm_context *ctx, char *what, size_t size, double *fraction);

/* Ask the call running on a scene of this context to stop: it returns
 * OHM_ERR_CANCELLED within about a second, having freed what it made and
 * written no file (a run's outputs are staged and put in place only when
 * it succeeds); the scene keeps what it held before that step and solves
 * again normally.  Any thread may call this, and so may the progress
 * callback and a signal handler (it is one lock-free atomic store).  A
 * request applies to the call running when it is made: every call that
 * runs steps (ohm_scene_run and the calls built on it, ohm_scene_solve,
 * ohm_scene_relight) drops, as it begins, a request made before it — one
 * aimed at a call that had already returned, or made while none ran — so
 * a late Esc never stops the next solve.  (A caller that cancels a job of
 * several calls should also stop issuing them: a request that arrives
 * between two calls is dropped by the second.)  Stopped at once:
 * reading slices, voxelizing, factorizing (between CHOLMOD's supernodes),
 * conjugate gradients (every iteration), Monte Carlo (every few hundred
 * photons) and between a run's steps and output files; the METIS ordering
 * and PETSc/hypre's set-up finish their current piece first. */
OHM_API void ohm_context_cancel(ohm_context *ctx);

/* ---- scene: steps --------------------------------------------------------- */

typedef struct ohm_scene ohm_scene;

/* A new, empty scene into *out (no mesh, grid, material or lights), which
 * reports through ctx (not NULL; it must outlive the scene). */
OHM_API int ohm_scene_new(ohm_scene **out, ohm_context *ctx);

/* Release a scene with its mesh, grid, solver and factor; NULL is
 * accepted.  Files it wrote stay. */
OHM_API void ohm_scene_free(ohm_scene *scene);

/* Run one action ("read", "voxelize", "material", "light", "solve", "place",
 * "write", "export", "render", "stats") with options, a NULL-terminated
 * array of "key=value" strings (NULL: none), as `ohm -ACTION key=value ...`
 * does.  Unknown actions and options fail with OHM_ERR_USAGE naming them. */
OHM_API int ohm_scene_run(ohm_scene *scene, const char *action, const char *const *options);

/* Run a chain of actions given as command-line words ("-read", "file=a.obj",
 * "-voxelize", ...), validated whole before any runs. */
OHM_API int ohm_scene_run_args(ohm_scene *scene, int argc, const char *const *argv);

/* Run a pipeline file (first line "ohm-pipeline 1", then one action per
 * line; `ohm help` describes the format), validated whole before any runs. */
OHM_API int ohm_scene_run_file(ohm_scene *scene, const char *path);

/* Hand over a triangle mesh, in millimetres: positions[3 * v + a] for
 * vertex v, axis a; triangles[3 * t + q] the q-th vertex of triangle t,
 * 0-based.  Copied; replaces the scene's mesh and drops its grid and
 * solution, as -read of a mesh file does.  `name` (may be NULL) stands for
 * the file in messages and metadata. */
OHM_API int ohm_scene_set_mesh(ohm_scene *scene, const double *positions, size_t nvertices,
                               const int64_t *triangles, size_t ntriangles, const char *name);

/* Hand over a density volume (CT/MRI intensities, or any scalar):
 * values[i + dims[0] * (j + dims[1] * k)], and the map from voxel index to
 * world millimetres, world = M (i, j, k, 1)^T with M row-major 3 x 4
 * (index_to_world[4 * row + col]), at voxel centres.  Copied; replaces the
 * scene's volume, as -read of a volume file does.  A transfer function
 * (-material transfer=FILE) maps it to optical coefficients; alone,
 * -voxelize threshold= makes the object from it: the cells between its
 * outermost voxel centres whose value passes, never one outside them.
 * Outside them the volume reads as its lowest value. */
OHM_API int ohm_scene_set_density(ohm_scene *scene, const float *values, const int64_t dims[3],
                                  const double index_to_world[12], const char *name);

/* Add one light: options as for the "light" action (type=directional |
 * point | spot | area | pencil | environment, and its position, direction,
 * power, colour, orbit=; an environment's sky=FILE, an equirectangular
 * .hdr or .exr; docs/lights.md).  A new kind of light is a new type= word
 * here, not a new function: the ABI stays as it is. */
OHM_API int ohm_scene_add_light(ohm_scene *scene, const char *const *options);

/* Remove every light (the setup of the last solve stays, for relighting). */
OHM_API int ohm_scene_clear_lights(ohm_scene *scene);

/* Solve the scene's lights: options as for the "solve" action (solver=auto
 * unless told); unless options say keep=0, the factor (or preconditioner,
 * or hierarchy) of every channel material is kept for ohm_scene_relight. */
OHM_API int ohm_scene_solve(ohm_scene *scene, const char *const *options);

/* Solve the scene's current lights again with the setup of the last
 * ohm_scene_solve: no new factorization.  A new mesh, grid, volume or
 * material needs ohm_scene_solve again (OHM_ERR_INVALID says so). */
OHM_API int ohm_scene_relight(ohm_scene *scene);

/* ---- scene: results ------------------------------------------------------ */

typedef struct ohm_grid_info {
    size_t size;            /* sizeof(ohm_grid_info): OHM_GRID_INFO_INIT sets it */
    int32_t dims[3];        /* cells per axis                                  */
    double origin[3];       /* centre of cell (0, 0, 0), mm                    */
    double voxel;           /* cell edge, mm                                   */
    int64_t cells;          /* dims[0] * dims[1] * dims[2]                     */
    int64_t interior_cells; /* cells inside the object                         */
    /* (1.0's fields end here; later ones are added below) */
} ohm_grid_info;
#define OHM_GRID_INFO_INIT {sizeof(ohm_grid_info), {0, 0, 0}, {0, 0, 0}, 0, 0, 0}

/* The scene's voxel grid (OHM_ERR_INVALID before voxelize) into *out,
 * whose size member says how much of it the caller has
 * (OHM_GRID_INFO_INIT); OHM_ERR_USAGE when it is smaller than 1.0's. */
OHM_API int ohm_scene_grid(ohm_grid_info *out, const ohm_scene *scene);

/* inside[cell] = 1 for the object's cells, 0 elsewhere; count must be the
 * grid's cells. */
OHM_API int ohm_scene_inside(uint8_t *inside, size_t count, const ohm_scene *scene);

typedef struct ohm_result_info {
    size_t size;             /* sizeof(ohm_result_info): OHM_RESULT_INFO_INIT   */
    int channels;            /* 1 (grey) or 3 (r, g, b)                         */
    int frames;              /* lights' frames solved (1 without orbits)        */
    int64_t unknowns;        /* cells solved                                    */
    int factorizations;      /* over the scene's solver's life                  */
    int64_t solves;          /* right-hand sides of the latest solve            */
    double residual;         /* largest scaled backward error                   */
    double power_incident;   /* W arriving on the surface                       */
    double power_entered;    /* W through it, after Fresnel reflection          */
    double power_in;         /* W deposited in the medium (the source)          */
    double power_absorbed;   /* W absorbed inside                               */
    double power_out;        /* W leaving: power_in = absorbed + out           */
    double seconds_setup;    /* analysis + factorization (or preconditioner)    */
    double seconds_solve;    /* the latest solve's sources and solves           */
    /* (1.0's fields end here; later ones are added below) */
} ohm_result_info;
#define OHM_RESULT_INFO_INIT {sizeof(ohm_result_info), 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0}

/* The latest solve's figures (OHM_ERR_INVALID when there is no current
 * solution: none yet, or lights changed since) into *out, sized as
 * ohm_scene_grid's. */
OHM_API int ohm_scene_result(ohm_result_info *out, const ohm_scene *scene);

/* The layout of a sized struct as this library knows it, for bindings that
 * cannot include this header (the Python package builds its ctypes
 * structs from it instead of copying them, so it sees the fields a later
 * 1.x adds).  One entry per member, in order. */
typedef enum ohm_member_type {
    OHM_MEMBER_SIZE = 1, /* size_t  */
    OHM_MEMBER_INT = 2,  /* int     */
    OHM_MEMBER_INT32 = 3,
    OHM_MEMBER_INT64 = 4,
    OHM_MEMBER_DOUBLE = 5,
    OHM_MEMBER_CHAR = 6  /* char: a text of up to count - 1 bytes, NUL-terminated (1.2) */
} ohm_member_type;

typedef struct ohm_struct_member {
    const char *name; /* the member's name in this header             */
    size_t offset;    /* offsetof(struct, member)                      */
    int type;         /* ohm_member_type of one element                 */
    int count;        /* elements: 3 for an array of three, else 1     */
} ohm_struct_member;

/* The members of struct `name` ("ohm_grid_info", "ohm_result_info" or,
 * from 1.2, "ohm_estimate_info") as
 * this library lays them out: *count entries, and the struct's size in
 * *size (either pointer may be NULL).  NULL, with the last error set, for
 * a name that is no sized struct of this library's. */
OHM_API const ohm_struct_member *ohm_struct_members(const char *name, size_t *count, size_t *size);

/* The fluence rate per grid cell (W/mm^2) for one channel and frame
 * (0-based); count = the grid's cells; 0 outside the object or below a
 * depth band. */
OHM_API int ohm_scene_fluence(double *out, size_t count, const ohm_scene *scene, int channel, int frame);

/* The exitance per grid cell (W/mm^2 leaving the cell's boundary faces; 0
 * for a cell with none), for one channel and frame, laid out as
 * ohm_scene_fluence. */
OHM_API int ohm_scene_exitance(double *out, size_t count, const ohm_scene *scene, int channel, int frame);

/* Exitance at each mesh vertex, out[v * channels + c] (count = vertices x
 * channels), as `-export ply=` colours it. */
OHM_API int ohm_scene_vertex_exitance(float *out, size_t count, const ohm_scene *scene, int frame);

/* A numeric figure of the scene's statistics (the keys of `-stats`:
 * "cells", "t_factor", "power_out", "factors", ...) into *out;
 * OHM_ERR_INVALID for a key it does not hold or that holds a text. */
OHM_API int ohm_scene_stat(double *out, const ohm_scene *scene, const char *key);

/* A text figure of the scene's statistics ("solver", "material", ...) into
 * *text, the scene's own string, valid until the scene's next call;
 * OHM_ERR_INVALID for a key it does not hold or that holds a number. */
OHM_API int ohm_scene_stat_text(const char **text, const ohm_scene *scene, const char *key);

/* ---- scene: what a solve will take, before anything is built (1.2) ------- */

typedef struct ohm_estimate_info {
    size_t size;            /* sizeof(ohm_estimate_info): OHM_ESTIMATE_INFO_INIT */
    int64_t interior_cells; /* predicted cells inside the object at dim=       */
    int64_t grid_cells;     /* cells of the grid's box, its margin included    */
    double bytes_direct;    /* the process's predicted peak (B) with each solver */
    double bytes_cg;
    double bytes_amg;
    double bytes_mg;
    double bytes_auto;
    double bytes_allowed;   /* max_memory=, or what the machine has available  */
    double margin;          /* the model's error margin: a solve is judged to
                               fit when its bytes x margin <= bytes_allowed    */
    int largest_dim;        /* the largest dim= that fits with `solver`; 0: none */
    int largest_dim_mg;     /* the same with mg                                 */
    char solver[16];        /* solver= as asked, or what solver=auto would take */
    char reason[256];       /* auto: its predicted times, and what fits        */
} ohm_estimate_info;
#define OHM_ESTIMATE_INFO_INIT {sizeof(ohm_estimate_info), 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, "", ""}

/* The memory a solve of the scene's mesh would take at dim= cells across,
 * with each solver, and the solver solver=auto would take for it, predicted
 * from the mesh's size and shape without building anything (the model:
 * docs/blender.md), into *out (sized as ohm_scene_grid's).  Options:
 * dim=N (required), solver=auto|direct|cg|amg|mg (default auto: *out
 * names its choice), channels=1..3 (default the scene's material's, else
 * 3), solves=N (solves of each channel to come, relights included;
 * default 1), max_memory=MB (default what the machine has available).
 * OHM_ERR_INVALID without a mesh. */
OHM_API int ohm_scene_estimate(ohm_estimate_info *out, const ohm_scene *scene, const char *const *options);

#ifdef __cplusplus
}
#endif
#endif
