/* solvers/booking.c — power booked per solve (docs/design.md §3): in
 * (deposited) = absorbed (sum G_a phi) + out (sum G_b phi) and the exitance
 * per face; the constant-mode correction of nearly singular pieces, which
 * makes that law hold exactly; and each channel's tally, added to the
 * solution in channel order. */
#include "physics/stencil.h"
#include "solvers/solver_impl.h"

#include <math.h>
#include <stdlib.h>

/* A piece whose sinks (ground + boundary conductance) are this small next to
 * its diagonal is nearly singular (e.g. sigma_a = 1e-9 with boundary=neumann):
 * x is a huge constant mode plus the variation that matters, and in double
 * precision sum(b - A x) = in - absorbed - out cannot fall below ~kappa eps,
 * however small the backward error (measured: 3.6e-9 at sink/diagonal ~ 1e-7,
 * 6e-10 at ~1e-6; tests/cli_extremes.sh).  For such pieces only, shift the constant
 * mode so the discrete conservation law holds exactly; the shift is reported
 * and the backward error is checked again afterwards. */
static const double NEAR_SINGULAR = 1e-5;

void ohm_tally_add(ohm_solution *sol, const channel_tally *t, int c)
{
    sol->power_incident += t->power_incident;
    sol->power_entered += t->power_entered;
    sol->power_in += t->power_in;
    sol->power_absorbed += t->power_absorbed;
    sol->power_out += t->power_out;
    sol->power_in_channel[c] += t->power_in;
    sol->power_out_channel[c] += t->power_out;
    sol->t_source += t->t_source;
    sol->t_solve += t->t_solve;
    if (t->residual > sol->residual) sol->residual = t->residual;
    if (t->mode_shift > sol->mode_shift) sol->mode_shift = t->mode_shift;
    sol->solves += t->solves;
    sol->solves_skipped += t->solves_skipped;
    sol->mode_corrections += t->mode_corrections;
}

/* Unknown v's ground conductance: the assembly's ga when it kept one (a
 * depth band's closure faces add to it), else the medium's, by the formula
 * the assembly used (bit for bit; 8 B per cell not held). */
static inline double ground_of(const double *ga, const ohm_network *net, const ohm_channel_medium *med, int64_t v)
{
    return ga ? ga[v] : ohm_network_ground_conductance(med, net->grid->h, v);
}

/* Unknown v's sink, ground plus its boundary faces' (from *f, advanced
 * past them: they come in unknown order), computed where it is needed
 * rather than held n long beside a large solve.  X holds the scaled
 * unknowns with eta_v (network.h): their sinks are s_v times phi's. */
static double unknown_sink(const double *ga, const double *gb, const ohm_network *net, const ohm_channel_medium *med,
                           int64_t v, int64_t *f)
{
    double s = ground_of(ga, net, med, v);
    for (; *f < net->nfaces && net->face_unknown[*f] == v; ++*f) s += gb[*f];
    return med->eta_v ? s * ohm_network_unknown_scale(med, v) : s;
}

