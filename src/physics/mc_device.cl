/* mc_device.cl — the Monte Carlo tracer on an OpenCL device (mc_device.c;
 * issue 37): one photon per work-item, with the physics of mc.c's
 * trace_photon step for step — free paths of sigma_s, continuous
 * absorption (track-length fluence), Henyey-Greenstein scattering with the
 * cell's g, Fresnel reflection or escape at boundary faces, reflection or
 * Snell refraction at changes of index, symmetry planes, the time gate,
 * the weight floor and the hybrid's handoff after `handoff_at` reduced
 * scatterings.  Lengths are in voxels, cell i spanning [i, i+1).
 *
 * mc_step.h's steps (a segment, absorption, scattering, crossing an
 * interface, the hybrid's handoff) are the host's own source, put in here
 * by the build.
 *
 * What differs from the host, and why:
 * - random numbers: Philox4x32-10 (Salmon et al., SC'11, "Parallel random
 *   numbers: as easy as 1, 2, 3"), keyed by the seed, its counter the
 *   photon's number and the draw's: photon k's path depends on (seed, k)
 *   only, whatever the device, launch or work-group it runs in;
 * - tallies: every photon adds into the grid with 64-bit compare-and-swap
 *   (OpenCL 1.2 has no atomic add of doubles), a cell's deposits gathered
 *   while the photon stays in it; the totals (absorbed, out, gated, handed,
 *   events, truncated) reduced per work-group in a fixed order.
 *
 * Build options (-D, MCX-CL's way: the kernel specialised to the scene):
 *   WG         the work-group size, a power of two
 *   MC_VARIES  per-cell coefficients (coef: sigma_a h, sigma_s h per cell)
 *   MC_CELL_G  per-cell anisotropy       MC_CELL_ETA  per-cell index
 *   MC_HANDOFF the hybrid's handoff tally */
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#pragma OPENCL EXTENSION cl_khr_int64_base_atomics : enable

#define W_MIN 1e-6
#define MAX_EVENTS 100000000L
#define NTOTALS 6 /* absorbed, out, gated, handed, events, truncated */

/* ---- Philox4x32-10 -------------------------------------------------------------------- */

uint4 philox4x32_10(uint4 ctr, uint2 key)
{
    for (int round = 0; round < 10; ++round) {
        if (round) key += (uint2)(0x9E3779B9u, 0xBB67AE85u);
        uint hi0 = mul_hi(0xD2511F53u, ctr.x), lo0 = 0xD2511F53u * ctr.x;
        uint hi1 = mul_hi(0xCD9E8D57u, ctr.z), lo1 = 0xCD9E8D57u * ctr.z;
        ctr = (uint4)(hi1 ^ ctr.y ^ key.x, lo1, hi0 ^ ctr.w ^ key.y, lo0);
    }
    return ctr;
}

/* Random123's known answers, for the suite (test_mc_device): out[4 i ..]
 * for ctr[i], key[i]. */
__kernel void philox_check(__global const uint4 *ctr, __global const uint2 *key, __global uint4 *out)
{
    size_t i = get_global_id(0);
    out[i] = philox4x32_10(ctr[i], key[i]);
}

typedef struct rng {
    uint4 ctr;   /* x, y: the draw counter; z, w: the photon's number */
    uint2 key;   /* the seed */
    double spare;
    int have;
} rng;

/* Uniform on [0, 1), 53 bits: each Philox block gives two. */
double uniform(rng *r)
{
    if (r->have) {
        r->have = 0;
        return r->spare;
    }
    uint4 o = philox4x32_10(r->ctr, r->key);
    if (++r->ctr.x == 0) ++r->ctr.y;
    ulong a = (((ulong)o.x << 32) | o.y) >> 11, b = (((ulong)o.z << 32) | o.w) >> 11;
    const double scale = 1.0 / 9007199254740992.0; /* 2^-53 */
    r->spare = (double)b * scale;
    r->have = 1;
    return (double)a * scale;
}

/* ---- tallies -------------------------------------------------------------------------------- */

void add_double(volatile __global double *p, double v)
{
    volatile __global ulong *q = (volatile __global ulong *)p;
    ulong seen = *q, was;
    do {
        was = seen;
        seen = atom_cmpxchg(q, was, as_ulong(as_double(was) + v));
    } while (seen != was);
}

/* ---- the scene ------------------------------------------------------------------------------ */

