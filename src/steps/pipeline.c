/* pipeline.c — parse, validate, document and run chains of actions. */
#include "steps/pipeline.h"
#include "base/suggest.h"
#include "device/request.h"

#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#define PIPELINE_MAGIC "ohm-pipeline"
#define PIPELINE_VERSION 1
/* A pipeline file is a short text; refuse anything that is clearly not one. */
#define PIPELINE_MAX_BYTES (4u << 20)

/* ---- lookup and suggestions ---------------------------------------------- */

const ohm_action *ohm_action_find(const char *name)
{
    for (const ohm_action *a = ohm_actions; a->name; ++a)
        if (strcmp(a->name, name) == 0) return a;
    return NULL;
}

static const char *suggest_action(const char *word)
{
    const char *names[64];
    size_t n = 0;
    for (const ohm_action *a = ohm_actions; a->name && n < 64; ++a) names[n++] = a->name;
    return ohm_suggest(word, names, n);
}

/* ---- value validation ------------------------------------------------------ */

/* OHM_OPT_DEVICE's words (device/request.h), which base/options.h cannot know */
static int check_device(const ohm_opt_spec *o, const char *v, const char *prefix, ohm_error *err)
{
    const char *expected = o->type == OHM_OPT_DEVICE ? ohm_device_request_expected(v) : NULL;
    return expected ? ohm_fail(err, OHM_ERR_USAGE, "%s %s=%s: %s", prefix, o->name, v, expected) : OHM_OK;
}

/* ---- building chains ------------------------------------------------------- */

void ohm_chain_free(ohm_chain *c)
{
    if (!c) return;
    for (size_t i = 0; i < c->n; ++i)
        ohm_opt_values_free(&c->items[i].opts);
    free(c->items);
    memset(c, 0, sizeof *c);
}

static int begin_action(ohm_chain *c, const char *name, const char *where, ohm_error *err)
{
    const ohm_action *a = ohm_action_find(name);
    if (!a) {
        const char *s = suggest_action(name);
        if (s)
            return ohm_fail(err, OHM_ERR_USAGE, "%s: unknown action '-%s'; did you mean '-%s'? (see 'ohm help')",
                            where, name, s);
        return ohm_fail(err, OHM_ERR_USAGE, "%s: unknown action '-%s' (see 'ohm help' for the list)", where, name);
    }
    if (c->n == c->cap) {
        size_t cap = c->cap ? 2 * c->cap : 8;
        ohm_invocation *items = realloc(c->items, cap * sizeof *items);
        if (!items) return ohm_fail(err, OHM_ERR_NOMEM, "out of memory");
        c->items = items;
        c->cap = cap;
    }
    ohm_invocation *inv = &c->items[c->n++];
    memset(inv, 0, sizeof *inv);
    inv->action = a;
    inv->opts.specs = a->opts;
    snprintf(inv->where, sizeof inv->where, "%s", where);
    return OHM_OK;
}

static int add_option(ohm_chain *c, const char *token, const char *where, ohm_error *err)
{
    ohm_invocation *inv = &c->items[c->n - 1];
    char prefix[sizeof inv->where + 80], see[96];
    snprintf(prefix, sizeof prefix, "%.255s: -%s", where, inv->action->name);
    snprintf(see, sizeof see, "(see 'ohm help %s')", inv->action->name);
    return ohm_opt_word(&inv->opts, token, prefix, see, check_device, err);
}

static int finish_action(const ohm_chain *c, ohm_error *err)
{
    if (c->n == 0) return OHM_OK;
    const ohm_invocation *inv = &c->items[c->n - 1];
    const ohm_action *a = inv->action;
    for (int i = 0; a->opts[i].name; ++i)
        if (a->opts[i].required && !inv->opts.values[i])
            return ohm_fail(err, OHM_ERR_USAGE, "%s: -%s needs %s= (%s)", inv->where, a->name, a->opts[i].name,
                            a->opts[i].doc);
    return a->check ? a->check(inv, err) : OHM_OK;
}

