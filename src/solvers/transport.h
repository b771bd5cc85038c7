/* solvers/transport.h — light transport in a solve, beside the linear
 * solvers (backend.h): Monte Carlo photons (physics/mc.h) traced through
 * the solver's network, media and lights, either in place of diffusion
 * (solver=mc) or for the hybrid's first scatterings, whose handed-off
 * weight becomes diffusion's source (solve.h, mc.handoff; docs/transport.md).
 * Private to src/solvers/; the code is solvers/transport.c.
 *
 * A transport solves no matrix: nothing is assembled or set up, and the
 * driver (solve.c) asks it for the whole solution in one call, where a
 * backend is set up per channel material and solves blocks of columns. */
#ifndef OHM_SOLVERS_TRANSPORT_H
#define OHM_SOLVERS_TRANSPORT_H

#include <stddef.h>

#include "base/ohm_error.h"
#include "solvers/solve_types.h"

struct channel_tally; /* solver_impl.h: what solving one channel adds */

/* A transport, in place of a backend, for a solver kind that traces photons
 * (choice.c's table). */
typedef struct ohm_transport_ops {
    const char *name;
    /* Every frame and channel of these lights solved into the solver's
     * solution (its fluence, exitance, standard errors and power books). */
    int (*solve)(ohm_solver *s, const ohm_light *lights, size_t nlights, ohm_error *err);
} ohm_transport_ops;

/* Monte Carlo transport: solver=mc. */
extern const ohm_transport_ops ohm_transport_mc;

/* ---- the hybrid's transport part ------------------------------------------------- */

/* The hybrid's state in a solve: solver_impl.h (a solver's batch work holds it). */
struct hybrid_part;

int ohm_hybrid_alloc(struct hybrid_part *h, size_t n, size_t nf, size_t batch, ohm_error *err);
void ohm_hybrid_free(struct hybrid_part *h);

/* Column j of B (zeroed first) gets frame f0 + j's handed-off weight in
 * channel c: the frame's light entries traced to their handoff; the
 * photons' own fluence, exitance and power go to h for ohm_hybrid_add. */
int ohm_hybrid_sources(ohm_solution *sol, struct channel_tally *t, double *B, struct hybrid_part *h, size_t f0,
                       size_t nb, int c, const ohm_channel_medium *med, const ohm_material *mat,
                       const ohm_light *lights, size_t nlights, const ohm_solve_params *params,
                       const ohm_occluder *occ, ohm_error *err);

/* After the diffusion solve's power is booked: the photons' part added to
 * frames f0..f0+nb of channel c (X their fluence). */
void ohm_hybrid_add(ohm_solution *sol, struct channel_tally *t, double *X, const struct hybrid_part *h, size_t f0,
                    size_t nb, int c);

/* Whether the hybrid applies to this solver's scene (optical media, the
 * Fresnel boundary, every cell kept); else a one-line error. */
int ohm_hybrid_applies(const ohm_solver *s, ohm_error *err);

#endif
