/* network.c — topology and assembly of the diffusion network (network.h). */
#include "physics/network.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "base/parallel.h"
#include "physics/material.h"

const int32_t ohm_face_offset[6][3] = {{-1, 0, 0}, {1, 0, 0}, {0, -1, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1}};

const char *ohm_boundary_name(ohm_boundary b)
{
    switch (b) {
    case OHM_BOUNDARY_ROBIN: return "robin";
    case OHM_BOUNDARY_NEUMANN: return "neumann";
    case OHM_BOUNDARY_DIRICHLET: return "dirichlet";
    }
    return "?";
}

void ohm_network_free(ohm_network *net)
{
    if (!net) return;
    ohm_cell_index_free(&net->unknowns);
    free(net->face_unknown);
    free(net->face_cell);
    free(net->face_dir);
    free(net->pieces.start);
    free(net->pieces.piece);
    memset(net, 0, sizeof *net);
}

/* The walk both stages share.  Unknowns are numbered in cell order (x
 * fastest), so a walk over them visits the grid in k, j, i order: (i,j,k) of
 * the next unknown comes from the previous one by an addition, and a
 * division is needed only where the walk leaves a row (about n^(2/3) times,
 * not twice per unknown and face as before). */
typedef struct walk {
    const ohm_network *net;
    const uint8_t *inside;
    int32_t dims[3];
    int64_t stride[6]; /* dense-index offset of the neighbour across face d */
    int32_t ijk[3];    /* the current unknown's cell */
    int64_t cell, v;   /* its dense index, and the unknown */
    ohm_cell_cursor next; /* the cells of v + 1, ... */
    int64_t piece_run; /* v's run of pieces (network.h), or one before it */
} walk;

static void walk_begin(walk *w, const ohm_network *net)
{
    const ohm_voxel_grid *g = net->grid;
    w->net = net;
    w->inside = g->inside;
    for (int a = 0; a < 3; ++a) w->dims[a] = g->dims[a];
    int64_t sy = g->dims[0], sz = (int64_t)g->dims[0] * g->dims[1];
    int64_t s[6] = {-1, 1, -sy, sy, -sz, sz};
    memcpy(w->stride, s, sizeof s);
    w->cell = -1;
    w->v = -2; /* the first walk_to places the cursors */
    w->next = (ohm_cell_cursor){0};
    w->piece_run = 0;
}

/* Move to unknown v (visited in increasing order; the next one's cell from
 * the cursor, another's by a search). */
static inline void walk_to(walk *w, int64_t v)
{
    if (v != w->v + 1) {
        w->next = ohm_network_cells(w->net, v);
        w->piece_run = w->net->pieces.count ? ohm_piece_runs_find(&w->net->pieces, v) : 0;
    }
    w->v = v;
    int64_t c = ohm_cell_cursor_next(&w->next), step = c - w->cell;
    if (w->cell >= 0 && w->ijk[0] + step < w->dims[0]) w->ijk[0] += (int32_t)step;
    else ohm_voxel_coords(w->net->grid, c, w->ijk);
    w->cell = c;
}

/* Neighbour of the current cell across face d: its unknown, -1 if outside
 * the object, -2 if the face is a mirror plane, -3 if it is interior but
 * below the depth band (a closure face).  Needs the unknown index complete. */
static inline int64_t walk_across(const walk *w, int d)
{
    int axis = d >> 1;
    int32_t x = w->ijk[axis];
    if (d & 1) {
        if (x == w->net->mirror.high[axis]) return -2; /* unused planes are negative: never a cell */
        if (x + 1 >= w->dims[axis]) return -1;
    } else {
        if (x == w->net->mirror.low[axis]) return -2;
        if (x == 0) return -1;
    }
    int64_t nc = w->cell + w->stride[d];
    int64_t u = ohm_network_unknown(w->net, (size_t)nc);
    if (u < 0 && w->net->active && w->inside[nc]) return -3;
    return u;
}

/* Grow the boundary-face arrays to hold at least need faces. */
static int reserve_faces(ohm_network *net, int64_t *cap, int64_t need)
{
    if (need <= *cap) return 0;
    int64_t c = *cap ? *cap : 1024;
    while (c < need) c *= 2;
    int64_t *fu = realloc(net->face_unknown, (size_t)c * sizeof *fu);
    if (!fu) return -1;
    net->face_unknown = fu;
    int64_t *fc = realloc(net->face_cell, (size_t)c * sizeof *fc);
    if (!fc) return -1;
    net->face_cell = fc;
    uint8_t *fd = realloc(net->face_dir, (size_t)c);
    if (!fd) return -1;
    net->face_dir = fd;
    *cap = c;
    return 0;
}