/* A first word that is no action: a misspelled command of `ohm`, or an
 * action without its '-'. */
static int not_an_action(const char *t, ohm_error *err)
{
    static const char *const commands[] = {"help", "run", "version", "validate", "bench", "accuracy", "devices"};
    if (ohm_action_find(t))
        return ohm_fail(err, OHM_ERR_USAGE, "unknown command '%s'; actions start with '-': did you mean '-%s'?", t, t);
    const char *s = ohm_suggest(t, commands, sizeof commands / sizeof *commands);
    if (s) return ohm_fail(err, OHM_ERR_USAGE, "unknown command '%s'; did you mean '%s'? (see 'ohm help')", t, s);
    return ohm_fail(err, OHM_ERR_USAGE, "unknown command '%s' (see 'ohm help')", t);
}

int ohm_chain_parse_args(ohm_chain *c, int argc, const char *const *argv, ohm_error *err)
{
    memset(c, 0, sizeof *c);
    if (argc > 0 && argv[0][0] != '-') return not_an_action(argv[0], err);
    for (int i = 0; i < argc; ++i) {
        char where[64];
        snprintf(where, sizeof where, "argument %d", i + 1);
        const char *t = argv[i];
        int rc;
        if (t[0] == '-' && t[1] && !strchr(t, '=')) {
            rc = finish_action(c, err);
            if (!rc) rc = begin_action(c, t + (t[1] == '-' ? 2 : 1), where, err);
        } else if (c->n == 0) {
            rc = ohm_fail(err, OHM_ERR_USAGE, "%s: '%s' comes before any action; actions start with '-' (see 'ohm help')",
                          where, t);
        } else {
            rc = add_option(c, t, where, err);
        }
        if (rc) {
            ohm_chain_free(c);
            return rc;
        }
    }
    int rc = finish_action(c, err);
    if (!rc && c->n == 0) rc = ohm_fail(err, OHM_ERR_USAGE, "no actions given (see 'ohm help')");
    if (rc) ohm_chain_free(c);
    return rc;
}

int ohm_invocation_parse(ohm_invocation *inv, const ohm_action *a, int argc, const char *const *argv, ohm_error *err)
{
    memset(inv, 0, sizeof *inv);
    inv->action = a;
    inv->opts.specs = a->opts;
    snprintf(inv->where, sizeof inv->where, "%s", a->name);
    ohm_chain one = {inv, 1, 1};
    int rc = OHM_OK;
    for (int i = 0; i < argc && !rc; ++i) {
        snprintf(inv->where, sizeof inv->where, "argument %d", i + 1);
        rc = add_option(&one, argv[i], inv->where, err);
    }
    if (!rc) rc = finish_action(&one, err);
    if (rc) ohm_invocation_free(inv);
    return rc;
}

void ohm_invocation_free(ohm_invocation *inv)
{
    ohm_opt_values_free(&inv->opts);
}

/* Split one line into tokens: whitespace-separated, "double quotes" group
 * (key="a b" -> key=a b), '#' outside quotes ends the line. */
static int tokenize(char *line, char **tokens, int max_tokens, int *ntokens, const char *where, ohm_error *err)
{
    int n = 0;
    char *r = line, *w = line;
    while (*r) {
        while (*r == ' ' || *r == '\t') ++r;
        if (!*r || *r == '#') break;
        if (n == max_tokens) return ohm_fail(err, OHM_ERR_USAGE, "%s: too many words on one line", where);
        tokens[n++] = w;
        int quoted = 0;
        while (*r && (quoted || (*r != ' ' && *r != '\t' && *r != '#'))) {
            if (*r == '"') {
                quoted = !quoted;
                ++r;
                continue;
            }
            *w++ = *r++;
        }
        if (quoted) return ohm_fail(err, OHM_ERR_USAGE, "%s: unterminated \"quote\"", where);
        char *next = r;
        if (*r == ' ' || *r == '\t') next = r + 1;
        *w = '\0';
        w = r = next;
        if (*r == '#') break;
    }
    *ntokens = n;
    return OHM_OK;
}

