/* ivoct — scene files (prefix scene_).
 *
 * A scene is an implicit surface f(x,y,z) = 0 in a box (or a parametric one,
 * implicitized into f when the scene is loaded), with the settings of
 * the octree build, the camera and the renderer, in the vocabulary of the
 * modules that use them: octree/ (oct_source_t, oct_params_t) and ray/
 * (ray_camera_t, ray_method_t), whose names, limits and checks it takes.
 * Scene files are INI, read with libinih; the format is in
 * docs/scene-format.md.  Every error names file:line:column and what was
 * expected.
 */
#ifndef IVOCT_SCENE_H
#define IVOCT_SCENE_H

#include "../expr/error.h"
#include "../expr/tape.h"
#include "../implicit/implicit.h"
#include "../octree/octree.h"
#include "../ray/ray.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct scene {
    char *path;            /* file the scene came from, NULL for -e */
    /* [surface] name (default: the file's base name), let.NAME = TEXT (in file
     * order; later ones may use earlier ones), f as written (continuation lines
     * joined by '\n'): what oct_save and the exports store */
    oct_source_t source;
    double box[6];         /* xmin xmax ymin ymax zmin zmax, finite, min <= max */
    tape_t *tape;          /* f compiled */
    /* [octree] depth (0..OCT_MAX_DEPTH), tests, refine; the other fields as
     * oct_params_default leaves them */
    oct_params_t octree;
    /* [camera] eye, target, up, fov, size (each 1..RAY_MAX_SIZE), set up by
     * ray_camera_init; the default eye and target frame the box */
    ray_camera_t camera;
    ray_method_t method;   /* [render] method, default the renderer's (newton-ah) */
    int has_light;         /* [render] light = x y z: a point light casting shadows */
    double light[3];
    /* a parametric surface ([surface] param.x, param.y, param.z): how f was
     * found (source.f is its f_tape, source.param the parametrization); NULL
     * for an implicit surface */
    imp_result_t *implicit;
} scene_t;

/* What scene_load_with does with a parametric surface. */
typedef struct scene_options {
    int implicitize;     /* an imp_method_t, or -1: the scene's implicitize (default auto) */
    imp_budget_t budget; /* of the implicitization; zeros: the defaults */
} scene_options_t;

/* scene_load's failures: bad input (the CLI's exit 2), or a runtime failure:
 * out of memory, an implicitization past its budget (exit 1). */
enum { SCENE_EINPUT = -1, SCENE_ERUNTIME = -2 };

/* Load a scene file.  On failure returns SCENE_EINPUT or SCENE_ERUNTIME,
 * fills err (file, line, column, what was expected) and leaves *s zeroed.  Not to be called from two
 * threads at once: libinih's settings are process globals. */
int scene_load(const char *path, scene_t *s, ivoct_error_t *err);
/* scene_load with options (opt NULL: the defaults, as scene_load). */
int scene_load_with(const char *path, const scene_options_t *opt, scene_t *s,
                    ivoct_error_t *err);

/* A scene from an expression and a box (ivoct eval -e): the other settings
 * are the defaults.  Errors carry the column in the expression. */
int scene_from_expr(const char *expr, const double box[6], scene_t *s, ivoct_error_t *err);

void scene_free(scene_t *s);

#ifdef __cplusplus
}
#endif
#endif
