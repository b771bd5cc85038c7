/* network.h — the resistor network of docs/design.md §3 (cell-centred finite
 * volumes).  Unknown phi_c is the fluence at the centre of every interior cell;
 * KCL at cell c:  sum_d G_cd (phi_c - phi_d) + G_a,c phi_c + sum_f G_b,f phi_c = S_c.
 *
 *   G_cd  = h * D_f, D_f the harmonic mean of D_c and D_d (exact for layers)
 *   G_a,c = sigma_a,c * h^3
 *   G_b,f = 0 (neumann, the paper's Eq. 11) | h^2/(h/(2D_c) + 2A) (robin,
 *           partial current) | 2 D_c h (dirichlet, phi = 0 on the face)
 *
 * Every solver's G_cd is held in single precision (rounded once, the same
 * bits in both its rows): a relative 6e-8 of D, far below anything a
 * material or the grid can resolve, and what lets a matrix-free solver
 * stream 12 bytes of links per unknown instead of 24.  The sinks G_a and
 * G_b stay in double: the matrix's column sums are exactly what the power
 * books absorb and let out, whatever the links' rounding.
 *
 * The matrix is symmetric positive definite when every connected piece has
 * some absorption or a non-Neumann boundary face; ohm checks that per piece
 * before factorizing and says which physical cause makes it singular.
 *
 * ohm_network holds the topology (unknown numbering, boundary faces, pieces),
 * built once per voxel grid; ohm_network_assemble builds one channel's matrix
 * from per-cell coefficients, straight into CHOLMOD's compressed-column form
 * (upper triangle, stype = 1, 64-bit indices). */
#ifndef OHM_NETWORK_H
#define OHM_NETWORK_H

#include <stdint.h>

#include <cholmod.h>

#include "base/curve.h"
#include "base/sorted.h"
#include "grid/cell_index.h"
#include "physics/fresnel.h"
#include "physics/stencil.h"
#include "base/ohm_error.h"
#include "grid/voxelize.h"

typedef enum ohm_boundary {
    OHM_BOUNDARY_ROBIN = 0,
    OHM_BOUNDARY_NEUMANN = 1,
    OHM_BOUNDARY_DIRICHLET = 2
} ohm_boundary;

/* Face directions: outward normal -x, +x, -y, +y, -z, +z. */
extern const int32_t ohm_face_offset[6][3];

/* Mirror (symmetry) planes, for the built-in validation scenes: a face on the
 * low (high) side of axis a of a cell whose index on that axis is low[a]
 * (high[a]) has zero flux and is not a boundary face; -1: none.  Low planes
 * make quarter domains; a plane on both sides of a one-cell-wide axis makes
 * a 1-D column exactly. */
typedef struct ohm_mirrors {
    int32_t low[3], high[3];
} ohm_mirrors;

/* The unknowns' connected pieces as runs of consecutive unknowns in one
 * piece: in cell order a piece's unknowns come in long runs (the Colin27
 * head at 0.5 mm: 2.7e7 unknowns in 148 pieces, 5910 runs, 71 kB where a
 * label per unknown was 108 MB).  At worst (a cloud of single-cell specks)
 * a run per unknown, 12 B where a label was 4.  count 0: one piece, every
 * unknown's 0. */
typedef struct ohm_piece_runs {
    int64_t count;
    int64_t *start; /* count + 1: run r is the unknowns start[r] .. start[r + 1] - 1 */
    int32_t *piece; /* count: its piece, numbered in the order of their smallest unknown;
                       32 bits: the voxelizer keeps grids below 2^31 cells
                       (checked in the build) */
} ohm_piece_runs;

/* The run holding unknown v (count > 0): a bisection. */
int64_t ohm_piece_runs_find(const ohm_piece_runs *pr, int64_t v);

/* Unknown v's piece, for v visited in increasing order: *run is a run at
 * or before v's (0, or ohm_piece_runs_find's), moved on to v's. */
