/* scan_check.h — structural checks of a .vdb file before OpenVDB reads it.
 *
 * OpenVDB 10 trusts every size in a .vdb: a string length, a metadata blob, a
 * tile count, a compressed-chunk size.  A 10 KB file can make it allocate
 * gigabytes or loop for minutes (docs/fuzzing.md).  ohm_vdb_check walks the
 * file the way io::File::open + getGrids() will (header, file metadata, grid
 * descriptors, and per grid: metadata, transform, tree topology and leaf
 * buffers), without allocating anything the file declares and without
 * decompressing, and refuses it with one line naming the file and what is
 * wrong if any declared size runs past the bytes that hold it.
 * docs/robustness.md lists what it checks and what stays trusted. */
#ifndef OHM_SCAN_CHECK_H
#define OHM_SCAN_CHECK_H

#include "base/ohm_error.h"

#ifdef __cplusplus
extern "C" {
#endif

/* 0 if `path` is a .vdb OpenVDB 10 can read without trusting a size it has
 * not seen the bytes for, and whose grids are all float grids; otherwise
 * OHM_ERR_PARSE (or OHM_ERR_IO/OHM_ERR_NOMEM) with the reason in err. */
int ohm_vdb_check(const char *path, ohm_error *err);

#ifdef __cplusplus
}
#endif
#endif
