/* export_csv.h — the solution cell by cell as text, for numpy, spreadsheets
 * and exact comparisons (-export csv=): one header line, then one line per
 * solved cell in cell order (x fastest): i,j,k (grid index), x,y,z (its
 * centre, mm), then fluence and exitance per channel (W/mm^2), every number
 * with 17 significant digits, so doubles read back exactly.  Written to a
 * temporary file and renamed. */
#ifndef OHM_EXPORT_CSV_H
#define OHM_EXPORT_CSV_H

#include "base/ohm_error.h"
#include "base/output.h"
#include "grid/voxelize.h"
#include "solvers/solve.h"

int ohm_export_csv(const char *path, const ohm_voxel_grid *grid, const ohm_solution *sol, int frame,
                   ohm_output_batch *batch, ohm_error *err);

#endif
