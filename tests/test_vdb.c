/* test_vdb.c — the C API over OpenVDB (wrappers/vdb/ohm_vdb.h): grid creation,
 * values, metadata, write/read round trip, error messages that name the path,
 * and OpenVDB's mesh -> level set on a unit cube. */
#include "check.h"
#include "base/ohm_error.h"
#include "ohm_vdb.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static ohm_vdb_grid *find_grid(ohm_vdb_grid **grids, size_t n, const char *name)
{
    for (size_t i = 0; i < n; ++i) {
        ohm_vdb_grid_info info;
        ohm_error err = {0, ""};
        if (ohm_vdb_grid_get_info(grids[i], &info, &err) == 0 && strcmp(info.name, name) == 0)
            return grids[i];
    }
    return NULL;
}

static float value_at(const ohm_vdb_grid *g, int32_t i, int32_t j, int32_t k)
{
    const int32_t ijk[3] = {i, j, k};
    float v = NAN;
    ohm_error err = {0, ""};
    if (ohm_vdb_grid_get_value(g, ijk, &v, &err) != 0) fprintf(stderr, "get_value: %s\n", err.msg);
    return v;
}

struct sum {
    size_t count;
    double total;
    int stop_after;
};

static int add_voxel(void *user, const int32_t ijk[3], float value)
{
    struct sum *s = user;
    (void)ijk;
    s->count++;
    s->total += value;
    return s->stop_after && (int)s->count >= s->stop_after ? 7 : 0;
}

static ohm_vdb_grid *make_fog(ohm_error *err)
{
    const double origin[3] = {1.0, 2.0, 3.0};
    ohm_vdb_grid *g = NULL;
    CHECK_MSG(ohm_vdb_grid_create(&g, "density", OHM_VDB_CLASS_FOG_VOLUME, 0.0f, 0.5, origin, err) == 0,
              "%s", err->msg);
    if (!g) return NULL;
    const int32_t ijk[] = {0, 0, 0, 1, 2, 3, -1, 0, 4};
    const float vals[] = {1.0f, 0.5f, 0.25f};
    CHECK_MSG(ohm_vdb_grid_set_values(g, ijk, vals, 3, err) == 0, "%s", err->msg);
    CHECK(ohm_vdb_grid_set_meta_string(g, "units", "mm", err) == 0);
    CHECK(ohm_vdb_grid_set_meta_double(g, "scale", 2.5, err) == 0);
    CHECK(ohm_vdb_grid_set_meta_int(g, "count", 42, err) == 0);
    /* Setting a key again with another type replaces it. */
    CHECK(ohm_vdb_grid_set_meta_double(g, "creator_note", 1.0, err) == 0);
    CHECK_MSG(ohm_vdb_grid_set_meta_string(g, "creator_note", "ohm test", err) == 0, "%s", err->msg);
    /* Reserved and empty keys are refused. */
    CHECK(ohm_vdb_grid_set_meta_string(g, "class", "fog volume", err) == OHM_ERR_INVALID);
    CHECK(ohm_vdb_grid_set_meta_int(g, "", 1, err) == OHM_ERR_INVALID);
    CHECK(ohm_vdb_grid_prune(g, err) == 0);
    return g;
}

/* A sphere of radius 4 voxels, narrow band of 3 voxels (background 1.5 mm at 0.5 mm). */
static ohm_vdb_grid *make_level_set(ohm_error *err)
{
    const double origin[3] = {-2.0, 0.0, 0.25};
    const double vs = 0.5;
    const float bg = 1.5f;
    ohm_vdb_grid *g = NULL;
    CHECK_MSG(ohm_vdb_grid_create(&g, "surface", OHM_VDB_CLASS_LEVEL_SET, bg, vs, origin, err) == 0,
              "%s", err->msg);
    if (!g) return NULL;
    int32_t ijk[15 * 15 * 15 * 3];
    float vals[15 * 15 * 15];
    size_t n = 0;
    for (int i = -7; i <= 7; ++i)
        for (int j = -7; j <= 7; ++j)
            for (int k = -7; k <= 7; ++k) {
                double d = (sqrt((double)(i * i + j * j + k * k)) - 4.0) * vs;
                if (fabs(d) < bg) {
                    ijk[3 * n] = i;
                    ijk[3 * n + 1] = j;
                    ijk[3 * n + 2] = k;
                    vals[n++] = (float)d;
                }
            }
    CHECK_MSG(ohm_vdb_grid_set_values(g, ijk, vals, n, err) == 0, "%s", err->msg);
    CHECK(ohm_vdb_grid_set_meta_string(g, "units", "mm", err) == 0);
    CHECK_MSG(ohm_vdb_grid_finish_level_set(g, err) == 0, "%s", err->msg);
    return g;
}

