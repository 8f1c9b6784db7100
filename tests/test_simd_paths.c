/* Every SIMD path of the evaluators gives the same bits (expr/tape.h, "SIMD
 * paths"), so the same octree.
 *
 * For each path this machine runs (tape_simd_paths, tape_simd_available):
 *   - the point, interval (with its choices), gradient, point + gradient and
 *     ray evaluators over random boxes of every scene and of the expressions
 *     that exercise every op (tests/support: tu_op_exprs), in batches of
 *     TAPE_BATCH + 37 (a full pass, then a short padded one), must equal the
 *     portable path's results byte for byte (NaN payloads included: the
 *     evaluators make the same NaN),
 *     and 1 to 8 points evaluated alone the same points in the full batch;
 *   - the octree of every scene, with the scene's tests and with the whole
 *     chain, built with 1 and 2 threads, must save to the same .ivo bytes;
 *   - the renders of the comparison surfaces and the CSG union, every method,
 *     must give the same buffers and counts but the count of evaluator passes,
 *     which may differ only between paths of different tape_short_lanes (the
 *     root finders fill a padded pass where that is free, ray/README.md).
 * Enclosure itself is the MPFI tests' job; they run once per path (ctest
 * names ending in @portable, @avx2, @avx512). */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "../octree/octree.h"
#include "../scene/scene.h"
#include "support/testutil.h"

enum { NBOX = TAPE_BATCH + 37, MAX_PATHS = 8 };

/* The paths this build has and this CPU runs, portable first. */
static int available_paths(char names[MAX_PATHS][16])
{
    char list[128];
    snprintf(list, sizeof list, "%s", tape_simd_paths());
    int n = 0;
    for (char *save = NULL, *p = strtok_r(list, " ", &save); p && n < MAX_PATHS;
         p = strtok_r(NULL, " ", &save))
        if (tape_simd_available(p))
            snprintf(names[n++], sizeof names[0], "%s", p);
    assert_true(n >= 1);
    assert_string_equal(names[0], "portable");
    return n;
}

static void use_path(const char *name)
{
    ivoct_error_t err;
    ivoct_error_clear(&err);
    if (tape_simd_select(name, &err))
        fail_msg("tape_simd_select(%s): %s", name, err.msg);
    assert_string_equal(tape_simd_name(), name);
}

/* Everything the evaluators return for one tape over one set of boxes. */
typedef struct results {
    iv_t F[NBOX];
    uint8_t *choices;
    iv_grad_t G[NBOX];
    double P[NBOX];
    tape_point_grad_t Q[NBOX];
    iv_t g[NBOX], dg[NBOX], g_only[NBOX];
    double rnd[NBOX];
} results_t;

static void evaluate(const tape_t *t, const iv_box_t *boxes, const double (*pt)[3],
                     const double o[3], const double d[3], const iv_t *T, results_t *r)
{
    tape_ws_t *ws = tape_ws_new(t->n);
    assert_non_null(ws);
    double x[NBOX], y[NBOX], z[NBOX];
    for (int i = 0; i < NBOX; i++)
        x[i] = pt[i][0], y[i] = pt[i][1], z[i] = pt[i][2];
    tape_eval_interval_choices(t, ws, NBOX, boxes, r->F, r->choices);
    tape_eval_grad(t, ws, NBOX, boxes, r->G);
    tape_eval_point(t, ws, NBOX, x, y, z, r->P);
    tape_eval_point_grad(t, ws, NBOX, x, y, z, r->Q);
    /* 1 to 8 of the points again, as a short batch (padded and run by a pass
     * of its own on some paths): the same bits */
    for (int k = 1; k <= 8; k++) {
        double Ps[8];
        tape_eval_point(t, ws, (size_t)k, x + NBOX - k, y + NBOX - k, z + NBOX - k, Ps);
        if (memcmp(Ps, r->P + NBOX - k, (size_t)k * sizeof *Ps))
            fail_msg("path %s: %d points as a short batch differ from the same points in a "
                     "full one",
                     tape_simd_name(), k);
    }
    tape_eval_ray(t, ws, o, d, NBOX, T, r->g, r->dg, r->rnd);
    tape_eval_ray(t, ws, o, d, NBOX, T, r->g_only, NULL, NULL);
    tape_ws_free(ws);
}