static inline int32_t ohm_piece_runs_next(const ohm_piece_runs *pr, int64_t *run, int64_t v)
{
    if (!pr->count) return 0;
    while (pr->start[*run + 1] <= v) ++*run;
    return pr->piece[*run];
}

typedef struct ohm_network {
    const ohm_voxel_grid *grid;   /* not owned; must outlive the network      */
    int64_t n;                    /* unknowns = interior cells                */
    ohm_cell_index unknowns;      /* which grid cells are unknowns; their numbers,
                                     and each unknown's cell (no table of them:
                                     8 B per unknown, ohm_network_cell) */
    int64_t nfaces;               /* boundary faces (mirror faces excluded)   */
    int64_t *face_unknown;        /* nfaces: the interior cell of face f      */
    int64_t *face_cell;           /* nfaces: its dense grid index             */
    uint8_t *face_dir;            /* nfaces: 0..5, see ohm_face_offset        */
    int64_t npieces;              /* connected pieces (face-adjacent cells)   */
    ohm_piece_runs pieces;        /* each unknown's piece (above)             */
    int64_t nnz;                  /* entries of the upper triangle of A       */
    ohm_mirrors mirror;           /* symmetry planes (above); -1: none        */
    const uint8_t *active;        /* depth band: the cells that are unknowns
                                     (not owned), or NULL: every interior cell */
    int64_t nclosure;             /* faces between the band and the dropped core */
} ohm_network;

/* mirrors: NULL for none. */
int ohm_network_build(ohm_network *net, const ohm_voxel_grid *grid, const ohm_mirrors *mirrors, ohm_error *err);

/* The same over a depth band (band.h): unknowns are the cells with active[c]
 * set (a subset of the interior, in cell order); a face between an unknown and
 * an interior cell outside the band is a closure face, not a boundary face:
 * the assembly gives it the absorbing-half-space conductance
 * h^2 / (h / (2 D) + 1 / (D sigma_tr)) — the flux J = D sigma_tr phi of light
 * decaying as e^(-sigma_tr z) — booked as absorbed. */
int ohm_network_build_band(ohm_network *net, const ohm_voxel_grid *grid, const ohm_mirrors *mirrors,
                           const uint8_t *active, ohm_error *err);
void ohm_network_free(ohm_network *net);

/* The unknown of dense grid cell c, or -1 when c is not one (unknowns are
 * numbered in cell order: cell_index.h). */
static inline int64_t ohm_network_unknown(const ohm_network *net, size_t c)
{
    return ohm_cell_index_of(&net->unknowns, c);
}

/* The dense grid index of unknown v, found by a search (cell_index.h): for
 * an unknown now and then.  Loops over unknowns in order read them from a
 * cursor, ohm_network_cells, at a few instructions each. */
static inline int64_t ohm_network_cell(const ohm_network *net, int64_t v)
{
    return ohm_cell_index_cell(&net->unknowns, v);
}

/* The cells of unknowns v, v + 1, ... in turn (ohm_cell_cursor_next). */
static inline ohm_cell_cursor ohm_network_cells(const ohm_network *net, int64_t v)
{
    return ohm_cell_index_cursor(&net->unknowns, v);
}

/* The boundary face of unknown v in direction d (0..5, ohm_face_offset), or
 * -1 when that side of v is no boundary face (a neighbour, a symmetry
 * plane).  Faces are stored in unknown order, a cell's together: a binary
 * search. */
int64_t ohm_network_face(const ohm_network *net, int64_t v, int d);

/* The end of face f's run: faces f .. end-1 belong to f's unknown (a cell's
 * faces are stored together), so `for (f = 0; f < nfaces; f = end)` visits
 * each boundary cell once. */
static inline int64_t ohm_network_face_run_end(const ohm_network *net, int64_t f)
{
    int64_t v = net->face_unknown[f], end = f + 1;
    while (end < net->nfaces && net->face_unknown[end] == v) ++end;
    return end;
}

