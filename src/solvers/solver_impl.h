/* solvers/solver_impl.h — private to src/solvers/: the solver object and the
 * structs its files share (in the spirit of PETSc's private kspimpl.h);
 * solve.h is the public face.  The files, one per job:
 *
 *   solve.c      the driver: create and set up (the network, the media, the
 *                backend per distinct channel material), each channel's
 *                batches, the media in turn or on several threads at once
 *   solution.c   the solution object: allocation, reset, the backend's
 *                report, exitance, conservation error, the medium read back
 *   media.c      the media: per-channel medium, depth-band compaction, the
 *                arrays and curves the solution keeps, which channels share one
 *   sources.c    right-hand sides: the lights' sources, frame entries, the
 *                per-face powers traced once for every channel, the
 *                unscattered beam
 *   transport.c  Monte Carlo: solver=mc and the hybrid's transport part
 *                (transport.h)
 *   batch.c      batches of frames: their size and work arrays, frames whose
 *                light did not change, warm starts, the scaled unknowns
 *   booking.c    power booked per solve, the constant-mode correction of
 *                nearly singular pieces, a channel's tally
 *   clear.c      the clear regions (physics/clear_regions.h) found in the
 *                media and their treatment: the medium diffusion reads
 *
 * Ownership: the solver owns its solution, its copies of the parameters'
 * strings, the occluder, every slot's matrix and backend state. */
#ifndef OHM_SOLVERS_SOLVER_IMPL_H
#define OHM_SOLVERS_SOLVER_IMPL_H

#include <stddef.h>
#include <stdint.h>

#include <cholmod.h>

#include "physics/clear_exchange.h"
#include "solvers/backend.h"
#include "solvers/solve_types.h"

/* What the photons tallied before their handoff, for nb frames of one
 * channel, per column. */
typedef struct hybrid_part {
    double *fluence, *face;       /* n and nf per column                   */
    double *fluence_se, *exit_se; /* scratch for the tracer                */
    double *power;                /* 3 per column: in, absorbed, out (W)    */
    struct ohm_mc_device *device; /* the photons' device (device=), opened at
                                     the first trace and kept; NULL: the host */
    int device_opened;
} hybrid_part;

/* What solving one channel adds to the solution's sums and counts.  Each
 * channel books into its own tally, added to the solution in channel order
 * afterwards (ohm_tally_add), so that channels solved on separate threads give
 * the same sums, to the bit, as one after the other. */
typedef struct channel_tally {
    double power_incident, power_entered;         /* the sources' light        */
    double power_in, power_absorbed, power_out;   /* the solved fluence's      */
    double t_source, t_solve;                     /* seconds, this channel's   */
    double residual;                              /* largest backward error    */
    double mode_shift;                            /* largest constant-mode shift */
    int64_t solves, solves_skipped, mode_corrections;
} channel_tally;

/* One distinct channel material's matrix and its set-up backend (a factor,
 * or a preconditioner): what a change of light reuses. */
typedef struct medium_slot {
    void *state;            /* the backend's, or NULL                     */
    /* the network's matrix for this medium, in the form the backend reads
     * (backend.h): assembled, or its stencil (OHM_BACKEND_STENCIL) */
    cholmod_sparse *A;
    ohm_stencil stencil;
    ohm_operator op;        /* the one of the two that is filled          */
    /* what the stencil is made from when a backend given A asks for it
     * (ohm_operator.make_stencil) */
    const ohm_network *net;
    ohm_channel_medium med;
    ohm_boundary boundary;
    const ohm_clear_exchange *exchange; /* the clear regions' coupling, or NULL */
    double *ga, *gb;        /* ground per unknown (NULL: ground_of), boundary per face */
    int ready;              /* A holds this medium's values, set up        */
} medium_slot;

