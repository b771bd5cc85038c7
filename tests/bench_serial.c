/* bench_serial.c — the network's serial stages alone (docs/serial-stages.md):
 * ohm_network_build_band and ohm_network_assemble timed in ns per interior
 * cell, and the bytes per cell the network and the assembled matrix hold.
 *
 * Not a ctest (no timed assertions in the suite): tests/CMakeLists.txt builds
 * it as the bench_serial target, scripts/serial-stages.sh runs it.
 *
 *   bench_serial time CELLS...   an ellipsoid of about CELLS interior cells in
 *                                its box (margin 4, as the voxelizer's default
 *                                band of 3 + 1): build, then one channel
 *                                assembled homogeneous and per-cell, and the
 *                                per-cell one refilled into an existing matrix
 *                                (ohm_network_assemble_into), then a scan's
 *                                medium (a density through a transfer
 *                                function's curves); best of 5, thread CPU time
 *   bench_serial digest          FNV-1a hashes of every array the network and
 *                                the assembly produce, over scenes that reach
 *                                every branch (mirror planes, a depth band,
 *                                grid edges, many pieces, paper mode, the
 *                                singular-piece message): two builds agree bit
 *                                for bit when their digests do. */
#define _POSIX_C_SOURCE 200809L /* clock_gettime */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "grid/band.h"
#include "physics/network.h"

/* ---- digest -------------------------------------------------------------- */