static void test_create_and_errors(void)
{
    /* Calling into ohm_error.c here also makes the linker take ohm_error.o from
     * libohm_core.a before it reaches libohm_vdb.a, which needs ohm_fail. */
    ohm_error err;
    ohm_error_clear(&err);
    ohm_vdb_grid *g = NULL;
    const double origin[3] = {0, 0, 0};
    CHECK(ohm_vdb_init(&err) == 0);
    CHECK(ohm_vdb_init(&err) == 0);
    CHECK(ohm_vdb_grid_create(&g, "x", 9, 0.0f, 1.0, origin, &err) == OHM_ERR_INVALID);
    CHECK(g == NULL);
    CHECK(err.code == OHM_ERR_INVALID && strstr(err.msg, "9") != NULL);
    CHECK(ohm_vdb_grid_create(&g, "x", OHM_VDB_CLASS_FOG_VOLUME, 0.0f, 0.0, origin, &err) ==
          OHM_ERR_INVALID);
    CHECK(ohm_vdb_grid_create(&g, "x", OHM_VDB_CLASS_FOG_VOLUME, 0.0f, NAN, origin, &err) ==
          OHM_ERR_INVALID);
    CHECK(ohm_vdb_grid_create(&g, "x", OHM_VDB_CLASS_LEVEL_SET, 0.0f, 1.0, origin, &err) ==
          OHM_ERR_INVALID);
    ohm_vdb_grid_free(NULL);

    /* An empty grid: bbox all zero, no active voxels. */
    CHECK(ohm_vdb_grid_create(&g, "empty", OHM_VDB_CLASS_UNKNOWN, 0.0f, 2.0, NULL, &err) == 0);
    ohm_vdb_grid_info info;
    CHECK(ohm_vdb_grid_get_info(g, &info, &err) == 0);
    CHECK(strcmp(info.name, "empty") == 0);
    CHECK(info.grid_class == OHM_VDB_CLASS_UNKNOWN);
    CHECK(info.active_voxels == 0);
    CHECK(info.bbox_min[0] == 0 && info.bbox_min[1] == 0 && info.bbox_min[2] == 0);
    CHECK(info.bbox_max[0] == 0 && info.bbox_max[1] == 0 && info.bbox_max[2] == 0);
    CHECK(info.voxel_size == 2.0);
    CHECK(info.origin[0] == 0.0 && info.origin[1] == 0.0 && info.origin[2] == 0.0);
    /* Not a level set. */
    CHECK(ohm_vdb_grid_finish_level_set(g, &err) == OHM_ERR_INVALID);
    /* Non-finite values are refused. */
    const int32_t ijk[3] = {0, 0, 0};
    const float bad = NAN;
    CHECK(ohm_vdb_grid_set_values(g, ijk, &bad, 1, &err) == OHM_ERR_NUMERIC);
    CHECK(ohm_vdb_grid_set_values(g, NULL, NULL, 0, &err) == 0);
    ohm_vdb_grid_free(g);
}