/* Union-find that always links the larger root under the smaller, so every
 * parent[x] <= x and each piece's root is its smallest unknown; path halving
 * keeps that (a grandparent is never larger than a parent). */
static inline int32_t find_root(int32_t *parent, int32_t x)
{
    while (parent[x] != x) {
        parent[x] = parent[parent[x]];
        x = parent[x];
    }
    return x;
}

/* label[0 .. n-1] as runs of equal labels (network.h); 0, or -1 out of memory */
static int piece_runs(ohm_piece_runs *pr, const int32_t *label, int64_t n)
{
    int64_t count = 1;
    for (int64_t v = 1; v < n; ++v) count += label[v] != label[v - 1];
    pr->start = malloc((size_t)(count + 1) * sizeof *pr->start);
    pr->piece = malloc((size_t)count * sizeof *pr->piece);
    if (!pr->start || !pr->piece) return -1;
    int64_t r = 0;
    for (int64_t v = 0; v < n; ++v)
        if (v == 0 || label[v] != label[v - 1]) {
            pr->start[r] = v;
            pr->piece[r++] = label[v];
        }
    pr->start[count] = n;
    pr->count = count;
    return 0;
}

int64_t ohm_piece_runs_find(const ohm_piece_runs *pr, int64_t v)
{
    return ohm_sorted_last_at_most(pr->start, pr->count, v);
}

/* The first boundary face of unknown v or of a later one (faces are
 * stored in unknown order): a bisection. */
static int64_t first_face_from(const ohm_network *net, int64_t v)
{
    int64_t lo = 0, hi = net->nfaces;
    while (lo < hi) {
        int64_t mid = lo + (hi - lo) / 2;
        if (net->face_unknown[mid] < v) lo = mid + 1;
        else hi = mid;
    }
    return lo;
}

int64_t ohm_network_face(const ohm_network *net, int64_t v, int d)
{
    for (int64_t f = first_face_from(net, v); f < net->nfaces && net->face_unknown[f] == v; ++f)
        if (net->face_dir[f] == d) return f;
    return -1;
}

int ohm_network_build(ohm_network *net, const ohm_voxel_grid *grid, const ohm_mirrors *mirrors, ohm_error *err)
{
    return ohm_network_build_band(net, grid, mirrors, NULL, err);
}

