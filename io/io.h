/* ivoct — writing output files atomically (prefix io_).
 *
 * Every output of ivoct is written to a temporary file in the destination's
 * folder and renamed over the destination only once complete and flushed, so
 * an error, a full disk or Ctrl-C never leaves a partial file behind. */
#ifndef IVOCT_IO_H
#define IVOCT_IO_H

#include <stdio.h>

#include "../expr/error.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct io_file {
    FILE *f;          /* write here */
    char *path;       /* the destination */
    char *tmp;        /* the temporary name */
} io_file_t;

/* Open a temporary file beside path.  Returns 0, or non-zero with err set
 * ("cannot write PATH: reason"). */
int io_open(io_file_t *out, const char *path, ivoct_error_t *err);

/* Flush, check for write errors, close and rename onto the destination.
 * On any failure the temporary file is removed and err says why. */
int io_commit(io_file_t *f, ivoct_error_t *err);

/* Close and remove the temporary file (after an error elsewhere). */
void io_abort(io_file_t *f);

#ifdef __cplusplus
}
#endif
#endif