/* A per-cell optical or resistive coefficient as held for a whole grid: a
 * float.  The media come from scans, which ohm holds as floats, through
 * transfer functions, and are written to .vdb as floats; rounding the
 * coefficient to float moves it by at most 6e-8 relative, far below the
 * scan's own precision and the discretisation's error, and halves the
 * media's memory (three channels: 24 bytes per cell instead of 48,
 * docs/serial-stages.md).  The transfer functions' ranges (transfer.h,
 * 1e-12 .. 1e12) lie well inside a float's normal range.  Arithmetic on
 * them is in double. */
typedef float ohm_coeff;

/* One channel's coefficients.  Per-unknown arrays may be NULL, meaning the
 * constant beside them. */
typedef struct ohm_channel_medium {
    int resistance_mode;        /* paper mode: G = 1/R between neighbours, 1/R_g to ground */
    double resistance, ground;  /* ohms, paper mode                           */
    const ohm_coeff *resistance_v; /* n, paper mode per cell, or NULL: the link between
                                      two cells is two half-resistors in series */
    const ohm_coeff *ground_v;     /* n, paper mode per cell, or NULL             */
    const ohm_coeff *sigma_a;      /* n, 1/mm, or NULL -> the curve, or sigma_a0 */
    const ohm_coeff *sigma_s;      /* n, reduced scattering, or NULL -> likewise */
    double sigma_a0, sigma_s0;
    /* A scan's media: a density per unknown and the transfer function's
     * curves of it (curve.h), evaluated where a coefficient is needed — 4 B
     * per cell for every channel and both coefficients; NULL / n = 0: none */
    const float *density;
    ohm_curve sigma_a_curve, sigma_s_curve;
    double eta;
    const double *eta_v;        /* n, the index per cell, or NULL -> eta (below) */
    double g;                   /* anisotropy: transport only (mc.h), sigma_s = sigma_s' / (1 - g) */
    const double *g_v;          /* n, the anisotropy per cell (transport only), or NULL -> g */
    ohm_fresnel fresnel;        /* robin: A from eta by the Fresnel moments or the fit */
} ohm_channel_medium;

/* Unknown v's coefficients, 1/mm: its own (an array), its density's (the
 * curves), or the medium's constant. */
static inline double ohm_medium_sigma_a(const ohm_channel_medium *m, int64_t v)
{
    if (m->sigma_a) return m->sigma_a[v];
    return m->density && m->sigma_a_curve.n ? ohm_curve_at(&m->sigma_a_curve, m->density[v]) : m->sigma_a0;
}
static inline double ohm_medium_sigma_s(const ohm_channel_medium *m, int64_t v)
{
    if (m->sigma_s) return m->sigma_s[v];
    return m->density && m->sigma_s_curve.n ? ohm_curve_at(&m->sigma_s_curve, m->density[v]) : m->sigma_s0;
}

/* Both at once: a scan's two curves share their knots (the transfer
 * function's densities), so one search serves both. */
static inline void ohm_medium_coefficients(const ohm_channel_medium *m, int64_t v, double *sa, double *ss)
{
    const ohm_curve *a = &m->sigma_a_curve, *s = &m->sigma_s_curve;
    if (m->sigma_a || m->sigma_s || !m->density || !a->n || a->x != s->x || a->n != s->n) {
        *sa = ohm_medium_sigma_a(m, v);
        *ss = ohm_medium_sigma_s(m, v);
        return;
    }
    size_t i0, i1;
    double w;
    ohm_curve_bracket(a->x, a->n, m->density[v], &i0, &i1, &w);
    double a0 = a->y[i0 * a->stride], a1 = a->y[i1 * a->stride];
    double s0 = s->y[i0 * s->stride], s1 = s->y[i1 * s->stride];
    *sa = a0 + w * (a1 - a0); /* ohm_curve_at's formula */
    *ss = s0 + w * (s1 - s0);
}

