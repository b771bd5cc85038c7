/* bench_sphere_sky.c — how uniform the exitance of a sphere under a uniform
 * sky is, at the resolutions given (docs/lights.md, "A sphere under a uniform
 * sky"): samples/larger_sphere.off at size=20 (r = 10 mm), sigma_a=0.01
 * sigma_s=1, `-light type=environment intensity=0.001`, shadows=grid, the
 * figures averaged over cones of 25 degrees about the 6 axes and the 8
 * diagonals.  Per dim it prints the diagonals' mean over the axes' mean,
 * minus 1, of: the power leaving per unit of the sphere's true area, the
 * per-face exitance (face_exitance, what the grids' per-cell exitance is
 * made of), the mesh's vertex exitance (the PLY's, the add-on's) and the
 * boundary cells' fluence; the spread of the 14 cones' face exitance,
 * vertex exitance and power leaving about their mean; the fraction of what
 * is deposited that is absorbed; the conservation error; and the boundary
 * faces' area per unit of true area (diagonals over axes).  A measuring tool, not a test: it asserts
 * nothing.  Usage: bench_sphere_sky [solver] [dim ...] (run from the
 * repository root; default: mg 32 40 48 64 96); OHM_SPHERE_SOLVE: more
 * options of -solve (deposit=surface, ...); OHM_SPHERE_SCENE and
 * OHM_SPHERE_MATERIAL: another mesh ("file=cube.off size=20") and material
 * ("sigma_a=0.05 sigma_s=2"), whose centre the cones are about;
 * OHM_SPHERE_CONE: the cones' half angle in degrees (25); OHM_SPHERE_RAW:
 * also print the power leaving and the face exitance about +x and about
 * (1,1,1) (a cube's face centre, an octahedron's). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "run_chain.h"
#include "outputs/export_ply.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

enum { CONES = 14 };

static void cone_dir(int k, double d[3])
{
    d[0] = d[1] = d[2] = 0;
    if (k < 6) d[k / 2] = k % 2 ? -1 : 1;
    else
        for (int a = 0; a < 3; ++a) d[a] = (((k - 6) >> a) & 1 ? -1 : 1) / sqrt(3.0);
}

/* Whether point p (relative to the centre) lies in the cone about d. */
static int in_cone(const double p[3], const double d[3], double cmin)
{
    double len = 0, along = 0;
    for (int a = 0; a < 3; ++a) {
        len += p[a] * p[a];
        along += p[a] * d[a];
    }
    return along >= cmin * sqrt(len);
}

/* diagonals' mean / axes' mean - 1, in percent */
static double diag_axes(const double v[CONES])
{
    double ax = 0, dg = 0;
    for (int k = 0; k < 6; ++k) ax += v[k] / 6;
    for (int k = 6; k < CONES; ++k) dg += v[k] / 8;
    return 100 * (dg / ax - 1);
}

/* largest |v - mean| / mean over the cones, in percent */
static double spread(const double v[CONES])
{
    double mean = 0, worst = 0;
    for (int k = 0; k < CONES; ++k) mean += v[k] / CONES;
    for (int k = 0; k < CONES; ++k) worst = fmax(worst, fabs(v[k] - mean) / mean);
    return 100 * worst;
}

