/* cli.h — the `ohm` command: dispatch help / run / chained actions and map
 * results to exit codes (0 ok, 1 failed run, 2 usage error). */
#ifndef OHM_CLI_H
#define OHM_CLI_H

int ohm_cli_main(int argc, char **argv);

#endif