int ohm_network_build_band(ohm_network *net, const ohm_voxel_grid *grid, const ohm_mirrors *mirrors,
                           const uint8_t *active, ohm_error *err)
{
    memset(net, 0, sizeof *net);
    net->grid = grid;
    net->active = active;
    for (int a = 0; a < 3; ++a) {
        net->mirror.low[a] = mirrors ? mirrors->low[a] : -1;
        net->mirror.high[a] = mirrors ? mirrors->high[a] : -1;
    }
    size_t ncells = (size_t)grid->dims[0] * (size_t)grid->dims[1] * (size_t)grid->dims[2];
    const uint8_t *inside = grid->inside;
    int64_t n = 0;
    if (active) {
        for (size_t c = 0; c < ncells; ++c) n += active[c] && inside[c];
    } else {
        n = (int64_t)grid->interior_cells;
    }
    if (n == 0) return ohm_fail(err, OHM_ERR_INVALID, "network: the voxel object has no interior cells");
    if (n > INT32_MAX) /* the voxelizer keeps grids below 2^31 cells; pieces are labelled in 32 bits */
        return ohm_fail(err, OHM_ERR_USAGE, "network: %lld interior cells, more than 2^31; use a larger voxel=",
                        (long long)n);
    int index_failed = ohm_cell_index_alloc(&net->unknowns, ncells);
    int32_t *parent = malloc((size_t)n * sizeof *parent); /* the pieces' union-find, then their labels */
    if (index_failed || !parent) goto nomem;
    int64_t u = 0;
    for (size_t c = 0; c < ncells; ++c) {
        if ((active ? active[c] : 1) && inside[c]) {
            ++u;
            ohm_cell_index_add(&net->unknowns, c);
        }
    }
    ohm_cell_index_finish(&net->unknowns, ncells);
    if (u != n) {
        free(parent);
        ohm_network_free(net);
        return ohm_fail(err, OHM_ERR_INTERNAL, "network: interior count mismatch");
    }
    net->n = n;

    /* One walk: boundary faces in unknown order (then direction), matrix
     * entries, closure faces, and pieces joined across lower neighbours. */
    int64_t nfaces = 0, offdiag = 0, nclosure = 0, cap = 0;
    walk w;
    walk_begin(&w, net);
    for (int64_t v = 0; v < n; ++v) {
        parent[v] = (int32_t)v;
        walk_to(&w, v);
        if (reserve_faces(net, &cap, nfaces + 6)) goto nomem;
        for (int d = 0; d < 6; ++d) {
            int64_t x = walk_across(&w, d);
            if (x == -1) {
                net->face_unknown[nfaces] = v;
                net->face_cell[nfaces] = w.cell;
                net->face_dir[nfaces] = (uint8_t)d;
                ++nfaces;
            } else if (x == -3) {
                ++nclosure;
            } else if (x >= 0 && x < v) {
                ++offdiag;
                int32_t ra = find_root(parent, (int32_t)v), rb = find_root(parent, (int32_t)x);
                if (ra < rb) parent[rb] = ra;
                else if (rb < ra) parent[ra] = rb;
            }
        }
    }
    /* Number the pieces 0.. in the order of their smallest unknown, in place:
     * parent[v] < v is already labelled and lies in v's piece. */
    int32_t npieces = 0;
    for (int64_t v = 0; v < n; ++v) {
        int32_t p = parent[v];
        parent[v] = p == v ? npieces++ : parent[p];
    }
    net->npieces = npieces;
    if (npieces > 1 && piece_runs(&net->pieces, parent, n)) goto nomem; /* one piece: no runs (network.h) */
    free(parent);
    parent = NULL;
    net->nclosure = nclosure;
    net->nfaces = nfaces;
    net->nnz = n + offdiag;
    /* give back the doubling's slack (at least one element, as callers may index an empty list's base) */
    int64_t keep = nfaces ? nfaces : 1;
    if (keep < cap) {
        int64_t *fu = realloc(net->face_unknown, (size_t)keep * sizeof *fu);
        if (fu) net->face_unknown = fu;
        int64_t *fc = realloc(net->face_cell, (size_t)keep * sizeof *fc);
        if (fc) net->face_cell = fc;
        uint8_t *fd = realloc(net->face_dir, (size_t)keep);
        if (fd) net->face_dir = fd;
    }
    return OHM_OK;

nomem:
    free(parent);
    ohm_network_free(net);
    return ohm_fail(err, OHM_ERR_NOMEM, "network: out of memory for %lld cells", (long long)n);
}

/* One channel's coefficients, with what does not vary hoisted.  Every value
 * is computed by the same expression, in the same order, as the per-cell
 * formulas of docs/design.md §3 (network.h), so a homogeneous medium's constants
 * are bit for bit what each cell would compute for itself. */
typedef struct coeffs {
    double A;    /* the boundary constant A, fresnel.h (optical media) */
    ohm_fresnel fresnel;
    const ohm_fresnel_table *tab; /* per-cell index (eta_v): interfaces' moments */
    int uniform; /* no per-cell array: every conductance is one constant  */
    double g_edge, g_ground, g_bound, g_closure;
    const double *D; /* a scan's D per unknown, evaluated once (each is a
                        neighbour's six times), or NULL: med_D */
} coeffs;

static inline double med_D(const ohm_channel_medium *m, int64_t v)
{
    double sa, ss;
    ohm_medium_coefficients(m, v, &sa, &ss);
    return 1.0 / (3.0 * (sa + ss));
}

static inline double cell_D(const coeffs *k, const ohm_channel_medium *m, int64_t v)
{
    return k->D ? k->D[v] : med_D(m, v);
}

/* Conductance between neighbouring unknowns v and w (their D: dv, dw). */
static inline double edge_conductance(const ohm_channel_medium *m, double h, int64_t v, int64_t w, double dv,
                                      double dw)
{
    if (m->resistance_mode)
        return m->resistance_v ? 1.0 / (0.5 * m->resistance_v[v] + 0.5 * m->resistance_v[w]) : 1.0 / m->resistance;
    /* harmonic mean: series resistors of half cells; dv dw first, so that
     * v's row and w's compute the same bits (link_single rounds both) */
    return h * 2.0 * (dv * dw) / (dv + dw);
}

