/* main.c — the ohm executable.  Under mpirun, rank 0 runs the command line
 * and the other ranks serve its distributed solves (solvers/amg.h). */
#include "cli/cli.h"
#include "solvers/amg.h"

int main(int argc, char **argv)
{
    int worker = ohm_mpi_start();
    if (worker < 0) return 1;
    if (worker > 0) return ohm_mpi_serve();
    int rc = ohm_cli_main(argc, argv);
    ohm_mpi_finish();
    return rc;
}
