#include "physics/shadow.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>


#include "physics/network.h"

struct ohm_occluder {
    ohm_shadows mode;
    const ohm_voxel_grid *grid;  /* not owned */
    const ohm_mesh *mesh;        /* not owned (normals for the filter) */
    double orientation;
    RTCDevice device;
    RTCScene scene;
};

const char *ohm_shadows_name(ohm_shadows s)
{
    return s == OHM_SHADOWS_MESH ? "mesh" : s == OHM_SHADOWS_GRID ? "grid" : "none";
}

/* Embree's RTCRayN / RTCHitN are structure-of-arrays; the C++ accessors in
 * rtcore_ray.h are not available from C, so index as they do. */
static inline float rayn_dir(const struct RTCRayN *ray, unsigned N, unsigned i, int a)
{
    return ((const float *)ray)[(4u + (unsigned)a) * N + i];
}
static inline unsigned hitn_prim(const struct RTCHitN *hit, unsigned N, unsigned i)
{
    return ((const unsigned *)hit)[5u * N + i];
}

/* Only front faces occlude (see shadow.h). */
static void front_faces_only(const struct RTCFilterFunctionNArguments *args)
{
    const ohm_occluder *occ = args->geometryUserPtr;
    const ohm_mesh *m = occ->mesh;
    for (unsigned i = 0; i < args->N; ++i) {
        if (args->valid[i] != -1) continue;
        unsigned t = hitn_prim(args->hit, args->N, i);
        const double *a = m->verts + 3 * m->tris[3 * t], *b = m->verts + 3 * m->tris[3 * t + 1],
                     *c = m->verts + 3 * m->tris[3 * t + 2];
        double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
        double dn = 0;
        for (int k = 0; k < 3; ++k) dn += n[k] * rayn_dir(args->ray, args->N, i, k);
        if (occ->orientation * dn >= 0) args->valid[i] = 0; /* back face or edge-on: ignore */
    }
}

void ohm_occluder_free(ohm_occluder *occ)
{
    if (!occ) return;
    if (occ->scene) rtcReleaseScene(occ->scene);
    if (occ->device) rtcReleaseDevice(occ->device);
    free(occ);
}

int ohm_embree_mesh_scene(RTCDevice *device, RTCScene *scene, const ohm_mesh *mesh, RTCFilterFunctionN occluded_filter,
                          void *user, const char *who, ohm_error *err)
{
    *device = NULL;
    *scene = NULL;
    if (mesh->ntris > 0xFFFFFFFFu || mesh->nverts > 0xFFFFFFFFu)
        return ohm_fail(err, OHM_ERR_INVALID, "%s: %zu triangles is more than Embree indexes", who, mesh->ntris);
    RTCDevice dev = rtcNewDevice("threads=1");
    if (!dev)
        return ohm_fail(err, OHM_ERR_INTERNAL, "%s: Embree could not start (error %d)", who,
                        (int)rtcGetDeviceError(NULL));
    RTCScene sc = rtcNewScene(dev);
    RTCGeometry geom = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    float *vb = rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                        mesh->nverts);
    unsigned *ib = rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned),
                                           mesh->ntris);
    if (!vb || !ib) {
        rtcReleaseGeometry(geom);
        rtcReleaseScene(sc);
        rtcReleaseDevice(dev);
        return ohm_fail(err, OHM_ERR_NOMEM, "%s: out of memory for %zu triangles", who, mesh->ntris);
    }
    for (size_t i = 0; i < 3 * mesh->nverts; ++i) vb[i] = (float)mesh->verts[i];
    for (size_t i = 0; i < 3 * mesh->ntris; ++i) ib[i] = (unsigned)mesh->tris[i];
    if (occluded_filter) {
        rtcSetGeometryUserData(geom, user);
        rtcSetGeometryOccludedFilterFunction(geom, occluded_filter);
    }
    rtcCommitGeometry(geom);
    rtcAttachGeometry(sc, geom);
    rtcReleaseGeometry(geom);
    rtcCommitScene(sc);
    if (rtcGetDeviceError(dev) != RTC_ERROR_NONE) {
        rtcReleaseScene(sc);
        rtcReleaseDevice(dev);
        return ohm_fail(err, OHM_ERR_INTERNAL, "%s: Embree failed to build the scene", who);
    }
    *device = dev;
    *scene = sc;
    return OHM_OK;
}