struct ohm_solver {
    ohm_solution sol;            /* topology, media, statistics; then results */
    ohm_solve_params params;     /* the caller's, with the band's arrays and
                                    the solver's own copies of its strings    */
    char ordering[16];
    char *petsc_options;
    ohm_material mat;
    const ohm_voxel_grid *grid;
    const ohm_log *log;          /* &log_own: the caller's, with the span       */
    const ohm_log *caller_log;   /* the caller's log, copied into log_own as
                                    each call begins (its callbacks may change) */
    ohm_log log_own;
    ohm_progress_span span;      /* the share of the solve's one progress bar
                                    the backend's solve now running fills      */
    int keep;                    /* keep every medium's setup between solves   */
    ohm_occluder *occ;
    cholmod_common cc;           /* for assembling A in CHOLMOD's form        */
    int cc_started;
    const ohm_backend_ops *backend; /* the linear solver, or NULL with a transport */
    const struct ohm_transport_ops *transport; /* solver=mc (transport.h), or NULL   */
    ohm_grid_layout layout;      /* the unknowns' cells, for ordering=grid    */
    ohm_clear_exchange exchange; /* clear regions' coupling (params.op.clear_cells, or
                                    clear=radiosity's regions), or empty      */
    uint8_t *clear_mask;         /* clear=radiosity: its regions' unknowns (the
                                    exchange reads it)                         */
    ohm_backend_report rep;      /* summed over the solver's life             */
    medium_slot slot[OHM_MAX_CHANNELS]; /* by the first channel of each medium */
    int held;                    /* keep = 0: the one slot holding resources, or -1 */
    int solved;                  /* the solution holds the last solve's fluence */
    /* clear=effective (clear.c): per channel, sigma_s' per unknown with the
     * clear regions' effective value, what diffusion's operator reads
     * instead of the medium's (NULL: the medium's); channels with one
     * medium share one array, listed once in clear_owned */
    const ohm_coeff *clear_ss[OHM_MAX_CHANNELS];
    ohm_coeff *clear_owned[OHM_MAX_CHANNELS];
};

/* Shadow rays and Fresnel do not depend on the channel: every frame's lights
 * traced once into per-face powers for all channels (when they fit in the
 * budget, else *cached = 0 and ohm_fill_sources traces per channel). */
typedef struct face_powers {
    double *enter[OHM_MAX_CHANNELS];   /* [frame * nfaces + f] */
    double *arrive[OHM_MAX_CHANNELS];  /* [frame]: the faces' sum, all the books need */
    double *enter_mu[OHM_MAX_CHANNELS]; /* entering power x the refracted ray's cosine */
    int cached;
} face_powers;

/* What solving a medium's channels allocates: the right-hand sides of a
 * batch, and the bookkeeping of frames whose light did not change. */
typedef struct batch_work {
    double *B;        /* n x batch                                         */
    size_t *col_of;   /* batch column -> distinct column                   */
    double *prev_b;   /* the last frame's right-hand side, for a later batch */
    hybrid_part hy;
} batch_work;

/* What every channel's diffusion solve reads: the lights, the batching, the
 * face powers traced for all channels, and the channels' media classes
 * (cls[c]: the first channel with c's medium, whose slot it solves with). */
typedef struct diffusion_run {
    ohm_solver *s;
    const ohm_light *lights;
    size_t nlights;
    int hybrid;
    size_t batch;
    face_powers fp;
    int channels, cls[OHM_MAX_CHANNELS];
    int nclasses;                /* distinct media: set-ups                  */
    int from_last;               /* X starts as the last solve's fluence (a relight) */
} diffusion_run;

/* solution.c */
void ohm_solution_report_backend(ohm_solution *sol, const ohm_backend_report *rep);
int ohm_solution_alloc(ohm_solution *sol, ohm_error *err);
void ohm_solution_reset(ohm_solution *sol, ohm_backend_report *rep, int keep_fluence);

/* media.c */
void ohm_medium_for(ohm_channel_medium *med, const ohm_material *mat, const ohm_solve_params *p, int c);
int ohm_setup_band(ohm_solution *sol, ohm_solve_params *out, ohm_coeff *compact[2 * OHM_MAX_CHANNELS],
                   const ohm_voxel_grid *grid, const ohm_material *mat, const ohm_solve_params *params,
                   const ohm_log *log, ohm_error *err);
