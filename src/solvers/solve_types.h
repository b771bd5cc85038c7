/* solve_types.h — the values a solve is given and gives back: the solver
 * kinds, the parameters (one struct per thing they configure) and the
 * solution.  A header of its own, without a .c, so that the solver's
 * private files (solver_impl.h, transport.h) can hold them without
 * including the driver's interface (solve.h), which includes them. */
#ifndef OHM_SOLVE_TYPES_H
#define OHM_SOLVE_TYPES_H

#include "physics/light.h"
#include "base/log.h"
#include "physics/material.h"
#include "physics/mc.h"
#include "physics/clear_regions.h"
#include "physics/network.h"
#include "device/request.h"

/* The reduced scatterings `-solve hybrid=auto` traces as transport when a
 * frame has a pencil beam (docs/transport.md: reflectance against radius
 * within 2.5% beyond 2 mm, where diffusion alone is 15-22% off). */
enum { OHM_HYBRID_PENCIL = 10 };

/* Which solver: -solve solver=, read once from its name where the text
 * comes in (ohm_solver_kind_parse) and passed on typed.  Zero is direct,
 * what a zeroed ohm_solve_params asks inside the library; the -solve action,
 * the API's solve and Python default to auto (steps/actions.c). */
typedef enum ohm_solver_kind {
    OHM_SOLVER_DIRECT = 0, /* CHOLMOD's factor (solvers/direct.c)                */
    OHM_SOLVER_CG,         /* MIC(0) conjugate gradients (cg.c)                   */
    OHM_SOLVER_AMG,        /* PETSc CG with hypre BoomerAMG (amg.c)               */
    OHM_SOLVER_MG,         /* geometric multigrid (mg.c)                          */
    OHM_SOLVER_AUTO,       /* mg first, then the quickest that fits (auto.c)      */
    OHM_SOLVER_MC          /* Monte Carlo transport instead of diffusion          */
} ohm_solver_kind;

/* What a kind of solver does, asked instead of its name: OHM_SOLVES_TRANSPORT
 * traces photons instead of solving diffusion (mc); OHM_SOLVES_ON_DEVICE its
 * work can run on device= (mg's cycle, mc's photons, and auto, whose first
 * solve is mg's). */
enum { OHM_SOLVES_TRANSPORT = 1u << 0, OHM_SOLVES_ON_DEVICE = 1u << 1 };

/* The parameters of a solve, one struct per thing they configure,
 * gathered in ohm_solve_params below; zero-initialised means every default
 * (the solver's zero is direct: see ohm_solver_kind). */

/* What the network's matrix is. */
typedef struct ohm_operator_params {
    ohm_boundary boundary;
    ohm_fresnel fresnel;        /* robin: how A comes from eta (fresnel.h); 0: exact */
    double band_k;              /* depth band (band.h): keep cells within
                                   band_k / sigma_tr of the surface; 0: all */
    const ohm_mirrors *mirrors; /* validation scenes only; NULL for none */
    ohm_clear_mode clear;       /* clear regions (clear_regions.h): found and
                                   treated, or (0, off) diffusion everywhere */
    /* clear regions (physics/clear_exchange.h): per unknown, 1 where light
     * crosses as transport (the radiosity–diffusion coupling), or NULL:
     * diffusion everywhere.  Kept by pointer: must outlive the solver. */
    const uint8_t *clear_cells;
    double clear_reach;         /* mm: the coupling's face pairs farther apart are
                                   not linked (clear_exchange.h).  With clear_cells:
                                   0 links every visible pair; with clear=radiosity
                                   on the regions found: 0 is ohm_clear_reach of the
                                   thickest region treated */
} ohm_operator_params;

/* The medium cell by cell, and who owns its arrays. */
typedef struct ohm_media_params {
    /* per-unknown coefficients (n entries per channel) for inhomogeneous
     * media; NULL: the material's constants */
    const ohm_coeff *sigma_a[OHM_MAX_CHANNELS];
    const ohm_coeff *sigma_s[OHM_MAX_CHANNELS];
    /* the refractive index per unknown (interior cells), 1..3, for every
     * channel, or NULL: the material's eta; network.h's interfaces.  Not
     * taken by give_media: the caller frees it after the solve. */
    const double *eta_v;
    /* the anisotropy per unknown (interior cells), in (-1, 1), or NULL: the
     * material's g; transport only (solver=mc, hybrid=): diffusion takes
     * sigma_s' as given.  Not taken by give_media either. */
    const double *g_v;
    /* A scan's media, instead of arrays: a density per unknown (interior
     * cells) and each channel's curves of it (the transfer function's,
     * curve.h; n = 0 where a coefficient is the material's constant),
     * evaluated where a coefficient is needed: 4 B per cell for all channels.
     * The solver copies the curves. */
    const float *density;
    ohm_curve density_sa[OHM_MAX_CHANNELS], density_ss[OHM_MAX_CHANNELS];
    /* Nonzero: the arrays in sigma_a[] and sigma_s[], density, resistance_v
     * and ground_v were malloc'd by the caller and ohm_solve takes them,
     * whether it succeeds or fails (the caller must not free them): the
     * solution keeps them instead of copies (4 B per cell and coefficient
     * less).  Zero: the caller keeps them alive as long as the solver. */
    int give_media;
    /* paper mode with per-cell resistances (transfer functions): n each */
    const ohm_coeff *resistance_v, *ground_v;
} ohm_media_params;