int ohm_chain_parse_text(ohm_chain *c, const char *text, size_t len, const char *name, ohm_error *err)
{
    memset(c, 0, sizeof *c);
    size_t lineno = 0, pos = 0;
    int header_seen = 0, rc = OHM_OK;
    char line[4096];
    while (pos < len && !rc) {
        size_t end = pos;
        while (end < len && text[end] != '\n') ++end;
        ++lineno;
        size_t l = end - pos;
        if (l && text[pos + l - 1] == '\r') --l;
        char where[OHM_PATH_MAX + 32];
        snprintf(where, sizeof where, "%s:%zu", name, lineno);
        if (l >= sizeof line) {
            rc = ohm_fail(err, OHM_ERR_USAGE, "%s: line is longer than %zu characters", where, sizeof line - 1);
            break;
        }
        memcpy(line, text + pos, l);
        line[l] = '\0';
        pos = end + 1;
        if (memchr(line, '\0', l)) {
            rc = ohm_fail(err, OHM_ERR_USAGE, "%s: NUL byte: this is not a text pipeline file", where);
            break;
        }
        char *tokens[64];
        int nt = 0;
        rc = tokenize(line, tokens, 64, &nt, where, err);
        if (rc || nt == 0) continue;
        if (!header_seen) {
            long v = 0;
            if (strcmp(tokens[0], PIPELINE_MAGIC) != 0 || nt != 2 || (v = strtol(tokens[1], NULL, 10)) < 1) {
                rc = ohm_fail(err, OHM_ERR_USAGE, "%s: expected the header line '%s %d'", where, PIPELINE_MAGIC,
                              PIPELINE_VERSION);
            } else if (v > PIPELINE_VERSION) {
                rc = ohm_fail(err, OHM_ERR_USAGE, "%s: pipeline format version %ld is newer than this ohm reads (%d)",
                              where, v, PIPELINE_VERSION);
            }
            header_seen = 1;
            continue;
        }
        rc = finish_action(c, err);
        const char *an = tokens[0][0] == '-' ? tokens[0] + 1 : tokens[0];
        if (!rc) rc = begin_action(c, an, where, err);
        for (int i = 1; i < nt && !rc; ++i) rc = add_option(c, tokens[i], where, err);
    }
    if (!rc) rc = finish_action(c, err);
    if (!rc && !header_seen)
        rc = ohm_fail(err, OHM_ERR_USAGE, "%s: empty: expected the header line '%s %d' and actions", name,
                      PIPELINE_MAGIC, PIPELINE_VERSION);
    if (!rc && c->n == 0) rc = ohm_fail(err, OHM_ERR_USAGE, "%s: no actions after the header", name);
    if (rc) ohm_chain_free(c);
    return rc;
}

