/* bench_mg_family.c — mg on the held-in family of media
 * (studies/block_medium.h, docs/multigrid.md "Any medium"): per medium and
 * grid, the iterations to the tolerance (deterministic), the levels, the
 * set-up's and the solve's seconds, the agreement with the Cholesky factor where it fits,
 * and the power the books miss.  One Markdown row per medium and size.
 *
 * Not a ctest (it times the set-up): tests/CMakeLists.txt builds it as the
 * bench_mg_family target.
 *
 *   bench_mg_family [media=a,b,...] [direct=N] [tol=T] N...
 *     media:  names of ohm_family_medium_name (default: all of them)
 *     direct: also solve by the factor up to N^3 cells (default 54)
 *     tol:    the relative residual (default 1e-10, solver=mg's) */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "family.h"

static int parse_media(const char *list, int *use)
{
    char buf[256];
    snprintf(buf, sizeof buf, "%s", list);
    memset(use, 0, OHM_FAMILY_COUNT * sizeof *use);
    for (char *save = NULL, *t = strtok_r(buf, ",", &save); t; t = strtok_r(NULL, ",", &save)) {
        int q = ohm_family_medium_of(t);
        if (q < 0) {
            fprintf(stderr, "bench_mg_family: media=%s: unknown medium '%s'\n", list, t);
            return -1;
        }
        use[q] = 1;
    }
    return 0;
}

int main(int argc, char **argv)
{
    int use[OHM_FAMILY_COUNT], direct_max = 54, sizes[16], nsizes = 0;
    double tol = 1e-10;
    for (int q = 0; q < OHM_FAMILY_COUNT; ++q) use[q] = 1;
    for (int i = 1; i < argc; ++i) {
        if (strncmp(argv[i], "media=", 6) == 0) {
            if (parse_media(argv[i] + 6, use)) return 2;
        } else if (strncmp(argv[i], "direct=", 7) == 0) {
            direct_max = atoi(argv[i] + 7);
        } else if (strncmp(argv[i], "tol=", 4) == 0) {
            tol = atof(argv[i] + 4);
        } else {
            int nx = atoi(argv[i]);
            if (nx < 8 || nx > 2000 || nsizes == 16) {
                fprintf(stderr, "bench_mg_family: %s: not a grid size in 8..2000\n", argv[i]);
                return 2;
            }
            sizes[nsizes++] = nx;
        }
    }
    if (nsizes == 0 || !(tol > 0)) {
        fprintf(stderr, "usage: bench_mg_family [media=a,b] [direct=N] [tol=T] N...\n");
        return 2;
    }
    printf("| medium | grid | cells | levels | set-up (s) | solve (s) | set-up's share (%%) | iterations | "
           "relative residual | vs direct (of the peak) | conservation |\n"
           "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    int rc = 0;
    for (int q = 0; q < OHM_FAMILY_COUNT; ++q)
        for (int s = 0; use[q] && s < nsizes; ++s) {
            family_result r;
            ohm_error err;
            ohm_error_clear(&err);
            if (family_solve((ohm_family_medium)q, sizes[s], tol, 0, sizes[s] <= direct_max, &r, &err)) {
                fprintf(stderr, "bench_mg_family: %s at %d^3: %s\n", ohm_family_medium_name(q), sizes[s], err.msg);
                printf("| %s | %d³ | | | | | | failed | | | |\n", ohm_family_medium_name(q), sizes[s]);
                rc = 1;
                continue;
            }
            char direct[32] = "—";
            if (r.vs_direct >= 0) snprintf(direct, sizeof direct, "%.1e", r.vs_direct);
            printf("| %s | %d³ | %.3g | %d | %.2f | %.2f | %.0f | %lld | %.1e | %s | %.1e |\n", ohm_family_medium_name(q),
                   sizes[s], (double)r.n, r.levels, r.t_setup, r.t_solve, 100.0 * r.t_setup / (r.t_setup + r.t_solve),
                   (long long)r.iterations, r.relres, direct, r.conservation);
            fflush(stdout);
        }
    return rc;
}
