/* ivoct — writing output files atomically (prefix io_).
 *
 * Every output of ivoct is written to a temporary file in the destination's
 * folder and renamed over the destination only once complete and flushed, so
 * an error or a full disk never leaves a partial file behind.  A commit group
 * renames several outputs together, only once all of them are complete.  The
 * temporary names of the whole process are registered, so that a signal
 * handler of the program (not of this library) can remove them all with
 * io_remove_temporaries.  See io/README.md. */
#ifndef IVOCT_IO_H
#define IVOCT_IO_H

#include <stddef.h>
#include <stdio.h>

#include "../expr/error.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct io_file {
    FILE *f;          /* write here */
    char *path;       /* the destination */
    char *tmp;        /* the temporary name (NULL: a device, written in place) */
    void *reg;        /* internal: the entry of tmp in the registry */
    char *buf;        /* internal: f's buffer (128 KiB, io.c), freed once f is closed */
} io_file_t;

/* Open a temporary file beside path.  Returns 0, or non-zero with err set
 * ("cannot write PATH: reason"). */
int io_open(io_file_t *out, const char *path, ivoct_error_t *err);

/* Flush, check for write errors, close and rename onto the destination.
 * On any failure the temporary file is removed and err says why. */
int io_commit(io_file_t *f, ivoct_error_t *err);

/* Close and remove the temporary file (after an error elsewhere). */
void io_abort(io_file_t *f);

/* ---- commit groups: several outputs renamed into place together ------------------ */

typedef struct io_group {
    io_file_t *files; /* closed, complete, not yet renamed */
    size_t n, cap;
} io_group_t;

#define IO_GROUP_INIT {NULL, 0, 0}

/* Flush, check for write errors and close f (opened with io_open), then hand
 * it to the group: its temporary is renamed by io_group_commit.  On failure
 * the temporary is removed, err says why and the group is unchanged. */
int io_group_add(io_group_t *g, io_file_t *f, ivoct_error_t *err);

/* A temporary name for an output that a writer of its own writes through
 * io_open / io_commit (oct_save, the exporters): *tmp (owned by the group)
 * is created empty beside path, keeps path's extension (PATH.tmp.PID.N.EXT)
 * and is renamed onto path by io_group_commit.  A device path is given back
 * as it is (written in place).  An error naming *tmp can be turned into one
 * naming path with io_group_rename_error. */
int io_group_reserve(io_group_t *g, const char *path, const char **tmp, ivoct_error_t *err);

/* In err->msg, replace every temporary name of the group by its destination. */
void io_group_rename_error(const io_group_t *g, ivoct_error_t *err);

/* Rename every file of the group onto its destination, in the order added,
 * with io_remove_temporaries held off until all are renamed.  On failure
 * err says why and every temporary not yet renamed is removed (a rename that
 * fails midway, which io_open's checks make rare, leaves the ones before it
 * in place).  The group is empty afterwards (ready for reuse or to be dropped). */
int io_group_commit(io_group_t *g, ivoct_error_t *err);

/* Remove every temporary of the group; the group is empty afterwards. */
void io_group_abort(io_group_t *g);

/* ---- for the program's signal handling ------------------------------------------- */

/* Remove every temporary file this process has open or in a group (from any
 * thread) and refuse from now on to create or rename any (io_open,
 * io_commit and io_group_commit fail with "interrupted").  Waits for a
 * rename in progress (a whole group commit) to finish, so the outputs are
 * either all renamed or none.  Returns how many files were removed.  Uses a
 * mutex: call it from a normal thread (a sigwait thread), not from inside a
 * signal handler. */
size_t io_remove_temporaries(void);

#ifdef __cplusplus
}
#endif
#endif
