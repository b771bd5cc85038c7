/* shadow.h — is a boundary face visible from a light?  (docs/relighting.md)
 *
 * The lit surface is the voxel object's: its staircase shades itself (a
 * voxelized sphere lit at an angle captures 55% too much light without shadow
 * rays, measured), so every mode traces through the voxel cells:
 *   grid  a 3-D DDA through the voxel object's cells (no mesh needed, e.g. for
 *         objects made from scans): the shadow of exactly what is simulated.
 *   mesh  the same, and rays against the triangle mesh with Embree (a BVH; the
 *         paper used an octree), so parts thinner than a voxel (ears, handles
 *         with no interior cell) cast shadows too.  A voxel face may lie
 *         inside the mesh, so only triangles facing the ray (outward normal .
 *         dir < 0) occlude: a ray leaving through the object's own surface is
 *         not shadowed.
 * Each face sends 2 x 2 rays from the centres of its quarters and is lit by
 * the fraction that get through, so partly shadowed faces are not all-or-none.
 * The occluder owns its Embree device and scene; ohm_occluder_free releases
 * them (NULL is fine).  Queries are read-only and thread-safe. */
#ifndef OHM_SHADOW_H
#define OHM_SHADOW_H

#include <embree3/rtcore.h>

#include "input/mesh.h"
#include "base/ohm_error.h"
#include "grid/voxelize.h"

typedef enum ohm_shadows {
    OHM_SHADOWS_NONE = 0,
    OHM_SHADOWS_MESH = 1,
    OHM_SHADOWS_GRID = 2
} ohm_shadows;

typedef struct ohm_occluder ohm_occluder;

/* mesh may be NULL for OHM_SHADOWS_GRID; orientation is +1 for outward-wound
 * meshes, -1 for inside-out ones (the voxelizer's report says which). */
int ohm_occluder_create(ohm_occluder **out, ohm_shadows mode, const ohm_voxel_grid *grid, const ohm_mesh *mesh,
                        int orientation, ohm_error *err);
void ohm_occluder_free(ohm_occluder *occ);

/* Fraction of boundary face (cell ijk, outward face direction d) that sees a
 * light in direction l (unit) at distance tmax (INFINITY: directional):
 * 0, 1/4, 1/2, 3/4 or 1.  NULL occ: 1. */
double ohm_face_visibility(const ohm_occluder *occ, const int32_t ijk[3], int d, const double l[3], double tmax);

const char *ohm_shadows_name(ohm_shadows s);

/* One Embree device and scene holding a mesh's triangles (single-threaded
 * device, float copies of the vertices), shared by the shadow rays and the
 * preview renderer.  occluded_filter may be NULL; user goes to the geometry.
 * `who` prefixes the messages ("shadows", "-render").  On failure nothing is
 * left allocated.  Release with rtcReleaseScene and rtcReleaseDevice. */
int ohm_embree_mesh_scene(RTCDevice *device, RTCScene *scene, const ohm_mesh *mesh, RTCFilterFunctionN occluded_filter,
                          void *user, const char *who, ohm_error *err);

/* Does anything in the scene block the ray from org (world mm) along the unit
 * direction dir before distance tmax (INFINITY: none)? */
int ohm_embree_occluded(RTCScene scene, const double org[3], const double dir[3], double tmax);

#endif