static void check_fog(const ohm_vdb_grid *g)
{
    ohm_error err = {0, ""};
    ohm_vdb_grid_info info;
    CHECK_MSG(ohm_vdb_grid_get_info(g, &info, &err) == 0, "%s", err.msg);
    CHECK(strcmp(info.name, "density") == 0);
    CHECK(info.grid_class == OHM_VDB_CLASS_FOG_VOLUME);
    CHECK(info.voxel_size == 0.5);
    CHECK(info.origin[0] == 1.0 && info.origin[1] == 2.0 && info.origin[2] == 3.0);
    CHECK(info.active_voxels == 3);
    CHECK(info.bbox_min[0] == -1 && info.bbox_min[1] == 0 && info.bbox_min[2] == 0);
    CHECK(info.bbox_max[0] == 1 && info.bbox_max[1] == 2 && info.bbox_max[2] == 4);
    CHECK(info.background == 0.0f);
    CHECK(value_at(g, 0, 0, 0) == 1.0f);
    CHECK(value_at(g, 1, 2, 3) == 0.5f);
    CHECK(value_at(g, -1, 0, 4) == 0.25f);
    CHECK(value_at(g, 5, 5, 5) == 0.0f);

    struct sum s = {0, 0.0, 0};
    CHECK(ohm_vdb_grid_foreach_active(g, add_voxel, &s, &err) == 0);
    CHECK(s.count == 3);
    CHECK(s.total == 1.75);
    struct sum s2 = {0, 0.0, 2};
    CHECK(ohm_vdb_grid_foreach_active(g, add_voxel, &s2, &err) == 7);
    CHECK(s2.count == 2);

    char buf[64];
    CHECK_MSG(ohm_vdb_grid_get_meta_string(g, "units", buf, sizeof buf, &err) == 0, "%s", err.msg);
    CHECK(strcmp(buf, "mm") == 0);
    CHECK_MSG(ohm_vdb_grid_get_meta_string(g, "creator_note", buf, sizeof buf, &err) == 0, "%s",
              err.msg);
    CHECK(strcmp(buf, "ohm test") == 0);
    char small[4];
    CHECK(ohm_vdb_grid_get_meta_string(g, "creator_note", small, sizeof small, &err) == 0);
    CHECK(strcmp(small, "ohm") == 0);
    /* The double and int fields exist with their own types (no getters for them). */
    CHECK(ohm_vdb_grid_get_meta_string(g, "scale", buf, sizeof buf, &err) == OHM_ERR_INVALID);
    CHECK_MSG(strstr(err.msg, "double") != NULL, "%s", err.msg);
    CHECK(ohm_vdb_grid_get_meta_string(g, "count", buf, sizeof buf, &err) == OHM_ERR_INVALID);
    CHECK_MSG(strstr(err.msg, "int64") != NULL, "%s", err.msg);
    CHECK(ohm_vdb_grid_get_meta_string(g, "nope", buf, sizeof buf, &err) == OHM_ERR_INVALID);
    CHECK_MSG(strstr(err.msg, "nope") != NULL, "%s", err.msg);
}

static void check_level_set(const ohm_vdb_grid *g)
{
    ohm_error err = {0, ""};
    ohm_vdb_grid_info info;
    CHECK_MSG(ohm_vdb_grid_get_info(g, &info, &err) == 0, "%s", err.msg);
    CHECK(strcmp(info.name, "surface") == 0);
    CHECK(info.grid_class == OHM_VDB_CLASS_LEVEL_SET);
    CHECK(info.voxel_size == 0.5);
    CHECK(info.origin[0] == -2.0 && info.origin[1] == 0.0 && info.origin[2] == 0.25);
    CHECK(info.background == 1.5f);
    CHECK(info.bbox_min[0] == -6 && info.bbox_max[0] == 6);
    /* Centre: outside the band, inside the sphere -> -background after flood fill. */
    CHECK(value_at(g, 0, 0, 0) == -1.5f);
    CHECK(value_at(g, 20, 0, 0) == 1.5f);
    CHECK(value_at(g, -100, 3, 0) == 1.5f);
    CHECK_REL(value_at(g, 5, 0, 0), 0.5, 1e-6);
    CHECK_REL(value_at(g, 3, 0, 0), -0.5, 1e-6);
    char buf[16];
    CHECK(ohm_vdb_grid_get_meta_string(g, "units", buf, sizeof buf, &err) == 0);
    CHECK(strcmp(buf, "mm") == 0);
}

