/* subcommand.c — see subcommand.h. */
#include "studies/subcommand.h"

#include <string.h>

int ohm_subcommand_wants_help(int argc, char **argv)
{
    return argc == 1 && (strcmp(argv[0], "help") == 0 || strcmp(argv[0], "--help") == 0 || strcmp(argv[0], "-h") == 0);
}

int ohm_subcommand_usage_error(ohm_error *err, const char *cmd, const char *fmt, va_list ap)
{
    char line[OHM_ERROR_MSG_MAX - 64];
    vsnprintf(line, sizeof line, fmt, ap);
    return ohm_fail(err, OHM_ERR_USAGE, "%s: %s (see 'ohm %s help')", cmd, line, cmd);
}

int ohm_subcommand_exit(int rc, const ohm_error *err, const char *cmd)
{
    if (rc) fprintf(stderr, "ohm: error: %s\n", err->msg[0] ? err->msg : cmd);
    return rc == OHM_OK ? 0 : rc == OHM_ERR_USAGE ? 2 : 1;
}