int ohm_occluder_create(ohm_occluder **out, ohm_shadows mode, const ohm_voxel_grid *grid, const ohm_mesh *mesh,
                        int orientation, ohm_error *err)
{
    *out = NULL;
    if (mode == OHM_SHADOWS_NONE) return OHM_OK;
    ohm_occluder *occ = calloc(1, sizeof *occ);
    if (!occ) return ohm_fail(err, OHM_ERR_NOMEM, "shadows: out of memory");
    occ->mode = mode;
    occ->grid = grid;
    occ->mesh = mesh;
    occ->orientation = orientation < 0 ? -1.0 : 1.0;
    if (mode == OHM_SHADOWS_GRID) {
        *out = occ;
        return OHM_OK;
    }
    if (!mesh || mesh->ntris == 0) {
        free(occ);
        return ohm_fail(err, OHM_ERR_INVALID, "shadows=mesh needs a mesh: use shadows=grid for objects without one");
    }
    int rc = ohm_embree_mesh_scene(&occ->device, &occ->scene, mesh, front_faces_only, occ, "shadows", err);
    if (rc) {
        free(occ);
        return rc;
    }
    *out = occ;
    return OHM_OK;
}

/* DDA (Amanatides & Woo 1987) from point p on face d of cell ijk (cell
 * units: cell i spans [i - 1/2, i + 1/2]) toward the light: any interior cell
 * on the way occludes. */
static int grid_occluded(const ohm_voxel_grid *g, const int32_t ijk[3], int d, const double p[3], const double l[3],
                         double tmax)
{
    int32_t c[3], step[3];
    double tnext[3], tdelta[3];
    for (int a = 0; a < 3; ++a) {
        c[a] = ijk[a] + ohm_face_offset[d][a]; /* the outside cell across the face */
        step[a] = l[a] > 0 ? 1 : (l[a] < 0 ? -1 : 0);
        if (step[a] == 0) {
            tnext[a] = tdelta[a] = INFINITY;
            continue;
        }
        double boundary = c[a] + 0.5 * step[a];
        tnext[a] = (boundary - p[a]) / l[a];
        tdelta[a] = 1.0 / fabs(l[a]);
    }
    double tlimit = isfinite(tmax) ? tmax / g->h : INFINITY;
    for (;;) {
        if (c[0] < 0 || c[1] < 0 || c[2] < 0 || c[0] >= g->dims[0] || c[1] >= g->dims[1] || c[2] >= g->dims[2])
            return 0; /* left the grid: nothing more can block */
        if (g->inside[ohm_voxel_index(g, c[0], c[1], c[2])]) return 1;
        int a = tnext[0] < tnext[1] ? (tnext[0] < tnext[2] ? 0 : 2) : (tnext[1] < tnext[2] ? 1 : 2);
        if (tnext[a] > tlimit) return 0; /* reached the light */
        c[a] += step[a];
        tnext[a] += tdelta[a];
    }
}

int ohm_embree_occluded(RTCScene scene, const double org[3], const double dir[3], double tmax)
{
    struct RTCRay ray;
    memset(&ray, 0, sizeof ray);
    ray.org_x = (float)org[0];
    ray.org_y = (float)org[1];
    ray.org_z = (float)org[2];
    ray.dir_x = (float)dir[0];
    ray.dir_y = (float)dir[1];
    ray.dir_z = (float)dir[2];
    ray.tnear = 0.0f;
    ray.tfar = isfinite(tmax) ? (float)tmax : INFINITY;
    ray.mask = 0xFFFFFFFFu;
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    rtcOccluded1(scene, &ctx, &ray);
    return ray.tfar < 0.0f; /* Embree sets tfar = -inf on a hit */
}

/* p in grid-index units, as the voxel DDA uses */
static int mesh_occluded(const ohm_occluder *occ, const double p[3], const double l[3], double tmax)
{
    const ohm_voxel_grid *g = occ->grid;
    double org[3];
    for (int a = 0; a < 3; ++a) org[a] = g->origin[a] + g->h * p[a];
    return ohm_embree_occluded(occ->scene, org, l, tmax);
}

double ohm_face_visibility(const ohm_occluder *occ, const int32_t ijk[3], int d, const double l[3], double tmax)
{
    if (!occ) return 1.0;
    int axis = d / 2, ta = (axis + 1) % 3, tb = (axis + 2) % 3;
    int seen = 0;
    for (int q = 0; q < 4; ++q) {
        /* centre of quarter q of the face, in cell units */
        double p[3];
        for (int a = 0; a < 3; ++a) p[a] = ijk[a] + 0.5 * ohm_face_offset[d][a];
        p[ta] += (q & 1) ? 0.25 : -0.25;
        p[tb] += (q & 2) ? 0.25 : -0.25;
        if (grid_occluded(occ->grid, ijk, d, p, l, tmax)) continue;
        if (occ->mode == OHM_SHADOWS_MESH && mesh_occluded(occ, p, l, tmax)) continue;
        ++seen;
    }
    return 0.25 * seen;
}
