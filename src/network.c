/* network.c — topology and assembly of the diffusion network (network.h). */
#include "network.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "material.h"

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
    free(net->cell);
    free(net->unknown);
    free(net->face_unknown);
    free(net->face_dir);
    free(net->piece);
    memset(net, 0, sizeof *net);
}

static int64_t find_root(int64_t *parent, int64_t x)
{
    while (parent[x] != x) {
        parent[x] = parent[parent[x]];
        x = parent[x];
    }
    return x;
}

/* Neighbour of cell (i,j,k) across face d: its unknown, -1 if outside the
 * object, -2 if the face is a mirror plane, -3 if it is interior but below
 * the depth band (a closure face). */
static int64_t across(const ohm_network *net, int32_t i, int32_t j, int32_t k, int d)
{
    const ohm_voxel_grid *g = net->grid;
    int32_t c[3] = {i, j, k};
    int axis = d / 2;
    if ((d % 2) == 0 && net->mirror_low[axis] >= 0 && c[axis] == net->mirror_low[axis]) return -2;
    int32_t a = i + ohm_face_offset[d][0], b = j + ohm_face_offset[d][1], e = k + ohm_face_offset[d][2];
    if (a < 0 || b < 0 || e < 0 || a >= g->dims[0] || b >= g->dims[1] || e >= g->dims[2]) return -1;
    size_t cell = ohm_voxel_index(g, a, b, e);
    int64_t u = net->unknown[cell];
    if (u < 0 && net->active && g->inside[cell]) return -3;
    return u;
}

int ohm_network_build(ohm_network *net, const ohm_voxel_grid *grid, const int32_t mirror_low[3], ohm_error *err)
{
    return ohm_network_build_band(net, grid, mirror_low, NULL, err);
}

int ohm_network_build_band(ohm_network *net, const ohm_voxel_grid *grid, const int32_t mirror_low[3],
                           const uint8_t *active, ohm_error *err)
{
    memset(net, 0, sizeof *net);
    net->grid = grid;
    net->active = active;
    for (int a = 0; a < 3; ++a) net->mirror_low[a] = mirror_low ? mirror_low[a] : -1;
    size_t ncells = (size_t)grid->dims[0] * (size_t)grid->dims[1] * (size_t)grid->dims[2];
    const uint8_t *unknowns = active ? active : grid->inside;
    int64_t n = 0;
    if (active) {
        for (size_t c = 0; c < ncells; ++c) n += active[c] && grid->inside[c];
    } else {
        n = (int64_t)grid->interior_cells;
    }
    if (n == 0) return ohm_fail(err, OHM_ERR_INVALID, "network: the voxel object has no interior cells");
    net->unknown = malloc(ncells * sizeof *net->unknown);
    net->cell = malloc((size_t)n * sizeof *net->cell);
    net->piece = malloc((size_t)n * sizeof *net->piece);
    if (!net->unknown || !net->cell || !net->piece) goto nomem;
    int64_t u = 0;
    for (size_t c = 0; c < ncells; ++c) {
        if (unknowns[c] && grid->inside[c]) {
            if (u == n) return ohm_fail(err, OHM_ERR_INTERNAL, "network: interior count mismatch");
            net->cell[u] = (int64_t)c;
            net->unknown[c] = u++;
        } else {
            net->unknown[c] = -1;
        }
    }
    net->n = n;

    /* Count boundary faces and matrix entries; join pieces. */
    int64_t nfaces = 0, offdiag = 0;
    for (int64_t v = 0; v < n; ++v) net->piece[v] = v;
    for (int64_t v = 0; v < n; ++v) {
        int32_t ijk[3];
        ohm_voxel_coords(grid, net->cell[v], ijk);
        int32_t i = ijk[0], j = ijk[1], k = ijk[2];
        for (int d = 0; d < 6; ++d) {
            int64_t w = across(net, i, j, k, d);
            if (w == -1) ++nfaces;
            else if (w == -3) ++net->nclosure;
            else if (w >= 0 && w < v) {
                ++offdiag;
                int64_t ra = find_root(net->piece, v), rb = find_root(net->piece, w);
                if (ra != rb) net->piece[ra] = rb;
            }
        }
    }
    /* Number the pieces 0..npieces-1. */
    int64_t *label = malloc((size_t)n * sizeof *label);
    if (!label) goto nomem;
    for (int64_t v = 0; v < n; ++v) label[v] = -1;
    int64_t npieces = 0;
    /* resolve every root before relabelling: piece[] holds parents until then */
    for (int64_t v = 0; v < n; ++v) {
        int64_t r = find_root(net->piece, v);
        if (label[r] < 0) label[r] = npieces++;
    }
    for (int64_t v = 0; v < n; ++v) net->piece[v] = find_root(net->piece, v);
    for (int64_t v = 0; v < n; ++v) net->piece[v] = label[net->piece[v]];
    free(label);
    net->npieces = npieces;

    net->nfaces = nfaces;
    net->nnz = n + offdiag;
    net->face_unknown = malloc((size_t)(nfaces ? nfaces : 1) * sizeof *net->face_unknown);
    net->face_dir = malloc((size_t)(nfaces ? nfaces : 1));
    if (!net->face_unknown || !net->face_dir) goto nomem;
    int64_t f = 0;
    for (int64_t v = 0; v < n; ++v) {
        int32_t ijk[3];
        ohm_voxel_coords(grid, net->cell[v], ijk);
        int32_t i = ijk[0], j = ijk[1], k = ijk[2];
        for (int d = 0; d < 6; ++d)
            if (across(net, i, j, k, d) == -1) {
                net->face_unknown[f] = v;
                net->face_dir[f] = (uint8_t)d;
                ++f;
            }
    }
    return OHM_OK;

nomem:
    ohm_network_free(net);
    return ohm_fail(err, OHM_ERR_NOMEM, "network: out of memory for %lld cells", (long long)n);
}

