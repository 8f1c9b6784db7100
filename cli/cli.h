/* ivoct command line — internal to cli/: the subcommands (cmd_*.c, dispatched
 * by main.c), the option parser they share (options.c) and the helpers
 * (util.c). */
#ifndef IVOCT_CLI_H
#define IVOCT_CLI_H

#include <stdbool.h>
#include <stddef.h>
#include <stdio.h>

#include "../expr/error.h"
#include "../octree/octree.h"

/* Exit codes (docs/DESIGN.md §4). */
/* EXIT_UNCERTIFIED: build --mesh-certified could not certify the mesh's
 * topology in some cells (listed on stderr); nothing written. */
enum { EXIT_OK = 0, EXIT_RUNTIME = 1, EXIT_USAGE = 2, EXIT_UNCERTIFIED = 3 };

#define IVOCT_VERSION "0.1.0"

/* A macro's value as a string literal: CLI_STR(OCT_MAX_DEPTH) is "21". */
#define CLI_STR_(x) #x
#define CLI_STR(x) CLI_STR_(x)

/* ---- subcommands (cmd_*.c): each returns an exit code ------------------------------ */

int cmd_eval(int argc, char **argv);
int cmd_build(int argc, char **argv);
int cmd_info(int argc, char **argv);
int cmd_render(int argc, char **argv);
int cmd_implicitize(int argc, char **argv);

/* ---- options (options.c) ------------------------------------------------------------
 * Each command describes its options in a table, parsed by cli_parse; the
 * command's --help is printed from the same table. */

typedef enum cli_kind {
    CLI_HELP,       /* print the command's help on stdout: the command exits 0 */
    CLI_FLAG,       /* bool *target = true */
    CLI_STRING,     /* const char **target = the value (the last one given wins) */
    CLI_INT,        /* long *target: an integer in [lo, hi] */
    CLI_DOUBLE,     /* double *target: nargs finite numbers */
    CLI_CUSTOM,     /* parse(opt, value, target, msg, n) */
    CLI_OPERAND,    /* const char **target: the next argument that is not an option */
} cli_kind_t;

typedef struct cli_option {
    const char *name;  /* "--depth"; for CLI_OPERAND its name in the help ("SCENE") */
    const char *alias; /* another spelling ("-q"), or NULL */
    cli_kind_t kind;
    void *target;
    int nargs;         /* values after the option: 0 means 1 for the kinds that take one */
    long lo, hi;       /* CLI_INT: the range */
    /* CLI_CUSTOM: 0 when the value is fine, else non-zero with the message
     * (one line, naming opt) in msg */
    int (*parse)(const char *opt, const char *value, void *target, char *msg, size_t n);
    bool *given;       /* may be NULL: set to true when the option is given */
    const char *needs; /* what is missing when the values are: "an expression"
                          (default "a value", "N values") */
    const char *arg;   /* in the help after the name: "N", "F.csv" */
    const char *help;  /* in the help; '\n' starts a continuation line; NULL: not listed */
} cli_option_t;

typedef struct cli_command {
    const char *name;            /* "build" */
    const char *synopsis;        /* the help above the option list */
    int column;                  /* width of the name column of the option list */
    const cli_option_t *options; /* the last one has name NULL */
} cli_command_t;

/* What cli_parse returns when the command is to run. */
#define CLI_RUN (-1)

/* Parse argv[1..argc-1] by cmd's table: options (any argument that starts
 * with '-' and is not "-") and operands, in any order.  Returns CLI_RUN, or an
 * exit code: EXIT_OK after --help, EXIT_USAGE after a one-line message on
 * stderr. */
int cli_parse(const cli_command_t *cmd, int argc, char **argv);

/* The synopsis, then "  NAME ARG   help" for every option with help. */
void cli_print_help(const cli_command_t *cmd, FILE *f);

/* ---- ivoct build's job (cmd_build.c), shared with the build over MPI (mpi.c) ------- */

struct scene;
struct oct_tree;
struct io_group;

typedef struct exports {
    const char *vtu, *htg, *vdb, *mesh;
    const char *mesh_certified; /* --mesh-certified F */
    int mesh_min_depth;         /* --mesh-min-depth, -1: the max depth - 2 */
} exports_t;

