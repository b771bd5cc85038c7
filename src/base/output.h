/* output.h — every file ohm writes goes through here: it is written to a
 * temporary file in the same directory, flushed to disk, and renamed over the
 * target only when complete.  A failure (or a kill) at any moment leaves any
 * earlier file at that path intact (docs/design.md §11). */
#ifndef OHM_OUTPUT_H
#define OHM_OUTPUT_H

#include <stdio.h>

#include "base/log.h"
#include "base/ohm_error.h"

#define OHM_PATH_MAX 4096

/* The outputs of one run of a chain, complete on disk under their temporary
 * names and renamed over their targets only when the whole chain has
 * succeeded (ohm_output_batch_commit), or removed when it fails
 * (ohm_output_batch_abort): a failed run leaves every earlier file as it
 * was.  A kill between two of the final renames leaves each file old or new,
 * never partial.  Zero-initialised is empty. */
typedef struct ohm_staged_output {
    char *path, *tmp; /* the target; its complete temporary */
} ohm_staged_output;

typedef struct ohm_output_batch {
    ohm_staged_output *items;
    size_t n, cap;
} ohm_output_batch;

typedef struct ohm_output {
    char path[OHM_PATH_MAX]; /* the final name                              */
    char tmp[OHM_PATH_MAX];  /* the temporary name, same directory           */
    FILE *stream;            /* open on tmp for stdio writers; NULL after commit/abort */
    ohm_output_batch *batch; /* NULL: commit renames at once; else it stages  */
} ohm_output;

/* Create the temporary file.  Fails, naming the path, when the target is a
 * directory or its directory is missing or not writable.  With a batch, the
 * commit stages the file in it instead of renaming it. */
int ohm_output_begin(ohm_output *o, const char *path, ohm_output_batch *batch, ohm_error *err);

/* For libraries that write by path (OpenVDB, OpenImageIO): close the stream
 * and return the temporary name for the library to overwrite. */
const char *ohm_output_tmp_path(ohm_output *o);

/* Flush, fsync and rename tmp -> path (with a batch: hand the complete
 * temporary to it; a second output to the same path replaces the first).
 * On failure the temporary is removed and the old file (if any) is
 * untouched. */
int ohm_output_commit(ohm_output *o, ohm_error *err);

/* The staged outputs renamed over their targets, in the order they were
 * written; the batch is left empty.  A failed rename removes the temporaries
 * not yet renamed and says which file. */
int ohm_output_batch_commit(ohm_output_batch *b, const ohm_log *log, ohm_error *err);

/* The staged temporaries removed; the targets untouched; the batch empty. */
void ohm_output_batch_abort(ohm_output_batch *b);

/* Whether path is staged (a later step that reads it needs it on disk). */
int ohm_output_batch_holds(const ohm_output_batch *b, const char *path);

/* Remove the temporary; safe to call after commit (does nothing then). */
void ohm_output_abort(ohm_output *o);

/* Ctrl-C / SIGTERM while a file is being written or staged: remove the
 * temporaries in flight (staged ones too), then die of the signal as usual, so an interruption leaves neither
 * a partial output nor litter (the earlier file at the path is untouched, as
 * it always is until the rename).  This needs the one piece of process-wide
 * state in ohm, a small table of the temporaries in flight: a signal handler
 * can reach nothing else.  The ohm command installs it; a library user may.
 * (SIGKILL cannot be caught: the old file is still intact, a temporary named
 * ".NAME.ohm-XXXXXX" may remain.)
 * Test hook: OHM_TEST_COMMIT_DELAY_MS=N in the environment waits N ms before
 * each rename, so tests can interrupt a write deterministically. */
void ohm_output_install_signal_cleanup(void);

#endif
