/* ivoct — internal to scene/: the pieces of the scene loader.  Not installed.
 *
 *   ini.c     the INI adaptor: reads the file, refuses what libinih cannot
 *             report well, runs libinih, and stores each key with its value
 *             pieces and their file positions (entry_t)
 *   values.c  the values of the stored keys: numbers, integers, tokens, names,
 *             test lists (octree/) and method names (ray/), every error at its
 *             file position
 *   scene.c   the scene: its sections and keys, defaults, the box, the camera,
 *             compiling the lets and f; scene_load, scene_from_expr
 *   parametric.c  a parametric surface: the parametrization read, implicitized
 *             (implicit/) into f, and the box its patch bounds
 *
 * Errors go through scene_fail_at, which keeps the one that comes first in the
 * file; scene_load reports it.
 */
#ifndef IVOCT_SCENE_INTERNAL_H
#define IVOCT_SCENE_INTERNAL_H

#include <stdbool.h>
#include <stddef.h>

#include "scene.h"

/* ---- sections and keys (scene.c) ------------------------------------------------ */

enum { SEC_NONE, SEC_SURFACE, SEC_OCTREE, SEC_CAMERA, SEC_RENDER, SEC_UNKNOWN };
enum {
    K_NAME, K_F, K_BOX, K_PARAM_X, K_PARAM_Y, K_PARAM_Z, K_U, K_V, K_IMPLICITIZE,
    K_DEPTH, K_TESTS, K_REFINE, K_EYE, K_TARGET, K_UP, K_FOV, K_SIZE, K_METHOD, K_LIGHT, K_COUNT
};
#define K_LET K_COUNT /* let.NAME: the only key that may be given more than once */

/* The SEC_* of a section name (n bytes), SEC_UNKNOWN when it is none. */
int scene_section_id(const char *name, size_t n);
/* The name of a section, "" for SEC_NONE and SEC_UNKNOWN. */
const char *scene_section_name(int sec);
/* "[surface], [octree], [camera] or [render]" */
extern const char scene_sections_expected[];
/* The K_* (or K_LET) of key (n bytes) in section sec, -1 when it has none. */
int scene_key_kind(int sec, const char *key, size_t n);
/* The name of a key kind other than K_LET. */
const char *scene_key_name(int kind);
/* The keys of a section for messages: "depth, tests or refine". */
const char *scene_keys_expected(int sec);

/* ---- the loader's state (ini.c) -------------------------------------------------- */

/* One line of a value: the key line's value, or a continuation line. */
typedef struct piece {
    char *text;
    int line, col; /* where the piece starts in the file */
} piece_t;

/* A key and its value as written. */
typedef struct entry {
    int kind;  /* K_* */
    char *key; /* as written */
    int line, col;
    piece_t *pieces;
    size_t n_pieces, cap_pieces;
} entry_t;

typedef struct loader {
    const char *path;
    char *buf; /* the file, without a UTF-8 byte order mark, NUL-terminated */
    size_t size;
    size_t *line_off, *line_len; /* line_len without the '\n' */
    int n_lines;
    unsigned char *cont; /* per line: a continuation line by inih's rule */
    unsigned char *sec;  /* per line: the SEC_* in force */
    bool has_surface;
    /* reader */
    size_t rpos, rlimit;
    int rline;
    /* stored keys, in file order */
    entry_t *entries;
    size_t n_entries, cap_entries;
    int seen[K_COUNT]; /* entry index + 1 */
    /* the entry whose value is being parsed, for the hint of scene_fail_at */
    const struct entry *cur;
    /* the first error (smallest line) found so far */
    bool failed;
    ivoct_error_t first;
    bool oom;
    bool over_budget; /* the error is a budget exceeded (a runtime failure, not bad input) */
} loader_t;

/* Read L->path and store its keys.  Returns non-zero with err set when the
 * file cannot be read at all (or memory runs out before it is split into
 * lines); otherwise 0, with the keys read before the first error of the
 * file's structure stored, and that error (if any) kept as by scene_fail_at. */
int scene_ini_read(loader_t *L, ivoct_error_t *err);
void scene_ini_free(loader_t *L);

/* The entry of a key given once, NULL when the file does not give it. */
const entry_t *scene_entry(const loader_t *L, int kind);

/* Keep the error at file position (line, col) if it comes before the one
 * already kept.  When the line is an indented line that continues L->cur, the
 * message says so. */
void scene_fail_at(loader_t *L, int line, int col, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;
void scene_fail_oom(loader_t *L);

/* An error of an expression in the value of entry e (ce's positions, its own and
 * an "opened at L:C" in its message, inside the value joined with '\n'), kept at
 * its file position (scene.c). */
void scene_fail_expr(loader_t *L, const entry_t *e, const ivoct_error_t *ce);

/* inih's isspace() in the C locale. */
static inline int scene_is_space(int c)
{
    return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f';
}

/* ---- a parametric surface (parametric.c) -------------------------------------------
 * With param.x, param.y and param.z given: parse them, implicitize (method and
 * budget from opt, or the scene's implicitize key), set s->source.f to the
 * implicit polynomial (the text the tape is compiled from), s->source.param and
 * patch, and s->implicit.  need_box: the file has no box, so the patch (u, v)
 * must bound one.  Errors through scene_fail_at; a budget exceeded also sets
 * L->over_budget.  Returns non-zero on error. */
int scene_parametric(loader_t *L, scene_t *s, const scene_options_t *opt, bool need_box);

/* ---- values (values.c) ------------------------------------------------------------
 * Each scene_val_* parses the value of entry e, reports an error through
 * scene_fail_at at its file position and returns non-zero then. */

/* The pieces of a value joined with sep ('\n' keeps the line structure that
 * errors are mapped back through); NULL when out of memory. */
char *scene_val_join(const entry_t *e, char sep);

/* (line, col) inside the value joined with '\n' -> file position. */
void scene_val_map_pos(const entry_t *e, int line, int col, int *fl, int *fc);

/* Free text joined with spaces, leading spaces dropped, not empty: "name". */
int scene_val_text(loader_t *L, const entry_t *e, const char *what, char **out);

/* Exactly count numbers, separated by blanks or commas.  round[i]: -1 for the
 * lower end of the decimal's enclosure, +1 for the upper, 0 for the nearest
 * double (round NULL: all 0).  pos (may be NULL) receives the file position
 * of each. */
int scene_val_numbers(loader_t *L, const entry_t *e, const char *what, const char *expected,
                      int count, const int *round, double *out, int (*pos)[2]);

/* Exactly count integers in [lo, hi]. */
int scene_val_ints(loader_t *L, const entry_t *e, const char *what, const char *expected,
                   int count, long lo, long hi, int *out);

/* A test list (oct_tests_parse). */
int scene_val_tests(loader_t *L, const entry_t *e, unsigned *tests);

/* One method name (ray_method_parse). */
int scene_val_method(loader_t *L, const entry_t *e, ray_method_t *m);

#endif