/* Keys added at the end of the stats file: write(f, user) prints
 * ',\n  "key": value' lines. */
typedef struct build_stats_extra {
    void (*write)(FILE *f, void *user);
    void *user;
} build_stats_extra_t;

typedef struct build_job {
    const struct scene *scene;
    oct_params_t params;          /* the scene's, overridden by the options */
    const char *cells, *save, *stats;
    exports_t ex;
    int threads;                  /* --threads (0: all cores) */
    size_t max_memory;            /* --max-memory (0: none) */
    bool certain;                 /* --certain: oct_certify after the build */
} build_job_t;

/* The memory budget of the outputs (cmd_build.c): whether tree's storage
 * plus what the most demanding of the outputs given (non-NULL paths) needs
 * fits in budget (0, else -1 with err naming the option); and the threads
 * that format --cells within it (threads, or fewer). */
int build_check_export_memory(const struct oct_tree *t, const char *cells, const char *save,
                              const exports_t *ex, size_t budget, ivoct_error_t *err);
int build_cells_threads(const struct oct_tree *t, int threads, size_t budget);

/* What the summary line of the certified mesh prints. */
typedef struct mesh_summary {
    bool made;
    size_t vertices, triangles, cells;
    int min_depth, max_depth; /* of the cells holding triangles */
    double seconds;
} mesh_summary_t;

/* Write every output of job for tree into g (not committed): EXIT_OK, or
 * EXIT_RUNTIME or EXIT_UNCERTIFIED with err set.  mesh (may be NULL): the
 * certified mesh's figures, for the summary. */
int build_write_outputs(const build_job_t *job, const struct oct_tree *tree,
                        struct io_group *g, const build_stats_extra_t *extra,
                        mesh_summary_t *mesh, ivoct_error_t *err);

/* ---- MPI (mpi.c, only in a build with IVOCT_MPI) -------------------------------------
 * Under mpirun (Open MPI's, or any that sets PMI/PMIx variables) main starts MPI
 * before the command runs and ends it after; anywhere else nothing changes. */
#ifdef IVOCT_MPI
/* Start MPI when started by mpirun (before the command, after the signal
 * thread); 0, or an exit code. */
int cli_mpi_start(int *argc, char ***argv);
/* The number of ranks when MPI was started, else 0. */
int cli_mpi_ranks(void);
/* The status every rank agrees on for a local rc (the failure of the lowest
 * rank that failed, whose message rank 0 prints); collective. */
int cli_mpi_agree(int rc);
/* ivoct build over the ranks (docs/cluster.md); an exit code, the same on every rank. */
int cli_mpi_build(const build_job_t *job, bool quiet);
/* This rank's number (0 without MPI). */
int cli_mpi_rank(void);
/* The sum of v over the ranks, on every rank (collective). */
uint64_t cli_mpi_sum_u64(uint64_t v);

/* ivoct render over the ranks (cmd_render.c, docs/cluster.md).  With fewer
 * frames than ranks each frame is cut into parts, one per rank (ray.h, "parts
 * of an image"), and gathered on rank 0, which writes every file; else frame k
 * goes to rank k mod N, which writes it. */
struct ray_image;
struct ray_stats;
typedef struct cli_mpi_render {
    int ranks;
    int parts;               /* N: each frame in N parts; 1: the frames dealt out */
    int gather;              /* the parts are gathered (a --png or a --vti to write) */
    int what;                /* of the buffers (ray_pack_t): all, or the shaded image */
    unsigned char *buf;      /* a packed part, the largest */
    uint64_t gather_bytes;   /* sent to rank 0 (after reduce: by all ranks, on rank 0) */
    double gather_time_s;    /* in the gathers; the stats give rank 0's */
    /* on rank 0 after cli_mpi_render_reduce */
    double *rank_time_s;     /* every rank's render time, summed over its frames */
    uint64_t *rank_rays, *rank_tape_evals;
    double balance;          /* max / mean rank time */
} cli_mpi_render_t;
/* The bytes of the gather's buffer: the largest of `parts` parts of a width
 * x height image, packed with `what` (ray_pack_t). */
double cli_mpi_render_buffer_bytes(int width, int height, int parts, int what);
/* Set r up for `frames` frames of width x height, gathering the buffers
 * `what` (ray_pack_t) when gather is set (local; -1 with err set: out of
 * memory, or a part too large for one message).  cli_mpi_render_end frees
 * it, whatever the outcome. */
