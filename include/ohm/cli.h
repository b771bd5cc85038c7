/* ohm/cli.h — what a program needs to be ohm's command line, beside the
 * scene API of <ohm.h>: the help text, the studies, distributed runs under
 * mpirun, and clean-up on signals.  Process concerns, kept out of ohm.h:
 * a library that uses ohm needs none of them.  The same error contract as
 * ohm.h: OHM_OK or a negative OHM_ERR_*. */
#ifndef OHM_PUBLIC_CLI_H
#define OHM_PUBLIC_CLI_H

#include <stdio.h>

#include "ohm.h"

#ifdef __cplusplus
extern "C" {
#endif

/* `ohm help` (action NULL) or `ohm help ACTION`, generated from the action
 * table, written to stream. */
OHM_API int ohm_help(FILE *stream, const char *action);

/* The studies: `ohm validate|bench|accuracy|devices ARGS` (argv[0] is the study's
 * name).  Tables go to stdout, messages (and the study's own error lines)
 * to stderr at ctx's verbosity (ctx may be NULL: normal).  OHM_OK when it
 * ran and every check passed; OHM_ERR_USAGE for bad arguments;
 * OHM_ERR_NUMERIC when it ran and a check failed or a step of it did
 * (its messages said which). */
OHM_API int ohm_study(ohm_context *ctx, int argc, char **argv);

/* Distributed solves (solver=amg under mpirun): first thing in main.
 * *serving is set to 1 on a rank that serves the others' solves (call
 * ohm_parallel_serve, then exit), 0 on the rank that runs the program.
 * A negative OHM_ERR_* when MPI could not start (it said why on stderr).
 * Without MPI (or outside mpirun) OHM_OK with *serving 0.  Process-wide:
 * MPI and PETSc start once per process. */
OHM_API int ohm_parallel_start(int *serving);

/* On a serving rank: take part in the program rank's solves until it calls
 * ohm_parallel_finish; OHM_OK, or a negative OHM_ERR_* when a solve failed. */
OHM_API int ohm_parallel_serve(void);

/* On the program rank, at the end: release the serving ranks. */
OHM_API void ohm_parallel_finish(void);

/* Remove half-written output files when the process is interrupted (SIGINT,
 * SIGTERM, SIGHUP): installs a process-wide handler, for programs, not for
 * libraries that own their signals.  Thread-safe: the list of files in
 * flight is kept with atomic operations. */
OHM_API void ohm_cleanup_outputs_on_signal(void);

#ifdef __cplusplus
}
#endif
#endif
