/* api_header.c — include/ohm.h compiles alone, as C11 and (api_header.cpp)
 * as C++, with -Wall -Wextra -pedantic -Werror, and so does ohm/cli.h; the
 * version macros are the library's, and the sized structs' *_INIT
 * initialisers compile without a warning in both languages. */
#include "ohm.h"
#include "ohm/cli.h"

#ifndef OHM_HEADER_LANGUAGE
#define OHM_HEADER_LANGUAGE "C11"
#endif

#include <stdio.h>
#include <string.h>

int main(void)
{
    char header[32];
    snprintf(header, sizeof header, "%d.%d.%d", OHM_VERSION_MAJOR, OHM_VERSION_MINOR, OHM_VERSION_PATCH);
    const char *lib = ohm_version(NULL, NULL, NULL);
    if (strcmp(lib, header) != 0) {
        fprintf(stderr, "api_header: header %s, library %s\n", header, lib);
        return 1;
    }
    ohm_context *ctx = NULL;
    if (ohm_context_new(&ctx) != OHM_OK) return 1;
    ohm_context_free(ctx);
    ohm_grid_info grid = OHM_GRID_INFO_INIT;
    ohm_result_info result = OHM_RESULT_INFO_INIT;
    if (grid.size != sizeof grid || result.size != sizeof result) return 1;
    printf("api_header: ohm %s, as %s\n", lib, OHM_HEADER_LANGUAGE);
    return 0;
}