/* Whether the optical coefficients vary cell by cell. */
static inline int ohm_medium_varies(const ohm_channel_medium *m)
{
    return m->sigma_a || m->sigma_s || (m->density && (m->sigma_a_curve.n || m->sigma_s_curve.n));
}

/* A refractive index per cell (eta_v).  Where two cells' indices differ, the
 * face between them is an interface of diffusion theory: the normal flux J is
 * continuous, and the partial currents on its two sides obey the Fresnel
 * reflection of each side (the boundary condition's derivation, fresnel.h,
 * applied to both half-spaces, as Aronson does for interfaces, JOSA A 12,
 * 1995; docs/transport.md derives it):
 *     (T_1/4) phi_1 - (T_2/4) phi_2 = (3/2) (C_2,1 + C_2,2) J,   T_i = 1 - 2 C_1,i
 * with C_n,i the moments for light in side i meeting the other (relative
 * index eta_i / eta_j).  Reciprocity, eta_1^2 T_1 = eta_2^2 T_2 = S, makes it
 * a jump in phi / eta^2, which is continuous where no flux crosses (the
 * radiance's n^2 law):
 *     phi_1/eta_1^2 - phi_2/eta_2^2 = 6 (C_2,1 + C_2,2) J / S.
 * In phi the matrix would not be symmetric; so with eta_v the unknown of cell
 * v is psi_v = phi_v / s_v, s_v = (eta_v / eta)^2 (1 where eta_v = eta), and
 * the conductance between v and w is
 *     G = h^2 / (h/(2 D_v s_v) + h/(2 D_w s_w) + eta^2 6 (C_2,v + C_2,w) / S),
 * symmetric; ground and boundary conductances are multiplied by s_v in the
 * matrix.  A boundary face uses its own cell's index for A.  ga and gb stay
 * the physical conductances (of phi): absorbed = sum ga phi, out = sum gb phi. */
static inline double ohm_network_unknown_scale(const ohm_channel_medium *m, int64_t v)
{
    if (!m->eta_v) return 1.0;
    double r = m->eta_v[v] / m->eta;
    return r * r;
}

/* Assemble A (caller frees with cholmod_l_free_sparse) and, optionally, the
 * per-unknown ground conductance ga[n] and per-face boundary conductance
 * gb[nfaces] (for power bookkeeping and exitance).  Without closure faces
 * (nclosure = 0) ga[v] is ohm_network_ground_conductance (below) exactly, so
 * a caller may pass NULL and compute it where it needs it.  Fails with a physical
 * explanation when a piece can neither absorb nor lose light. */
int ohm_network_assemble(cholmod_sparse **A, double *ga, double *gb, const ohm_network *net,
                         const ohm_channel_medium *med, ohm_boundary boundary, cholmod_common *cc, ohm_error *err);

/* The same into a matrix this network's assembly made before (any channel):
 * the pattern is the network's, the same for every medium, so only the
 * values are rewritten, in place.  Reusing the memory is the point: a fresh
 * matrix is 72 bytes per unknown whose first writes page-fault at ~3 ns/B on
 * this project's machine, 3x the assembly's arithmetic (docs/serial-stages.md).
 * On failure A's values are undefined (its shape is kept). */
int ohm_network_assemble_into(cholmod_sparse *A, double *ga, double *gb, const ohm_network *net,
                              const ohm_channel_medium *med, ohm_boundary boundary, ohm_error *err);

/* Unknown v's conductance to ground (absorption sigma_a h^3, or paper mode's
 * 1 / R_g), without the depth band's closure faces. */
double ohm_network_ground_conductance(const ohm_channel_medium *m, double h, int64_t v);

const char *ohm_boundary_name(ohm_boundary b);

/* Fill *st (zeroed, or this network's stencil to refill with another
 * medium) and ga, gb as ohm_network_assemble does; the same checks. */
int ohm_network_stencil(ohm_stencil *st, double *ga, double *gb, const ohm_network *net,
                        const ohm_channel_medium *med, ohm_boundary boundary, ohm_error *err);

#endif