typedef struct scene {
    int dims[3];
    int mlow[3], mhigh[3];        /* symmetry planes (network.h), -1: none */
    __global const int *unknown;  /* per grid cell: its unknown, or -1     */
    __global const int *face_start; /* n + 1: unknown v's faces are face_start[v] .. [v+1] - 1 */
    __global const uchar *face_dir;
    double sa0, ss0, g0, eta0;    /* 1/voxel; the constants when not per cell */
    __global const double *coef;  /* MC_VARIES: 2 per unknown              */
    __global const double *g;     /* MC_CELL_G                             */
    __global const double *eta;   /* MC_CELL_ETA                           */
} scene;

int unknown_at(const scene *sc, const int n[3])
{
    for (int a = 0; a < 3; ++a)
        if (n[a] < 0 || n[a] >= sc->dims[a]) return -1;
    return sc->unknown[(long)n[0] + (long)sc->dims[0] * ((long)n[1] + (long)sc->dims[1] * (long)n[2])];
}

/* network.h's ohm_network_face: the boundary face of v in direction d, or -1 */
int face_of(const scene *sc, int v, int d)
{
    for (int f = sc->face_start[v]; f < sc->face_start[v + 1]; ++f)
        if (sc->face_dir[f] == d) return f;
    return -1;
}

void coefficients(const scene *sc, int v, double *sa, double *ss)
{
#ifdef MC_VARIES
    *sa = sc->coef[2 * (long)v];
    *ss = sc->coef[2 * (long)v + 1];
#else
    *sa = sc->sa0;
    *ss = sc->ss0;
#endif
}

double cell_g(const scene *sc, int v)
{
#ifdef MC_CELL_G
    return sc->g[v];
#else
    return sc->g0;
#endif
}

double cell_eta(const scene *sc, int v)
{
#ifdef MC_CELL_ETA
    return sc->eta[v];
#else
    return sc->eta0;
#endif
}

/* ---- the physics (mc.c) ------------------------------------------------------------------- */

/* the steps the host takes alike: one source, mc_step.h (the build puts
 * its text here) — the hybrid's handoff into the grid's handoff tally */
typedef rng mc_rng;
typedef int mc_index;
#define MC_UNIFORM(r) uniform(r)
#ifdef MC_HANDOFF
typedef struct mc_to {
    const scene *sc;
    __global double *handoff;
} mc_to;
#define MC_UNKNOWN_AT(to, n) unknown_at((to)->sc, n)
#define MC_HANDOFF_ADD(to, u, w) add_double(&(to)->handoff[u], w)
#endif
#include "physics/mc_step.h"

/* ---- one photon per work-item ------------------------------------------------------------- */

/* Entries: cdf (cumulative power, last 1); ecell 4 per entry (the cell's
 * i, j, k; its face direction d + 8 at_point); ev its unknown; egeo 6 per
 * entry (the point in voxel coordinates, the direction inside). */