/* The interface term of network.h's G between cells of index ev and ew (in
 * the scaled unknowns of a medium of index eta): eta^2 6 (C_2,v + C_2,w) / S,
 * S the mean of the two sides' eta^2 T (equal by reciprocity; the mean keeps
 * G exactly symmetric in v and w). */
static double interface_resistance(const ohm_fresnel_table *tab, double ev, double ew, double eta)
{
    double c1v, c2v, c1w, c2w;
    ohm_fresnel_table_moments(tab, ev / ew, &c1v, &c2v);
    ohm_fresnel_table_moments(tab, ew / ev, &c1w, &c2w);
    double S = 0.5 * (ev * ev * (1.0 - 2.0 * c1v) + ew * ew * (1.0 - 2.0 * c1w));
    return eta * eta * 6.0 * (c2v + c2w) / S;
}

/* edge_conductance with a per-cell index (network.h). */
static inline double edge_conductance_eta(const coeffs *k, const ohm_channel_medium *m, double h, int64_t v,
                                          int64_t w, double dv, double dw)
{
    double ev = m->eta_v[v], ew = m->eta_v[w];
    double sv = ohm_network_unknown_scale(m, v), sw = ohm_network_unknown_scale(m, w);
    double r = h / (2.0 * dv * sv) + h / (2.0 * dw * sw);
    if (ev != ew) r += interface_resistance(k->tab, ev, ew, m->eta);
    return h * h / r;
}

/* The boundary constant of unknown v's faces: its own index's (network.h). */
static inline double cell_A(const coeffs *k, const ohm_channel_medium *m, int64_t v)
{
    if (!m->eta_v || m->resistance_mode) return k->A;
    if (k->fresnel == OHM_FRESNEL_POLYNOMIAL) return ohm_boundary_A(m->eta_v[v], OHM_FRESNEL_POLYNOMIAL);
    double c1, c2;
    ohm_fresnel_table_moments(k->tab, m->eta_v[v], &c1, &c2);
    return ohm_boundary_A_of_moments(c1, c2);
}

static inline double ground_conductance(const ohm_channel_medium *m, double h, int64_t v)
{
    if (m->resistance_mode) return 1.0 / (m->ground_v ? m->ground_v[v] : m->ground);
    return ohm_medium_sigma_a(m, v) * h * h * h;
}

double ohm_network_ground_conductance(const ohm_channel_medium *m, double h, int64_t v)
{
    return ground_conductance(m, h, v);
}

static inline double boundary_conductance(const ohm_channel_medium *m, double h, int64_t v, double dv, ohm_boundary b,
                                          double A)
{
    switch (b) {
    case OHM_BOUNDARY_NEUMANN: return 0.0;
    case OHM_BOUNDARY_DIRICHLET:
        /* phi = 0 on the face, half a cell away: D h^2 / (h/2) */
        if (m->resistance_mode) return 2.0 / (m->resistance_v ? m->resistance_v[v] : m->resistance);
        return 2.0 * dv * h;
    case OHM_BOUNDARY_ROBIN:
        /* half a cell of diffusion in series with the partial-current
         * condition phi_face = 2 A J (Jensen et al. 2001, Eq. 5-6) */
        return h * h / (h / (2.0 * dv) + 2.0 * A);
    }
    return 0.0;
}

/* The depth band's closure face (network.h): half a cell of diffusion in
 * series with the absorbing half-space's impedance 1 / (D sigma_tr). */
static inline double closure_conductance(const ohm_channel_medium *m, double h, int64_t v, double D)
{
    double sa, ss;
    ohm_medium_coefficients(m, v, &sa, &ss);
    double st = sa + ss;
    double sigma_tr = sqrt(3.0 * sa * st);
    if (!(sigma_tr > 0)) return 0.0; /* no absorption: the core reflects (zero flux) */
    return h * h / (h / (2.0 * D) + 1.0 / (D * sigma_tr));
}

