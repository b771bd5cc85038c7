/* relight.c — the paper's promise through libohm: factor once, then every
 * new light costs two triangular solves.  A directional light turns about
 * the object; each frame is relit from the kept factor and its time and
 * power printed.
 *
 *   relight MESH [FRAMES] [DIM] [FLUENCE.txt]
 *
 * With FLUENCE.txt, every frame's fluence is written there cell by cell
 * ("frame i j k phi_r phi_g phi_b", 17 digits) from ohm_scene_fluence.
 *
 * Build against an installed ohm:
 *   cc relight.c $(pkg-config --cflags --libs ohm) -lm -o relight */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include <ohm.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

static double now(void)
{
    struct timespec ts;
    timespec_get(&ts, TIME_UTC);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* A directional light at angle a about the vertical axis, 30 degrees down;
 * dir gets its option. */
static int set_light(ohm_scene *scene, double a, char dir[128])
{
    snprintf(dir, 128, "dir=%.17g,%.17g,%.17g", -cos(a) * cos(0.5236), -sin(0.5236), -sin(a) * cos(0.5236));
    const char *light[] = {"type=directional", dir, NULL};
    int rc = ohm_scene_clear_lights(scene);
    return rc ? rc : ohm_scene_add_light(scene, light);
}

/* The fluence of every channel of the latest solve, cell by cell. */
static int write_fluence(FILE *f, const ohm_scene *scene, int frame)
{
    ohm_grid_info g = OHM_GRID_INFO_INIT;
    ohm_result_info r = OHM_RESULT_INFO_INIT;
    int rc = ohm_scene_grid(&g, scene);
    if (!rc) rc = ohm_scene_result(&r, scene);
    double *phi = rc ? NULL : malloc((size_t)g.cells * (size_t)r.channels * sizeof *phi);
    uint8_t *inside = rc ? NULL : malloc((size_t)g.cells);
    if (!rc && (!phi || !inside)) rc = OHM_ERR_NOMEM;
    if (!rc) rc = ohm_scene_inside(inside, (size_t)g.cells, scene);
    for (int c = 0; !rc && c < r.channels; ++c)
        rc = ohm_scene_fluence(phi + (size_t)c * (size_t)g.cells, (size_t)g.cells, scene, c, 0);
    for (int64_t cell = 0; !rc && cell < g.cells; ++cell) {
        if (!inside[cell]) continue;
        int64_t i = cell % g.dims[0], j = (cell / g.dims[0]) % g.dims[1], k = cell / ((int64_t)g.dims[0] * g.dims[1]);
        fprintf(f, "%d %lld %lld %lld", frame, (long long)i, (long long)j, (long long)k);
        for (int c = 0; c < r.channels; ++c) fprintf(f, " %.17g", phi[(size_t)c * (size_t)g.cells + (size_t)cell]);
        fputc('\n', f);
    }
    free(phi);
    free(inside);
    return rc;
}

int main(int argc, char **argv)
{
    if (argc < 2 || argc > 5) {
        fprintf(stderr, "usage: %s MESH [FRAMES] [DIM] [FLUENCE.txt]\n", argv[0]);
        return 2;
    }
    int frames = argc > 2 ? atoi(argv[2]) : 8;
    if (frames < 1) frames = 1;
    char file[4096], dim[64];
    snprintf(file, sizeof file, "file=%s", argv[1]);
    snprintf(dim, sizeof dim, "dim=%s", argc > 3 ? argv[3] : "48");
    const char *read[] = {file, "size=50", NULL};
    const char *voxelize[] = {dim, NULL};
    const char *material[] = {"preset=marble", NULL};

    ohm_context *ctx = NULL;
    ohm_scene *scene = NULL;
    int rc = ohm_context_new(&ctx);
    if (!rc) {
        ohm_context_set_verbosity(ctx, 0);
        rc = ohm_scene_new(&scene, ctx);
    }
    if (!rc) rc = ohm_scene_run(scene, "read", read);
    if (!rc) rc = ohm_scene_run(scene, "voxelize", voxelize);
    if (!rc) rc = ohm_scene_run(scene, "material", material);
    FILE *dump = NULL;
    if (!rc && argc > 4 && !(dump = fopen(argv[4], "w"))) {
        fprintf(stderr, "relight: cannot write %s\n", argv[4]);
        rc = OHM_ERR_IO;
    }
    char dir[128];
    if (!rc) rc = set_light(scene, 0.0, dir);
    double t0 = now();
    /* the factor, asked for by name: it is what relights with two triangular
     * solves (the default, solver=auto, takes multigrid for one light) */
    const char *factor[] = {"solver=direct", NULL};
    if (!rc) rc = ohm_scene_solve(scene, factor); /* analysis + factorization, kept */
    ohm_result_info r = OHM_RESULT_INFO_INIT;
    if (!rc) rc = ohm_scene_result(&r, scene);
    if (!rc)
        printf("frame 1: %s: setup and solve %.3f s, %lld cells, %d factorizations\n", dir, now() - t0,
               (long long)r.unknowns, r.factorizations);
    if (!rc && dump) rc = write_fluence(dump, scene, 1);
    int factors = rc ? 0 : r.factorizations;
    for (int f = 1; f < frames && !rc; ++f) {
        rc = set_light(scene, 2.0 * M_PI * f / frames, dir);
        double t = now();
        if (!rc) rc = ohm_scene_relight(scene);
        if (!rc) rc = ohm_scene_result(&r, scene);
        if (!rc)
            printf("frame %d: %s: relit in %.2f ms, power out %.6g W of %.6g W in, %d factorizations in all\n",
                   f + 1, dir, 1e3 * (now() - t), r.power_out, r.power_in, r.factorizations);
        if (!rc && dump) rc = write_fluence(dump, scene, f + 1);
    }
    if (dump && fclose(dump) && !rc) rc = OHM_ERR_IO;
    if (!rc && r.factorizations != factors) {
        fprintf(stderr, "relight: a relight factored again\n");
        rc = OHM_ERR_INTERNAL;
    } else if (rc) {
        fprintf(stderr, "relight: %s\n", ohm_error_last());
    }
    ohm_scene_free(scene);
    ohm_context_free(ctx);
    return rc ? 1 : 0;
}