/* Per-unknown coefficients of one channel. */
static inline double med_sa(const ohm_channel_medium *m, int64_t v) { return m->sigma_a ? m->sigma_a[v] : m->sigma_a0; }
static inline double med_ss(const ohm_channel_medium *m, int64_t v) { return m->sigma_s ? m->sigma_s[v] : m->sigma_s0; }
static inline double med_D(const ohm_channel_medium *m, int64_t v) { return 1.0 / (3.0 * (med_sa(m, v) + med_ss(m, v))); }

/* Conductance between neighbouring unknowns v and w. */
static inline double edge_conductance(const ohm_channel_medium *m, double h, int64_t v, int64_t w)
{
    if (m->resistance_mode)
        return m->resistance_v ? 1.0 / (0.5 * m->resistance_v[v] + 0.5 * m->resistance_v[w]) : 1.0 / m->resistance;
    double dv = med_D(m, v), dw = med_D(m, w);
    return h * 2.0 * dv * dw / (dv + dw); /* harmonic mean: series resistors of half cells */
}

static inline double ground_conductance(const ohm_channel_medium *m, double h, int64_t v)
{
    if (m->resistance_mode) return 1.0 / (m->ground_v ? m->ground_v[v] : m->ground);
    return med_sa(m, v) * h * h * h;
}

static inline double boundary_conductance(const ohm_channel_medium *m, double h, int64_t v, ohm_boundary b, double A)
{
    switch (b) {
    case OHM_BOUNDARY_NEUMANN: return 0.0;
    case OHM_BOUNDARY_DIRICHLET:
        /* phi = 0 on the face, half a cell away: D h^2 / (h/2) */
        if (m->resistance_mode) return 2.0 / (m->resistance_v ? m->resistance_v[v] : m->resistance);
        return 2.0 * med_D(m, v) * h;
    case OHM_BOUNDARY_ROBIN:
        /* half a cell of diffusion in series with the partial-current
         * condition phi_face = 2 A J (Jensen et al. 2001, Eq. 5-6) */
        return h * h / (h / (2.0 * med_D(m, v)) + 2.0 * A);
    }
    return 0.0;
}

/* The depth band's closure face (network.h): half a cell of diffusion in
 * series with the absorbing half-space's impedance 1 / (D sigma_tr). */
static inline double closure_conductance(const ohm_channel_medium *m, double h, int64_t v)
{
    double D = med_D(m, v), sa = med_sa(m, v), st = sa + med_ss(m, v);
    double sigma_tr = sqrt(3.0 * sa * st);
    if (!(sigma_tr > 0)) return 0.0; /* no absorption: the core reflects (zero flux) */
    return h * h / (h / (2.0 * D) + 1.0 / (D * sigma_tr));
}

