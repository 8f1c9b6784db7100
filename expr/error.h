/* ivoct — error reports shared by every module.
 *
 * Library code never prints, exits or aborts: a function that can fail returns
 * a status (0 ok, non-zero failure) and fills an ivoct_error_t.  For scene
 * input the error names file, line and column (1-based); line = 0 means the
 * error has no position. */
#ifndef IVOCT_ERROR_H
#define IVOCT_ERROR_H

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ivoct_error {
    char file[256];  /* "" when the input was not a file (e.g. `-e EXPR`) */
    int line;        /* 1-based; 0 = no position */
    int col;         /* 1-based; 0 = no column */
    char msg[512];   /* what went wrong / what was expected, no trailing newline */
} ivoct_error_t;

/* Clear the record (empty file and message, no position). */
void ivoct_error_clear(ivoct_error_t *err);

/* Set msg with printf formatting; keeps file/line/col as they are.  err may be NULL. */
void ivoct_error_set(ivoct_error_t *err, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* Set position and message in one call.  err may be NULL. */
void ivoct_error_at(ivoct_error_t *err, int line, int col, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;

/* Format as one line "file:line:col: msg" (parts that are absent are left out)
 * into buf of size n; returns buf. */
char *ivoct_error_format(const ivoct_error_t *err, char *buf, unsigned long n);

#ifdef __cplusplus
}
#endif
#endif
