/* mc_device.cl — the Monte Carlo tracer on an OpenCL device (mc_device.c):
 * one photon per work-item.  The photon's loop and every step of its
 * physics are the host's own source (mc_loop.h, with mc_step.h and
 * fresnel_inside.h), put in here by the build; this file supplies what
 * mc_loop.h asks of its includer — the random numbers, the scene in the
 * device's layout, the tallies — and the kernels.  Lengths are in voxels,
 * cell i spanning [i, i+1).
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

/* the totals each work-item keeps, reduced per work-group (mc_device.c reads them in this order) */
enum { T_absorbed, T_out, T_gated, T_handed, T_events, T_truncated, NTOTALS };

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
    int mirror_low[3], mirror_high[3]; /* symmetry planes (network.h), -1: none */
    __global const int *unknown;  /* per grid cell: its unknown, or -1     */
    __global const int *face_start; /* n + 1: unknown v's faces are face_start[v] .. [v+1] - 1 */
    __global const uchar *face_dir;
    double sa0, ss0, g0, eta0;    /* 1/voxel; the constants when not per cell */
    __global const double *coef;  /* MC_VARIES: 2 per unknown              */
    __global const double *g;     /* MC_CELL_G                             */
    __global const double *eta;   /* MC_CELL_ETA                           */
    /* the entries: cdf (cumulative power, last 1); ecell 4 per entry (the
     * cell's i, j, k; its face direction d + 8 at_point); ev its unknown;
     * egeo 6 per entry (the point in voxel coordinates, the direction inside) */
    __global const double *cdf;
    long nentries;
    __global const int *ecell, *ev;
    __global const double *egeo;
    double max_path;              /* voxels; INFINITY: no gate             */
    int total_fluence;
    double handoff;               /* the hybrid's reduced scatterings; 0: none */
} scene;

/* what mc_loop.h asks of its includer (its header lists it) */
typedef rng mc_rng;
typedef int mc_index;
typedef long mc_long;
#define MC_GLOBAL __global
#define MC_UNIFORM(r) uniform(r)
typedef scene mc_scene;

void mc_entry(const scene *sc, long e, int *v, int c[3], int *d, int *at_point, double at[3], double u[3])
{
    int4 ec = vload4(e, sc->ecell);
    *d = ec.w & 7;
    *at_point = ec.w >> 3;
    *v = sc->ev[e];
    c[0] = ec.x, c[1] = ec.y, c[2] = ec.z;
    for (int a = 0; a < 3; ++a) {
        at[a] = sc->egeo[6 * e + a];
        u[a] = sc->egeo[6 * e + 3 + a];
    }
}

int mc_unknown_at(const scene *sc, const int n[3])
{
    for (int a = 0; a < 3; ++a)
        if (n[a] < 0 || n[a] >= sc->dims[a]) return -1;
    return sc->unknown[(long)n[0] + (long)sc->dims[0] * ((long)n[1] + (long)sc->dims[1] * (long)n[2])];
}

void mc_coefficients(const scene *sc, int v, double *sa, double *ss)
{
#ifdef MC_VARIES
    *sa = sc->coef[2 * (long)v];
    *ss = sc->coef[2 * (long)v + 1];
#else
    *sa = sc->sa0;
    *ss = sc->ss0;
#endif
}

/* the build options as flags (-D MC_CELL_G defines it 1) */
#ifndef MC_CELL_G
#define MC_CELL_G 0
#endif
#ifndef MC_CELL_ETA
#define MC_CELL_ETA 0
#endif

double mc_cell_g(const scene *sc, int v)
{
    return MC_CELL_G ? sc->g[v] : sc->g0;
}

double mc_cell_eta(const scene *sc, int v)
{
    return MC_CELL_ETA ? sc->eta[v] : sc->eta0;
}

#define MC_ETA_VARIES(sc) MC_CELL_ETA

/* network.h's ohm_network_face: the boundary face of v in direction d, or -1 */
int face_of(const scene *sc, int v, int d)
{
    for (int f = sc->face_start[v]; f < sc->face_start[v + 1]; ++f)
        if (sc->face_dir[f] == d) return f;
    return -1;
}

/* the tallies: the grid's, and this work-item's totals */
typedef struct mc_to {
    __global double *phi, *face, *handoff;
    double pending; /* the current cell's fluence, not yet added */
    double tot[NTOTALS];
} mc_to;

#define MC_TOTAL(to, name) ((to)->tot[T_##name])

void mc_tally_fluence(mc_to *to, int v, double x)
{
    to->pending += x;
}

void mc_tally_left(mc_to *to, int v)
{
    if (to->pending != 0) add_double(&to->phi[v], to->pending);
    to->pending = 0;
}

void mc_tally_exit(const scene *sc, mc_to *to, int v, int d, double w)
{
    int f = face_of(sc, v, d);
    if (f >= 0) add_double(&to->face[f], w);
}

void mc_tally_handoff(mc_to *to, int v, double w)
{
    add_double(&to->handoff[v], w);
}

#include "physics/mc_loop.h"

/* ---- one photon per work-item ------------------------------------------------------------- */

/* The entries and the scene: as in struct scene above. */
__kernel void trace(long first, long count, uint2 key, __global const double *cdf, long nentries,
                    __global const int *ecell, __global const int *ev, __global const double *egeo,
                    int4 dims, int4 mlow, int4 mhigh, __global const int *unknown, __global const int *face_start,
                    __global const uchar *face_dir, double4 medium, __global const double *coef,
                    __global const double *gv, __global const double *etav, double max_path, int total_fluence,
                    double handoff_at, __global double *phi, __global double *face, __global double *handoff,
                    __global double *partial)
{
    scene sc = {{dims.x, dims.y, dims.z}, {mlow.x, mlow.y, mlow.z}, {mhigh.x, mhigh.y, mhigh.z}, unknown,
                face_start, face_dir, medium.x, medium.y, medium.z, medium.w, coef, gv, etav,
                cdf, nentries, ecell, ev, egeo, max_path, total_fluence, handoff_at};
    mc_to to = {phi, face, handoff, 0.0, {0, 0, 0, 0, 0, 0}};
    long k = (long)get_global_id(0);
    if (k < count) {
        long photon = first + k;
        rng r = {(uint4)(0u, 0u, (uint)photon, (uint)(photon >> 32)), key, 0.0, 0};
        mc_trace_photon(&sc, &to, &r);
    }
    /* the work-group's totals, in a fixed order */
    __local double red[NTOTALS * WG];
    int lid = (int)get_local_id(0);
    for (int i = 0; i < NTOTALS; ++i) red[i * WG + lid] = to.tot[i];
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