static uint64_t fnv(uint64_t h, const void *p, size_t n)
{
    const unsigned char *b = p;
    for (size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 1099511628211ull;
    return h;
}

static uint64_t hash_network(const ohm_network *net)
{
    const ohm_voxel_grid *g = net->grid;
    size_t ncells = (size_t)g->dims[0] * (size_t)g->dims[1] * (size_t)g->dims[2];
    uint64_t h = 1469598103934665603ull;
    int64_t sc[5] = {net->n, net->nfaces, net->npieces, net->nnz, net->nclosure};
    h = fnv(h, sc, sizeof sc);
    for (int64_t v = 0; v < net->n; ++v) { /* the unknowns' cells, as the table they were (same digest) */
        int64_t c = ohm_network_cell(net, v);
        h = fnv(h, &c, sizeof c);
    }
    for (size_t c = 0; c < ncells; ++c) { /* the index as the table it replaced (same digest) */
        int64_t u = ohm_network_unknown(net, c);
        h = fnv(h, &u, sizeof u);
    }
    if (net->pieces.count) { /* the labels per unknown, as the table they were (same digest) */
        int64_t run = 0;
        for (int64_t v = 0; v < net->n; ++v) {
            int32_t p = ohm_piece_runs_next(&net->pieces, &run, v);
            h = fnv(h, &p, sizeof p);
        }
    } else { /* one piece: the labels it no longer keeps were all 0 (same digest) */
        const int64_t zero = 0;
        for (int64_t v = 0; v < net->n; ++v) h = fnv(h, &zero, sizeof zero);
    }
    h = fnv(h, net->face_unknown, (size_t)net->nfaces * sizeof *net->face_unknown);
    h = fnv(h, net->face_dir, (size_t)net->nfaces);
    return h;
}

/* A deterministic value in [0, 1) per index (splitmix64). */
static double unit(uint64_t x)
{
    x += 0x9e3779b97f4a7c15ull;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
    x ^= x >> 31;
    return (double)(x >> 11) / 9007199254740992.0;
}

static int make_grid(ohm_voxel_grid *g, int nx, int ny, int nz, double h)
{
    memset(g, 0, sizeof *g);
    g->dims[0] = nx, g->dims[1] = ny, g->dims[2] = nz;
    g->h = h;
    size_t n = (size_t)nx * (size_t)ny * (size_t)nz;
    g->inside = calloc(n, 1);
    return g->inside ? 0 : -1;
}

static void count_inside(ohm_voxel_grid *g)
{
    size_t n = (size_t)g->dims[0] * (size_t)g->dims[1] * (size_t)g->dims[2], c = 0;
    for (size_t i = 0; i < n; ++i) c += g->inside[i] != 0;
    g->interior_cells = c;
}

/* An ellipsoid with semi-axes (a, b, c) cells, centred, margin m. */
static int make_ellipsoid(ohm_voxel_grid *g, double a, double b, double c, int m, double h)
{
    int nx = 2 * (int)ceil(a) + 2 * m, ny = 2 * (int)ceil(b) + 2 * m, nz = 2 * (int)ceil(c) + 2 * m;
    if (make_grid(g, nx, ny, nz, h)) return -1;
    double cx = 0.5 * (nx - 1), cy = 0.5 * (ny - 1), cz = 0.5 * (nz - 1);
    for (int k = 0; k < nz; ++k)
        for (int j = 0; j < ny; ++j)
            for (int i = 0; i < nx; ++i) {
                double x = (i - cx) / a, y = (j - cy) / b, z = (k - cz) / c;
                g->inside[ohm_voxel_index(g, i, j, k)] = x * x + y * y + z * z <= 1.0;
            }
    count_inside(g);
    return 0;
}

/* Assemble one channel and print the digest of everything it produced (or of
 * the error message). */
static void digest_assembly(const char *name, const ohm_network *net, const ohm_channel_medium *med, ohm_boundary b)
{
    ohm_error err;
    ohm_error_clear(&err);
    cholmod_common cc;
    cholmod_l_start(&cc);
    cholmod_sparse *A = NULL;
    double *ga = malloc((size_t)net->n * sizeof *ga), *gb = malloc((size_t)(net->nfaces + 1) * sizeof *gb);
    int rc = ohm_network_assemble(&A, ga, gb, net, med, b, &cc, &err);
    uint64_t h = 1469598103934665603ull;
    if (rc) {
        h = fnv(h, err.msg, strlen(err.msg));
        printf("%-34s %-9s rc %d %016llx  %s\n", name, ohm_boundary_name(b), rc, (unsigned long long)h, err.msg);
    } else {
        h = fnv(h, A->p, (size_t)(net->n + 1) * sizeof(int64_t));
        h = fnv(h, A->i, (size_t)net->nnz * sizeof(int64_t));
        h = fnv(h, A->x, (size_t)net->nnz * sizeof(double));
        h = fnv(h, ga, (size_t)net->n * sizeof *ga);
        h = fnv(h, gb, (size_t)net->nfaces * sizeof *gb);
        /* the same call without the optional outputs must give the same matrix */
        cholmod_sparse *A2 = NULL;
        int rc2 = ohm_network_assemble(&A2, NULL, NULL, net, med, b, &cc, &err);
        int same = rc2 == 0 && memcmp(A->x, A2->x, (size_t)net->nnz * sizeof(double)) == 0;
        cholmod_l_free_sparse(&A2, &cc);
        printf("%-34s %-9s rc 0 %016llx%s\n", name, ohm_boundary_name(b), (unsigned long long)h,
               same ? "" : "  (differs without ga/gb!)");
    }
    cholmod_l_free_sparse(&A, &cc);
    cholmod_l_finish(&cc);
    free(ga);
    free(gb);
}

static int digest_scene(const char *name, const ohm_voxel_grid *g, const int32_t *mirror_low, const uint8_t *active)
{
    ohm_network net;
    ohm_error err;
    ohm_error_clear(&err);
    ohm_mirrors mirror = {{-1, -1, -1}, {-1, -1, -1}};
    for (int a = 0; a < 3 && mirror_low; ++a) mirror.low[a] = mirror_low[a];
    int rc = ohm_network_build_band(&net, g, &mirror, active, &err);
    if (rc) {
        printf("%-34s build rc %d: %s\n", name, rc, err.msg);
        return 0;
    }
    printf("%-34s network   n %lld faces %lld pieces %lld nnz %lld closure %lld %016llx\n", name, (long long)net.n,
           (long long)net.nfaces, (long long)net.npieces, (long long)net.nnz, (long long)net.nclosure,
           (unsigned long long)hash_network(&net));
    int64_t n = net.n;
    ohm_coeff *sa = malloc((size_t)n * sizeof *sa), *ss = malloc((size_t)n * sizeof *ss);
    ohm_coeff *r = malloc((size_t)n * sizeof *r), *rg = malloc((size_t)n * sizeof *rg);
    if (!sa || !ss || !r || !rg) return -1;
    for (int64_t v = 0; v < n; ++v) {
        sa[v] = (ohm_coeff)(0.001 + 0.05 * unit((uint64_t)v));
        ss[v] = (ohm_coeff)(0.5 + 3.0 * unit((uint64_t)v + 0x100000000ull));
        r[v] = (ohm_coeff)(500.0 + 1000.0 * unit((uint64_t)v + 0x200000000ull));
        rg[v] = (ohm_coeff)(1e4 + 1e6 * unit((uint64_t)v + 0x300000000ull));
    }
    static const ohm_boundary bs[3] = {OHM_BOUNDARY_ROBIN, OHM_BOUNDARY_NEUMANN, OHM_BOUNDARY_DIRICHLET};
    char label[96];
    for (int q = 0; q < 3; ++q) {
        ohm_channel_medium m = {0};
        m.sigma_a0 = 0.0041, m.sigma_s0 = 2.62, m.eta = 1.3;
        snprintf(label, sizeof label, "%s/homogeneous", name);
        digest_assembly(label, &net, &m, bs[q]);
        m.sigma_a = sa, m.sigma_s = ss;
        snprintf(label, sizeof label, "%s/per-cell", name);
        digest_assembly(label, &net, &m, bs[q]);
        m.sigma_a = NULL; /* per-cell scattering over a constant absorption */
        m.eta = 1.37;
        snprintf(label, sizeof label, "%s/per-cell-ss", name);
        digest_assembly(label, &net, &m, bs[q]);
        ohm_channel_medium p = {0};
        p.resistance_mode = 1, p.resistance = 1000.0, p.ground = 1e5;
        snprintf(label, sizeof label, "%s/resistance", name);
        digest_assembly(label, &net, &p, bs[q]);
        p.resistance_v = r, p.ground_v = rg;
        snprintf(label, sizeof label, "%s/resistance-per-cell", name);
        digest_assembly(label, &net, &p, bs[q]);
    }
    /* no absorption anywhere: singular with neumann (the message names a cell) */
    ohm_channel_medium z = {0};
    z.sigma_a0 = 0.0, z.sigma_s0 = 1.0, z.eta = 1.3;
    snprintf(label, sizeof label, "%s/no-absorption", name);
    digest_assembly(label, &net, &z, OHM_BOUNDARY_NEUMANN);
    digest_assembly(label, &net, &z, OHM_BOUNDARY_ROBIN);
    /* absorption in only some cells: the pieces without it are singular */
    for (int64_t v = 0; v < n; ++v) sa[v] = ohm_network_cell(&net, v) % 7 == 0 ? 0.01f : 0.0f;
    z.sigma_a = sa;
    snprintf(label, sizeof label, "%s/sparse-absorption", name);
    digest_assembly(label, &net, &z, OHM_BOUNDARY_NEUMANN);
    free(sa), free(ss), free(r), free(rg);
    ohm_network_free(&net);
    return 0;
}

static int digest(void)
{
    ohm_voxel_grid g;
    /* an ellipsoid in a margin, as voxelized */
    if (make_ellipsoid(&g, 17.3, 12.6, 9.1, 4, 0.25)) return -1;
    if (digest_scene("ellipsoid", &g, NULL, NULL)) return -1;
    uint8_t *active = NULL;
    int64_t kept = 0;
    ohm_error err;
    if (ohm_depth_band(&active, &kept, &g, 3.5 * g.h, &err)) return -1;
    if (digest_scene("ellipsoid-band", &g, NULL, active)) return -1;
    free(active);
    ohm_voxel_grid_free(&g);

    /* a box filling its grid to the edges, mirror planes on two low sides
     * (the validation scenes' octants) */
    if (make_grid(&g, 13, 9, 11, 0.5)) return -1;
    memset(g.inside, 1, (size_t)13 * 9 * 11);
    count_inside(&g);
    int32_t mirror[3] = {0, -1, 0};
    if (digest_scene("box-to-edges-mirror", &g, mirror, NULL)) return -1;
    if (digest_scene("box-to-edges", &g, NULL, NULL)) return -1;
    int32_t mirror1[3] = {3, 2, -1}; /* planes through the middle */
    if (digest_scene("box-mirror-inside", &g, mirror1, NULL)) return -1;
    ohm_voxel_grid_free(&g);

    /* random cells: many pieces, isolated cells, holes, cells on every edge */
    if (make_grid(&g, 23, 19, 17, 1.0)) return -1;
    size_t nc = (size_t)23 * 19 * 17;
    for (size_t c = 0; c < nc; ++c) g.inside[c] = unit(c + 77) < 0.42;
    count_inside(&g);
    if (digest_scene("random", &g, NULL, NULL)) return -1;
    int32_t mirror2[3] = {0, 0, 5};
    if (digest_scene("random-mirror", &g, mirror2, NULL)) return -1;
    if (ohm_depth_band(&active, &kept, &g, 1.2, &err)) return -1;
    if (digest_scene("random-band", &g, NULL, active)) return -1;
    /* an arbitrary subset as the band (not what ohm_depth_band makes) */
    for (size_t c = 0; c < nc; ++c) active[c] = unit(c + 991) < 0.7;
    if (digest_scene("random-subset", &g, mirror2, active)) return -1;
    free(active);
    ohm_voxel_grid_free(&g);

    /* one cell; a one-cell-thin sheet */
    if (make_grid(&g, 3, 3, 3, 1.0)) return -1;
    g.inside[13] = 1;
    count_inside(&g);
    if (digest_scene("single-cell", &g, NULL, NULL)) return -1;
    ohm_voxel_grid_free(&g);
    if (make_grid(&g, 9, 1, 7, 1.0)) return -1;
    memset(g.inside, 1, 63);
    count_inside(&g);
    if (digest_scene("sheet-one-thick", &g, NULL, NULL)) return -1;
    ohm_voxel_grid_free(&g);
    return 0;
}

/* ---- timing -------------------------------------------------------------- */

static double best_of(double a, double b) { return a < b ? a : b; }

/* CPU time of this thread (s): the machine is shared, and another job's
 * load stretches wall time but not this (it still shares caches and memory
 * bandwidth, so figures under load are upper bounds). */
static double cpu_now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

enum { REPS = 5 };

static int time_one(double cells)
{
    /* semi-axes 1 : 0.8 : 0.6 cells; volume 4/3 pi a^3 * 0.48 */
    double a = cbrt(cells / (4.0 / 3.0 * 3.14159265358979323846 * 0.48));
    ohm_voxel_grid g;
    if (make_ellipsoid(&g, a, 0.8 * a, 0.6 * a, 4, 0.1)) return -1;
    size_t ncells = (size_t)g.dims[0] * (size_t)g.dims[1] * (size_t)g.dims[2];
    ohm_error err;
    ohm_network net;
    double t_build = INFINITY, t_hom = INFINITY, t_het = INFINITY, t_build1 = 0, t_hom1 = 0;
    for (int rep = 0; rep < REPS; ++rep) {
        double t0 = cpu_now();
        if (ohm_network_build(&net, &g, NULL, &err)) {
            fprintf(stderr, "bench_serial: %s\n", err.msg);
            return -1;
        }
        double t = cpu_now() - t0;
        if (rep == 0) t_build1 = t; /* a run builds once, into memory never written before */
        t_build = best_of(t_build, t);
        if (rep < REPS - 1) ohm_network_free(&net);
    }
    int64_t n = net.n;
    ohm_coeff *sa = malloc((size_t)n * sizeof *sa), *ss = malloc((size_t)n * sizeof *ss);
    double *ga = malloc((size_t)n * sizeof *ga), *gb = malloc((size_t)net.nfaces * sizeof *gb);
    if (!sa || !ss || !ga || !gb) return -1;
    for (int64_t v = 0; v < n; ++v) {
        sa[v] = (ohm_coeff)(0.0041 * (1.0 + 0.5 * unit((uint64_t)v)));
        ss[v] = (ohm_coeff)(2.62 * (1.0 + 0.5 * unit((uint64_t)v + 0x100000000ull)));
    }
    cholmod_common cc;
    cholmod_l_start(&cc);
    double A_bytes = 0;
    for (int het = 0; het < 2; ++het)
        for (int rep = 0; rep < REPS; ++rep) {
            ohm_channel_medium m = {0};
            m.sigma_a0 = 0.0041, m.sigma_s0 = 2.62, m.eta = 1.3;
            if (het) m.sigma_a = sa, m.sigma_s = ss;
            cholmod_sparse *A = NULL;
            double t0 = cpu_now();
            if (ohm_network_assemble(&A, ga, gb, &net, &m, OHM_BOUNDARY_ROBIN, &cc, &err)) {
                fprintf(stderr, "bench_serial: %s\n", err.msg);
                return -1;
            }
            double t = cpu_now() - t0;
            if (!het && rep == 0) t_hom1 = t;
            if (het) t_het = best_of(t_het, t);
            else t_hom = best_of(t_hom, t);
            A_bytes = (double)(n + 1) * 8.0 + (double)A->nzmax * 16.0;
            cholmod_l_free_sparse(&A, &cc);
        }
    /* refilling one matrix, as ohm_solve does for every channel material
     * after the first (the heterogeneous medium into the homogeneous one's) */
    double t_refill = INFINITY, t_scan = INFINITY;
    {
        ohm_channel_medium hom = {0}, het = {0};
        hom.sigma_a0 = 0.0041, hom.sigma_s0 = 2.62, hom.eta = 1.3;
        het = hom, het.sigma_a = sa, het.sigma_s = ss;
        cholmod_sparse *A = NULL;
        if (ohm_network_assemble(&A, ga, gb, &net, &hom, OHM_BOUNDARY_ROBIN, &cc, &err)) {
            fprintf(stderr, "bench_serial: %s\n", err.msg);
            return -1;
        }
        for (int rep = 0; rep < REPS; ++rep) {
            double t0 = cpu_now();
            if (ohm_network_assemble_into(A, ga, gb, &net, &het, OHM_BOUNDARY_ROBIN, &err)) {
                fprintf(stderr, "bench_serial: %s\n", err.msg);
                return -1;
            }
            t_refill = best_of(t_refill, cpu_now() - t0);
        }
        /* a scan's medium: a density per cell through samples/walnut.transfer's
         * red channel (six knots), evaluated by the assembly (network.h) */
        static const double knots[6] = {0, 3000, 6000, 11000, 15000, 22526};
        static const double wsa[6] = {0.5, 0.5, 0.02, 0.02, 0.3, 0.3}, wss[6] = {0.01, 0.01, 1.5, 1.5, 2.0, 2.0};
        float *density = malloc((size_t)(n ? n : 1) * sizeof *density);
        if (!density) return -1;
        for (int64_t v = 0; v < n; ++v) density[v] = (float)(22526.0 * unit((uint64_t)v + 0x200000000ull));
        ohm_channel_medium scan = hom;
        scan.density = density;
        scan.sigma_a_curve = (ohm_curve){6, knots, wsa, 1};
        scan.sigma_s_curve = (ohm_curve){6, knots, wss, 1};
        for (int rep = 0; rep < REPS; ++rep) {
            double t0 = cpu_now();
            if (ohm_network_assemble_into(A, ga, gb, &net, &scan, OHM_BOUNDARY_ROBIN, &err)) {
                fprintf(stderr, "bench_serial: %s\n", err.msg);
                return -1;
            }
            t_scan = best_of(t_scan, cpu_now() - t0);
        }
        free(density);
        cholmod_l_free_sparse(&A, &cc);
    }
    cholmod_l_finish(&cc);
    /* what the network keeps for the run (network.h's arrays) */
    double net_bytes = (double)((ncells + 63) / 64) * (sizeof *net.unknowns.bits + sizeof *net.unknowns.rank) +
                       (double)net.pieces.count * (sizeof *net.pieces.start + sizeof *net.pieces.piece) +
                       (double)net.nfaces * (sizeof *net.face_unknown + sizeof *net.face_cell + sizeof *net.face_dir);
    double nn = (double)n;
    printf("| %lld | %d×%d×%d | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f |\n",
           (long long)n, g.dims[0], g.dims[1], g.dims[2], (double)ncells / nn, 1e9 * t_build1 / nn,
           1e9 * t_build / nn, 1e9 * t_hom1 / nn, 1e9 * t_hom / nn, 1e9 * t_het / nn, 1e9 * t_refill / nn,
           1e9 * t_scan / nn, net_bytes / nn, A_bytes / nn);
    free(sa), free(ss), free(ga), free(gb);
    ohm_network_free(&net);
    ohm_voxel_grid_free(&g);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc >= 2 && strcmp(argv[1], "digest") == 0) return digest() ? 1 : 0;
    if (argc >= 3 && strcmp(argv[1], "time") == 0) {
        printf("| interior cells | grid | grid cells per cell | build, first (ns/cell) | build, best (ns/cell) | "
               "assemble, first (ns/cell) | assemble, best (ns/cell) | assemble per-cell medium, best (ns/cell) | "
               "refill per-cell medium, best (ns/cell) | refill scan medium, best (ns/cell) | network (B/cell) | "
               "matrix A (B/cell) |\n");
        printf("|---|---|---|---|---|---|---|---|---|---|---|---|\n");
        for (int a = 2; a < argc; ++a)
            if (time_one(atof(argv[a]))) return 1;
        return 0;
    }
    fprintf(stderr, "usage: bench_serial digest | bench_serial time CELLS...\n");
    return 2;
}