static void test_round_trip(const char *dir)
{
    ohm_error err = {0, ""};
    char path[512], bad[512], txt[512];
    snprintf(path, sizeof path, "%s/grids.vdb", dir);
    snprintf(bad, sizeof bad, "%s/no/such/dir/out.vdb", dir);
    snprintf(txt, sizeof txt, "%s/not-a-vdb.vdb", dir);

    ohm_vdb_grid *grids[2] = {make_fog(&err), make_level_set(&err)};
    if (!grids[0] || !grids[1]) {
        ohm_vdb_grid_free(grids[0]);
        ohm_vdb_grid_free(grids[1]);
        return;
    }
    check_fog(grids[0]);
    check_level_set(grids[1]);

    CHECK_MSG(ohm_vdb_write(path, grids, 2, &err) == 0, "%s", err.msg);
    /* Overwriting works. */
    CHECK_MSG(ohm_vdb_write(path, grids, 2, &err) == 0, "%s", err.msg);

    /* A path in a directory that does not exist. */
    ohm_error werr = {0, ""};
    CHECK(ohm_vdb_write(bad, grids, 2, &werr) == OHM_ERR_IO);
    CHECK_MSG(strstr(werr.msg, bad) != NULL, "message '%s' does not name '%s'", werr.msg, bad);
    CHECK(strchr(werr.msg, '\n') == NULL);
    /* A directory as the path. */
    CHECK(ohm_vdb_write(dir, grids, 2, &werr) == OHM_ERR_IO);
    CHECK_MSG(strstr(werr.msg, dir) != NULL, "%s", werr.msg);
    ohm_vdb_grid_free(grids[0]);
    ohm_vdb_grid_free(grids[1]);

    ohm_vdb_grid **back = NULL;
    size_t n = 0;
    CHECK_MSG(ohm_vdb_read(&back, &n, path, &err) == 0, "%s", err.msg);
    CHECK(n == 2);
    if (back) {
        const ohm_vdb_grid *fog = find_grid(back, n, "density");
        const ohm_vdb_grid *ls = find_grid(back, n, "surface");
        CHECK(fog != NULL);
        CHECK(ls != NULL);
        if (fog) check_fog(fog);
        if (ls) check_level_set(ls);
        for (size_t i = 0; i < n; ++i) ohm_vdb_grid_free(back[i]);
        free(back);
    }

    /* A file with no grids reads as n = 0. */
    char empty[512];
    snprintf(empty, sizeof empty, "%s/empty.vdb", dir);
    CHECK_MSG(ohm_vdb_write(empty, NULL, 0, &err) == 0, "%s", err.msg);
    back = (ohm_vdb_grid **)1;
    n = 99;
    CHECK_MSG(ohm_vdb_read(&back, &n, empty, &err) == 0, "%s", err.msg);
    CHECK(n == 0);
    CHECK(back == NULL);

    /* A missing file. */
    char missing[512];
    snprintf(missing, sizeof missing, "%s/missing.vdb", dir);
    ohm_error rerr = {0, ""};
    CHECK(ohm_vdb_read(&back, &n, missing, &rerr) == OHM_ERR_IO);
    CHECK_MSG(strstr(rerr.msg, missing) != NULL, "%s", rerr.msg);
    /* A directory. */
    CHECK(ohm_vdb_read(&back, &n, dir, &rerr) == OHM_ERR_IO);
    CHECK_MSG(strstr(rerr.msg, dir) != NULL, "%s", rerr.msg);
    /* A text file. */
    FILE *f = fopen(txt, "w");
    CHECK(f != NULL);
    if (f) {
        fputs("this is not a VDB file\nat all\n", f);
        fclose(f);
        rerr.msg[0] = '\0';
        CHECK(ohm_vdb_read(&back, &n, txt, &rerr) == OHM_ERR_PARSE);
        CHECK_MSG(strstr(rerr.msg, txt) != NULL, "%s", rerr.msg);
        CHECK(strchr(rerr.msg, '\n') == NULL);
        CHECK(n == 0 && back == NULL);
    }
    remove(path);
    remove(empty);
    remove(txt);
}

static void test_mesh_to_level_set(void)
{
    ohm_error err = {0, ""};
    /* The unit cube [0,1]^3, outward-facing triangles. */
    const double v[8 * 3] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0,
                             0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1};
    const int64_t t[12 * 3] = {0, 2, 1, 0, 3, 2, /* z = 0 */
                               4, 5, 6, 4, 6, 7, /* z = 1 */
                               0, 1, 5, 0, 5, 4, /* y = 0 */
                               3, 7, 6, 3, 6, 2, /* y = 1 */
                               0, 4, 7, 0, 7, 3, /* x = 0 */
                               1, 2, 6, 1, 6, 5 /* x = 1 */};
    const double origin[3] = {0, 0, 0};
    ohm_vdb_grid *g = NULL;
    CHECK_MSG(ohm_vdb_mesh_to_level_set(&g, v, 8, t, 12, 0.1, origin, 3.0f, &err) == 0, "%s",
              err.msg);
    if (g) {
        ohm_vdb_grid_info info;
        CHECK(ohm_vdb_grid_get_info(g, &info, &err) == 0);
        CHECK(info.grid_class == OHM_VDB_CLASS_LEVEL_SET);
        CHECK_REL(info.voxel_size, 0.1, 1e-12);
        CHECK(info.active_voxels > 0);
        float centre = value_at(g, 5, 5, 5);   /* (0.5, 0.5, 0.5) */
        float near_in = value_at(g, 9, 5, 5);  /* 0.1 inside the x = 1 face */
        float near_out = value_at(g, 12, 5, 5); /* 0.2 outside */
        float far_out = value_at(g, 30, 5, 5);
        CHECK_MSG(centre < 0.0f, "centre %g", (double)centre);
        CHECK_MSG(near_in < 0.0f && fabs(near_in + 0.1) < 0.02, "near_in %g", (double)near_in);
        CHECK_MSG(near_out > 0.0f && fabs(near_out - 0.2) < 0.02, "near_out %g", (double)near_out);
        CHECK_MSG(far_out > 0.0f, "far_out %g", (double)far_out);
        ohm_vdb_grid_free(g);
    }

    /* An index out of range. */
    int64_t tb[12 * 3];
    memcpy(tb, t, sizeof tb);
    tb[17] = 8;
    g = NULL;
    CHECK(ohm_vdb_mesh_to_level_set(&g, v, 8, tb, 12, 0.1, origin, 3.0f, &err) == OHM_ERR_INVALID);
    CHECK(g == NULL);
    CHECK_MSG(strstr(err.msg, "8") != NULL, "%s", err.msg);
    tb[17] = -1;
    CHECK(ohm_vdb_mesh_to_level_set(&g, v, 8, tb, 12, 0.1, origin, 3.0f, &err) == OHM_ERR_INVALID);
    /* A bad voxel size or half width. */
    CHECK(ohm_vdb_mesh_to_level_set(&g, v, 8, t, 12, -0.1, origin, 3.0f, &err) == OHM_ERR_INVALID);
    CHECK(ohm_vdb_mesh_to_level_set(&g, v, 8, t, 12, 0.1, origin, 0.5f, &err) == OHM_ERR_INVALID);
}

