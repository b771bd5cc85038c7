/* make_vdb_seeds.c — writes the small .vdb seeds in tests/fuzz/seeds/vdb/ for
 * the vdb harness (scripts/fuzz.sh vdb).  Build (not part of the fuzz run):
 *   clang -c -Isrc -Iwrappers/vdb tests/fuzz/make_vdb_seeds.c -o /tmp/m.o
 *   clang++ -std=c++17 -c -Isrc -Iwrappers/vdb wrappers/vdb/ohm_vdb.cpp -o /tmp/v.o
 *   clang -c -Isrc src/base/ohm_error.c -o /tmp/e.o
 *   clang++ /tmp/m.o /tmp/v.o /tmp/e.o -lopenvdb -ltbb -lImath-3_1 -o /tmp/make_vdb_seeds
 *   /tmp/make_vdb_seeds tests/fuzz/seeds/vdb */
#include "ohm_vdb.h"
#include <stdio.h>

static int one(const char *dir, const char *file, const char *name, int cls, int n, float bg, double vs)
{
    ohm_error e;
    ohm_vdb_grid *g = NULL;
    const double origin[3] = {1.0, -2.0, 0.5};
    int32_t ijk[3 * 64];
    float v[64];
    for (int i = 0; i < n; ++i) {
        ijk[3 * i] = i % 4; ijk[3 * i + 1] = (i / 4) % 4; ijk[3 * i + 2] = i / 16;
        v[i] = 0.25f * (float)i;
    }
    char path[512];
    snprintf(path, sizeof path, "%s/%s", dir, file);
    if (ohm_vdb_grid_create(&g, name, cls, bg, vs, origin, &e) || ohm_vdb_grid_set_values(g, ijk, v, (size_t)n, &e) ||
        ohm_vdb_write(path, &g, 1, &e)) {
        fprintf(stderr, "%s\n", e.msg);
        ohm_vdb_grid_free(g);
        return 1;
    }
    ohm_vdb_grid_free(g);
    return 0;
}

int main(int argc, char **argv)
{
    const char *dir = argc > 1 ? argv[1] : ".";
    int rc = 0;
    rc |= one(dir, "density-fog-4x4x4.vdb", "density", OHM_VDB_CLASS_FOG_VOLUME, 64, 0.0f, 0.5);
    rc |= one(dir, "density-one-voxel.vdb", "density", OHM_VDB_CLASS_FOG_VOLUME, 1, 0.0f, 2.0);
    rc |= one(dir, "other-name.vdb", "sdf", OHM_VDB_CLASS_LEVEL_SET, 20, 3.0f, 1.0);
    return rc;
}
