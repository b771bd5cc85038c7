#include "base/output.h"

#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <time.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* The temporaries in flight, for the signal handler (see output.h). */
enum { IN_FLIGHT_MAX = 16 };
static char in_flight[IN_FLIGHT_MAX][OHM_PATH_MAX];
static volatile sig_atomic_t in_flight_used[IN_FLIGHT_MAX];

static void in_flight_add(const char *tmp)
{
    for (int i = 0; i < IN_FLIGHT_MAX; ++i)
        if (!in_flight_used[i]) {
            snprintf(in_flight[i], sizeof in_flight[i], "%s", tmp);
            in_flight_used[i] = 1;
            return;
        }
}

static void in_flight_remove(const char *tmp)
{
    for (int i = 0; i < IN_FLIGHT_MAX; ++i)
        if (in_flight_used[i] && strcmp(in_flight[i], tmp) == 0) in_flight_used[i] = 0;
}

static void cleanup_and_die(int sig)
{
    for (int i = 0; i < IN_FLIGHT_MAX; ++i)
        if (in_flight_used[i]) unlink(in_flight[i]); /* async-signal-safe */
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

int ohm_output_begin(ohm_output *o, const char *path, ohm_error *err)
{
    memset(o, 0, sizeof *o);
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
    const char *delay = getenv("OHM_TEST_COMMIT_DELAY_MS"); /* test hook, see output.h */
    if (delay && !failed) {
        long ms = strtol(delay, NULL, 10);
        struct timespec ts = {ms / 1000, (ms % 1000) * 1000000L};
        if (ms > 0) nanosleep(&ts, NULL);
    }
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