int ohm_network_assemble(cholmod_sparse **Aout, double *ga, double *gb, const ohm_network *net,
                         const ohm_channel_medium *med, ohm_boundary boundary, cholmod_common *cc, ohm_error *err)
{
    *Aout = NULL;
    if (med->resistance_mode && boundary == OHM_BOUNDARY_ROBIN)
        return ohm_fail(err, OHM_ERR_USAGE,
                        "boundary=robin needs optical coefficients (sigma_a, sigma_s, eta); with resistance= "
                        "use boundary=neumann (the paper's) or dirichlet");
    const ohm_voxel_grid *g = net->grid;
    const double h = g->h;
    const double A = med->resistance_mode ? 0.0 : ohm_boundary_A(med->eta);
    int64_t n = net->n;
    cholmod_sparse *M = cholmod_l_allocate_sparse((size_t)n, (size_t)n, (size_t)net->nnz, 1, 1, 1, CHOLMOD_REAL, cc);
    double *sink = calloc((size_t)net->npieces, sizeof *sink); /* ground + boundary per piece */
    if (!M || !sink) {
        cholmod_l_free_sparse(&M, cc);
        free(sink);
        return ohm_fail(err, OHM_ERR_NOMEM, "network: out of memory assembling %lld unknowns (%lld entries)",
                        (long long)n, (long long)net->nnz);
    }
    int64_t *Ap = M->p, *Ai = M->i;
    double *Ax = M->x;
    int64_t pos = 0;
    int64_t f = 0; /* boundary faces come in unknown order, as built */
    for (int64_t v = 0; v < n; ++v) {
        Ap[v] = pos;
        int32_t ijk[3];
        ohm_voxel_coords(g, net->cell[v], ijk);
        int32_t i = ijk[0], j = ijk[1], k = ijk[2];
        double diag = 0.0;
        /* lower neighbours in the order -z, -y, -x give ascending rows */
        static const int lower[3] = {4, 2, 0};
        for (int q = 0; q < 3; ++q) {
            int64_t w = across(net, i, j, k, lower[q]);
            if (w < 0) continue;
            double gcd = edge_conductance(med, h, v, w);
            Ai[pos] = w;
            Ax[pos] = -gcd;
            ++pos;
        }
        double gav = ground_conductance(med, h, v);
        for (int d = 0; d < 6; ++d) {
            int64_t w = across(net, i, j, k, d);
            if (w >= 0) diag += edge_conductance(med, h, v, w);
            else if (w == -3) gav += closure_conductance(med, h, v);
        }
        diag += gav;
        if (ga) ga[v] = gav;
        double sinkv = gav;
        while (f < net->nfaces && net->face_unknown[f] == v) {
            double gbf = boundary_conductance(med, h, v, boundary, A);
            if (gb) gb[f] = gbf;
            diag += gbf;
            sinkv += gbf;
            ++f;
        }
        sink[net->piece[v]] += sinkv;
        Ai[pos] = v;
        Ax[pos] = diag;
        ++pos;
    }
    Ap[n] = pos;

    /* A piece with no ground and no leaking face has a constant null vector:
     * light injected there can neither be absorbed nor leave. */
    for (int64_t p = 0; p < net->npieces; ++p) {
        if (sink[p] > 0) continue;
        int64_t v = 0;
        while (net->piece[v] != p) ++v;
        int32_t ijk[3];
        ohm_voxel_coords(g, net->cell[v], ijk);
        int32_t i = ijk[0], j = ijk[1], k = ijk[2];
        free(sink);
        cholmod_l_free_sparse(&M, cc);
        if (med->resistance_mode)
            return ohm_fail(err, OHM_ERR_NUMERIC,
                            "singular network: the piece containing cell (%d,%d,%d) has no path to ground and "
                            "boundary=%s lets nothing out",
                            i, j, k, ohm_boundary_name(boundary));
        return ohm_fail(err, OHM_ERR_NUMERIC,
                        "singular matrix: sigma_a = 0 with boundary=%s in the piece containing cell (%d,%d,%d): light "
                        "can neither leave nor be absorbed (use boundary=robin, or give sigma_a > 0)",
                        ohm_boundary_name(boundary), i, j, k);
    }
    free(sink);
    *Aout = M;
    return OHM_OK;
}