static void measure(const char *solver, int dim)
{
    const double r = 10.0, cmin = cos((getenv("OHM_SPHERE_CONE") ? atof(getenv("OHM_SPHERE_CONE")) : 25.0) * M_PI / 180.0), cone_area = 2 * M_PI * (1 - cmin) * r * r;
    char lines[1024];
    const char *scene = getenv("OHM_SPHERE_SCENE"), *more = getenv("OHM_SPHERE_SOLVE");
    snprintf(lines, sizeof lines,
             "read file=%s\nvoxelize dim=%d\nmaterial %s\n"
             "light type=environment intensity=0.001\nsolve shadows=grid solver=%s %s\n",
             scene ? scene : "samples/larger_sphere.off size=20", dim,
             getenv("OHM_SPHERE_MATERIAL") ? getenv("OHM_SPHERE_MATERIAL") : "sigma_a=0.01 sigma_s=1", solver,
             more ? more : "");
    ohm_state s;
    if (run_lines(&s, lines)) {
        ohm_state_free(&s);
        return;
    }
    const ohm_solution *sol = ohm_state_solution(&s);
    const ohm_network *net = &sol->net;
    const ohm_voxel_grid *g = net->grid;
    double centre[3];
    for (int a = 0; a < 3; ++a) centre[a] = g->origin[a] + 0.5 * (g->dims[a] - 1) * g->h;
    double area[CONES] = {0}, out[CONES] = {0}, face[CONES] = {0}, vert[CONES] = {0}, flu[CONES] = {0};
    int nface[CONES] = {0}, nvert[CONES] = {0}, ncell[CONES] = {0};
    for (int64_t f = 0; f < net->nfaces; ++f) {
        int32_t c[3];
        ohm_voxel_coords(g, net->face_cell[f], c);
        double p[3], q[3];
        for (int a = 0; a < 3; ++a) {
            p[a] = g->origin[a] + g->h * (c[a] + 0.5 * ohm_face_offset[net->face_dir[f]][a]) - centre[a];
            q[a] = g->origin[a] + g->h * c[a] - centre[a];
        }
        int first = f == 0 || net->face_unknown[f - 1] != net->face_unknown[f];
        for (int k = 0; k < CONES; ++k) {
            double d[3];
            cone_dir(k, d);
            if (in_cone(p, d, cmin)) {
                out[k] += ohm_solution_face_power(sol, 0, 0, f);
                area[k] += g->h * g->h;
                face[k] += sol->face_exitance[0][f];
                ++nface[k];
            }
            if (first && in_cone(q, d, cmin)) {
                flu[k] += sol->fluence[0][net->face_unknown[f]];
                ++ncell[k];
            }
        }
    }
    float *vx = NULL;
    ohm_error err;
    ohm_error_clear(&err);
    if (!ohm_vertex_exitance(&vx, &s.mesh, &s.grid, sol, 0, &err)) {
        for (size_t v = 0; v < s.mesh.nverts; ++v) {
            double p[3];
            for (int a = 0; a < 3; ++a) p[a] = s.mesh.verts[3 * v + (size_t)a] - centre[a];
            for (int k = 0; k < CONES; ++k) {
                double d[3];
                cone_dir(k, d);
                if (in_cone(p, d, cmin)) vert[k] += vx[v], ++nvert[k];
            }
        }
    }
    free(vx);
    for (int k = 0; k < CONES; ++k) {
        out[k] /= cone_area;
        area[k] /= cone_area;
        face[k] /= nface[k];
        vert[k] /= nvert[k];
        flu[k] /= ncell[k];
    }
    if (getenv("OHM_SPHERE_RAW"))
        printf("axes: leaving %.6g face %.6g; diagonals: leaving %.6g face %.6g\n", (out[0] + out[1]) / 2,
               (face[0] + face[1]) / 2, (out[6] + out[13]) / 2, (face[6] + face[13]) / 2);
    printf("%4d | %+6.2f%% | %+6.2f%% | %+6.2f%% | %+6.2f%% | %5.2f%% | %5.2f%% | %5.2f%% | %.4f | %.2e | %+.2f%%\n", dim,
           diag_axes(out), diag_axes(face), diag_axes(vert), diag_axes(flu), spread(face), spread(vert), spread(out),
           sol->power_absorbed / sol->power_in, ohm_solution_conservation_error(sol), diag_axes(area));
    fflush(stdout);
    ohm_state_free(&s);
}

int main(int argc, char **argv)
{
    const char *solver = argc > 1 ? argv[1] : "mg";
    static const int dims[] = {32, 40, 48, 64, 96};
    printf("dim | leaving per true area | face exitance | vertex exitance | boundary fluence"
           " (diagonals / axes - 1) | spread of the 14 cones: face, vertex, leaving | absorbed / in |"
           " conservation | faces' area per true area (diagonals / axes - 1)\n");
    if (argc > 2)
        for (int i = 2; i < argc; ++i) measure(solver, atoi(argv[i]));
    else
        for (size_t i = 0; i < sizeof dims / sizeof *dims; ++i) measure(solver, dims[i]);
    return 0;
}