int cli_mpi_render_start(cli_mpi_render_t *r, int width, int height, int frames, int gather,
                         int what, ivoct_error_t *err);
/* Every rank's part of img onto rank 0's img (collective; r->parts > 1 and
 * r->gather). */
void cli_mpi_render_gather(cli_mpi_render_t *r, struct ray_image *img);
/* After the last frame (collective): total, this rank's counts and render
 * time, becomes the totals over the ranks (on every rank; time_s on rank 0:
 * the slowest rank's when the frames are split, else the sum) and the
 * per-rank figures go to rank 0. */
void cli_mpi_render_reduce(cli_mpi_render_t *r, struct ray_stats *total);
/* The stats' "mpi" object (a build_stats_extra_t writer; user: r), on rank 0. */
void cli_mpi_render_stats(FILE *f, void *user);
void cli_mpi_render_end(cli_mpi_render_t *r);
/* End MPI (when started); returns rc. */
int cli_mpi_finish(int rc);
#endif

/* ---- the allocator (allocator.c) ------------------------------------------------- */

/* The malloc this program runs on, for --version: "jemalloc VERSION (thp: ..,
 * arenas: ..)" in the release build, "the C library's malloc" otherwise. */
const char *cli_allocator(void);

/* ---- helpers (util.c) ------------------------------------------------------------ */

/* Print "ivoct CMD: message (see 'ivoct CMD --help')" to stderr; returns EXIT_USAGE. */
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

/* The parser (CLI_CUSTOM) of --max-memory: a size in bytes with an optional
 * K, M or G suffix (and B); target is a size_t. */
int cli_parse_memory(const char *opt, const char *value, void *target, char *msg, size_t n);

/* Print a double for JSON with 17 significant digits (round-trip exact).
 * Infinities print as 1e999 / -1e999 (JSON has no infinity; JSON readers such
 * as Python's read them back as inf), NaN as null. */
void cli_json_double(FILE *f, double x);

/* Print a JSON string literal (quotes, backslashes and control characters escaped). */
void cli_json_string(FILE *f, const char *s);

/* For the stats of a parametric scene: ',\n  "implicitize": {"method": .., "seconds": ..,
 * "degree": .., "terms": ..}'; nothing for an implicit one. */
struct scene;
void cli_json_implicitize(FILE *f, const struct scene *s);

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

/* The bar and the signal thread share the terminal's last line: the bar is
 * drawn between cli_progress_lock, which returns 0 (and does not lock) once a
 * signal is being handled, and cli_progress_unlock, told whether the line was
 * left open (no newline yet); the signal thread ends an open line, under the
 * same lock, before its message, and no bar is drawn after it (signals.c). */
int cli_progress_lock(void);
void cli_progress_unlock(int line_open);

/* ---- signals (signals.c) ---------------------------------------------------------
 * SIGINT, SIGTERM and SIGHUP are taken by a thread of their own, which removes
 * every temporary file of io/ and ends the process with the signal (exit
 * status 128 + N in a shell); SIGXFSZ is ignored (a file past ulimit -f is a
 * write error).  Called first thing in main, before any thread exists. */
void cli_signals_start(const char *cmd);

/* What main returns: rc, unless a signal is being handled, in which case this
 * waits for the signal thread to end the process. */
int cli_signals_finish(int rc);

/* The command's failure is reported and its outputs are taken back: a signal
 * from now on ends the process without a message (mpirun ends the other ranks
 * with SIGTERM as soon as one exits non-zero: cli/mpi.c). */
void cli_signals_settled(void);

/* The test hook (tests/test_signals.sh): when IVOCT_TEST_PAUSE_AT is `step`
 * (or a comma-separated list of steps that holds it), print "ivoct: test pause
 * at STEP" on stderr and wait there for a signal.
 * Steps: build (before the octree is built), each output of build (cells,
 * save, stats, vtu, htg, vdb, mesh: before it is written), commit (before the
 * outputs are renamed into place), render, frame (before each frame's files),
 * and interrupted (in the signal thread, before the temporaries are removed). */
void cli_test_pause(const char *step);

#endif
