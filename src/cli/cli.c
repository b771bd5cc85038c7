#include "cli/cli.h"

#include <stdio.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ohm_version.h"
#include "studies/accuracy.h"
#include "studies/bench.h"
#include "base/output.h"
#include "steps/pipeline.h"
#include "studies/validate.h"
#include "base/suggest.h"

static int exit_code(int rc) { return rc == OHM_OK ? 0 : rc == OHM_ERR_USAGE ? 2 : 1; }

static int report(int rc, const ohm_error *err)
{
    if (rc) fprintf(stderr, "ohm: error: %s\n", err->msg[0] ? err->msg : "failed");
    return exit_code(rc);
}

/* `ohm validate transport` KEY=VALUE arguments (validate.h). */
static int transport_args(ohm_transport_config *cfg, int argc, char **argv, ohm_error *err)
{
    for (int i = 0; i < argc; ++i) {
        const char *eq = strchr(argv[i], '=');
        char *end = NULL;
        if (!eq) return ohm_fail(err, OHM_ERR_USAGE, "validate transport: '%s': expected KEY=VALUE", argv[i]);
        size_t k = (size_t)(eq - argv[i]);
        const char *val = eq + 1;
        double x = strtod(val, &end);
        int number = end != val && *end == '\0' && isfinite(x);
        if (k == 1 && !strncmp(argv[i], "h", k) && number && x > 0 && x <= 10) cfg->h = x;
        else if (k == 4 && !strncmp(argv[i], "size", k) && number && x >= 4 && x <= 1000) cfg->size = x;
        else if (k == 7 && !strncmp(argv[i], "photons", k) && number && x >= 16 && x <= 1e12) cfg->photons = (int64_t)x;
        else if (k == 4 && !strncmp(argv[i], "seed", k) && number && x >= 0 && x < 9e15) cfg->seed = (uint64_t)x;
        else if (k == 6 && !strncmp(argv[i], "hybrid", k) && number && x >= 0 && x <= 1000 && x == floor(x))
            cfg->hybrid = (int)x;
        else if (k == 7 && !strncmp(argv[i], "fresnel", k) && (!strcmp(val, "exact") || !strcmp(val, "polynomial")))
            cfg->fresnel = strcmp(val, "exact") ? OHM_FRESNEL_POLYNOMIAL : OHM_FRESNEL_EXACT;
        else if (k == 7 && !strncmp(argv[i], "deposit", k) &&
                 (!strcmp(val, "exponential") || !strcmp(val, "point") || !strcmp(val, "surface")))
            cfg->deposit = !strcmp(val, "point")     ? OHM_DEPOSIT_POINT
                           : !strcmp(val, "surface") ? OHM_DEPOSIT_SURFACE
                                                     : OHM_DEPOSIT_EXPONENTIAL;
        else
            return ohm_fail(err, OHM_ERR_USAGE,
                            "validate transport: '%s': expected h=0..10 size=4..1000 photons=16.. seed=N "
                            "fresnel=exact|polynomial deposit=exponential|point|surface hybrid=0..1000",
                            argv[i]);
    }
    return OHM_OK;
}

static int run_chain(const ohm_chain *chain, int verbosity)
{
    ohm_state state;
    ohm_state_init(&state);
    state.log.verbosity = verbosity;
    ohm_error err;
    ohm_error_clear(&err);
    int rc = ohm_chain_run(chain, &state, &err);
    ohm_state_free(&state);
    return report(rc, &err);
}

