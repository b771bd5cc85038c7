/* fuzz_mesh.c — libFuzzer harness for the mesh readers; FORMAT is one of
 * ohm_mesh_parse_obj/off/ply/stl (set with -DFORMAT=...).  Run with
 * scripts/fuzz.sh FORMAT SECONDS.  Checks: no crash or UB (sanitizers), a
 * failure leaves the mesh zeroed with a one-line message, a success has
 * in-range indices and finite coordinates. */
#include "input/mesh.h"
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    ohm_mesh m; ohm_error e;
    /* exact-size copy so over-reads are caught */
    char *copy = malloc(size ? size : 1);
    if (size) memcpy(copy, data, size);
    int rc = FORMAT(&m, size ? copy : NULL, size, "fuzz", &e);
    if (rc == 0) {
        ohm_mesh_topology t;
        double lo[3], hi[3];
        ohm_mesh_bounds(&m, lo, hi);
        (void)ohm_mesh_signed_volume(&m);
        if (ohm_mesh_topology_compute(&t, &m, &e) != 0) abort();
        for (size_t i = 0; i < 3 * m.ntris; ++i) if (m.tris[i] < 0 || (uint64_t)m.tris[i] >= m.nverts) abort();
        for (size_t i = 0; i < 3 * m.nverts; ++i) if (!(m.verts[i] - m.verts[i] == 0)) abort();
        ohm_mesh_free(&m);
    } else {
        if (m.verts || m.tris || m.nverts || m.ntris) abort();
        if (e.code != rc || !memchr(e.msg, 0, sizeof e.msg) || strchr(e.msg, '\n')) abort();
    }
    free(copy);
    return 0;
}
