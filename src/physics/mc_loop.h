/* mc_loop.h — one photon of the Monte Carlo tracer (mc.h), from its entry
 * to its end: the event loop the host (mc.c, a thread per batch) and the
 * OpenCL device (mc_device.cl, a work-item per photon) both run, one source
 * written in what C11 and OpenCL C share (mc.c includes it; the build puts
 * its text, and that of the headers it includes, into mc_device.cl's).
 * The steps it takes are mc_step.h's.
 *
 * The includer defines, before including it:
 *   mc_rng          its random-number state's type
 *   MC_UNIFORM(r)   a double uniform on [0, 1) from r
 *   mc_index        an unknown's number (int64_t on the host, int on a device)
 *   mc_long         a count of photons or events (64 bits)
 *   MC_GLOBAL       the address space of the scene's arrays (__global; empty)
 *   MC_HANDOFF      where the hybrid's handoff is compiled in
 *   mc_scene        what the photon reads, a struct with at least
 *                     MC_GLOBAL const double *cdf;  mc_long nentries;
 *                       the entries' cumulative power (the last 1)
 *                     int mirror_low[3], mirror_high[3];  symmetry planes
 *                       (network.h's ohm_mirrors), -1: none
 *                     double max_path;  voxels to the time gate, INFINITY: none
 *                     int total_fluence;  tally the unscattered beam too
 *                     double handoff;  > 0: the hybrid's reduced scatterings
 *   and the functions, static inline where it can:
 *     void mc_entry(const mc_scene *sc, mc_long e, mc_index *v, int c[3], int *d, int *at_point,
 *                   double at[3], double u[3])
 *       entry e's unknown, cell, face direction (0..5, network.h), whether
 *       it enters at a point and that point (voxel coordinates), its
 *       direction inside
 *     mc_index mc_unknown_at(const mc_scene *sc, const int n[3])
 *       the unknown of grid cell n, or -1 outside the grid or the object
 *     void mc_coefficients(const mc_scene *sc, mc_index v, double *sa, double *ss)
 *       sigma_a and sigma_s = sigma_s' / (1 - g) of unknown v, in 1/voxel
 *     double mc_cell_g(const mc_scene *sc, mc_index v), mc_cell_eta(...)
 *       the anisotropy and the index of unknown v
 *     MC_ETA_VARIES(sc)  whether cells have their own index
 *   mc_to           where the tallies go, with:
 *     void mc_tally_fluence(mc_to *to, mc_index v, double x)
 *       x (weight x voxels) added to unknown v's fluence
 *     void mc_tally_left(mc_to *to, mc_index v)
 *       the photon leaves unknown v (to another cell, or ends there): a
 *       device adds what it gathered in v here
 *     void mc_tally_exit(const mc_scene *sc, mc_to *to, mc_index v, int d, double w)
 *       weight w out through unknown v's boundary face in direction d
 *     void mc_tally_handoff(mc_to *to, mc_index v, double w)
 *       (MC_HANDOFF) w added to unknown v's handed-off weight
 *     MC_TOTAL(to, name)  an lvalue: the totals absorbed, out, gated,
 *       handed (weights), events, truncated (counts)
 *
 * Lengths are in voxels, cell i spanning [i, i+1); directions unit vectors. */
#ifndef OHM_PHYSICS_MC_LOOP_H
#define OHM_PHYSICS_MC_LOOP_H

#include "physics/mc_step.h"

/* Below this weight (of a photon's 1 at entry) a photon ends, depositing the
 * rest where it is (mc.h). */
#define MC_W_MIN 1e-6
/* A photon still alive after this many path segments (a medium that neither
 * absorbs nor lets light out, in practice) ends the same way, and is counted. */
#define MC_MAX_EVENTS 100000000

/* One photon of weight 1, from an entry picked by its share of the power
 * to its end (mc.h): free paths, continuous absorption with the track
 * length's fluence, Henyey-Greenstein scattering, Fresnel reflection or
 * escape at boundary faces, reflection or refraction at changes of index,
 * symmetry planes, the time gate, the weight floor, the hybrid's handoff. */