/* The streaming writer: grids added one at a time (each freed once added)
 * read back as ohm_vdb_write's do; a close short of the grids announced, a
 * repeated name and a full device fail, leaving no file. */
static void test_streaming_writer(const char *dir)
{
    ohm_error err = {0, ""};
    char path[512];
    snprintf(path, sizeof path, "%s/streamed.vdb", dir);
    ohm_vdb_writer *w = NULL;
    CHECK_MSG(ohm_vdb_writer_open(&w, path, 2, &err) == 0, "%s", err.msg);
    for (int i = 0; w && i < 2; ++i) {
        ohm_vdb_grid *g = i == 0 ? make_fog(&err) : make_level_set(&err);
        CHECK_MSG(g && ohm_vdb_writer_add(w, g, &err) == 0, "%s", err.msg);
        ohm_vdb_grid_free(g);
    }
    CHECK_MSG(w && ohm_vdb_writer_close(w, &err) == 0, "%s", err.msg);
    ohm_vdb_grid **back = NULL;
    size_t n = 0;
    CHECK_MSG(ohm_vdb_read(&back, &n, path, &err) == 0, "%s", err.msg);
    CHECK(n == 2);
    if (back) {
        const ohm_vdb_grid *fog = find_grid(back, n, "density"), *ls = find_grid(back, n, "surface");
        CHECK(fog && ls);
        if (fog) check_fog(fog);
        if (ls) check_level_set(ls);
        for (size_t i = 0; i < n; ++i) ohm_vdb_grid_free(back[i]);
        free(back);
    }
    CHECK(unlink(path) == 0);

    ohm_vdb_grid *fog = make_fog(&err);
    /* fewer grids than announced */
    w = NULL;
    CHECK(ohm_vdb_writer_open(&w, path, 3, &err) == 0 && ohm_vdb_writer_add(w, fog, &err) == 0);
    CHECK(ohm_vdb_writer_close(w, &err) == OHM_ERR_INTERNAL && strstr(err.msg, "1 grids written of the 3"));
    CHECK_MSG(access(path, F_OK) != 0, "%s left behind", path);
    /* the same name twice */
    w = NULL;
    CHECK(ohm_vdb_writer_open(&w, path, 2, &err) == 0 && ohm_vdb_writer_add(w, fog, &err) == 0);
    CHECK(ohm_vdb_writer_add(w, fog, &err) == OHM_ERR_INTERNAL && strstr(err.msg, "two grids named 'density'"));
    ohm_vdb_writer_abort(w);
    CHECK_MSG(access(path, F_OK) != 0, "%s left behind", path);
    /* a full device: the failure is seen, not a file that ends short */
    if (access("/dev/full", W_OK) == 0) {
        w = NULL;
        int rc = ohm_vdb_writer_open(&w, "/dev/full", 1, &err);
        if (!rc) rc = ohm_vdb_writer_add(w, fog, &err);
        if (!rc) rc = ohm_vdb_writer_close(w, &err);
        else ohm_vdb_writer_abort(w);
        CHECK_MSG(rc == OHM_ERR_IO && strstr(err.msg, "/dev/full"), "rc %d: %s", rc, err.msg);
    }
    ohm_vdb_grid_free(fog);
}

int main(void)
{
    char dir[] = "/tmp/ohm-test-vdb-XXXXXX";
    if (!mkdtemp(dir)) {
        perror("mkdtemp");
        return 1;
    }
    test_create_and_errors();
    test_round_trip(dir);
    test_streaming_writer(dir);
    test_mesh_to_level_set();
    CHECK_MSG(rmdir(dir) == 0, "could not remove %s", dir);
    return check_summary();
}
