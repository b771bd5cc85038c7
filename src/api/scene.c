/* api/scene.c — a scene's steps: the pipeline's actions by name, arrays
 * handed over, lights, solve and relight (include/ohm.h). */
#include "api/api.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "steps/pipeline.h"
#include "physics/light_kind.h"

void ohm_api_sync_log(ohm_scene *scene)
{
    scene->state.log = scene->ctx->log;
}

int ohm_scene_new(ohm_scene **out, ohm_context *ctx)
{
    if (!out) return ohm_api_fail(OHM_ERR_USAGE, "ohm_scene_new: out is NULL");
    *out = NULL;
    if (!ctx) return ohm_api_fail(OHM_ERR_USAGE, "ohm_scene_new: no context (make one with ohm_context_new)");
    ohm_scene *scene = calloc(1, sizeof *scene);
    if (!scene) return ohm_api_fail(OHM_ERR_NOMEM, "ohm_scene_new: out of memory");
    scene->ctx = ctx;
    ohm_state_init(&scene->state);
    ohm_api_sync_log(scene);
    *out = scene;
    return OHM_OK;
}

void ohm_scene_free(ohm_scene *scene)
{
    if (!scene) return;
    ohm_state_free(&scene->state);
    free(scene);
}

void ohm_api_scene_begin(ohm_scene *scene)
{
    atomic_store(&scene->ctx->cancel, 0);
    ohm_api_sync_log(scene);
}

static int run_chain(ohm_scene *scene, ohm_chain *chain)
{
    ohm_api_scene_begin(scene);
    ohm_error err;
    ohm_error_clear(&err);
    int rc = ohm_chain_run(chain, &scene->state, &err);
    ohm_chain_free(chain);
    return ohm_api_return(rc, &err);
}

int ohm_scene_run_args(ohm_scene *scene, int argc, const char *const *argv)
{
    if (!scene || (argc > 0 && !argv)) return ohm_api_fail(OHM_ERR_USAGE, "ohm_scene_run_args: scene or argv is NULL");
    ohm_error err;
    ohm_error_clear(&err);
    ohm_chain chain;
    int rc = ohm_chain_parse_args(&chain, argc, argv, &err);
    if (rc) return ohm_api_return(rc, &err);
    return run_chain(scene, &chain);
}

int ohm_scene_run_file(ohm_scene *scene, const char *path)
{
    if (!scene || !path) return ohm_api_fail(OHM_ERR_USAGE, "ohm_scene_run_file: scene or path is NULL");
    ohm_error err;
    ohm_error_clear(&err);
    ohm_chain chain;
    int rc = ohm_chain_parse_file(&chain, path, &err);
    if (rc) return ohm_api_return(rc, &err);
    return run_chain(scene, &chain);
}

/* One action with options, and an extra option first when `extra` is set. */
static int run_action(ohm_scene *scene, const char *action, const char *extra, const char *const *options)
{
    if (!scene || !action) return ohm_api_fail(OHM_ERR_USAGE, "ohm_scene_run: scene or action is NULL");
    size_t n = 0;
    while (options && options[n]) ++n;
    const char **argv = malloc((n + 2) * sizeof *argv);
    char *word = malloc(strlen(action) + 2);
    if (!argv || !word) {
        free(argv);
        free(word);
        return ohm_api_fail(OHM_ERR_NOMEM, "ohm_scene_run: out of memory");
    }
    word[0] = '-';
    strcpy(word + 1, action);
    int argc = 0;
    argv[argc++] = word;
    if (extra) argv[argc++] = extra;
    for (size_t i = 0; i < n; ++i) argv[argc++] = options[i];
    int rc = ohm_scene_run_args(scene, argc, argv);
    free(argv);
    free(word);
    return rc;
}

int ohm_scene_run(ohm_scene *scene, const char *action, const char *const *options)
{
    if (action && action[0] == '-')
        return ohm_api_fail(OHM_ERR_USAGE, "ohm_scene_run: action '%s': give its name without '-'", action);
    return run_action(scene, action, NULL, options);
}

int ohm_scene_set_mesh(ohm_scene *scene, const double *positions, size_t nvertices, const int64_t *triangles,
                       size_t ntriangles, const char *name)
{
    if (!scene || (nvertices && !positions) || (ntriangles && !triangles))
        return ohm_api_fail(OHM_ERR_USAGE, "ohm_scene_set_mesh: scene, positions or triangles is NULL");
    const char *what = name ? name : "mesh arrays";
    if (nvertices < 3 || ntriangles < 1)
        return ohm_api_fail(OHM_ERR_INVALID, "%s: %zu vertices and %zu triangles: a closed mesh needs at least 3 and 1",
                            what, nvertices, ntriangles);
    if (nvertices > SIZE_MAX / (3 * sizeof(double)) || ntriangles > SIZE_MAX / (3 * sizeof(int64_t)))
        return ohm_api_fail(OHM_ERR_NOMEM, "%s: too many vertices or triangles", what);
    for (size_t v = 0; v < 3 * nvertices; ++v)
        if (!isfinite(positions[v]))
            return ohm_api_fail(OHM_ERR_INVALID, "%s: vertex %zu has a non-finite coordinate", what, v / 3);
    for (size_t t = 0; t < 3 * ntriangles; ++t)
        if (triangles[t] < 0 || (uint64_t)triangles[t] >= nvertices)
            return ohm_api_fail(OHM_ERR_INVALID, "%s: triangle %zu refers to vertex %lld, the mesh has %zu vertices",
                                what, t / 3, (long long)triangles[t], nvertices);
    ohm_mesh m;
    m.nverts = nvertices;
    m.ntris = ntriangles;
    m.verts = malloc(3 * nvertices * sizeof *m.verts);
    m.tris = malloc(3 * ntriangles * sizeof *m.tris);
    if (!m.verts || !m.tris) {
        ohm_mesh_free(&m);
        return ohm_api_fail(OHM_ERR_NOMEM, "%s: out of memory for %zu vertices", what, nvertices);
    }
    memcpy(m.verts, positions, 3 * nvertices * sizeof *m.verts);
    memcpy(m.tris, triangles, 3 * ntriangles * sizeof *m.tris);
    ohm_api_sync_log(scene);
    ohm_error err;
    ohm_error_clear(&err);
    return ohm_api_return(ohm_state_set_mesh(&scene->state, &m, what, 1.0, ohm_now(), &err), &err);
}