static void same_results(const char *what, const char *path, const tape_t *t,
                         const results_t *a, const results_t *b)
{
#define SAME(field, size)                                                                    \
    if (memcmp(a->field, b->field, size))                                                    \
        fail_msg("%s: path %s: %s differs from the portable path's", what, path, #field);
    SAME(F, sizeof a->F);
    SAME(choices, (size_t)NBOX * t->n);
    SAME(G, sizeof a->G);
    SAME(P, sizeof a->P);
    SAME(Q, sizeof a->Q);
    SAME(g, sizeof a->g);
    SAME(dg, sizeof a->dg);
    SAME(g_only, sizeof a->g_only);
    SAME(rnd, sizeof a->rnd);
#undef SAME
}

static long evaluators_agree(const char *what, const tape_t *t, const double box[6],
                             char paths[MAX_PATHS][16], int npaths, uint64_t *rng)
{
    iv_box_t boxes[NBOX];
    double pt[NBOX][3];
    iv_t T[NBOX];
    double o[3], d[3], norm = 0;
    for (int i = 0; i < NBOX; i++) {
        boxes[i] = tu_random_subbox(box, rng);
        tu_box_point(&boxes[i], i, rng, pt[i]);
    }
    for (int k = 0; k < 3; k++) {
        o[k] = tu_lerp(box[2 * k], box[2 * k + 1], tu_uniform(rng));
        d[k] = 2 * tu_uniform(rng) - 1;
        norm += d[k] * d[k];
    }
    double edge = fmax(box[1] - box[0], fmax(box[3] - box[2], box[5] - box[4]));
    for (int k = 0; k < 3; k++)
        d[k] /= sqrt(norm);
    for (int i = 0; i < NBOX; i++) {
        double a = edge * (tu_uniform(rng) - 0.5), w = i % 5 == 0 ? 0 : edge * tu_uniform(rng) / 8;
        T[i] = iv_make(a, a + w);
    }
    results_t *ref = calloc(1, sizeof *ref), *mine = calloc(1, sizeof *mine);
    assert_non_null(ref);
    assert_non_null(mine);
    ref->choices = malloc((size_t)NBOX * t->n);
    mine->choices = malloc((size_t)NBOX * t->n);
    use_path(paths[0]);
    evaluate(t, boxes, (const double(*)[3])pt, o, d, T, ref);
    for (int p = 1; p < npaths; p++) {
        use_path(paths[p]);
        evaluate(t, boxes, (const double(*)[3])pt, o, d, T, mine);
        same_results(what, paths[p], t, ref, mine);
    }
    free(ref->choices), free(mine->choices), free(ref), free(mine);
    return NBOX;
}

static void test_evaluators(void **state)
{
    (void)state;
    char paths[MAX_PATHS][16];
    int npaths = available_paths(paths);
    uint64_t rng = tu_seed(0x51dd);
    long lanes = 0;
    int rounds = tu_sanitizer_build() ? 2 : 8;
    for (size_t e = 0; e < tu_n_op_exprs; e++) {
        tape_t *t = tu_compile(tu_op_exprs[e]);
        for (int b = 0; b < TU_N_OP_BOXES; b++)
            for (int r = 0; r < rounds; r++)
                lanes += evaluators_agree(tu_op_exprs[e], t, tu_op_boxes[b], paths, npaths, &rng);
        tape_free(t);
    }
    char **files;
    int n = tu_scene_files(&files);
    for (int i = 0; i < n; i++) {
        scene_t s;
        tu_load_scene(files[i], &s);
        for (int r = 0; r < rounds; r++)
            lanes += evaluators_agree(files[i], s.tape, s.box, paths, npaths, &rng);
        scene_free(&s);
    }
    tu_free_list(files, n);
    printf("%d paths (", npaths);
    for (int p = 0; p < npaths; p++)
        printf("%s%s", p ? " " : "", paths[p]);
    printf("): %ld lanes of every evaluator identical\n", lanes);
    tape_simd_select(NULL, NULL);
}

static void test_trees(void **state)
{
    (void)state;
    char paths[MAX_PATHS][16];
    int npaths = available_paths(paths);
    char dir[] = "/tmp/ivoct-simd-XXXXXX";
    assert_non_null(mkdtemp(dir));
    int depth = tu_sanitizer_build() ? 4 : 6;
    char **files;
    int n = tu_scene_files(&files);
    for (int i = 0; i < n; i++) {
        scene_t s;
        tu_load_scene(files[i], &s);
        ivoct_error_t err;
        ivoct_error_clear(&err);
        double edge = fmax(s.box[1] - s.box[0], fmax(s.box[3] - s.box[2], s.box[5] - s.box[4]));
        for (int chain = 0; chain < 2; chain++) {
            unsigned tests =
                chain ? OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ | OCT_TEST_ILIE : s.octree.tests;
            unsigned char *first = NULL;
            size_t first_n = 0;
            for (int p = 0; p < npaths; p++) {
                use_path(paths[p]);
                for (int threads = 1; threads <= 2; threads++) {
                    oct_params_t prm = {.depth = depth, .tests = tests,
                                        .refine = chain ? 0.02 * edge : 0, .threads = threads};
                    oct_tree_t *t;
                    if (oct_build(s.tape, s.box, &prm, &t, &err) != 0)
                        fail_msg("%s: oct_build: %s", files[i], err.msg);
                    char out[4200];
                    snprintf(out, sizeof out, "%s/tree.ivo", dir);
                    if (oct_save(t, &s.source, out, &err) != 0)
                        fail_msg("oct_save %s: %s", out, err.msg);
                    size_t nb;
                    unsigned char *bytes = tu_read_file(out, &nb);
                    remove(out);
                    oct_free(t);
                    if (!first) {
                        first = bytes, first_n = nb;
                        continue;
                    }
                    if (nb != first_n || memcmp(bytes, first, nb))
                        fail_msg("%s (%s): the tree of path %s, %d threads differs from "
                                 "path %s, 1 thread",
                                 files[i], chain ? "whole chain" : "scene's tests", paths[p],
                                 threads, paths[0]);
                    free(bytes);
                }
            }
            free(first);
        }
        printf("%-40s depth %d: identical .ivo on %d paths x 1, 2 threads\n", s.source.name,
               depth, npaths);
        scene_free(&s);
    }
    tu_free_list(files, n);
    rmdir(dir);
    tape_simd_select(NULL, NULL);
}

/* The first buffer or count in which b differs from a, or NULL: the passes
 * count only when both came from paths that pad alike (same_padding). */
static const char *difference(const ray_image_t *a, const ray_stats_t *sa, const ray_image_t *b,
                              const ray_stats_t *sb, int same_padding)
{
    size_t n = (size_t)a->width * a->height;
    if (memcmp(a->t, b->t, n * sizeof *a->t))
        return "t";
    if (memcmp(a->point, b->point, 3 * n * sizeof *a->point))
        return "point";
    if (memcmp(a->normal, b->normal, 3 * n * sizeof *a->normal))
        return "normal";
    if (memcmp(a->hit, b->hit, n) || memcmp(a->kind, b->kind, n))
        return "hit";
    if (memcmp(a->rgb, b->rgb, 3 * n))
        return "rgb";
    if (sa->hits != sb->hits || sa->tangent_hits != sb->tangent_hits ||
        sa->segments != sb->segments || sa->leaves != sb->leaves)
        return "counts";
    if (same_padding && sa->tape_evals != sb->tape_evals)
        return "passes";
    return NULL;
}

/* The same image on every path: buffers byte for byte, the counts of hits,
 * segments and leaves; the passes equal where the paths pad alike. */
static void test_renders(void **state)
{
    (void)state;
    char paths[MAX_PATHS][16];
    int npaths = available_paths(paths);
    const int size = tu_image_size(32);
    const char *names[TU_N_COMPARISON + 1];
    for (int k = 0; k < TU_N_COMPARISON; k++)
        names[k] = tu_comparison_surfaces[k];
    names[TU_N_COMPARISON] = "csg-64-spheres";
    long fewer = 0;
    for (int k = 0; k <= TU_N_COMPARISON; k++) {
        scene_t s;
        tu_load_scene(names[k], &s);
        oct_tree_t *tree = tu_scene_octree(&s);
        ray_camera_t cam;
        ivoct_error_t err;
        ivoct_error_clear(&err);
        if (ray_camera_init(&cam, s.camera.eye, s.camera.target, s.camera.up, s.camera.fov, size,
                            size, &err))
            fail_msg("%s: camera: %s", names[k], err.msg);
        for (int m = 0; m < RAY_METHOD_COUNT; m++) {
            ray_image_t first;
            ray_stats_t sf;
            use_path(paths[0]);
            size_t first_short = tape_short_lanes();
            tu_render(&s, &cam, tree, (ray_method_t)m, 1, &first, &sf);
            for (int p = 1; p < npaths; p++) {
                use_path(paths[p]);
                ray_image_t img;
                ray_stats_t st;
                tu_render(&s, &cam, tree, (ray_method_t)m, 1, &img, &st);
                const char *what =
                    difference(&first, &sf, &img, &st, tape_short_lanes() == first_short);
                if (what)
                    fail_msg("%s, %s: %s on path %s differs from path %s", names[k],
                             ray_method_name((ray_method_t)m), what, paths[p], paths[0]);
                fewer += st.tape_evals < sf.tape_evals;
                ray_image_free(&img);
            }
            ray_image_free(&first);
        }
        oct_free(tree);
        scene_free(&s);
    }
    printf("renders %dx%d of %d scenes, %d methods: the same images on %d paths (%ld with "
           "fewer passes on a padding path)\n",
           size, size, TU_N_COMPARISON + 1, RAY_METHOD_COUNT, npaths, fewer);
    tape_simd_select(NULL, NULL);
}

/* tape_simd_select refuses names it does not know, and NULL is the default. */
static void test_select(void **state)
{
    (void)state;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    assert_int_not_equal(tape_simd_select("sse9", &err), 0);
    assert_non_null(strstr(err.msg, "sse9"));
    assert_non_null(strstr(err.msg, "portable"));
    assert_int_equal(tape_simd_available("sse9"), 0);
    assert_int_equal(tape_simd_available(NULL), 0);
    assert_int_equal(tape_simd_available("portable"), 1);
    assert_int_equal(tape_simd_select("portable", &err), 0);
    assert_string_equal(tape_simd_name(), "portable");
    assert_int_equal(tape_simd_select(NULL, &err), 0);
    assert_true(tape_simd_available(tape_simd_name()));
    /* the portable path runs the lanes it is given (no padding) */
    assert_int_equal(tape_simd_select("portable", &err), 0);
    assert_int_equal(tape_short_lanes(), 0);
    assert_int_equal(tape_simd_select(NULL, &err), 0);
    assert_true(tape_short_lanes() <= TAPE_BATCH);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_select),
        cmocka_unit_test(test_evaluators),
        cmocka_unit_test(test_trees),
        cmocka_unit_test(test_renders),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