int ohm_cli_main(int argc, char **argv)
{
    ohm_output_install_signal_cleanup(); /* Ctrl-C leaves no partial output */
    ohm_error err;
    ohm_error_clear(&err);
    int verbosity = 1, first = 1;
    while (first < argc) {
        if (strcmp(argv[first], "--quiet") == 0 || strcmp(argv[first], "-q") == 0) verbosity = 0;
        else if (strcmp(argv[first], "--verbose") == 0 || strcmp(argv[first], "-v") == 0) verbosity = 2;
        else break;
        ++first;
    }
    if (first >= argc) {
        ohm_help_overview(stderr);
        return 2;
    }
    const char *cmd = argv[first];
    if (strcmp(cmd, "help") == 0 || strcmp(cmd, "--help") == 0 || strcmp(cmd, "-h") == 0 ||
        strcmp(cmd, "-help") == 0) {
        if (first + 1 < argc) return report(ohm_help_action(stdout, argv[first + 1], &err), &err);
        ohm_help_overview(stdout);
        return 0;
    }
    if (strcmp(cmd, "--version") == 0 || strcmp(cmd, "version") == 0) {
        printf("ohm %s\n", OHM_VERSION);
        return 0;
    }
    if (strcmp(cmd, "bench") == 0) return ohm_bench_main(argc - first - 1, argv + first + 1);
    if (strcmp(cmd, "accuracy") == 0) return ohm_accuracy_main(argc - first - 1, argv + first + 1);
    if (strcmp(cmd, "validate") == 0) {
        /* the solver against exact references; the table goes to stdout.
         * `ohm validate figure1 FILE.csv`: the paper's Figure 1 profiles. */
        ohm_log log = {.verbosity = verbosity > 1 ? 1 : 0};
        ohm_validation v;
        memset(&v, 0, sizeof v);
        if (first + 1 < argc && strcmp(argv[first + 1], "figure1") == 0) {
            if (first + 3 != argc) {
                fprintf(stderr, "ohm: error: usage: ohm validate figure1 FILE.csv\n");
                return 2;
            }
            ohm_output out;
            int frc = ohm_output_begin(&out, argv[first + 2], &err);
            if (!frc) frc = ohm_paper_figure1(out.stream, &v, &log, &err);
            if (!frc) frc = ohm_output_commit(&out, &err);
            else ohm_output_abort(&out);
            if (frc) return report(frc, &err);
            ohm_validation_print(stdout, &v);
            return 0;
        }
        if (first + 1 < argc && strcmp(argv[first + 1], "transport") == 0) {
            ohm_transport_config cfg;
            ohm_transport_config_default(&cfg);
            int trc = transport_args(&cfg, argc - first - 2, argv + first + 2, &err);
            if (!trc) trc = ohm_validate_mc(&v, cfg.photons, cfg.seed, cfg.threads, &log, &err);
            if (!trc) trc = ohm_validate_transport(&v, &cfg, &log, &err);
            if (trc) return report(trc, &err);
            return ohm_validation_print(stdout, &v) ? 1 : 0;
        }
        if (first + 1 < argc) {
            fprintf(stderr, "ohm: error: usage: ohm validate [figure1 FILE.csv | transport [h=MM] [size=MM] [photons=N] [seed=N] [fresnel=exact|polynomial] [deposit=exponential|point|surface] [hybrid=N]]\n");
            return 2;
        }
        int vrc = ohm_validate_all(&v, &log, &err);
        int failed = ohm_validation_print(stdout, &v);
        if (vrc) return report(vrc, &err);
        return failed ? 1 : 0;
    }
    ohm_chain chain;
    int rc;
    if (strcmp(cmd, "run") == 0) {
        if (first + 2 != argc) {
            fprintf(stderr, "ohm: error: usage: ohm run PIPELINE_FILE\n");
            return 2;
        }
        rc = ohm_chain_parse_file(&chain, argv[first + 1], &err);
    } else if (cmd[0] != '-') {
        const char *cmds[] = {"help", "run", "version", "validate", "bench", "accuracy"};
        const char *s = ohm_suggest(cmd, cmds, 5);
        if (!s && ohm_action_find(cmd)) {
            fprintf(stderr, "ohm: error: unknown command '%s'; actions start with '-': did you mean '-%s'?\n", cmd, cmd);
            return 2;
        }
        if (s) fprintf(stderr, "ohm: error: unknown command '%s'; did you mean '%s'? (see 'ohm help')\n", cmd, s);
        else fprintf(stderr, "ohm: error: unknown command '%s' (see 'ohm help')\n", cmd);
        return 2;
    } else {
        rc = ohm_chain_parse_args(&chain, argc - first, argv + first, &err);
    }
    if (rc) return report(rc, &err);
    rc = run_chain(&chain, verbosity);
    ohm_chain_free(&chain);
    return rc;
}