static void coeffs_init(coeffs *k, const ohm_channel_medium *m, double h, ohm_boundary b,
                        const ohm_fresnel_table *tab)
{
    memset(k, 0, sizeof *k);
    k->A = m->resistance_mode ? 0.0 : ohm_boundary_A(m->eta, m->fresnel);
    k->fresnel = m->fresnel;
    k->tab = tab;
    k->uniform = !ohm_medium_varies(m) && (!m->resistance_mode || (!m->resistance_v && !m->ground_v)) &&
                 (m->resistance_mode || !m->eta_v);
    if (k->uniform) {
        double D = med_D(m, 0); /* unused in paper mode but by the closure, as per cell */
        k->g_edge = edge_conductance(m, h, 0, 0, D, D);
        k->g_ground = ground_conductance(m, h, 0);
        k->g_bound = boundary_conductance(m, h, 0, D, b, k->A);
        k->g_closure = closure_conductance(m, h, 0, D);
    }
}

int ohm_network_assemble(cholmod_sparse **Aout, double *ga, double *gb, const ohm_network *net,
                         const ohm_channel_medium *med, ohm_boundary boundary, cholmod_common *cc, ohm_error *err)
{
    *Aout = NULL;
    int64_t n = net->n;
    cholmod_sparse *M = cholmod_l_allocate_sparse((size_t)n, (size_t)n, (size_t)net->nnz, 1, 1, 1, CHOLMOD_REAL, cc);
    if (!M)
        return ohm_fail(err, OHM_ERR_NOMEM, "network: out of memory assembling %lld unknowns (%lld entries)",
                        (long long)n, (long long)net->nnz);
    int rc = ohm_network_assemble_into(M, ga, gb, net, med, boundary, err);
    if (rc) {
        cholmod_l_free_sparse(&M, cc);
        return rc;
    }
    *Aout = M;
    return OHM_OK;
}

/* What assembling one channel holds while it walks the unknowns: the
 * coefficients, the interfaces' table (per-cell index), a scan's D per
 * unknown, and each piece's sinks for the singularity check.  The CSC
 * matrix and the stencil are two writers of the same rows (assembly_row). */
typedef struct assembly {
    const ohm_network *net;
    const ohm_channel_medium *med;
    ohm_boundary boundary;
    double h;
    int per_cell_eta;
    ohm_fresnel_table *tab;
    double *dcache;
    double *sink; /* ground + boundary per piece */
    coeffs co;
    walk w;
} assembly;

/* Row v of the network's matrix (docs/design.md §3): the neighbour across each
 * face (walk_across's codes) and the link's conductance, the ground
 * conductance (the depth band's closure faces added), the boundary
 * conductance of each of its nfaces boundary faces, and the scale of the
 * unknown (network.h; 1 without eta_v).  The diagonal is
 * sum ge + (ga + nfaces gb) sv, summed in that order by the CSC writer. */
typedef struct assembly_row {
    int64_t nb[6];
    double ge[6];
    double ga, gb, sv;
    int nfaces;
} assembly_row;

static void assembly_free(assembly *as)
{
    free(as->sink);
    free(as->tab);
    free(as->dcache);
}

/* Above this many unknowns the stencil's rows and a scan's D per unknown
 * are computed on every core (base/parallel.h). */
enum { PARALLEL_ASSEMBLY_MIN = 1 << 16, DCACHE_CHUNKS = 64 };

typedef struct dcache_job {
    double *D;
    const ohm_channel_medium *med;
    int64_t n, chunks;
} dcache_job;

static void dcache_rows(void *user, int64_t i)
{
    const dcache_job *job = user;
    int64_t chunks = job->n >= PARALLEL_ASSEMBLY_MIN ? job->chunks : 1;
    for (int64_t v = job->n * i / chunks; v < job->n * (i + 1) / chunks; ++v) job->D[v] = med_D(job->med, v);
}

