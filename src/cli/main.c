/* main.c — the ohm executable.  Under mpirun, rank 0 runs the command line
 * and the other ranks serve its distributed solves. */
#include "cli/cli.h"
#include "ohm/cli.h"

int main(int argc, char **argv)
{
    int serving = 0;
    if (ohm_parallel_start(&serving)) return 1;
    if (serving) return ohm_parallel_serve() == OHM_OK ? 0 : 1;
    int rc = ohm_cli_main(argc, argv);
    ohm_parallel_finish();
    return rc;
}
