/* cli.c — the `ohm` command, a client of the public API (include/ohm.h)
 * and of nothing else: help, version, the studies, pipeline files and
 * chains of actions, with their results mapped to exit codes. */
#include "cli/cli.h"

#include <signal.h>
#include <stdio.h>
#include <string.h>

#include "ohm.h"
#include "ohm/cli.h"

/* 130: stopped by Ctrl-C (128 + SIGINT, as shells report it) */
static int exit_code(int rc)
{
    return rc == OHM_OK ? 0 : rc == OHM_ERR_USAGE ? 2 : rc == OHM_ERR_CANCELLED ? 128 + SIGINT : 1;
}

/* Ctrl-C: the first asks the running scene to stop (it returns
 * OHM_ERR_CANCELLED within about a second, its staged outputs removed); a
 * second one, if the first is not answered, does what it did before the
 * scene ran: the library's clean-up of temporaries, then the default
 * action.  The context is the process's one running scene's. */
static ohm_context *volatile interrupted_ctx;
static struct sigaction before_scene;

static void on_interrupt(int sig)
{
    (void)sig;
    ohm_context_cancel(interrupted_ctx); /* one atomic store: async-signal-safe */
    sigaction(SIGINT, &before_scene, NULL);
}

static void catch_interrupt(ohm_context *ctx)
{
    interrupted_ctx = ctx;
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_interrupt;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, &before_scene);
}

static void release_interrupt(void)
{
    sigaction(SIGINT, &before_scene, NULL);
    interrupted_ctx = NULL;
}

static int report(int rc)
{
    if (rc) fprintf(stderr, "ohm: error: %s\n", ohm_error_last()[0] ? ohm_error_last() : "failed");
    return exit_code(rc);
}

/* A pipeline file (path) or a chain of command-line words, on a new scene. */
static int run_scene(int verbosity, const char *path, int argc, char **argv)
{
    ohm_context *ctx = NULL;
    ohm_scene *scene = NULL;
    int rc = ohm_context_new(&ctx);
    if (!rc) {
        ohm_context_set_verbosity(ctx, verbosity);
        rc = ohm_scene_new(&scene, ctx);
    }
    /* (char ** to const char *const *: the words are only read) */
    if (!rc) {
        catch_interrupt(ctx);
        rc = path ? ohm_scene_run_file(scene, path) : ohm_scene_run_args(scene, argc, (const char *const *)argv);
        release_interrupt();
    }
    ohm_scene_free(scene);
    ohm_context_free(ctx);
    return report(rc);
}

int ohm_cli_main(int argc, char **argv)
{
    ohm_cleanup_outputs_on_signal(); /* Ctrl-C leaves no partial output */
    int verbosity = 1, first = 1;
    while (first < argc) {
        if (strcmp(argv[first], "--quiet") == 0 || strcmp(argv[first], "-q") == 0) verbosity = 0;
        else if (strcmp(argv[first], "--verbose") == 0 || strcmp(argv[first], "-v") == 0) verbosity = 2;
        else break;
        ++first;
    }
    if (first >= argc) {
        ohm_help(stderr, NULL);
        return 2;
    }
    const char *cmd = argv[first];
    if (strcmp(cmd, "help") == 0 || strcmp(cmd, "--help") == 0 || strcmp(cmd, "-h") == 0 ||
        strcmp(cmd, "-help") == 0)
        return report(ohm_help(stdout, first + 1 < argc ? argv[first + 1] : NULL));
    if (strcmp(cmd, "--version") == 0 || strcmp(cmd, "version") == 0) {
        printf("ohm %s\n", ohm_version(NULL, NULL, NULL));
        return 0;
    }
    if (strcmp(cmd, "bench") == 0 || strcmp(cmd, "accuracy") == 0 || strcmp(cmd, "validate") == 0 ||
        strcmp(cmd, "devices") == 0) {
        ohm_context *ctx = NULL;
        if (ohm_context_new(&ctx)) return report(OHM_ERR_NOMEM);
        ohm_context_set_verbosity(ctx, verbosity);
        int rc = ohm_study(ctx, argc - first, argv + first); /* it printed its own errors */
        ohm_context_free(ctx);
        return exit_code(rc);
    }
    if (strcmp(cmd, "run") == 0) {
        if (first + 2 != argc) {
            fprintf(stderr, "ohm: error: usage: ohm run PIPELINE_FILE\n");
            return 2;
        }
        return run_scene(verbosity, argv[first + 1], 0, NULL);
    }
    return run_scene(verbosity, NULL, argc - first, argv + first);
}