static int correct_constant_modes(channel_tally *t, const ohm_network *net, double *X, const double *B, size_t ncols,
                                  const double *ga, const double *gb, const ohm_operator *op,
                                  const ohm_channel_medium *med)
{
    int64_t n = net->n, np = net->npieces, f = 0;
    double *sink = calloc((size_t)np, sizeof *sink), *diag = calloc((size_t)np, sizeof *diag);
    double *defect = malloc((size_t)np * sizeof *defect);
    if (!sink || !diag || !defect) {
        free(sink), free(diag), free(defect);
        return -1;
    }
    const ohm_piece_runs *pieces = &net->pieces;
    int64_t run = 0;
    if (op->stencil) /* its sinks are these, in one vectorised pass */
        ohm_stencil_piece_sums(op->stencil, pieces->start, pieces->piece, pieces->count, sink, diag);
    else
        for (int64_t v = 0; v < n; ++v) {
            int64_t p = ohm_piece_runs_next(pieces, &run, v);
            sink[p] += unknown_sink(ga, gb, net, med, v, &f);
            diag[p] += ohm_operator_diag(op, v);
        }
    int any = 0;
    for (int64_t p = 0; p < np; ++p) any |= sink[p] < NEAR_SINGULAR * diag[p];
    for (size_t col = 0; any && col < ncols; ++col) {
        double *x = X + col * (size_t)n;
        const double *b = B + col * (size_t)n;
        for (int64_t p = 0; p < np; ++p) defect[p] = 0;
        f = 0;
        run = 0;
        for (int64_t v = 0; v < n; ++v)
            defect[ohm_piece_runs_next(pieces, &run, v)] += b[v] - unknown_sink(ga, gb, net, med, v, &f) * x[v];
        double xmax = 0;
        for (int64_t v = 0; v < n; ++v) xmax = fmax(xmax, fabs(x[v]));
        for (int64_t p = 0; p < np; ++p) {
            if (!(sink[p] < NEAR_SINGULAR * diag[p]) || !(sink[p] > 0)) continue;
            double c = defect[p] / sink[p];
            if (!pieces->count)
                for (int64_t v = 0; v < n; ++v) x[v] += c;
            for (int64_t r = 0; r < pieces->count; ++r)
                if (pieces->piece[r] == p)
                    for (int64_t v = pieces->start[r]; v < pieces->start[r + 1]; ++v) x[v] += c;
            t->mode_corrections++;
            if (xmax > 0 && fabs(c) / xmax > t->mode_shift) t->mode_shift = fabs(c) / xmax;
        }
    }
    free(sink), free(diag), free(defect);
    return any;
}

/* Book the power of frames f0..f0+nb of channel c (X: their fluence, solved
 * in place in sol->fluence[c]): in (deposited) = absorbed (sum G_a phi) + out
 * (sum G_b phi), docs/design.md §3; and store the exitance per face (a cell's is
 * derived from its faces' when read: ohm_solution_exitance_frame). */
void ohm_book_power(ohm_solution *sol, channel_tally *t, const double *X, const double *B, const double *ga,
                    const double *gb, const ohm_channel_medium *med, size_t f0, size_t nb, int c)
{
    const ohm_network *net = &sol->net;
    size_t n = (size_t)net->n, nf = (size_t)(net->nfaces ? net->nfaces : 1);
    const double area = net->grid->h * net->grid->h;
    double in = 0, absorbed = 0, out = 0;
    for (size_t j = 0; j < nb; ++j) {
        size_t fr = f0 + j;
        const double *x = X + j * n, *b = B + j * n;
        double *fx = sol->face_exitance[c] + fr * nf;
        for (size_t v = 0; v < n; ++v) {
            in += b[v];
            absorbed += ground_of(ga, net, med, (int64_t)v) * x[v];
        }
        for (int64_t f = 0; f < net->nfaces; ++f) {
            double p = gb[f] * x[net->face_unknown[f]];
            out += p;
            fx[f] = p / area;
        }
    }
    t->power_in += in;
    t->power_absorbed += absorbed;
    t->power_out += out;
}

/* The constant-mode correction of nearly singular pieces, then the backward
 * error again (it must stay within the direct solver's limit). */
int ohm_conserve_exactly(channel_tally *t, const ohm_network *net, double *X, const double *B, size_t nu,
                         const double *ga, const double *gb, const ohm_operator *op, const ohm_channel_medium *med,
                         double *berr, ohm_error *err)
{
    int corrected = correct_constant_modes(t, net, X, B, nu, ga, gb, op, med);
    if (corrected < 0) return ohm_fail(err, OHM_ERR_NOMEM, "solve: out of memory");
    if (corrected == 0) return OHM_OK;
    *berr = ohm_operator_backward_error(op, B, X, nu, 0);
    if (!(*berr <= 1e-10))
        return ohm_fail(err, OHM_ERR_NUMERIC, "solve: backward error %.3g after the constant-mode correction", *berr);
    return OHM_OK;
}