__kernel void trace(long first, long count, uint2 key, __global const double *cdf, long nentries,
                    __global const int *ecell, __global const int *ev, __global const double *egeo,
                    int4 dims, int4 mlow, int4 mhigh, __global const int *unknown, __global const int *face_start,
                    __global const uchar *face_dir, double4 medium, __global const double *coef,
                    __global const double *gv, __global const double *etav, double max_path, int total_fluence,
                    double handoff_at, __global double *phi, __global double *face, __global double *handoff,
                    __global double *partial)
{
    scene sc = {{dims.x, dims.y, dims.z}, {mlow.x, mlow.y, mlow.z}, {mhigh.x, mhigh.y, mhigh.z}, unknown,
                face_start, face_dir, medium.x, medium.y, medium.z, medium.w, coef, gv, etav};
    double tot[NTOTALS] = {0, 0, 0, 0, 0, 0};
    long k = (long)get_global_id(0);
    if (k < count) {
        long photon = first + k;
        rng r = {(uint4)(0u, 0u, (uint)photon, (uint)(photon >> 32)), key, 0.0, 0};
        /* the entry, by its share of the power (mc.c's pick_entry) */
        double xi = uniform(&r);
        long lo = 0, hi = nentries - 1;
        while (lo < hi) {
            long mid = lo + (hi - lo) / 2;
            if (cdf[mid] <= xi) lo = mid + 1;
            else hi = mid;
        }
        int4 ec = vload4(lo, ecell);
        int d = ec.w & 7, at_point = ec.w >> 3, axis = d / 2;
        int v = ev[lo];
        int c[3] = {ec.x, ec.y, ec.z};
        double p[3], u[3];
        for (int a = 0; a < 3; ++a) {
            double x = at_point ? egeo[6 * lo + a] : c[a] + uniform(&r);
            p[a] = clamp(x, (double)c[a], c[a] + 1.0);
            u[a] = egeo[6 * lo + 3 + a];
        }
        p[axis] = c[axis] + ((d & 1) ? 1.0 : 0.0);
        double w = 1.0, sa, ss;
        coefficients(&sc, v, &sa, &ss);
        double tau = -log(1.0 - uniform(&r)), path_left = max_path;
        int scattered = 0;
        double reduced = 0, pending = 0; /* pending: cell v's fluence not yet added */
        long events = 0;
        for (;; ++events) {
            if (events >= MAX_EVENTS) {
                tot[5] += 1;
                break;
            }
            int ax, scatters, gated;
            double s = mc_segment(c, p, u, ss, tau, path_left, &ax, &scatters, &gated);
            path_left -= s;
            double x = sa * s, lost = mc_absorbed_fraction(x);
            if (scattered || total_fluence) pending += x > 1e-9 ? w * lost / sa : w * s;
            double w1 = w - w * lost;
            tot[0] += w - w1;
            w = w1;
            if (gated) {
                tot[2] += w;
                w = 0;
                break;
            }
            for (int a = 0; a < 3; ++a) p[a] += s * u[a];
            if (scatters) {
                double g = cell_g(&sc, v);
                scattered = 1;
#ifdef MC_HANDOFF
                if (handoff_at > 0 && (reduced += 1.0 - g) >= handoff_at - 1e-9) {
                    mc_to to = {&sc, handoff};
                    mc_hand_off(&to, v, c, p, w);
                    tot[3] += w;
                    w = 0;
                    break;
                }
#endif
                mc_scatter(u, g, &r);
                tau = -log(1.0 - uniform(&r));
            } else {
                tau -= ss * s;
                int step = u[ax] > 0 ? 1 : -1;
                p[ax] = (double)(step > 0 ? c[ax] + 1 : c[ax]);
                if (c[ax] == (step < 0 ? sc.mlow[ax] : sc.mhigh[ax])) { /* symmetry plane */
                    u[ax] = -u[ax];
                    continue;
                }
                int n[3] = {c[0], c[1], c[2]};
                n[ax] += step;
                int nv = unknown_at(&sc, n);
#ifdef MC_CELL_ETA
                int stays = nv >= 0 && etav[nv] != etav[v] && !mc_cross_interface(u, ax, etav[v], etav[nv], &r);
#else
                int stays = 0;
#endif
                if (stays) {
                    /* reflected at an internal change of index: stays in v */
                } else if (nv >= 0) {
                    if (pending != 0) add_double(&phi[v], pending);
                    pending = 0;
                    c[ax] = n[ax];
                    v = nv;
                    coefficients(&sc, v, &sa, &ss);
                } else { /* a boundary face: reflected with the Fresnel probability, else out */
                    double R = ohm_fresnel_inside(cell_eta(&sc, v), fabs(u[ax]));
                    if (R < 1.0 && uniform(&r) >= R) {
                        int f = face_of(&sc, v, 2 * ax + (step > 0));
                        if (f >= 0) add_double(&face[f], w);
                        tot[1] += w;
                        w = 0;
                        break;
                    }
                    u[ax] = -u[ax];
                }
            }
            if (w < W_MIN) break;
        }
        if (pending != 0) add_double(&phi[v], pending);
        tot[0] += w; /* what is left ends here */
        tot[4] = (double)events;
    }
    /* the work-group's totals, in a fixed order */
    __local double red[NTOTALS * WG];
    int lid = (int)get_local_id(0);
    for (int i = 0; i < NTOTALS; ++i) red[i * WG + lid] = tot[i];
    for (int stride = WG / 2; stride > 0; stride /= 2) {
        barrier(CLK_LOCAL_MEM_FENCE);
        if (lid < stride)
            for (int i = 0; i < NTOTALS; ++i) red[i * WG + lid] += red[i * WG + lid + stride];
    }
    if (lid == 0)
        for (int i = 0; i < NTOTALS; ++i) partial[NTOTALS * get_group_id(0) + i] = red[i * WG];
}

/* A batch folded into the sums (mc.c's fold_batch, for the fluence):
 * phi_sum += phi, phi_sq += phi^2, phi = 0. */
__kernel void fold(__global double *phi, __global double *phi_sum, __global double *phi_sq, long n)
{
    for (long v = get_global_id(0); v < n; v += get_global_size(0)) {
        double x = phi[v];
        phi_sum[v] += x;
        phi_sq[v] += x * x;
        phi[v] = 0;
    }
}

__kernel void fill_zero(__global double *a, long n)
{
    for (long i = get_global_id(0); i < n; i += get_global_size(0)) a[i] = 0;
}
