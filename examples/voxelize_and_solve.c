/* voxelize_and_solve.c — the smallest whole run through libohm: a mesh made
 * of marble, lit from above, solved, its power balance printed and its
 * fluence written as a .vdb Blender renders.
 *
 *   voxelize_and_solve MESH [DIM] [OUT.vdb]
 *
 * Build against an installed ohm:
 *   cc voxelize_and_solve.c $(pkg-config --cflags --libs ohm) -o voxelize_and_solve */
#include <stdio.h>
#include <stdlib.h>

#include <ohm.h>

int main(int argc, char **argv)
{
    if (argc < 2 || argc > 4) {
        fprintf(stderr, "usage: %s MESH [DIM] [OUT.vdb]\n", argv[0]);
        return 2;
    }
    char file[4096], dim[64], out[4096];
    snprintf(file, sizeof file, "file=%s", argv[1]);
    snprintf(dim, sizeof dim, "dim=%s", argc > 2 ? argv[2] : "48");
    const char *read[] = {file, "size=50", NULL};
    const char *voxelize[] = {dim, NULL};
    const char *material[] = {"preset=marble", NULL};
    const char *light[] = {"type=directional", "dir=0,-1,-0.5", NULL};

    ohm_context *ctx = NULL;
    ohm_scene *scene = NULL;
    int rc = ohm_context_new(&ctx);
    if (!rc) rc = ohm_scene_new(&scene, ctx);
    if (!rc) rc = ohm_scene_run(scene, "read", read);
    if (!rc) rc = ohm_scene_run(scene, "voxelize", voxelize);
    if (!rc) rc = ohm_scene_run(scene, "material", material);
    if (!rc) rc = ohm_scene_add_light(scene, light);
    if (!rc) rc = ohm_scene_solve(scene, NULL);

    ohm_result_info r = OHM_RESULT_INFO_INIT;
    ohm_grid_info g = OHM_GRID_INFO_INIT;
    if (!rc) rc = ohm_scene_result(&r, scene);
    if (!rc) rc = ohm_scene_grid(&g, scene);
    double *fluence = NULL, fluence_sum = 0;
    if (!rc && !(fluence = malloc((size_t)g.cells * sizeof *fluence))) rc = OHM_ERR_NOMEM;
    if (!rc) rc = ohm_scene_fluence(fluence, (size_t)g.cells, scene, 0, 0);
    for (int64_t c = 0; !rc && c < g.cells; ++c) fluence_sum += fluence[c];
    if (!rc && argc > 3) {
        snprintf(out, sizeof out, "file=%s", argv[3]);
        const char *write[] = {out, NULL};
        rc = ohm_scene_run(scene, "write", write);
    }
    if (!rc) {
        printf("cells %lld of %d x %d x %d, voxel %.17g mm\n", (long long)g.interior_cells, g.dims[0], g.dims[1],
               g.dims[2], g.voxel);
        printf("power_in %.17g\npower_absorbed %.17g\npower_out %.17g\n", r.power_in, r.power_absorbed, r.power_out);
        printf("fluence_sum_r %.17g\n", fluence_sum);
    } else {
        fprintf(stderr, "voxelize_and_solve: %s\n", ohm_error_last());
    }
    free(fluence);
    ohm_scene_free(scene);
    ohm_context_free(ctx);
    return rc ? 1 : 0;
}
