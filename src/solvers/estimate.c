/* solvers/estimate.c — see estimate.h. */
#include "solvers/estimate.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "solvers/backend.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

static const double BASE_BYTES = 95.0 * 1048576.0;
static const double GRID_BYTES_PER_CELL = 13.0;
static const double PAD_CELLS = 4; /* the band's 3 and one more, each side */
static const double FACTOR_BYTES_PER_NONZERO = 11.0;
static const double FACTOR_NNZ_COEFF = 2.19, FACTOR_NNZ_POWER = 1.4, FACTOR_NNZ_THICKNESS_POWER = 0.94;
static const double DIRECT_PER_CELL = 150.0, CG_PER_CELL = 375.0, MG_PER_CELL = 410.0, AUTO_PER_CELL = 650.0;
static const double AMG_SERIAL = 74.0, AMG_PER_CHANNEL = 392.0;
/* mg's column, per cell (docs/multigrid.md: 16-18 iterations and ~500 ns
 * per cell a column on the block medium from 1e5 to 1e7 cells) */
static const double MG_COLUMN_NS = 500.0;

void ohm_shape_of(ohm_shape *out, const ohm_mesh *mesh)
{
    memset(out, 0, sizeof *out);
    out->compactness = 1.0;
    if (!mesh->nverts || !mesh->ntris) return;
    double lo[3], hi[3], area = 0;
    ohm_mesh_bounds(mesh, lo, hi);
    for (int a = 0; a < 3; ++a) out->extent[a] = hi[a] - lo[a];
    out->volume = fabs(ohm_mesh_signed_volume(mesh));
    for (size_t t = 0; t < mesh->ntris; ++t) {
        const double *p = &mesh->verts[3 * mesh->tris[3 * t]], *q = &mesh->verts[3 * mesh->tris[3 * t + 1]],
                     *r = &mesh->verts[3 * mesh->tris[3 * t + 2]];
        double u[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]}, v[3] = {r[0] - p[0], r[1] - p[1], r[2] - p[2]};
        double c[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
        area += 0.5 * sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    }
    /* (36 pi V^2 / S^3)^(1/3) = (3V/S) / (3V/(4 pi))^(1/3): the mean
     * thickness 3V/S over a sphere's of the same volume */
    if (area > 0) out->compactness = fmin(1.0, fmax(0.05, cbrt(36.0 * M_PI * out->volume * out->volume / (area * area * area))));
}

/* (interior cells, cells of the grid's box) at dim cells across */
static void cells_at(const ohm_shape *shape, int dim, double *interior, double *box)
{
    double longest = fmax(shape->extent[0], fmax(shape->extent[1], shape->extent[2]));
    *interior = *box = 0;
    if (!(longest > 0) || dim < 1) return;
    double h = longest / dim;
    *box = 1;
    for (int a = 0; a < 3; ++a) *box *= fmax(1.0, ceil(shape->extent[a] / h - 1e-9)) + 2 * PAD_CELLS;
    *interior = fmin(shape->volume / (h * h * h), *box);
}

static double solver_bytes(const ohm_shape *shape, double n, ohm_solver_kind solver, int channels)
{
    switch (solver) {
    case OHM_SOLVER_DIRECT: {
        double nnz = FACTOR_NNZ_COEFF * pow(n, FACTOR_NNZ_POWER) * pow(shape->compactness, FACTOR_NNZ_THICKNESS_POWER);
        return FACTOR_BYTES_PER_NONZERO * channels * nnz + DIRECT_PER_CELL * n;
    }
    case OHM_SOLVER_CG: return CG_PER_CELL * n;
    case OHM_SOLVER_AMG: return (AMG_SERIAL + AMG_PER_CHANNEL * channels) * n;
    case OHM_SOLVER_MG: return MG_PER_CELL * n;
    case OHM_SOLVER_AUTO: return AUTO_PER_CELL * n;
    case OHM_SOLVER_MC: return 0; /* not modelled */
    }
    return 0;
}

static double whole_bytes(const ohm_shape *shape, int dim, ohm_solver_kind solver, int channels)
{
    double n, box;
    cells_at(shape, dim, &n, &box);
    return BASE_BYTES + GRID_BYTES_PER_CELL * box + solver_bytes(shape, n, solver, channels);
}

/* auto's choice: the quickest of mg, direct and amg for `solves` solves of
 * each channel, among those whose bytes fit (the first solve of each
 * channel is mg's whatever auto takes after it: its probe) */
static void auto_choice(ohm_solve_estimate *out, double n, int channels, double solves, double allowed)
{
    double columns = fmax(1.0, solves) * channels, rest = columns - channels;
    double t_probe = channels * 1e-9 * MG_COLUMN_NS * n;
    struct {
        ohm_solver_kind kind;
        double t;
    } c[3] = {{OHM_SOLVER_MG, rest * 1e-9 * MG_COLUMN_NS * n},
              {OHM_SOLVER_DIRECT, ohm_auto_direct_seconds(n, channels, rest)},
              {OHM_SOLVER_AMG, ohm_auto_amg_seconds(n, channels, rest)}};
    int nc = ohm_backend_amg_available() ? 3 : 2, best = -1;
    size_t len = (size_t)snprintf(out->auto_reason, sizeof out->auto_reason,
                                  "%.3g cells, %.0f solve(s) of %d channel(s), predicted:", n, fmax(1.0, solves),
                                  channels);
    for (int k = 0; k < nc; ++k) {
        int fits = OHM_ESTIMATE_MARGIN * out->bytes[c[k].kind] <= allowed;
        if (fits && (best < 0 || c[k].t < c[best].t)) best = k;
        if (len < sizeof out->auto_reason)
            len += (size_t)snprintf(out->auto_reason + len, sizeof out->auto_reason - len, " %s %.3g s%s%s",
                                    ohm_solver_kind_name(c[k].kind), t_probe + c[k].t, fits ? "" : " (does not fit)",
                                    k + 1 < nc ? "," : "");
    }
    out->auto_choice = best < 0 ? OHM_SOLVER_MG : c[best].kind;
}

void ohm_estimate_solve(ohm_solve_estimate *out, const ohm_shape *shape, int dim, int channels, double solves,
                        double allowed)
{
    memset(out, 0, sizeof *out);
    cells_at(shape, dim, &out->interior_cells, &out->box_cells);
    for (int k = 0; k <= OHM_SOLVER_MC; ++k)
        out->bytes[k] = k == OHM_SOLVER_MC ? 0 : whole_bytes(shape, dim, (ohm_solver_kind)k, channels);
    auto_choice(out, out->interior_cells, channels, solves, allowed);
}

int ohm_estimate_largest_dim(const ohm_shape *shape, ohm_solver_kind solver, int channels, double allowed)
{
    int lo = 0, hi = 4096;
    while (lo < hi) {
        int mid = (lo + hi + 1) / 2;
        if (OHM_ESTIMATE_MARGIN * whole_bytes(shape, mid, solver, channels) <= allowed) lo = mid;
        else hi = mid - 1;
    }
    return lo >= 4 ? lo : 0;
}