static inline void mc_trace_photon(const mc_scene *sc, mc_to *to, mc_rng *r)
{
    mc_long e = mc_pick_entry(sc->cdf, sc->nentries, MC_UNIFORM(r));
    mc_index v;
    int c[3], d, at_point;
    double at[3], u[3], p[3];
    mc_entry(sc, e, &v, c, &d, &at_point, at, u);
    mc_start_point(c, d, at_point, at, r, p);
    double w = 1.0, sa, ss;
    mc_coefficients(sc, v, &sa, &ss);
    double tau = mc_depth(r), path_left = sc->max_path;
    int scattered = 0; /* the unscattered beam is not diffuse fluence (mc.h) */
#ifdef MC_HANDOFF
    double reduced = 0; /* reduced scatterings so far: sum of 1 - g (the hybrid's clock) */
#endif
    mc_long ev = 0;
    for (;; ++ev) {
        if (ev >= MC_MAX_EVENTS) {
            MC_TOTAL(to, truncated) += 1;
            break;
        }
        int ax, scatters, gated;
        double s = mc_segment(c, p, u, ss, tau, path_left, &ax, &scatters, &gated);
        path_left -= s;
        /* absorption along the segment, exactly: w e^(-sa s); its track
         * length integral w (1 - e^(-sa s)) / sa is the fluence tally */
        double x = sa * s, lost = mc_absorbed_fraction(x);
        if (scattered || sc->total_fluence) mc_tally_fluence(to, v, x > 1e-9 ? w * lost / sa : w * s);
        double w1 = w - w * lost;
        MC_TOTAL(to, absorbed) += w - w1;
        w = w1;
        if (gated) {
            MC_TOTAL(to, gated) += w;
            w = 0;
            break;
        }
        for (int a = 0; a < 3; ++a) p[a] += s * u[a];
        if (scatters) {
            double g = mc_cell_g(sc, v);
            scattered = 1;
#ifdef MC_HANDOFF
            /* the hybrid's: diffusion from here (the margin: ten steps of 1 - 0.9 sum to 0.99..9) */
            if (sc->handoff > 0 && (reduced += 1.0 - g) >= sc->handoff - 1e-9) {
                mc_hand_off(sc, to, v, c, p, w);
                MC_TOTAL(to, handed) += w;
                w = 0;
                break;
            }
#endif
            mc_scatter(u, g, r);
            tau = mc_depth(r);
        } else {
            tau -= ss * s;
            int step = u[ax] > 0 ? 1 : -1;
            p[ax] = (double)(step > 0 ? c[ax] + 1 : c[ax]);
            if (c[ax] == (step < 0 ? sc->mirror_low[ax] : sc->mirror_high[ax])) { /* symmetry plane */
                u[ax] = -u[ax];
                continue;
            }
            int n[3] = {c[0], c[1], c[2]};
            n[ax] += step;
            mc_index nv = mc_unknown_at(sc, n);
            if (nv >= 0 && MC_ETA_VARIES(sc) && mc_cell_eta(sc, nv) != mc_cell_eta(sc, v) &&
                !mc_cross_interface(u, ax, mc_cell_eta(sc, v), mc_cell_eta(sc, nv), r)) {
                /* reflected at an internal change of index: stays in v */
            } else if (nv >= 0) {
                mc_tally_left(to, v);
                c[ax] = n[ax];
                v = nv;
                mc_coefficients(sc, v, &sa, &ss);
            } else { /* a boundary face: reflected with the Fresnel probability, else out */
                double R = ohm_fresnel_inside(mc_cell_eta(sc, v), fabs(u[ax]));
                if (R < 1.0 && MC_UNIFORM(r) >= R) {
                    mc_tally_exit(sc, to, v, 2 * ax + (step > 0), w);
                    MC_TOTAL(to, out) += w;
                    w = 0;
                    break;
                }
                u[ax] = -u[ax];
            }
        }
        if (w < MC_W_MIN) break;
    }
    mc_tally_left(to, v);
    MC_TOTAL(to, absorbed) += w; /* what is left ends here (mc.h) */
    MC_TOTAL(to, events) += ev;
}

#endif