static int assembly_begin(assembly *as, const ohm_network *net, const ohm_channel_medium *med, ohm_boundary boundary,
                          ohm_error *err)
{
    memset(as, 0, sizeof *as);
    if (med->resistance_mode && boundary == OHM_BOUNDARY_ROBIN)
        return ohm_fail(err, OHM_ERR_USAGE,
                        "boundary=robin needs optical coefficients (sigma_a, sigma_s, eta); with resistance= "
                        "use boundary=neumann (the paper's) or dirichlet");
    int64_t n = net->n;
    as->net = net;
    as->med = med;
    as->boundary = boundary;
    as->h = net->grid->h;
    as->per_cell_eta = med->eta_v && !med->resistance_mode;
    as->tab = as->per_cell_eta ? malloc(sizeof *as->tab) : NULL;
    as->sink = calloc((size_t)(net->npieces ? net->npieces : 1), sizeof *as->sink);
    if (!as->sink || (as->per_cell_eta && !as->tab)) {
        assembly_free(as);
        return ohm_fail(err, OHM_ERR_NOMEM, "network: out of memory assembling %lld unknowns", (long long)n);
    }
    if (as->tab) ohm_fresnel_table_init(as->tab);
    coeffs_init(&as->co, med, as->h, boundary, as->tab);
    /* A scan's D from its density, once per unknown rather than once per
     * face (the curves' search is most of a cell's cost, bench_serial): 8 B
     * per cell held while assembling; without the memory, on demand. */
    if (!as->co.uniform && !med->resistance_mode && med->density &&
        (as->dcache = malloc((size_t)(n ? n : 1) * 8))) {
        dcache_job job = {as->dcache, med, n, DCACHE_CHUNKS};
        ohm_parallel_for(n >= PARALLEL_ASSEMBLY_MIN ? DCACHE_CHUNKS : 1, ohm_usable_cores(), dcache_rows, &job);
        as->co.D = as->dcache;
    }
    walk_begin(&as->w, net);
    return OHM_OK;
}

/* A link's conductance as the network holds it, for every solver: rounded
 * to single precision (network.h), a positive one kept positive.  One
 * beyond FLT_MAX is kept as it is: the stencil refuses it (stencil_rows),
 * an assembled A holds it. */
static inline double link_single(double g)
{
    if (!(g > 0) || g > FLT_MAX) return g;
    return g < FLT_MIN ? FLT_MIN : (double)(float)g;
}

/* Row v, visited in increasing order by the walk w (the assembly's own, or
 * one thread's), its sinks booked to its piece in sink[]. */
static void assembly_next(const assembly *as, walk *w, double *sink, int64_t v, assembly_row *r)
{
    const coeffs *co = &as->co;
    const ohm_channel_medium *med = as->med;
    const double h = as->h;
    walk_to(w, v);
    int nclosure_v = 0;
    r->nfaces = 0;
    double dv = co->uniform ? 0.0 : cell_D(co, med, v);
    r->sv = as->per_cell_eta ? ohm_network_unknown_scale(med, v) : 1.0;
    for (int d = 0; d < 6; ++d) {
        int64_t u = r->nb[d] = walk_across(w, d);
        r->ge[d] = 0.0;
        if (u >= 0 && co->uniform) r->ge[d] = link_single(co->g_edge);
        else if (u >= 0) {
            double du = cell_D(co, med, u);
            r->ge[d] = link_single(as->per_cell_eta ? edge_conductance_eta(co, med, h, v, u, dv, du)
                                                    : edge_conductance(med, h, v, u, dv, du));
        } else if (u == -1) ++r->nfaces;
        else if (u == -3) ++nclosure_v;
    }
    /* the sums in face order, as the per-face formulation adds them */
    double gav = co->uniform ? co->g_ground : ground_conductance(med, h, v);
    double gcl = !nclosure_v ? 0.0 : co->uniform ? co->g_closure : closure_conductance(med, h, v, dv);
    for (int d = 0; d < 6; ++d)
        if (r->nb[d] == -3) gav += gcl;
    r->ga = gav;
    r->gb = !r->nfaces ? 0.0
            : co->uniform ? co->g_bound
                          : boundary_conductance(med, h, v, dv, as->boundary, cell_A(co, med, v));
    double sinkv = gav;
    for (int q = 0; q < r->nfaces; ++q) sinkv += r->gb;
    sink[ohm_piece_runs_next(&as->net->pieces, &w->piece_run, v)] += sinkv;
}

/* A piece with no ground and no leaking face has a constant null vector:
 * light injected there can neither be absorbed nor leave. */