/* The light's sources: how it enters, what shadows it, what phi includes. */
typedef struct ohm_source_params {
    ohm_deposit deposit;
    int total_fluence;         /* 0: phi is the diffuse fluence (diffusion's own); 1: the
                                  unscattered beam's fluence added (ohm_source_unscattered_face;
                                  mc: traced), what transport codes report */
    ohm_shadows shadows;       /* none (every face turned to a light is lit), mesh, grid */
    const ohm_mesh *mesh;      /* for shadows=mesh                       */
    int orientation;           /* +1, or -1 for an inside-out mesh       */
    /* Validation scenes place their own sources: when set, called once per
     * channel instead of the lights (`lights` may be NULL, one frame).
     * Fills b (n x ncols, zeroed) and returns 0. */
    int (*custom_source)(void *user, double *b, size_t ncols, const ohm_network *net, int channel);
    void *custom_user;
} ohm_source_params;

/* How the system is solved: the backend, its ordering, tolerance and memory. */
typedef struct ohm_numeric_params {
    ohm_solver_kind solver;    /* backend (solvers/backend.h), or mc (mc.h) */
    double cg_tol;             /* relative residual iterative backends stop at; 0: 1e-10 */
    const char *petsc_options; /* amg: options for PETSc's database, or NULL  */
    const char *ordering;      /* auto | metis | amd | nesdis | grid | best; NULL: metis */
    int from_scan;             /* ordering=auto: the object is a density volume's */
    ohm_device_request device; /* where mg's solve runs (zero: the host)     */
    double max_rhs_bytes;      /* cap on B and X per batch; 0: 1 GiB     */
    double max_memory;         /* bytes the factor may take; 0: what the machine has */
} ohm_numeric_params;

/* Members whose group is a choice: eta_v sits with the media, not the
 * operator, though the index shapes the Fresnel boundary: it is a per-cell
 * array like the coefficients, compacted with them to a depth band and
 * checked with g_v.  total_fluence sits with the sources: it adds the
 * unscattered beam's own fluence, traced from the same light entries.
 * max_memory sits with the numerics though mc reads it too: a cap on what
 * the backend that runs may hold (the factor, or mc's tallies). */
typedef struct ohm_solve_params {
    ohm_operator_params op;    /* what the network's matrix is            */
    ohm_media_params media;    /* the medium per cell                     */
    ohm_source_params src;     /* the light's sources                     */
    ohm_numeric_params num;    /* how it is solved                        */
    ohm_mc_params mc;          /* solver=mc: photons, seed, g, threads; with a
                                  diffusion solver and mc.handoff > 0, the
                                  hybrid: each frame's light is traced as
                                  transport up to its mc.handoff-th scattering,
                                  and diffusion carries it from there (the
                                  handed-off weight is the source; fluence and
                                  exitance are the sums of both parts)        */
} ohm_solve_params;

