/* ohm_vdb.h — a small C API over OpenVDB (the only code that sees OpenVDB).
 *
 * Opaque handles, int status codes (0 ok, negative ohm error code), a caller-
 * owned ohm_error for the message.  Every exported function body runs inside one
 * catch-all (OHM_VDB_TRY in ohm_vdb.cpp), so no C++ exception ever reaches C.
 *
 * Grids are float grids.  Index (i,j,k) is the centre of a cell; its world
 * position (mm) is  origin + (i,j,k) * voxel_size  — the OpenVDB convention.
 * ohm_vdb_write writes exactly the path it is given: the caller (src/base/output.c)
 * gives it a temporary name and renames it once the write succeeded. */
#ifndef OHM_VDB_H
#define OHM_VDB_H

#include <stddef.h>
#include <stdint.h>

#include "base/ohm_error.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ohm_vdb_grid ohm_vdb_grid;

enum ohm_vdb_class {
    OHM_VDB_CLASS_UNKNOWN = 0,
    OHM_VDB_CLASS_LEVEL_SET = 1,
    OHM_VDB_CLASS_FOG_VOLUME = 2
};

/* Process-wide OpenVDB initialisation (registers grid types); idempotent and
 * thread-safe (openvdb::initialize is).  Called by every entry point that
 * needs it, so callers never have to. */
int ohm_vdb_init(ohm_error *err);

/* A new empty float grid with a uniform linear transform. */
int ohm_vdb_grid_create(ohm_vdb_grid **out, const char *name, int grid_class,
                        float background, double voxel_size, const double origin[3],
                        ohm_error *err);
void ohm_vdb_grid_free(ohm_vdb_grid *g); /* NULL is fine */

/* Set n active voxels: ijk holds 3*n coordinates, values n floats. */
int ohm_vdb_grid_set_values(ohm_vdb_grid *g, const int32_t *ijk, const float *values,
                            size_t n, ohm_error *err);

/* Level sets: give inactive voxels inside the narrow band -background
 * (signed flood fill), then prune.  Call after the last set_values. */
int ohm_vdb_grid_finish_level_set(ohm_vdb_grid *g, ohm_error *err);
/* Any grid: prune tiles of equal inactive value. */
int ohm_vdb_grid_prune(ohm_vdb_grid *g, ohm_error *err);

/* Grid metadata. */
int ohm_vdb_grid_set_meta_string(ohm_vdb_grid *g, const char *key, const char *value, ohm_error *err);
int ohm_vdb_grid_set_meta_double(ohm_vdb_grid *g, const char *key, double value, ohm_error *err);
int ohm_vdb_grid_set_meta_int(ohm_vdb_grid *g, const char *key, int64_t value, ohm_error *err);
/* Copies into buf (NUL-terminated, truncated); OHM_ERR_INVALID if absent or
 * not a string. */
int ohm_vdb_grid_get_meta_string(const ohm_vdb_grid *g, const char *key, char *buf, size_t buflen,
                                 ohm_error *err);

/* What a grid is. */
typedef struct ohm_vdb_grid_info {
    char name[256];
    int grid_class;             /* enum ohm_vdb_class                       */
    double voxel_size;          /* world units (mm) per voxel, uniform      */
    double origin[3];           /* world position of index (0,0,0)          */
    int32_t bbox_min[3];        /* active-voxel bounding box, index space   */
    int32_t bbox_max[3];        /* (inclusive); all zero when empty         */
    uint64_t active_voxels;
    float background;
} ohm_vdb_grid_info;
int ohm_vdb_grid_get_info(const ohm_vdb_grid *g, ohm_vdb_grid_info *out, ohm_error *err);

/* Value at one index (active or not). */
int ohm_vdb_grid_get_value(const ohm_vdb_grid *g, const int32_t ijk[3], float *value, ohm_error *err);

/* Call fn for every active voxel, in OpenVDB's iteration order; fn returns 0 to
 * go on, non-zero to stop (that value is then returned). */
typedef int (*ohm_vdb_voxel_fn)(void *user, const int32_t ijk[3], float value);
int ohm_vdb_grid_foreach_active(const ohm_vdb_grid *g, ohm_vdb_voxel_fn fn, void *user, ohm_error *err);

/* Write grids of distinct names to one .vdb file (with blosc/zip
 * compression as OpenVDB chooses); file-level metadata none.  Overwrites
 * `path`; on failure removes what it wrote. */
int ohm_vdb_write(const char *path, ohm_vdb_grid *const *grids, size_t n, ohm_error *err);

/* The same file written one grid at a time, so that only the grid being
 * written need exist: open with the number of grids to come, add each (a
 * grid may be freed once added), close.  Any failure (and an abort, or a
 * close with fewer grids than announced) removes the file; after a failed
 * add, only ohm_vdb_writer_abort. */
typedef struct ohm_vdb_writer ohm_vdb_writer;
int ohm_vdb_writer_open(ohm_vdb_writer **out, const char *path, size_t ngrids, ohm_error *err);
int ohm_vdb_writer_add(ohm_vdb_writer *w, const ohm_vdb_grid *g, ohm_error *err);
int ohm_vdb_writer_close(ohm_vdb_writer *w, ohm_error *err); /* frees w */
void ohm_vdb_writer_abort(ohm_vdb_writer *w);                /* frees w; NULL is fine */

/* Read every float grid of a file.  *out is a malloc'd array of n handles;
 * free each with ohm_vdb_grid_free and the array with free().  A grid that is
 * not a float grid is an error naming it and its type. */
int ohm_vdb_read(ohm_vdb_grid ***out, size_t *n, const char *path, ohm_error *err);

/* OpenVDB's own mesh -> narrow-band level set (meshToLevelSet), on a grid with
 * the given voxel size and origin.  Its sign is NOT reliable for open meshes
 * (it produces hollow shells): ohm uses it only as an independent check. */
int ohm_vdb_mesh_to_level_set(ohm_vdb_grid **out, const double *verts, size_t nverts,
                              const int64_t *tris, size_t ntris, double voxel_size,
                              const double origin[3], float half_width_voxels, ohm_error *err);

#ifdef __cplusplus
}
#endif
#endif
