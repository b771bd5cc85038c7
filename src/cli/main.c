/* main.c — the ohm executable.  Under mpirun, rank 0 runs the command line
 * and the other ranks serve its distributed solves. */
#include "cli/cli.h"
#include "ohm.h"

int main(int argc, char **argv)
{
    int worker = ohm_parallel_start();
    if (worker < 0) return 1;
    if (worker > 0) return ohm_parallel_serve();
    int rc = ohm_cli_main(argc, argv);
    ohm_parallel_finish();
    return rc;
}
