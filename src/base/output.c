#include "base/output.h"

#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdatomic.h>
#include <time.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* The temporaries in flight, for the signal handler (see output.h): the
 * names themselves live in each ohm_output or staged batch entry until they
 * are renamed or removed; the table only points at them.  A chain stages
 * one file per output (an orbit's frames each), so the table is sized for
 * long sequences. */
enum { IN_FLIGHT_MAX = 4096 };
/* Process-wide, as signals are: each slot is claimed and released with an
 * atomic compare-and-swap, so scenes writing on several threads never lose
 * or share a slot, and the handler reads each slot in one lock-free load. */
static _Atomic(const char *) in_flight[IN_FLIGHT_MAX];

static void in_flight_add(const char *tmp)
{
    for (int i = 0; i < IN_FLIGHT_MAX; ++i) {
        const char *none = NULL;
        if (atomic_compare_exchange_strong(&in_flight[i], &none, tmp)) return;
    }
}

static void in_flight_remove(const char *tmp)
{
    for (int i = 0; i < IN_FLIGHT_MAX; ++i) {
        const char *mine = tmp;
        atomic_compare_exchange_strong(&in_flight[i], &mine, NULL);
    }
}

static void cleanup_and_die(int sig)
{
    for (int i = 0; i < IN_FLIGHT_MAX; ++i) {
        const char *tmp = atomic_load(&in_flight[i]);
        if (tmp) unlink(tmp); /* async-signal-safe */
    }
    signal(sig, SIG_DFL);
    raise(sig);
}

void ohm_output_install_signal_cleanup(void)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = cleanup_and_die;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGHUP, &sa, NULL);
}

int ohm_output_begin(ohm_output *o, const char *path, ohm_output_batch *batch, ohm_error *err)
{
    memset(o, 0, sizeof *o);
    o->batch = batch;
    if (!path || !*path) return ohm_fail(err, OHM_ERR_USAGE, "no output file name given");
    size_t len = strlen(path);
    if (len + 16 >= sizeof o->path) return ohm_fail(err, OHM_ERR_IO, "%s: path is too long", path);
    memcpy(o->path, path, len + 1);

    struct stat st;
    if (stat(path, &st) == 0 && S_ISDIR(st.st_mode))
        return ohm_fail(err, OHM_ERR_IO, "%s: is a directory, expected a file name to write", path);

    /* Temporary name: "<dir>/.<base>.ohm-XXXXXX", hidden, same filesystem. */
    const char *slash = strrchr(path, '/');
    size_t dirlen = slash ? (size_t)(slash - path) + 1 : 0;
    const char *base = path + dirlen;
    int n = snprintf(o->tmp, sizeof o->tmp, "%.*s.%s.ohm-XXXXXX", (int)dirlen, path, base);
    if (n < 0 || (size_t)n >= sizeof o->tmp) return ohm_fail(err, OHM_ERR_IO, "%s: path is too long", path);
    int fd = mkstemp(o->tmp);
    if (fd < 0) {
        int e = errno;
        o->tmp[0] = '\0';
        return ohm_fail(err, OHM_ERR_IO, "cannot write '%s': %s", path, strerror(e));
    }
    /* mkstemp makes 0600; outputs are ordinary files: honour the umask. */
    mode_t um = umask(0);
    umask(um);
    (void)fchmod(fd, 0666 & ~um);
    in_flight_add(o->tmp);
    o->stream = fdopen(fd, "wb");
    if (!o->stream) {
        int e = errno;
        close(fd);
        unlink(o->tmp);
        in_flight_remove(o->tmp);
        o->tmp[0] = '\0';
        return ohm_fail(err, OHM_ERR_IO, "cannot write '%s': %s", path, strerror(e));
    }
    return OHM_OK;
}

const char *ohm_output_tmp_path(ohm_output *o)
{
    if (o->stream) {
        fclose(o->stream);
        o->stream = NULL;
    }
    return o->tmp;
}

/* Test hook (output.h): OHM_TEST_COMMIT_DELAY_MS before each rename, in
 * builds for the test suite only (CMake's OHM_TEST_HOOKS). */
static void test_delay(void)
{
#ifdef OHM_TEST_HOOKS
    const char *delay = getenv("OHM_TEST_COMMIT_DELAY_MS");
    long ms = delay ? strtol(delay, NULL, 10) : 0;
    struct timespec ts = {ms / 1000, (ms % 1000) * 1000000L};
    if (ms > 0) nanosleep(&ts, NULL);
#endif
}

static void staged_free(ohm_staged_output *it)
{
    in_flight_remove(it->tmp);
    free(it->path);
    free(it->tmp);
    it->path = it->tmp = NULL;
}

