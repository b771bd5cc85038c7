/* factor_watch.h — progress and cancellation inside CHOLMOD's supernodal
 * factorization (direct.c), which offers neither: a factorization of 10^6
 * cells runs for tens of seconds without a word.
 *
 * How: CHOLMOD's supernodal factorization (Supernodal/t_cholmod_super_numeric.c)
 * does its arithmetic in BLAS and LAPACK calls from the calling thread: for
 * each supernode, dsyrk and dgemm for the updates from its descendants, then
 * dpotrf on its diagonal block and dtrsm below it.  factor_watch.c defines
 * those four Fortran symbols itself and forwards each to the library's (found
 * with dlsym(RTLD_NEXT)), counting their flops against the analysis's total
 * for the progress.  A host program that links LAPACK itself (Blender) would
 * have CHOLMOD's calls bound to its copy instead: the first watch points
 * libcholmod's own slots for the four at ours (rebind.h), so the watch holds
 * in any process.  Once the run is cancelled they do nothing, and dpotrf
 * answers info = 1 ("the first pivot is not positive"): CHOLMOD then stops at
 * that supernode exactly as for an indefinite matrix (status
 * CHOLMOD_NOT_POSDEF; its memory all its own, the half-made factor freed by
 * the caller), and ohm_cholesky_factorize reports the cancellation instead.
 * The latency is one BLAS call of one supernode (milliseconds to a few
 * tenths of a second at 10^6 cells).
 *
 * A watch belongs to the thread that factorizes; a call on a thread without
 * one (PETSc, hypre, anything else in the process) passes straight through
 * at the cost of reading one thread-local pointer.  A simplicial
 * factorization (small grids, where CHOLMOD judges supernodes not worth it)
 * makes no such calls and is not watched: it takes well under a second. */
#ifndef OHM_FACTOR_WATCH_H
#define OHM_FACTOR_WATCH_H

#include "base/log.h"

typedef struct ohm_factor_watch {
    ohm_progress progress;
    double flops, done;  /* the analysis's estimate; counted so far              */
    double t_reported;   /* when progress was last reported                      */
    int cancelled;       /* it refused a call: the run was cancelled             */
} ohm_factor_watch;

/* Watch the factorization this thread runs next, of `flops` estimated
 * floating-point operations (until ohm_factor_watch_end). */
void ohm_factor_watch_begin(ohm_factor_watch *w, double flops, const ohm_log *log, const char *what);
void ohm_factor_watch_end(ohm_factor_watch *w);

#endif
