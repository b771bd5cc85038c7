/* studies/study.c — `ohm validate | bench | accuracy ARGS`: the studies'
 * own command lines, behind one entry (the public API's ohm_study). */
#include "studies/study.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/output.h"
#include "studies/accuracy.h"
#include "studies/bench.h"
#include "studies/devices.h"
#include "studies/validate.h"

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
        else if (k == 6 && !strncmp(argv[i], "device", k) && !ohm_device_request_parse(&cfg->device, val, NULL))
            continue; /* read once: typed from here on */
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
                            "fresnel=exact|polynomial deposit=exponential|point|surface hybrid=0..1000 "
                            "device=host|gpu|cpu|opencl:N|auto",
                            argv[i]);
    }
    return OHM_OK;
}

/* `ohm validate ...`: the solver against exact references; the table goes
 * to stdout.  `ohm validate figure1 FILE.csv`: the paper's Figure 1 profiles. */
static int validate_main(int argc, char **argv, int verbosity)
{
    ohm_error err;
    ohm_error_clear(&err);
    ohm_log log = {.verbosity = verbosity > 1 ? 1 : 0};
    ohm_validation v;
    memset(&v, 0, sizeof v);
    if (argc > 1 && strcmp(argv[1], "figure1") == 0) {
        if (argc != 3) {
            fprintf(stderr, "ohm: error: usage: ohm validate figure1 FILE.csv\n");
            return 2;
        }
        ohm_output out;
        int frc = ohm_output_begin(&out, argv[2], NULL, &err);
        if (!frc) frc = ohm_paper_figure1(out.stream, &v, &log, &err);
        if (!frc) frc = ohm_output_commit(&out, &err);
        else ohm_output_abort(&out);
        if (frc) return report(frc, &err);
        ohm_validation_print(stdout, &v);
        return 0;
    }
    /* transport: the Monte Carlo reference, then diffusion against it; mc:
     * the reference alone (its published values) */
    int transport = argc > 1 && strcmp(argv[1], "transport") == 0, mc_only = argc > 1 && strcmp(argv[1], "mc") == 0;
    if (transport || mc_only) {
        ohm_transport_config cfg;
        ohm_transport_config_default(&cfg);
        int trc = transport_args(&cfg, argc - 2, argv + 2, &err);
        if (!trc) trc = ohm_validate_mc(&v, cfg.photons, cfg.seed, cfg.threads, cfg.device, &log, &err);
        if (!trc && transport) trc = ohm_validate_transport(&v, &cfg, &log, &err);
        if (trc) return report(trc, &err);
        return ohm_validation_print(stdout, &v) ? 1 : 0;
    }
    if (argc > 1) {
        fprintf(stderr, "ohm: error: usage: ohm validate [figure1 FILE.csv | transport [h=MM] [size=MM] [photons=N] "
                        "[seed=N] [fresnel=exact|polynomial] [deposit=exponential|point|surface] [hybrid=N] "
                        "[device=D] | mc [photons=N] [seed=N] [device=D]]\n");
        return 2;
    }
    int vrc = ohm_validate_all(&v, &log, &err);
    int failed = ohm_validation_print(stdout, &v);
    if (vrc) return report(vrc, &err);
    return failed ? 1 : 0;
}

int ohm_study_main(int argc, char **argv, int verbosity)
{
    if (argc < 1) return 2;
    if (strcmp(argv[0], "bench") == 0) return ohm_bench_main(argc - 1, argv + 1);
    if (strcmp(argv[0], "accuracy") == 0) return ohm_accuracy_main(argc - 1, argv + 1);
    if (strcmp(argv[0], "validate") == 0) return validate_main(argc, argv, verbosity);
    if (strcmp(argv[0], "devices") == 0) return ohm_devices_main(argc - 1, argv + 1);
    fprintf(stderr, "ohm: error: unknown study '%s': expected validate, bench, accuracy or devices\n", argv[0]);
    return 2;
}