typedef struct ohm_solution {
    int channels;
    int frames;                         /* columns solved (1 without orbits)          */
    int64_t n;                          /* unknowns                                   */
    ohm_network net;                    /* topology (cell of each unknown, faces)     */
    /* Per channel, frame-major: value of unknown v in frame f at [f * n + v]. */
    double *fluence[OHM_MAX_CHANNELS];  /* fluence rate phi (W/mm^2)                  */
    /* solver=mc: standard errors of fluence and of each cell's exitance,
     * frame-major like fluence; NULL for the diffusion solvers */
    double *fluence_se[OHM_MAX_CHANNELS], *exitance_se[OHM_MAX_CHANNELS];
    double *face_exitance[OHM_MAX_CHANNELS]; /* frame-major, nfaces per frame:
                                           G_b phi / h^2 per face; a cell's exitance
                                           is the mean of its faces' (below)          */
    /* The medium when it varies cell by cell, in unknown order (NULL when
     * homogeneous), for the sigma_a / sigma_s output grids: the params'
     * arrays themselves when given (give_media), the depth band's compacted
     * ones, else copies.  Channels with one array share it; medium_owned
     * lists each distinct array once, for ohm_solution_free. */
    const ohm_coeff *medium_sa[OHM_MAX_CHANNELS], *medium_ss[OHM_MAX_CHANNELS];
    ohm_coeff *medium_owned[2 * OHM_MAX_CHANNELS];
    /* Or a scan's: the density per unknown (owned) and the curves of it
     * (their knots and values in curve_store), as the params gave them. */
    float *medium_density;
    ohm_curve medium_sa_curve[OHM_MAX_CHANNELS], medium_ss_curve[OHM_MAX_CHANNELS];
    double *curve_store;
    /* statistics (the -stats JSON, docs/cli.md) */
    int factors;
    int analyses;                       /* symbolic analyses (one per grid)           */
    int64_t solves;                     /* columns solved, summed over channels       */
    int64_t solves_skipped;             /* frames whose light did not change: reused  */
    double nnz_A, nnz_L, flops;
    char ordering[16];
    char solver[8];                     /* direct | cg | amg | mc: what ran           */
    int64_t mc_photons;                 /* mc: photons traced, over channels and frames */
    int64_t mc_events;                  /* mc: path segments traced                   */
    int64_t mc_truncated;               /* mc: photons stopped by the event cap       */
    int mc_threads;                     /* mc: threads that traced                    */
    int solve_threads;                  /* diffusion: threads that solved the media at
                                           once (keep=1 relights), 1: one after another */
    char solver_reason[256];            /* why (auto's estimate, or "asked for")      */
    char device[96];                    /* the OpenCL device mg's solve or the traced
                                           photons (mc, the hybrid's) ran on; "": host */
    int64_t cg_iterations;              /* CG iterations (MIC- or AMG-preconditioned),
                                           summed over columns                        */
    double cg_relres;                   /* largest final relative residual            */
    double cg_tol;                      /* the relative residual asked (iterative)    */
    int64_t cg_stalled;                 /* columns accepted short of cg_tol (at the
                                           iteration cap or a residual floor)         */
    double t_cg_setup;                  /* building the preconditioners (cg, amg)     */
    double solver_bytes;                /* memory the backend held (its estimate)     */
    int ranks;                          /* MPI ranks that solved (amg), else 1        */
    int mg_levels;                      /* mg: its hierarchy's levels, else 0         */
    double band_depth;                  /* mm kept below the surface; 0: no band      */
    int64_t band_dropped;               /* interior cells below the band              */
    uint8_t *band_active;               /* the band's cells (net.active points here)  */
    /* the clear regions found (clear_regions.h; none when clear=off or the
     * solver transports photons) and what is done with them */
    ohm_clear_regions clear;
    ohm_clear_mode clear_action;        /* the treatment applied; off: none          */
    double t_clear;                     /* finding them and making the treatment's media */
    int64_t clear_nodes, clear_pairs;   /* clear=radiosity: the coupling's wall nodes
                                           and linked node pairs                      */
    double clear_reach_mm;              /* and the distance they are linked within    */
    double *band_eta, *band_g;          /* eta_v, g_v compacted to the band's unknowns, or NULL */
    double t_network;                   /* the network's topology: depth band (if any),
                                           unknowns, faces, pieces — once per grid    */
    double t_assemble;                  /* the matrices (and ga, gb), summed over the
                                           distinct channel materials                 */
    double t_analyze, t_factor, t_source, t_solve;
    double t_shadow_setup;              /* building the occluder (Embree BVH)         */
    double residual;                    /* largest scaled backward error              */
    int refined;                        /* solves that took a refinement step         */
    int64_t mode_corrections;           /* near-singular pieces whose constant mode was
                                           projected onto exact conservation          */
    double mode_shift;                  /* largest such shift relative to the fluence */
    /* W: arriving on the surface; entering it (after Fresnel); in = the
     * source (diffusion: the scattered part of what entered, the rest being
     * absorbed at its first collision; mc: what entered); absorbed; out */
    double power_incident, power_entered, power_in, power_absorbed, power_out;
    double power_out_channel[OHM_MAX_CHANNELS], power_in_channel[OHM_MAX_CHANNELS];
} ohm_solution;

/* The solver object (solver_impl.h); solve.h says what it keeps. */
typedef struct ohm_solver ohm_solver;

#endif