static int assembly_end(assembly *as, ohm_error *err)
{
    const ohm_network *net = as->net;
    for (int64_t p = 0; p < net->npieces; ++p) {
        if (as->sink[p] > 0) continue;
        int64_t v = 0; /* the piece's first unknown */
        for (int64_t r = 0; r < net->pieces.count; ++r)
            if (net->pieces.piece[r] == p) {
                v = net->pieces.start[r];
                break;
            }
        int32_t ijk[3];
        ohm_voxel_coords(net->grid, ohm_network_cell(net, v), ijk);
        int32_t i = ijk[0], j = ijk[1], k = ijk[2];
        int resistance = as->med->resistance_mode;
        const char *bname = ohm_boundary_name(as->boundary);
        assembly_free(as);
        if (resistance)
            return ohm_fail(err, OHM_ERR_NUMERIC,
                            "singular network: the piece containing cell (%d,%d,%d) has no path to ground and "
                            "boundary=%s lets nothing out",
                            i, j, k, bname);
        return ohm_fail(err, OHM_ERR_NUMERIC,
                        "singular matrix: sigma_a = 0 with boundary=%s in the piece containing cell (%d,%d,%d): light "
                        "can neither leave nor be absorbed (use boundary=robin, or give sigma_a > 0)",
                        bname, i, j, k);
    }
    assembly_free(as);
    return OHM_OK;
}

/* ga and gb of row r (either may be NULL); *f: the row's first boundary face,
 * advanced past its faces (they come in unknown order, as built). */
static inline void assembly_sinks(const assembly_row *r, int64_t v, double *ga, double *gb, int64_t *f)
{
    if (ga) ga[v] = r->ga;
    for (int q = 0; q < r->nfaces; ++q, ++*f)
        if (gb) gb[*f] = r->gb;
}

int ohm_network_assemble_into(cholmod_sparse *M, double *ga, double *gb, const ohm_network *net,
                              const ohm_channel_medium *med, ohm_boundary boundary, ohm_error *err)
{
    int64_t n = net->n;
    if ((int64_t)M->nrow != n || (int64_t)M->ncol != n || (int64_t)M->nzmax < net->nnz || M->stype != 1 ||
        M->xtype != CHOLMOD_REAL || M->itype != CHOLMOD_LONG || !M->packed)
        return ohm_fail(err, OHM_ERR_INTERNAL, "network: the matrix to refill is not this network's shape");
    assembly as;
    int rc = assembly_begin(&as, net, med, boundary, err);
    if (rc) return rc;
    int64_t *Ap = M->p, *Ai = M->i;
    double *Ax = M->x;
    int64_t pos = 0, f = 0;
    for (int64_t v = 0; v < n; ++v) {
        assembly_row r;
        assembly_next(&as, &as.w, as.sink, v, &r);
        Ap[v] = pos;
        /* lower neighbours in the order -z, -y, -x give ascending rows */
        static const int lower[3] = {4, 2, 0};
        for (int q = 0; q < 3; ++q) {
            int d = lower[q];
            if (r.nb[d] < 0) continue;
            Ai[pos] = r.nb[d];
            Ax[pos] = -r.ge[d];
            ++pos;
        }
        double diag = 0.0;
        for (int d = 0; d < 6; ++d)
            if (r.nb[d] >= 0) diag += r.ge[d];
        diag += r.ga * r.sv; /* the scaled unknown's (network.h); sv = 1 without eta_v */
        for (int q = 0; q < r.nfaces; ++q) diag += r.gb * r.sv;
        assembly_sinks(&r, v, ga, gb, &f);
        Ai[pos] = v;
        Ax[pos] = diag;
        ++pos;
    }
    Ap[n] = pos;
    return assembly_end(&as, err);
}

/* One thread's share of the stencil: unknowns v0 .. v1-1, its own walk
 * and piece sums (added up afterwards), from its first boundary face. */
typedef struct stencil_share {
    const assembly *as;
    ohm_stencil *st;
    double *ga, *gb;
    int64_t v0, v1;
    double *sink;
    ohm_stencil_runs runs; /* the share's, joined afterwards (not on a refill) */
    int find_runs;
    int overflow; /* an offset beyond 32 bits */
    int broken;   /* a link the stencil cannot hold: no conductance, or a
                     +x neighbour that is not the next unknown */
} stencil_share;

