/* ivoct command line — helpers shared by the subcommands (internal to cli/). */
#ifndef IVOCT_CLI_H
#define IVOCT_CLI_H

#include <stdbool.h>
#include <stdio.h>

#include "../expr/error.h"

/* Exit codes (DESIGN.md §4). */
enum { EXIT_OK = 0, EXIT_RUNTIME = 1, EXIT_USAGE = 2 };

#define IVOCT_VERSION "0.1.0"

/* Subcommands: each returns an exit code. */
int cmd_eval(int argc, char **argv);
int cmd_build(int argc, char **argv);
int cmd_info(int argc, char **argv);
int cmd_render(int argc, char **argv);

/* Print "ivoct CMD: message" to stderr; returns EXIT_USAGE. */
int cli_usage_error(const char *cmd, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* Print an error record as one line "ivoct: file:line:col: msg" to stderr. */
void cli_print_error(const ivoct_error_t *err);

/* Strict number parsing of a whole argument: finite double / int in range.
 * Return false (and print why) on failure. */
bool cli_parse_double(const char *cmd, const char *opt, const char *text, double *out);
bool cli_parse_int(const char *cmd, const char *opt, const char *text, long lo, long hi,
                   long *out);

/* Print a double for JSON with 17 significant digits (round-trip exact).
 * Infinities print as 1e999 / -1e999 (JSON has no infinity; JSON readers such
 * as Python's read them back as inf), NaN as null. */
void cli_json_double(FILE *f, double x);

/* A progress bar on stderr, shown once the work has lasted a second.  The
 * caller only installs it when stderr is a terminal and not --quiet.  With
 * frames > 1 the fraction is of frame `frame` of `frames`. */
typedef struct cli_progress {
    const char *label;
    double start; /* omp_get_wtime() at the start */
    int shown, frame, frames;
} cli_progress_t;

/* The callback: user is a cli_progress_t. */
void cli_show_progress(void *user, double fraction);

/* Print a JSON string literal (quotes, backslashes and control characters escaped). */
void cli_json_string(FILE *f, const char *s);

#endif
