/* api/commands.c — the command line's other entry points: help, the
 * studies, distributed runs, interrupted outputs (include/ohm.h). */
#include "api/api.h"
#include "ohm/cli.h"

#include "base/output.h"
#include "solvers/amg.h"
#include "steps/pipeline.h"
#include "studies/study.h"

int ohm_help(FILE *stream, const char *action)
{
    if (!stream) return ohm_api_fail(OHM_ERR_USAGE, "ohm_help: stream is NULL");
    if (!action) {
        ohm_help_overview(stream);
        return OHM_OK;
    }
    ohm_error err;
    ohm_error_clear(&err);
    return ohm_api_return(ohm_help_action(stream, action, &err), &err);
}

int ohm_study(ohm_context *ctx, int argc, char **argv)
{
    if (argc < 1 || !argv) return ohm_api_fail(OHM_ERR_USAGE, "ohm_study: no study named");
    /* the studies speak in the command line's exit codes (they print their
     * own error lines): 0 done, 2 bad usage, 1 anything else */
    int code = ohm_study_main(argc, argv, ctx ? ctx->log.verbosity : 1);
    if (code == 0) return OHM_OK;
    if (code == 2) return ohm_api_fail(OHM_ERR_USAGE, "ohm %s: bad usage (see its messages)", argv[0]);
    return ohm_api_fail(OHM_ERR_NUMERIC, "ohm %s: failed (see its messages)", argv[0]);
}

int ohm_parallel_start(int *serving)
{
    if (!serving) return ohm_api_fail(OHM_ERR_USAGE, "ohm_parallel_start: serving is NULL");
    int rc = ohm_mpi_start(); /* 0 the program's rank, > 0 a serving rank, < 0 no MPI */
    *serving = rc > 0;
    if (rc < 0) return ohm_api_fail(OHM_ERR_INTERNAL, "ohm_parallel_start: MPI could not start (see stderr)");
    return OHM_OK;
}

int ohm_parallel_serve(void)
{
    int status = ohm_mpi_serve(); /* the rank's exit status */
    return status == 0 ? OHM_OK : ohm_api_fail(OHM_ERR_NUMERIC, "ohm_parallel_serve: a distributed solve failed");
}

void ohm_parallel_finish(void)
{
    ohm_mpi_finish();
}

void ohm_cleanup_outputs_on_signal(void)
{
    ohm_output_install_signal_cleanup();
}
