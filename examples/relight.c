/* relight.c — the paper's promise through libohm: factor once, then every
 * new light costs two triangular solves.  A directional light turns about
 * the object; each frame is relit from the kept factor and its time and
 * power printed.
 *
 *   relight MESH [FRAMES] [DIM]
 *
 * Build against an installed ohm:
 *   cc relight.c $(pkg-config --cflags --libs ohm) -lm -o relight */
#include <math.h>
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

/* A directional light at angle a about the vertical axis, 30 degrees down. */
static int set_light(ohm_scene *scene, double a)
{
    char dir[128];
    snprintf(dir, sizeof dir, "dir=%.17g,%.17g,%.17g", -cos(a) * cos(0.5236), -sin(0.5236), -sin(a) * cos(0.5236));
    const char *light[] = {"type=directional", dir, NULL};
    int rc = ohm_scene_clear_lights(scene);
    return rc ? rc : ohm_scene_add_light(scene, light);
}

int main(int argc, char **argv)
{
    if (argc < 2 || argc > 4) {
        fprintf(stderr, "usage: %s MESH [FRAMES] [DIM]\n", argv[0]);
        return 2;
    }
    int frames = argc > 2 ? atoi(argv[2]) : 8;
    if (frames < 1) frames = 1;
    char file[4096], dim[64];
    snprintf(file, sizeof file, "file=%s", argv[1]);
    snprintf(dim, sizeof dim, "dim=%s", argc > 3 ? argv[3] : "48");
    const char *read[] = {file, "size=50", NULL};
    const char *voxelize[] = {dim, NULL};
    const char *material[] = {"preset=skin1", NULL};

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
    if (!rc) rc = set_light(scene, 0.0);
    double t0 = now();
    if (!rc) rc = ohm_scene_solve(scene, NULL); /* analysis + factorization, kept */
    ohm_result_info r;
    if (!rc) rc = ohm_scene_result(&r, scene);
    if (!rc)
        printf("setup and first frame: %.3f s, %lld cells, %d factorizations\n", now() - t0, (long long)r.unknowns,
               r.factorizations);
    int factors = rc ? 0 : r.factorizations;
    for (int f = 1; f < frames && !rc; ++f) {
        rc = set_light(scene, 2.0 * M_PI * f / frames);
        double t = now();
        if (!rc) rc = ohm_scene_relight(scene);
        if (!rc) rc = ohm_scene_result(&r, scene);
        if (!rc)
            printf("frame %d: relit in %.2f ms, power out %.6g W of %.6g W in, %d factorizations in all\n", f + 1,
                   1e3 * (now() - t), r.power_out, r.power_in, r.factorizations);
    }
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
