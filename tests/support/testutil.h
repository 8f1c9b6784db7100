/* Helpers and data shared by the tests: a seeded PRNG and random sub-boxes,
 * the scene directory and the lists of scenes the tests use, scene, expression
 * and file loading that fail the running cmocka test on error, the list of
 * expressions that exercises every operation of the tape language. */
#ifndef IVOCT_TEST_UTIL_H
#define IVOCT_TEST_UTIL_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "../../expr/interval.h"
#include "../../expr/tape.h"
#include "../../ray/ray.h"
#include "../../scene/scene.h"

/* splitmix64: fast, fixed-seed, good enough for test inputs */
static inline uint64_t tu_next(uint64_t *s)
{
    uint64_t z = (*s += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

/* uniform in [0, 1) */
static inline double tu_uniform(uint64_t *s)
{
    return (double)(tu_next(s) >> 11) * 0x1p-53;
}

/* a + (b - a) u, clamped to [a, b] */
double tu_lerp(double a, double b, double u);

/* A random sub-box of box {xmin xmax ymin ymax zmin zmax}: edges from the
 * whole box's down to 2^-30 of it (log-uniform), at a uniform place; one in 16
 * is a point box. */
iv_box_t tu_random_subbox(const double box[6], uint64_t *rng);

/* A point of r: an end (one in four each) or a uniform interior point. */
double tu_pick(iv_t r, uint64_t *rng);

/* Axis k (0, 1, 2) of a box. */
iv_t tu_box_side(const iv_box_t *b, int k);

/* Sample point j of a box: j = 0..7 its corners, 8 its centre, then
 * alternately a random point on a random face (odd j) and inside (even j). */
void tu_box_point(const iv_box_t *b, int j, uint64_t *rng, double p[3]);

/* The seed: IVOCT_SEED from the environment, else the given default. */
uint64_t tu_seed(uint64_t fallback);

/* Is this the sanitizer build (IVOCT_ASAN set and not "0")?  Tests shrink
 * their sizes there: the instrumented code runs ~10x slower. */
int tu_sanitizer_build(void);

/* Scale factor for iteration counts: IVOCT_TEST_SCALE, else 0.1 in the
 * sanitizer build (IVOCT_ASAN set), else 1. */
double tu_scale(void);

/* The source tree: IVOCT_SOURCE_DIR, else ".". */
const char *tu_source_dir(void);

/* How many scene files scenes/ holds: one per surface of docs/surfaces.md (19), and
 * the six parametric scenes (scenes/param-*.ini). */
#define TU_N_SCENE_FILES 25

/* Paths of the scene files (scenes/NAME.ini), sorted; returns the count, *paths
 * malloc'd (free with tu_free_list).  Fails the current test when there are
 * fewer than TU_N_SCENE_FILES (a scene file lost). */
int tu_scene_files(char ***paths);
void tu_free_list(char **list, int n);

/* The eight comparison surfaces of docs/surfaces.md (scenes/NAME.ini; all
 * polynomials, degree 2 to 8), which the ray tests render with every method. */
#define TU_N_COMPARISON 8
extern const char *const tu_comparison_surfaces[TU_N_COMPARISON];

/* A scene into *s (scene_free it): NAME is scenes/NAME.ini, a NAME with a '/'
 * is the path itself.  Fails the current test on error, with the position. */
void tu_load_scene(const char *name, scene_t *s);

/* The octree of a scene's [octree] settings, on 2 threads, at most depth 6
 * in the sanitizer build (tu_scale() < 1).  Fails the current test on error. */
oct_tree_t *tu_scene_octree(const scene_t *s);

/* The side of a test image: full pixels scaled by sqrt(tu_scale()), at least
 * 16 (so that the pixel count scales with IVOCT_TEST_SCALE). */
int tu_image_size(int full);

/* A point light to the right of the camera's target and above it, as far
 * from the target as the eye: a light from the side, so that every surface
 * casts shadows and holds attached ones. */
void tu_side_light(const ray_camera_t *cam, double light[3]);

/* Render scene s through cam with method m on `threads` threads into a new
 * image (ray_image_free it): the octree source of tree, or the box source
 * when tree is NULL; sampling's step 1/1000 of the box diagonal.  Fails the
 * current test on error.  tu_render_source: the same from a source of the
 * caller's (an octree source with its options changed). */
void tu_render(const scene_t *s, const ray_camera_t *cam, const oct_tree_t *tree,
               ray_method_t m, int threads, ray_image_t *img, ray_stats_t *st);
void tu_render_source(const scene_t *s, const ray_camera_t *cam, const ray_source_t *src,
                      ray_method_t m, int threads, ray_image_t *img, ray_stats_t *st);

/* The whole file, NUL-terminated (not counted in *n; n may be NULL), malloc'd;
 * fails the current test when it cannot be read.  tu_read_stream: the same
 * for what is left of an open stream (rewind it first for the whole). */
unsigned char *tu_read_file(const char *path, size_t *n);
unsigned char *tu_read_stream(FILE *f, size_t *n);

/* Every operation of the tape language, alone and composed (the list the
 * evaluators' tests run through: test_eval_ray_mpfi, test_ilie_mpfi), and
 * boxes for them: a general one, a small one around 0 (poles, domain edges), a
 * big one (overflow). */
extern const char *const tu_op_exprs[];
extern const size_t tu_n_op_exprs;
#define TU_N_OP_BOXES 3
extern const double tu_op_boxes[TU_N_OP_BOXES][6];

/* The tape of expression f, with u, v, w defined as the given expressions
 * (e.g. u = "x - 1e8" translates a scene written in u, v, w); tu_compile(f) is
 * f in x, y, z.  Fails the current test on error. */
tape_t *tu_compile_uvw(const char *f, const char *u, const char *v, const char *w);
tape_t *tu_compile(const char *f);

/* Wall-clock seconds (monotonic). */
double tu_now(void);

/* One result row for a benchmark table: when IVOCT_STAB_CSV names a file,
 * append "suite,case,outcome,time_s,error" to it (bench/stability.sh sets it;
 * the tests run without it).  Commas inside the fields are written as ';'. */
void tu_result_row(const char *suite, const char *name, const char *outcome, double time_s,
                   double error);

#endif