/* The complete temporary handed to the batch (ohm_output_commit). */
static int stage(ohm_output *o, ohm_error *err)
{
    ohm_output_batch *b = o->batch;
    for (size_t i = 0; i < b->n; ++i) /* written twice in one run: the later file wins */
        if (strcmp(b->items[i].path, o->path) == 0) {
            unlink(b->items[i].tmp);
            staged_free(&b->items[i]);
            memmove(b->items + i, b->items + i + 1, (b->n - i - 1) * sizeof *b->items);
            --b->n;
            break;
        }
    if (b->n == b->cap) {
        size_t cap = b->cap ? 2 * b->cap : 8;
        ohm_staged_output *grown = realloc(b->items, cap * sizeof *grown);
        if (!grown) {
            ohm_output_abort(o);
            return ohm_fail(err, OHM_ERR_NOMEM, "cannot write '%s': out of memory", o->path);
        }
        b->items = grown;
        b->cap = cap;
    }
    ohm_staged_output *it = &b->items[b->n];
    it->path = strdup(o->path);
    it->tmp = strdup(o->tmp);
    if (!it->path || !it->tmp) {
        free(it->path);
        free(it->tmp);
        ohm_output_abort(o);
        return ohm_fail(err, OHM_ERR_NOMEM, "cannot write '%s': out of memory", o->path);
    }
    in_flight_add(it->tmp); /* the table now points at the batch's copy (added first: never unlisted) */
    in_flight_remove(o->tmp);
    ++b->n;
    o->tmp[0] = '\0';
    return OHM_OK;
}

static void batch_clear(ohm_output_batch *b)
{
    free(b->items);
    b->items = NULL;
    b->n = b->cap = 0;
}

int ohm_output_batch_commit(ohm_output_batch *b, const ohm_log *log, ohm_error *err)
{
    int rc = OHM_OK;
    for (size_t i = 0; i < b->n; ++i) {
        ohm_staged_output *it = &b->items[i];
        if (!rc) test_delay();
        /* a cancelled run renames nothing more: the files not yet in place
         * keep their old contents (each file is whole, old or new) */
        if (!rc && ohm_log_cancelled(log)) rc = ohm_fail_cancelled(err, "writing the outputs");
        if (!rc && rename(it->tmp, it->path) != 0)
            rc = ohm_fail(err, OHM_ERR_IO, "cannot write '%s': %s", it->path, strerror(errno));
        if (rc) unlink(it->tmp);
        staged_free(it);
    }
    batch_clear(b);
    return rc;
}

void ohm_output_batch_abort(ohm_output_batch *b)
{
    for (size_t i = 0; i < b->n; ++i) {
        unlink(b->items[i].tmp);
        staged_free(&b->items[i]);
    }
    batch_clear(b);
}

int ohm_output_batch_holds(const ohm_output_batch *b, const char *path)
{
    for (size_t i = 0; b && i < b->n; ++i)
        if (strcmp(b->items[i].path, path) == 0) return 1;
    return 0;
}

int ohm_output_commit(ohm_output *o, ohm_error *err)
{
    if (!o->tmp[0]) return ohm_fail(err, OHM_ERR_INTERNAL, "%s: output was not started", o->path);
    int failed = 0, e = 0;
    if (o->stream) {
        if (fflush(o->stream) != 0 || ferror(o->stream)) failed = 1, e = errno;
        if (!failed && fsync(fileno(o->stream)) != 0 && errno != EINVAL) failed = 1, e = errno;
        if (fclose(o->stream) != 0 && !failed) failed = 1, e = errno;
        o->stream = NULL;
    } else {
        /* Written by a library through the path: reopen to flush to disk. */
        int fd = open(o->tmp, O_RDONLY);
        if (fd < 0) failed = 1, e = errno;
        else {
            if (fsync(fd) != 0 && errno != EINVAL) failed = 1, e = errno;
            close(fd);
        }
    }
    if (!failed && o->batch) return stage(o, err);
    if (!failed) test_delay();
    if (!failed && rename(o->tmp, o->path) != 0) failed = 1, e = errno;
    if (failed) unlink(o->tmp);
    in_flight_remove(o->tmp);
    if (failed) {
        o->tmp[0] = '\0';
        return ohm_fail(err, OHM_ERR_IO, "cannot write '%s': %s", o->path, strerror(e));
    }
    o->tmp[0] = '\0';
    return OHM_OK;
}

void ohm_output_abort(ohm_output *o)
{
    if (o->stream) {
        fclose(o->stream);
        o->stream = NULL;
    }
    if (o->tmp[0]) {
        unlink(o->tmp);
        in_flight_remove(o->tmp);
        o->tmp[0] = '\0';
    }
}