int ohm_chain_parse_file(ohm_chain *c, const char *path, ohm_error *err)
{
    memset(c, 0, sizeof *c);
    struct stat st;
    if (stat(path, &st) != 0) return ohm_fail(err, OHM_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    if (S_ISDIR(st.st_mode)) return ohm_fail(err, OHM_ERR_IO, "%s: is a directory, expected a pipeline file", path);
    if (!S_ISREG(st.st_mode)) return ohm_fail(err, OHM_ERR_IO, "%s: not a regular file, expected a pipeline file", path);
    if ((unsigned long long)st.st_size > PIPELINE_MAX_BYTES)
        return ohm_fail(err, OHM_ERR_USAGE, "%s: %lld bytes is too large for a pipeline file", path,
                        (long long)st.st_size);
    FILE *f = fopen(path, "rb");
    if (!f) return ohm_fail(err, OHM_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    char *buf = malloc((size_t)st.st_size + 1);
    if (!buf) {
        fclose(f);
        return ohm_fail(err, OHM_ERR_NOMEM, "out of memory");
    }
    size_t got = fread(buf, 1, (size_t)st.st_size, f);
    int read_err = ferror(f);
    fclose(f);
    if (read_err) {
        free(buf);
        return ohm_fail(err, OHM_ERR_IO, "%s: read error", path);
    }
    int rc = ohm_chain_parse_text(c, buf, got, path, err);
    free(buf);
    return rc;
}

/* ---- option access ------------------------------------------------------------ */

int ohm_opt_given(const ohm_invocation *inv, const char *name) { return ohm_opt_values_given(&inv->opts, name); }

const char *ohm_opt_str(const ohm_invocation *inv, const char *name)
{
    const char *v = ohm_opt_text(&inv->opts, name);
    return v ? v : "";
}

long long ohm_opt_int(const ohm_invocation *inv, const char *name)
{
    const char *v = ohm_opt_text(&inv->opts, name);
    long long x = 0;
    if (v) ohm_opt_parse_int(v, &x);
    return x;
}

double ohm_opt_real(const ohm_invocation *inv, const char *name)
{
    const char *v = ohm_opt_text(&inv->opts, name);
    double x = 0;
    if (v) ohm_opt_parse_real(v, &x);
    return x;
}

void ohm_opt_vec3(const ohm_invocation *inv, const char *name, double out[3])
{
    const char *v = ohm_opt_text(&inv->opts, name);
    out[0] = out[1] = out[2] = 0;
    if (v) ohm_opt_parse_vec3(v, out);
}

int ohm_opt_real13(const ohm_invocation *inv, const char *name, double out[3])
{
    const char *v = ohm_opt_text(&inv->opts, name);
    out[0] = out[1] = out[2] = 0;
    return v ? ohm_opt_parse_real13(v, out) : 0;
}

/* ohm_opt_reader's functions: the ohm_opt_* above, on the invocation ctx */
static int reader_given(const void *ctx, const char *name) { return ohm_opt_given(ctx, name); }
static const char *reader_str(const void *ctx, const char *name) { return ohm_opt_str(ctx, name); }
static long long reader_int(const void *ctx, const char *name) { return ohm_opt_int(ctx, name); }
static double reader_real(const void *ctx, const char *name) { return ohm_opt_real(ctx, name); }
static void reader_vec3(const void *ctx, const char *name, double out[3]) { ohm_opt_vec3(ctx, name, out); }
static int reader_real13(const void *ctx, const char *name, double out[3]) { return ohm_opt_real13(ctx, name, out); }

ohm_opt_reader ohm_opt_reader_of(const ohm_invocation *inv)
{
    ohm_opt_reader r = {inv, inv->where, reader_given, reader_str, reader_int, reader_real, reader_vec3, reader_real13};
    return r;
}

/* ---- running ------------------------------------------------------------------- */

/* Whether a step reads a file the run has staged but not yet renamed into
 * place (a -read of what an earlier -write wrote): any option value of a step
 * that does not itself write, equal to a staged path. */
static int reads_staged(const ohm_invocation *inv, const ohm_output_batch *b)
{
    if (inv->action->flags & OHM_ACTION_WRITES) return 0;
    for (int k = 0; k < OHM_MAX_OPTS; ++k)
        if (inv->opts.values[k] && ohm_output_batch_holds(b, inv->opts.values[k])) return 1;
    return 0;
}

static int run_step(const ohm_invocation *inv, ohm_state *s, ohm_error *err)
{
    if (reads_staged(inv, s->outputs)) { /* it must find the file on disk: the run's outputs so far go first */
        ohm_log_info(&s->log, "%s: reads a file this run wrote: its outputs so far are put in place first",
                     inv->where);
        int rc = ohm_output_batch_commit(s->outputs, &s->log, err);
        if (rc) return rc;
    }
    if (ohm_log_cancelled(&s->log))
        return ohm_fail(err, OHM_ERR_CANCELLED, "%s: -%s: cancelled before it began", inv->where, inv->action->name);
    int rc = inv->action->run(s, inv, err);
    if (rc == OHM_ERR_CANCELLED) { /* the step's own words, and where it stood */
        char said[sizeof err->msg];
        snprintf(said, sizeof said, "%s", err->msg);
        ohm_fail(err, rc, "%s: -%s: %s", inv->where, inv->action->name, said);
    }
    return rc;
}

/* Whether step i waits for the scene: it runs once the scene steps right
 * after it have, so that the natural order "read, voxelize error=,
 * material, light, solve" works as the user wrote it. */
static int step_waits(const ohm_chain *c, size_t i)
{
    const ohm_invocation *inv = &c->items[i];
    return inv->action->waits && inv->action->waits(inv) && i + 1 < c->n &&
           (c->items[i + 1].action->flags & OHM_ACTION_SETS_SCENE);
}

/* The order the steps run in, c->n indices into order[]: as written,
 * except that a step that waits moves after the scene steps that follow it
 * (ohm_chain_check follows the same order). */
static void run_order(const ohm_chain *c, size_t *order)
{
    size_t k = 0, waiting = SIZE_MAX;
    for (size_t i = 0; i < c->n; ++i) {
        if (waiting != SIZE_MAX && !(c->items[i].action->flags & OHM_ACTION_SETS_SCENE)) {
            order[k++] = waiting;
            waiting = SIZE_MAX;
        }
        if (waiting == SIZE_MAX && step_waits(c, i)) waiting = i;
        else order[k++] = i;
    }
    if (waiting != SIZE_MAX) order[k++] = waiting;
}

static int run_steps(const ohm_chain *c, const size_t *order, ohm_state *s, ohm_error *err)
{
    for (size_t k = 0; k < c->n; ++k) {
        const ohm_invocation *inv = &c->items[order[k]];
        if (step_waits(c, order[k]))
            ohm_log_info(&s->log, "%s: -%s runs after the -material and -light steps that follow it", inv->where,
                         inv->action->name);
        int rc = run_step(inv, s, err);
        if (rc) return rc;
    }
    return OHM_OK;
}

/* ---- what each step needs from the ones before it ----------------------------- */

static const char *const resource_names[OHM_RES_COUNT] = {"a mesh",     "a volume", "a voxel object", "a material",
                                                          "a transfer", "lights",   "a solution"};

/* Who made each resource, as the check walks the chain: the step's index,
 * HELD (the state the chain starts on) or NONE; and who removed it. */
enum { NONE = -1, HELD = -2 };

typedef struct chain_walk {
    const ohm_chain *c;
    int made_by[OHM_RES_COUNT];
    int dropped_by[OHM_RES_COUNT], dropped_from[OHM_RES_COUNT];
} chain_walk;

static unsigned held_resources(const ohm_state *s)
{
    return (s->have_mesh ? OHM_RES_MESH : 0u) | (s->have_scan ? OHM_RES_VOLUME : 0u) |
           (s->have_grid ? OHM_RES_GRID : 0u) | (s->have_material ? OHM_RES_MATERIAL : 0u) |
           (s->have_transfer ? OHM_RES_TRANSFER : 0u) | (s->nlights ? OHM_RES_LIGHTS : 0u) |
           (ohm_state_solution(s) ? OHM_RES_SOLUTION : 0u);
}

static int present(const chain_walk *w, unsigned mask)
{
    for (int r = 0; r < OHM_RES_COUNT; ++r)
        if ((mask >> r & 1u) && w->made_by[r] != NONE) return 1;
    return 0;
}

static int all_present(const chain_walk *w, unsigned mask)
{
    for (int r = 0; r < OHM_RES_COUNT; ++r)
        if ((mask >> r & 1u) && w->made_by[r] == NONE) return 0;
    return 1;
}

/* "-solve at argument 7", or "the scene" for what the state held */
static void step_name(char *buf, size_t size, const chain_walk *w, int step)
{
    if (step < 0) snprintf(buf, size, "the scene it starts on");
    else snprintf(buf, size, "-%s at %s", w->c->items[step].action->name, w->c->items[step].where);
}

/* The need's failure: the step's own message, and the earlier step that
 * removed what it needs, or that gave something else instead. */
static int unmet(const chain_walk *w, const ohm_invocation *inv, const ohm_need *need, ohm_error *err)
{
    char other[800] = "", by[320], from[320]; /* a step's name holds its `where` (256) */
    for (int r = 0; r < OHM_RES_COUNT && !other[0]; ++r) {
        if (!(need->any >> r & 1u) || w->dropped_by[r] == NONE) continue;
        step_name(by, sizeof by, w, w->dropped_by[r]);
        step_name(from, sizeof from, w, w->dropped_from[r]);
        snprintf(other, sizeof other, " (%s comes after %s and replaces or invalidates %s it made)", by, from,
                 resource_names[r]);
    }
    /* a mesh wanted where the chain has a volume, or the other way round */
    unsigned instead = (need->any & OHM_RES_MESH ? OHM_RES_VOLUME : 0u) | (need->any & OHM_RES_VOLUME ? OHM_RES_MESH : 0u);
    for (int r = 0; r < OHM_RES_COUNT && !other[0]; ++r) {
        if (!(instead >> r & 1u) || w->made_by[r] == NONE) continue;
        step_name(by, sizeof by, w, w->made_by[r]);
        snprintf(other, sizeof other, " (%s gave %s instead)", by, resource_names[r]);
    }
    return ohm_fail(err, OHM_ERR_USAGE, "%s: -%s: %s%s; nothing was run", inv->where, inv->action->name, need->missing,
                    other);
}

/* Every step's needs (ohm_step_io) met by the state s starts the chain
 * with and the steps that run before it, in the order ohm_chain_run runs
 * them; else OHM_ERR_USAGE with one line naming the step, what it lacks,
 * and the earlier step that removed it or gave something else instead.
 * Runs nothing.  ohm_chain_run calls it first. */
static int ohm_chain_check(const ohm_chain *c, const ohm_state *s, ohm_error *err)
{
    size_t *order = malloc((c->n ? c->n : 1) * sizeof *order);
    if (!order) return ohm_fail(err, OHM_ERR_NOMEM, "out of memory");
    run_order(c, order);
    chain_walk w = {.c = c};
    unsigned held = held_resources(s);
    for (int r = 0; r < OHM_RES_COUNT; ++r) {
        w.made_by[r] = held >> r & 1u ? HELD : NONE;
        w.dropped_by[r] = w.dropped_from[r] = NONE;
    }
    int rc = OHM_OK;
    for (size_t k = 0; k < c->n && !rc; ++k) {
        const ohm_invocation *inv = &c->items[order[k]];
        if (!inv->action->io) continue;
        ohm_step_io io;
        memset(&io, 0, sizeof io);
        inv->action->io(inv, &io);
        for (int i = 0; i < OHM_MAX_NEEDS && io.needs[i].any && !rc; ++i)
            if (all_present(&w, io.needs[i].when) && !present(&w, io.needs[i].any))
                rc = unmet(&w, inv, &io.needs[i], err);
        for (int r = 0; r < OHM_RES_COUNT; ++r) {
            if ((io.drops >> r & 1u) && w.made_by[r] != NONE) {
                w.dropped_by[r] = (int)order[k];
                w.dropped_from[r] = w.made_by[r];
                w.made_by[r] = NONE;
            }
            if (io.provides >> r & 1u) {
                w.made_by[r] = (int)order[k];
                w.dropped_by[r] = w.dropped_from[r] = NONE;
            }
        }
    }
    free(order);
    return rc;
}

int ohm_chain_run(const ohm_chain *c, ohm_state *s, ohm_error *err)
{
    int rc = ohm_chain_check(c, s, err);
    if (rc) return rc;
    size_t *order = malloc((c->n ? c->n : 1) * sizeof *order);
    if (!order) return ohm_fail(err, OHM_ERR_NOMEM, "out of memory");
    run_order(c, order);
    if (s->outputs) { /* inside a run: part of it */
        rc = run_steps(c, order, s, err);
        free(order);
        return rc;
    }
    ohm_output_batch batch = {0};
    s->outputs = &batch;
    rc = run_steps(c, order, s, err);
    free(order);
    s->outputs = NULL;
    if (rc) {
        ohm_output_batch_abort(&batch);
        return rc;
    }
    return ohm_output_batch_commit(&batch, &s->log, err);
}

/* ---- help ---------------------------------------------------------------------- */

static const char *type_name(const ohm_opt_spec *o)
{
    switch (o->type) {
    case OHM_OPT_INT: return "integer";
    case OHM_OPT_REAL: return "number";
    case OHM_OPT_STRING: return "text";
    case OHM_OPT_ENUM: return o->choices;
    case OHM_OPT_VEC3: return "x,y,z";
    case OHM_OPT_REAL13: return "v|r,g,b";
    case OHM_OPT_DEVICE: return "host|auto|gpu|cpu|opencl:N";
    }
    return "";
}

void ohm_help_overview(FILE *f)
{
    fputs("ohm — subsurface light scattering in voxel volumes\n\n"
          "usage:\n"
          "  ohm [--quiet|--verbose] -ACTION key=value ... -ACTION key=value ...\n"
          "  ohm run PIPELINE_FILE        the same actions, one per line, after 'ohm-pipeline 1'\n"
          "  ohm help [ACTION]            this overview, or one action's options\n"
          "  ohm validate                 the solver against exact references: a table, exit 1 on failure\n"
          "  ohm validate transport|mc    diffusion against Monte Carlo transport, or the tracer against\n"
          "                               published values (photons= seed= device=)\n"
          "  ohm bench [key=value ...]    the paper's Table 2 for a mesh, with this machine's limits (bench help)\n"
          "  ohm accuracy [key=value ...] error against resolution and solver, measured (accuracy help)\n"
          "  ohm devices                  the OpenCL devices (device=opencl:N), each one's kernels tested\n"
          "  ohm --version\n\n"
          "Actions run left to right on one shared state (mesh, voxel grid, ...).\n\n"
          "actions:\n",
          f);
    for (const ohm_action *a = ohm_actions; a->name; ++a) fprintf(f, "  -%-12s %s\n", a->name, a->summary);
    fputs("\nexample:\n"
          "  ohm -read file=samples/spot.obj size=50 -voxelize dim=64 -write file=spot.vdb -stats file=spot.json\n\n"
          "Logs and progress go to stderr.  Exit codes: 0 ok, 1 the run failed, 2 usage error.\n",
          f);
}

int ohm_help_action(FILE *f, const char *name, ohm_error *err)
{
    const char *n = name[0] == '-' ? name + 1 : name;
    const ohm_action *a = ohm_action_find(n);
    if (!a) {
        const char *s = suggest_action(n);
        if (s) return ohm_fail(err, OHM_ERR_USAGE, "help: unknown action '%s'; did you mean '%s'?", n, s);
        return ohm_fail(err, OHM_ERR_USAGE, "help: unknown action '%s' (see 'ohm help')", n);
    }
    fprintf(f, "-%s: %s\n\n", a->name, a->summary);
    if (a->doc) fprintf(f, "%s\n\n", a->doc);
    fputs("options:\n", f);
    if (!a->opts[0].name) fputs("  (none)\n", f);
    for (int i = 0; a->opts[i].name; ++i) {
        const ohm_opt_spec *o = &a->opts[i];
        char left[96];
        snprintf(left, sizeof left, "%s=<%s>", o->name, type_name(o));
        fprintf(f, "  %-28s %s", left, o->doc);
        if (o->required) fputs(" (required)", f);
        else if (o->def) fprintf(f, " (default %s)", o->def);
        if ((o->type == OHM_OPT_INT || o->type == OHM_OPT_REAL || o->type == OHM_OPT_REAL13) && o->min != o->max)
            fprintf(f, " [%g .. %g]", o->min, o->max);
        fputc('\n', f);
    }
    return OHM_OK;
}
