/* subcommand.h — what `ohm bench` and `ohm accuracy` share: key=value words
 * after the command, `help`, a usage error that names the command (exit 2),
 * and the exit code from a result. */
#ifndef OHM_SUBCOMMAND_H
#define OHM_SUBCOMMAND_H

#include <stdarg.h>
#include <stdio.h>

#include "base/ohm_error.h"

/* argv is just "help" (or --help, -h). */
int ohm_subcommand_wants_help(int argc, char **argv);

/* "CMD: WHAT (see 'ohm CMD help')" as an OHM_ERR_USAGE. */
int ohm_subcommand_usage_error(ohm_error *err, const char *cmd, const char *fmt, va_list ap);

/* Print the error line (if rc), and return the process exit code: 0 done,
 * 2 bad usage, 1 anything else. */
int ohm_subcommand_exit(int rc, const ohm_error *err, const char *cmd);

#endif