static void stencil_rows(void *user, int64_t i)
{
    stencil_share *sh = (stencil_share *)user + i;
    const assembly *as = sh->as;
    const ohm_network *net = as->net;
    ohm_stencil *st = sh->st;
    walk w;
    walk_begin(&w, net);
    int64_t f = first_face_from(net, sh->v0);
    for (int64_t v = sh->v0; v < sh->v1; ++v) {
        assembly_row r;
        assembly_next(as, &w, sh->sink, v, &r);
        int32_t off[4];
        for (int d = 2; d < 6; ++d) {
            int64_t delta = r.nb[d] >= 0 ? r.nb[d] - v : 0;
            if (delta < INT32_MIN || delta > INT32_MAX) sh->overflow = 1;
            off[d - 2] = (int32_t)delta;
        }
        if (sh->find_runs) ohm_stencil_runs_push(&sh->runs, v, off);
        /* the stencil's rule (network.h): a +x link is v + 1's, every link's
         * conductance > 0 */
        for (int d = 0; d < 6; ++d)
            if (r.nb[d] >= 0 && (!(r.ge[d] > 0 && r.ge[d] <= FLT_MAX) || (d < 2 && r.nb[d] != v + (d ? 1 : -1))))
                sh->broken = 1;
        st->gx[v] = (float)r.ge[1]; /* exact: link_single's */
        st->gy[v] = (float)r.ge[3];
        st->gz[v] = (float)r.ge[5];
        double sink = r.ga * r.sv; /* the diagonal's terms beyond the links, in its order */
        for (int q = 0; q < r.nfaces; ++q) sink += r.gb * r.sv;
        st->sink[v] = sink;
        assembly_sinks(&r, v, sh->ga, sh->gb, &f);
    }
}

int ohm_network_stencil(ohm_stencil *st, double *ga, double *gb, const ohm_network *net,
                        const ohm_channel_medium *med, ohm_boundary boundary, ohm_error *err)
{
    int64_t n = net->n;
    size_t m = (size_t)(n ? n : 1);
    if (st->n != n || !st->gx) { /* else a refill: same network and runs, new values */
        ohm_stencil_free(st);
        st->gx = malloc(m * sizeof *st->gx);
        st->gy = malloc(m * sizeof *st->gy);
        st->gz = malloc(m * sizeof *st->gz);
        st->sink = malloc(m * sizeof *st->sink);
        st->n = n;
        if (!st->gx || !st->gy || !st->gz || !st->sink) {
            ohm_stencil_free(st);
            return ohm_fail(err, OHM_ERR_NOMEM, "network: out of memory for the stencil of %lld unknowns (%.0f MB)",
                            (long long)n, (double)n * 20 / 1e6);
        }
    }
    ohm_stencil_drop_extra(st); /* a refill's: the network's own links only */
    assembly as;
    int rc = assembly_begin(&as, net, med, boundary, err);
    if (rc) return rc;
    /* rows are independent: on every core, each share with its own walk and
     * piece sums (the rows' values do not depend on the split) */
    int shares = n >= PARALLEL_ASSEMBLY_MIN ? ohm_usable_cores() : 1;
    if (shares > 16) shares = 16;
    stencil_share sh[16];
    size_t np = (size_t)(net->npieces ? net->npieces : 1);
    for (int i = 0; i < shares; ++i) {
        sh[i] = (stencil_share){&as, st, ga, gb, n * i / shares, n * (i + 1) / shares, NULL, {0}, !st->run_start, 0, 0};
        if (!(sh[i].sink = i == 0 ? as.sink : calloc(np, sizeof *sh[i].sink))) rc = OHM_ERR_NOMEM;
    }
    if (!rc) ohm_parallel_for(shares, shares, stencil_rows, sh);
    int overflow = 0, broken = 0;
    ohm_stencil_runs lists[16];
    for (int i = 0; i < shares; ++i) {
        overflow |= sh[i].overflow;
        broken |= sh[i].broken;
        for (size_t p = 0; i > 0 && sh[i].sink && p < np; ++p) as.sink[p] += sh[i].sink[p];
        if (i > 0) free(sh[i].sink);
        lists[i] = sh[i].runs;
    }
    if (!rc && !overflow && !broken && !st->run_start) rc = ohm_stencil_adopt_runs(st, lists, shares, err) ? OHM_ERR_NOMEM : OHM_OK;
    for (int i = 0; i < shares; ++i) ohm_stencil_runs_free(&lists[i]);
    if (rc || overflow || broken) {
        assembly_free(&as);
        if (rc) return ohm_fail(err, OHM_ERR_NOMEM, "network: out of memory assembling %lld unknowns", (long long)n);
        if (broken)
            return ohm_fail(err, OHM_ERR_NUMERIC, "network: a link of zero (or no finite) conductance: the medium's "
                            "coefficients are out of range for the stencil; use solver=direct or cg");
        return ohm_fail(err, OHM_ERR_USAGE, "network: a grid slice holds more unknowns than the stencil's 32-bit "
                        "offsets reach; use solver=direct or cg");
    }
    return assembly_end(&as, err);
}
