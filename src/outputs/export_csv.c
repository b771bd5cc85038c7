/* export_csv.c — see export_csv.h. */
#include "outputs/export_csv.h"

#include <stdlib.h>

#include "base/output.h"

static const char *const channel_name[3] = {"r", "g", "b"};

static void write_header(FILE *f, int channels)
{
    fputs("i,j,k,x_mm,y_mm,z_mm", f);
    for (int q = 0; q < 2; ++q)
        for (int c = 0; c < channels; ++c)
            fprintf(f, ",%s%s%s", q ? "exitance" : "fluence", channels > 1 ? "_" : "", channels > 1 ? channel_name[c] : "");
    fputc('\n', f);
}

int ohm_export_csv(const char *path, const ohm_voxel_grid *grid, const ohm_solution *sol, int frame,
                   ohm_output_batch *batch, ohm_error *err)
{
    size_t n = (size_t)sol->n;
    int channels = sol->channels < 3 ? sol->channels : 3;
    double *exitance[3] = {NULL, NULL, NULL};
    for (int c = 0; c < channels; ++c) {
        exitance[c] = malloc((n ? n : 1) * sizeof(double));
        if (!exitance[c]) {
            for (int q = 0; q < c; ++q) free(exitance[q]);
            return ohm_fail(err, OHM_ERR_NOMEM, "%s: out of memory for the exitance", path);
        }
        ohm_solution_exitance_frame(exitance[c], sol, c, frame);
    }
    ohm_output out;
    int rc = ohm_output_begin(&out, path, batch, err);
    if (!rc) {
        FILE *f = out.stream;
        write_header(f, channels);
        int64_t nx = grid->dims[0], ny = grid->dims[1];
        ohm_cell_cursor cells = ohm_network_cells(&sol->net, 0);
        for (size_t u = 0; u < n; ++u) {
            int64_t cell = ohm_cell_cursor_next(&cells);
            int64_t i = cell % nx, j = (cell / nx) % ny, k = cell / (nx * ny);
            fprintf(f, "%lld,%lld,%lld,%.17g,%.17g,%.17g", (long long)i, (long long)j, (long long)k,
                    grid->origin[0] + grid->h * (double)i, grid->origin[1] + grid->h * (double)j,
                    grid->origin[2] + grid->h * (double)k);
            for (int c = 0; c < channels; ++c) fprintf(f, ",%.17g", sol->fluence[c][(size_t)frame * n + u]);
            for (int c = 0; c < channels; ++c) fprintf(f, ",%.17g", exitance[c][u]);
            fputc('\n', f);
        }
        rc = ohm_output_commit(&out, err);
    }
    for (int c = 0; c < channels; ++c) free(exitance[c]);
    return rc;
}
