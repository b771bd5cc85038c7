/* mesh.h — triangle meshes in, and what ohm needs to know about them.
 *
 * Stage 1 of the pipeline (docs/design.md §2): read OBJ / PLY / STL / OFF into one
 * indexed triangle soup, polygons fan-triangulated.  The readers are small,
 * careful and our own (docs/mesh-readers.md says why): every error names
 * the file and the line (text formats) or the element / byte offset (binary
 * formats), and no declared count is trusted before the bytes are there.
 *
 * Ownership: ohm_mesh owns `verts` and `tris`; ohm_mesh_free releases them and
 * accepts NULL or a zeroed mesh. */
#ifndef OHM_MESH_H
#define OHM_MESH_H

#include <stddef.h>
#include <stdint.h>

#include "base/ohm_error.h"

typedef struct ohm_mesh {
    double *verts;     /* 3 * nverts coordinates, x y z                     */
    int64_t *tris;     /* 3 * ntris vertex indices, 0-based, < nverts       */
    size_t nverts;
    size_t ntris;
} ohm_mesh;

/* Topology report, computed from the triangles (edges as unordered pairs). */
typedef struct ohm_mesh_topology {
    size_t boundary_edges;      /* used by exactly one triangle (holes, rims)  */
    size_t nonmanifold_edges;   /* used by three or more triangles             */
    size_t misoriented_edges;   /* a directed edge used twice (flipped faces)  */
    size_t degenerate_tris;     /* zero area or repeated vertex                */
    size_t components;          /* pieces connected through shared vertices    */
    size_t unused_verts;        /* vertices no triangle uses                   */
} ohm_mesh_topology;

/* Read a mesh; the format is chosen from the extension (.obj .ply .stl .off,
 * case-insensitive).  On failure `out` is left zeroed and err says
 * "path:line: what" (text) or "path: element N / byte B: what" (binary). */
int ohm_mesh_read(ohm_mesh *out, const char *path, ohm_error *err);

/* Per-format entry points over a memory buffer (used by the fuzz harnesses
 * and by ohm_mesh_read).  `name` is only used in messages. */
int ohm_mesh_parse_obj(ohm_mesh *out, const char *data, size_t len, const char *name, ohm_error *err);
int ohm_mesh_parse_off(ohm_mesh *out, const char *data, size_t len, const char *name, ohm_error *err);
int ohm_mesh_parse_ply(ohm_mesh *out, const char *data, size_t len, const char *name, ohm_error *err);
int ohm_mesh_parse_stl(ohm_mesh *out, const char *data, size_t len, const char *name, ohm_error *err);

void ohm_mesh_free(ohm_mesh *m);

/* Axis-aligned bounds of the vertices that triangles use. */
void ohm_mesh_bounds(const ohm_mesh *m, double lo[3], double hi[3]);

/* Enclosed volume by the divergence theorem, sum det(a,b,c)/6: exact for a
 * closed, consistently oriented mesh; negative when it is wound inside-out. */
double ohm_mesh_signed_volume(const ohm_mesh *m);

/* Scale every coordinate by s (about the origin). */
void ohm_mesh_scale(ohm_mesh *m, double s);

int ohm_mesh_topology_compute(ohm_mesh_topology *out, const ohm_mesh *m, ohm_error *err);

#endif
