/* opt_spec.h — the key=value options of an action, declared as data.
 *
 * Declared here, below every stage, so that a stage which owns options (the
 * light kinds in physics/light_kind.h) declares them beside the code that
 * reads them; steps/pipeline.h parses and validates every action's options
 * against these declarations and hands them back through an ohm_opt_reader. */
#ifndef OHM_OPT_SPEC_H
#define OHM_OPT_SPEC_H

typedef enum ohm_opt_type {
    OHM_OPT_INT,    /* integer in [min, max]                                */
    OHM_OPT_REAL,   /* finite real in [min, max]                            */
    OHM_OPT_STRING, /* any text (file names)                                */
    OHM_OPT_ENUM,   /* one of choices, "a|b|c"                              */
    OHM_OPT_VEC3,   /* x,y,z finite reals                                   */
    OHM_OPT_REAL13, /* one finite real (grey) or three (r,g,b), each in [min, max] */
    OHM_OPT_DEVICE  /* host, auto, gpu, cpu or opencl:N: checked by its users
                       against device/request.h (a later stage than base) */
} ohm_opt_type;

typedef struct ohm_opt_spec {
    const char *name;
    ohm_opt_type type;
    const char *def;      /* default as text, NULL = none                   */
    const char *doc;
    const char *choices;  /* ENUM: "mm|cm|m|in"                             */
    double min, max;      /* INT, REAL: inclusive range (min == max: none)  */
    int required;
} ohm_opt_spec;

/* Validated option values, read by name (steps/pipeline.h's ohm_opt_*
 * behind it): what a stage below the steps sees of an invocation.  Absent
 * options read as their default (0 / "" when there is none). */
typedef struct ohm_opt_reader {
    const void *ctx;
    const char *where; /* "command line argument 3", for messages */
    int (*given)(const void *ctx, const char *name);
    const char *(*str)(const void *ctx, const char *name);
    long long (*integer)(const void *ctx, const char *name);
    double (*real)(const void *ctx, const char *name);
    void (*vec3)(const void *ctx, const char *name, double out[3]);
    int (*real13)(const void *ctx, const char *name, double out[3]); /* 1 or 3 values */
} ohm_opt_reader;

#endif
