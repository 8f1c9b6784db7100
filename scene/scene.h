/* ivoct — scene files (prefix scene_).
 *
 * A scene is an implicit surface f(x,y,z) = 0 in a box, with the settings of
 * the octree build, the camera and the renderer.  Scene files are INI, read
 * with libinih; the format is in docs/scene-format.md.  Every error names
 * file:line:column and what was expected.
 */
#ifndef IVOCT_SCENE_H
#define IVOCT_SCENE_H

#include "../expr/error.h"
#include "../expr/tape.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The certified tests of the octree's chain, cheapest first. */
enum {
    SCENE_TEST_INTERVAL = 1u << 0,
    SCENE_TEST_LIPSCHITZ = 1u << 1,
    SCENE_TEST_ILIE = 1u << 2,
};

typedef struct scene {
    char *path;       /* file the scene came from, NULL for -e */
    char *name;       /* [surface] name; defaults to the file's base name */
    size_t n_lets;    /* [surface] let.NAME = TEXT, in file order (later ones may use earlier ones) */
    char **let_names;
    char **let_texts;
    char *f_text;     /* [surface] f as written (continuation lines joined by '\n') */
    double box[6];    /* xmin xmax ymin ymax zmin zmax, finite, min <= max */
    tape_t *tape;     /* f compiled */

    int depth;        /* [octree] depth, default 8 */
    unsigned tests;   /* [octree] tests, bitmask of SCENE_TEST_*, default interval|lipschitz */
    double refine;    /* [octree] refine, default 0 (off) */

    double eye[3], target[3], up[3]; /* [camera]; defaults frame the box */
    double fov;                      /* degrees, vertical; default 30 */
    int width, height;               /* default 300 300 */

    char method[32];  /* [render] method, default "newton-ah" */
} scene_t;

/* Load a scene file.  On failure returns non-zero, fills err (file, line,
 * column, what was expected) and leaves *s zeroed.  Not to be called from two
 * threads at once: libinih's settings are process globals. */
int scene_load(const char *path, scene_t *s, ivoct_error_t *err);

/* A scene from an expression and a box (ivoct eval -e).  Errors carry the
 * column in the expression. */
int scene_from_expr(const char *expr, const double box[6], scene_t *s, ivoct_error_t *err);

void scene_free(scene_t *s);

/* Parse a test list "interval, lipschitz" into a bitmask; 0 on success. */
int scene_parse_tests(const char *text, unsigned *tests, ivoct_error_t *err);

/* Comma-separated names of a test bitmask into buf. */
char *scene_tests_string(unsigned tests, char *buf, unsigned long n);

#ifdef __cplusplus
}
#endif
#endif
