/* pipeline.h — actions declared as data, and chains of them.
 *
 * After OpenVDB's vdb_tool: a run is a chain of actions, each with key=value
 * options, executed left to right on one ohm_state.  The table in actions.c is
 * the single source of truth: parsing, validation, `ohm help` and the pipeline
 * file format are all driven by it, so the docs cannot drift from the code.
 *
 * A chain comes from the command line (`ohm -read file=a.obj -voxelize dim=64`)
 * or from a pipeline file (`ohm run FILE`): first line "ohm-pipeline 1", then
 * one action per line ("read file=a.obj", a leading '-' is optional), '#'
 * starts a comment, values may be "double quoted".  Both go through the same
 * validation and the same executor, so they produce identical results.
 * The whole chain is validated before anything runs — its options, and what
 * each step needs from the ones before it — so that a typo or a step that
 * cannot use an earlier one's result fails at once with exit 2, not after a
 * long solve. */
#ifndef OHM_PIPELINE_H
#define OHM_PIPELINE_H

#include <stddef.h>

#include "base/ohm_error.h"
#include "base/options.h"
#include "steps/state.h"

typedef struct ohm_action ohm_action;

/* One action with its parsed option values (text, validated). */
typedef struct ohm_invocation {
    const ohm_action *action;
    ohm_opt_values opts;        /* by the action's spec index (base/options.h) */
    char where[256];            /* "command line argument 3" / "x.ohm:12"   */
} ohm_invocation;

typedef int (*ohm_action_fn)(ohm_state *s, const ohm_invocation *inv, ohm_error *err);

/* What a step needs from the steps before it (or from the state the chain
 * starts on), and what it leaves for the steps after it: the whole chain is
 * checked against these before any step runs (ohm_chain_check), so that a
 * later step that cannot use an earlier one's result fails at once, not
 * after a long solve. */
enum {
    OHM_RES_MESH = 1u << 0,     /* a triangle mesh (-read of a mesh)           */
    OHM_RES_VOLUME = 1u << 1,   /* a density volume (-read of a scan)           */
    OHM_RES_GRID = 1u << 2,     /* the voxel object (-voxelize)                 */
    OHM_RES_MATERIAL = 1u << 3, /* -material                                    */
    OHM_RES_TRANSFER = 1u << 4, /* the material maps a volume's density         */
    OHM_RES_LIGHTS = 1u << 5,   /* at least one -light                          */
    OHM_RES_SOLUTION = 1u << 6, /* a solution for the lights there are (-solve) */
    OHM_RES_COUNT = 7
};

/* One need: any of the resources in `any`, when every one in `when` is
 * there (0: always); `missing` is the step's message without it ("no
 * lights: add -light first"). */
typedef struct ohm_need {
    unsigned any, when;
    const char *missing;
} ohm_need;

enum { OHM_MAX_NEEDS = 4 };

typedef struct ohm_step_io {
    ohm_need needs[OHM_MAX_NEEDS]; /* the first with any == 0 ends them   */
    unsigned provides;             /* resources it makes                  */
    unsigned drops;                /* resources it makes stale or removes */
} ohm_step_io;

/* An action's needs and products for one invocation (its options decide
 * some: -read of a mesh or a volume, -export ply=). */
typedef void (*ohm_action_io_fn)(const ohm_invocation *inv, ohm_step_io *io);

/* ohm_action.flags.  SETS_SCENE: sets up the scene (the material, the
 * lights), which a step that `waits` needs whichever side of it the user
 * wrote it on.  WRITES: writes files, so its option values name outputs,
 * never a staged file it would have to read (ohm_chain_run). */
enum { OHM_ACTION_SETS_SCENE = 1u, OHM_ACTION_WRITES = 2u };

struct ohm_action {
    const char *name;
    const char *summary;
    const char *doc;             /* a paragraph for `ohm help NAME`          */
    const ohm_opt_spec *opts;    /* terminated by {0}                        */
    ohm_action_fn run;
    unsigned flags;              /* OHM_ACTION_SETS_SCENE, OHM_ACTION_WRITES  */
    /* NULL or 1 when this invocation must see the whole scene: it then runs
     * after the scene-setting steps that directly follow it (-voxelize
     * error=, whose probes solve the scene) */
    int (*waits)(const ohm_invocation *inv);
    ohm_action_io_fn io;         /* what it needs and provides (above)       */
    /* NULL, or options that do not go together, found when the action's
     * words are parsed (before any step runs) */
    int (*check)(const ohm_invocation *inv, ohm_error *err);
};

/* The table (actions.c), terminated by an entry with name NULL. */
extern const ohm_action ohm_actions[];
const ohm_action *ohm_action_find(const char *name);

/* Option access for run functions.  Values were validated when parsed, so
 * these only fall back to the default (or 0 / "" when there is none). */
int ohm_opt_given(const ohm_invocation *inv, const char *name);
const char *ohm_opt_str(const ohm_invocation *inv, const char *name);
long long ohm_opt_int(const ohm_invocation *inv, const char *name);
double ohm_opt_real(const ohm_invocation *inv, const char *name);
void ohm_opt_vec3(const ohm_invocation *inv, const char *name, double out[3]);
/* REAL13: returns how many values (1 or 3) and fills out[0..2] (one value is
 * copied to all three). */
int ohm_opt_real13(const ohm_invocation *inv, const char *name, double out[3]);
/* The same values through base/opt_spec.h's reader, for a stage below the
 * steps that owns options (the light kinds). */
ohm_opt_reader ohm_opt_reader_of(const ohm_invocation *inv);

typedef struct ohm_chain {
    ohm_invocation *items;
    size_t n, cap;
} ohm_chain;

void ohm_chain_free(ohm_chain *c);

/* Parse argv[0..argc) ("-action", "key=value", ...).  OHM_ERR_USAGE with a
 * message naming the token and suggesting the nearest valid name (a first
 * word without '-': the nearest of `ohm`'s commands, or the action). */
int ohm_chain_parse_args(ohm_chain *c, int argc, const char *const *argv, ohm_error *err);

/* key=value words against the options of an action outside the table (a
 * call that takes options as an action does: the library's
 * ohm_scene_estimate), checked as the chain's parser checks them, into
 * *inv (where: "argument N" as on the command line); free it with
 * ohm_invocation_free.  The ohm_opt_* calls read it. */
int ohm_invocation_parse(ohm_invocation *inv, const ohm_action *a, int argc, const char *const *argv, ohm_error *err);
void ohm_invocation_free(ohm_invocation *inv);

/* Parse a pipeline file (or a buffer, for tests and fuzzing). */
int ohm_chain_parse_file(ohm_chain *c, const char *path, ohm_error *err);
int ohm_chain_parse_text(ohm_chain *c, const char *text, size_t len, const char *name, ohm_error *err);

/* Run every invocation in order (a step that `waits` after the scene steps
 * that follow it); stops at the first failure, whose message
 * names the action and where it came from.  All or nothing for its outputs:
 * every file the run writes is staged complete beside its target and
 * renamed into place only when the whole chain has succeeded, so a failed
 * run leaves every earlier file as it was (base/output.h).  A step that
 * reads a file the run has written first puts the outputs so far in place. */
int ohm_chain_run(const ohm_chain *c, ohm_state *s, ohm_error *err);

/* Help, generated from the table. */
void ohm_help_overview(FILE *f);
int ohm_help_action(FILE *f, const char *name, ohm_error *err);

#endif
