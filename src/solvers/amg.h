/* solvers/amg.h — the process's MPI role, for main(): rank 0 runs the
 * pipeline, every other rank serves the amg backend (amg.c).
 *
 *   int w = ohm_mpi_start();      // first thing in main
 *   if (w < 0) return 1;          // could not start, or refused (said why)
 *   if (w > 0) return ohm_mpi_serve();
 *   ... run the pipeline ...
 *   ohm_mpi_finish();             // releases the workers; fine when unused
 *
 * Without mpirun, ohm_mpi_start does nothing and MPI starts (one process)
 * only when solver=amg is first used. */
#ifndef OHM_SOLVERS_AMG_H
#define OHM_SOLVERS_AMG_H

int ohm_mpi_start(void);
int ohm_mpi_serve(void);
void ohm_mpi_finish(void);

#endif