int ohm_scene_set_density(ohm_scene *scene, const float *values, const int64_t dims[3],
                          const double index_to_world[12], const char *name)
{
    if (!scene || !values || !dims || !index_to_world)
        return ohm_api_fail(OHM_ERR_USAGE, "ohm_scene_set_density: scene, values, dims or index_to_world is NULL");
    const char *what = name ? name : "density array";
    for (int a = 0; a < 3; ++a)
        if (dims[a] < 1 || dims[a] > INT32_MAX)
            return ohm_api_fail(OHM_ERR_INVALID, "%s: dims %lld x %lld x %lld: each must be 1 .. %d", what,
                                (long long)dims[0], (long long)dims[1], (long long)dims[2], INT32_MAX);
    double count = (double)dims[0] * (double)dims[1] * (double)dims[2];
    if (count * sizeof(float) > (double)(SIZE_MAX / 2))
        return ohm_api_fail(OHM_ERR_NOMEM, "%s: %.3g voxels are too many", what, count);
    for (int q = 0; q < 12; ++q)
        if (!isfinite(index_to_world[q]))
            return ohm_api_fail(OHM_ERR_INVALID, "%s: index_to_world[%d] is not finite", what, q);
    const double *M = index_to_world; /* the 3 x 3 part must be invertible */
    double det = M[0] * (M[5] * M[10] - M[6] * M[9]) - M[1] * (M[4] * M[10] - M[6] * M[8]) +
                 M[2] * (M[4] * M[9] - M[5] * M[8]);
    if (!(fabs(det) > 0))
        return ohm_api_fail(OHM_ERR_INVALID, "%s: index_to_world is singular (a voxel of zero size)", what);
    size_t n = (size_t)count;
    ohm_scan scan;
    memset(&scan, 0, sizeof scan);
    scan.values = malloc(n * sizeof *scan.values);
    if (!scan.values) return ohm_api_fail(OHM_ERR_NOMEM, "%s: out of memory for %zu voxels", what, n);
    scan.min = INFINITY;
    scan.max = -INFINITY;
    for (size_t v = 0; v < n; ++v) {
        if (!isfinite(values[v])) {
            free(scan.values);
            return ohm_api_fail(OHM_ERR_INVALID, "%s: voxel %zu is not finite", what, v);
        }
        scan.values[v] = values[v];
        scan.min = fmin(scan.min, values[v]);
        scan.max = fmax(scan.max, values[v]);
    }
    scan.background = scan.min; /* an array states no background: its lowest value (scan.h) */
    for (int a = 0; a < 3; ++a) {
        scan.dims[a] = (int32_t)dims[a];
        for (int c = 0; c < 4; ++c) scan.index_to_world[a][c] = M[4 * a + c];
    }
    ohm_api_sync_log(scene);
    ohm_state_set_scan(&scene->state, &scan, what, ohm_now());
    return OHM_OK;
}

int ohm_scene_add_light(ohm_scene *scene, const char *const *options)
{
    return run_action(scene, "light", NULL, options);
}

int ohm_scene_clear_lights(ohm_scene *scene)
{
    if (!scene) return ohm_api_fail(OHM_ERR_USAGE, "ohm_scene_clear_lights: scene is NULL");
    ohm_lights_free(scene->state.lights, scene->state.nlights);
    scene->state.lights = NULL;
    scene->state.nlights = 0;
    scene->state.have_solution = 0;
    return OHM_OK;
}

int ohm_scene_solve(ohm_scene *scene, const char *const *options)
{
    int keep_given = 0;
    for (size_t i = 0; options && options[i]; ++i) keep_given |= strncmp(options[i], "keep=", 5) == 0;
    return run_action(scene, "solve", keep_given ? NULL : "keep=1", options);
}

int ohm_scene_relight(ohm_scene *scene)
{
    if (!scene) return ohm_api_fail(OHM_ERR_USAGE, "ohm_scene_relight: scene is NULL");
    ohm_api_scene_begin(scene);
    ohm_error err;
    ohm_error_clear(&err);
    return ohm_api_return(ohm_state_relight(&scene->state, &err), &err);
}
