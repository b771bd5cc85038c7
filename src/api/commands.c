/* api/commands.c — the command line's other entry points: help, the
 * studies, distributed runs, interrupted outputs (include/ohm.h). */
#include "api/api.h"

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
    if (argc < 1 || !argv) {
        ohm_api_fail(OHM_ERR_USAGE, "ohm_study: no study named");
        return 2;
    }
    return ohm_study_main(argc, argv, ctx ? ctx->log.verbosity : 1);
}

int ohm_parallel_start(void)
{
    return ohm_mpi_start();
}

int ohm_parallel_serve(void)
{
    return ohm_mpi_serve();
}

void ohm_parallel_finish(void)
{
    ohm_mpi_finish();
}

void ohm_cleanup_outputs_on_signal(void)
{
    ohm_output_install_signal_cleanup();
}