void ohm_take_media(ohm_solution *sol, const ohm_media_params *p);
int ohm_keep_media(ohm_solution *sol, ohm_media_params *p, ohm_coeff *compact[2 * OHM_MAX_CHANNELS],
                   ohm_error *err);
int ohm_same_medium(const ohm_material *mat, const ohm_media_params *p, int c, int e);
int ohm_check_cell_optics(const ohm_voxel_grid *grid, const ohm_media_params *p, ohm_error *err);

/* clear.c */
int ohm_solver_find_clear(ohm_solver *s, ohm_error *err);
/* The radiosity coupling of the cells mask marks, face pairs within reach mm,
 * built into s->exchange and booked in the solution and the log: for the
 * regions found (clear=radiosity) and for a mask given (op.clear_cells). */
int ohm_solver_couple_clear(ohm_solver *s, const uint8_t *mask, double reach, ohm_error *err);
void ohm_diffusion_medium(ohm_channel_medium *med, const ohm_solver *s, int c);

/* sources.c */
int ohm_fill_sources(const ohm_solution *sol, channel_tally *t, double *B, size_t f0, size_t nb, int c,
                     const ohm_channel_medium *med,
                     const ohm_light *lights, size_t nlights, const ohm_source_params *src,
                     double *const *fp_enter, double *const *fp_enter_mu, double *const *fp_arrive,
                     const ohm_occluder *occ, ohm_error *err);
int ohm_frame_entries(ohm_light_entries *in, const ohm_network *net, const ohm_light *lights, size_t nlights,
                      size_t fr, int channels, double eta, const double *eta_v, const ohm_occluder *occ,
                      ohm_error *err);
int ohm_add_unscattered(ohm_solution *sol, double *X, size_t f0, size_t nb, int c, const ohm_channel_medium *med,
                        const ohm_material *mat, const ohm_light *lights, size_t nlights, const ohm_occluder *occ,
                        ohm_error *err);
void ohm_face_powers_free(face_powers *fp);
int ohm_face_powers_trace(face_powers *fp, ohm_solver *s, const ohm_light *lights, size_t nlights, double cap,
                          ohm_error *err);

/* batch.c */
size_t ohm_distinct_columns(channel_tally *t, double *B, size_t *col_of, size_t nb, const double *prev_b,
                            size_t n);
void ohm_warm_start(double *X, const ohm_solution *sol, size_t f0, int c, int warm_from, size_t n);
void ohm_expand_columns(double *X, double *B, const ohm_solution *sol, const size_t *col_of, size_t nb, size_t f0,
                        int c, double *prev_b, size_t n);
void ohm_scale_unknowns(double *X, size_t ncols, size_t n, const ohm_channel_medium *med, int to_phi);
size_t ohm_batch_frames(const ohm_solver *s, size_t frames, int hybrid);
void ohm_batch_work_free(batch_work *w);
int ohm_batch_work_alloc(batch_work *w, const ohm_solution *sol, size_t batch, int hybrid, ohm_error *err);

/* booking.c */
void ohm_tally_add(ohm_solution *sol, const channel_tally *t, int c);
void ohm_book_power(ohm_solution *sol, channel_tally *t, const double *X, const double *B, const double *ga,
                    const double *gb, const ohm_channel_medium *med, size_t f0, size_t nb, int c);
int ohm_conserve_exactly(channel_tally *t, const ohm_network *net, double *X, const double *B, size_t nu,
                         const double *ga, const double *gb, const ohm_operator *op, const ohm_channel_medium *med,
                         double *berr, ohm_error *err);

/* The object that solves a kind of solver (choice.c's table): its backend
 * (NULL for a kind that transports photons), or its transport (NULL for
 * every diffusion solver). */
const ohm_backend_ops *ohm_solver_kind_backend(ohm_solver_kind kind);
const struct ohm_transport_ops *ohm_solver_kind_transport(ohm_solver_kind kind);

#endif
