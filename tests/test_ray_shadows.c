/* Certified shadows (ray/README.md, "Shadows") against the MPFR reference
 * (tests/support/ray_reference.c), not against the renderer's own output.
 *
 * On the eight comparison surfaces (each scene's camera, 48x48), with a point
 * light to the side of the target (so that the images hold both cast and
 * attached shadows), every certified method, with the box source and with the
 * scene's octree.  For every hit pixel whose shadow the renderer decided
 * (RAY_LIT or RAY_SHADOWED), the shadow ray is rebuilt from the image alone --
 * its end q from ray_shadow_origin and the pixel's t, its direction q - light
 * rounded per axis as the renderer does -- and the reference decides whether
 * f has a root on it (rref_ray over the part of [0, 1] in the box):
 *  - strict: where the reference is not ambiguous (the ray passes within ~1e-9
 *    of touching the surface, or the surface is within ~1e-9 of where the ray
 *    enters or leaves the box or of q), RAY_SHADOWED exactly where it has a
 *    root;
 *  - exempt, counted: ambiguous rays; even there a root away from the box
 *    faces must not be called lit (a lit pixel is a certified exclusion);
 *  - undecided pixels (counted as shadow by the renderer) are counted; those
 *    where the reference is lit and not ambiguous (a shadow that was
 *    conservative for nothing) are bounded at UNDECIDED_PERMILLE per mille
 *    of the hits.
 * Not vacuous: the reference finds shadowed and lit pixels on every surface.
 *
 * The any-hit search the shadow rays run (ray_opts_t.any_root), on random
 * rays through each surface's box, every certified method: it misses exactly
 * where the full search misses; where it reports a root, the reference has a
 * root in its bracket [t_lo, t_hi], and the full search's first hit is not
 * after it.  The same ray cut into 1..8 segments (ray_find_root_n, which the
 * shadow rays feed up to RAY_MAX_SEGMENTS leaves at a time): the same
 * hit/miss, a certified root at the same t to 1e-12, `which` the segment
 * holding the bracket's start, and with any_root the same misses.
 *
 * Then, on gumdrop and on the CSG union (leaf tapes): 1 and 2 threads give
 * the same buffers byte for byte; leaf tapes built with the light's margin
 * give the same shadows as the scene's tape; the .vti carries the shadow
 * array and the light.
 *
 * IVOCT_ASAN=1: 16x16 images, octrees of depth 6 at most. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "../octree/octree.h"
#include "../ray/ray.h"
#include "../scene/scene.h"
#include "support/ray_reference.h"
#include "support/testutil.h"

#define UNDECIDED_PERMILLE 2

enum { SRC_BOX, SRC_OCTREE, NSRC };
static const char *const SRC_NAME[NSRC] = {"box", "octree"};

/* The scene's camera at size x size, and tu_side_light of it. */
static void camera_and_light(const scene_t *s, int size, ray_camera_t *cam, double light[3])
{
    ivoct_error_t err;
    ivoct_error_clear(&err);
    assert_int_equal(ray_camera_init(cam, s->camera.eye, s->camera.target, s->camera.up,
                                     s->camera.fov, size, size, &err),
                     0);
    tu_side_light(cam, light);
}

static void render(const scene_t *s, const ray_camera_t *cam, const oct_tree_t *tree,
                   const oct_leaf_tapes_t *tapes, ray_method_t m, const double light[3],
                   int threads, ray_image_t *img, ray_stats_t *st)
{
    ivoct_error_t err;
    ivoct_error_clear(&err);
    assert_int_equal(ray_image_alloc(img, cam->width, cam->height, &err), 0);
    ray_box_source_t bs;
    ray_octree_source_t os;
    ray_source_t src = tree ? ray_octree_source(&os, tree) : ray_box_source(&bs, s->box);
    if (tree)
        os.tapes = tapes;
    ray_render_opts_t o;
    ray_render_opts_default(&o);
    o.method = m;
    o.threads = threads;
    o.light_on = 1;
    memcpy(o.light, light, sizeof o.light);
    if (ray_render(s->tape, cam, &src, &o, img, st, &err))
        fail_msg("render: %s", err.msg);
    assert_int_equal(img->lit, 1);
}

/* The reference of the shadow ray of pixel i: 1 root, 0 none, and whether
 * it is ambiguous and whether a root lies away from the box faces. */
typedef struct shadow_ref {
    int hit, ambiguous, near_box;
} shadow_ref_t;

static shadow_ref_t reference(rref_t *ref, const scene_t *s, const ray_camera_t *cam,
                              const ray_image_t *img, size_t i, const double light[3])
{
    double q[3], d[3];
    ray_shadow_origin(cam->eye, img->dir + 3 * i, img->t[i], q);
    for (int a = 0; a < 3; a++)
        d[a] = q[a] - light[a];
    shadow_ref_t out = {0, 0, 0};
    double s0, s1;
    if (!ray_clip_box(s->box, light, d, &s0, &s1) || s0 > 1)
        fail_msg("pixel %zu: the shadow ray misses the box it ends in", i);
    rref_result_t r;
    rref_ray(ref, light, d, s0 > 0 ? s0 : 0, s1 < 1 ? s1 : 1, &r);
    out.hit = r.hit;
    out.ambiguous = r.ambiguous;
    out.near_box = r.near_box;
    return out;
}

static void test_shadows_against_reference(void **state)
{
    (void)state;
    const int size = tu_image_size(48);
    printf("%dx%d pixels\n", size, size);
    printf("%-15s %-7s %-13s %5s %6s %6s %6s %6s %6s %9s %9s\n", "surface", "source", "method",
           "hits", "shadow", "lit", "undec", "u-lit", "exempt", "evals/ray", "shadow/pr");
    size_t failures = 0;
    for (size_t k = 0; k < TU_N_COMPARISON; k++) {
        const char *name = tu_comparison_surfaces[k];
        scene_t s;
        tu_load_scene(name, &s);
        ray_camera_t cam;
        double light[3];
        camera_and_light(&s, size, &cam, light);
        assert_true(rref_supported(s.tape));
        rref_t *ref = rref_new(s.tape);
        assert_non_null(ref);
        oct_tree_t *tree = tu_scene_octree(&s);
        size_t ref_shadowed = 0, ref_lit = 0;
        for (int j = 0; j < NSRC; j++)
            for (int m = 0; m < RAY_METHOD_COUNT; m++) {
                if (!ray_method_certified((ray_method_t)m))
                    continue;
                ray_image_t img;
                ray_stats_t st;
                render(&s, &cam, j == SRC_OCTREE ? tree : NULL, NULL, (ray_method_t)m, light, 2,
                       &img, &st);
                size_t n_sh = 0, n_lit = 0, n_und = 0, und_lit = 0, exempt = 0;
                for (size_t i = 0; i < (size_t)size * size; i++) {
                    if (!img.hit[i]) {
                        assert_int_equal(img.shadow[i], RAY_LIT);
                        continue;
                    }
                    shadow_ref_t r = reference(ref, &s, &cam, &img, i, light);
                    int sh = img.shadow[i];
                    if (j == SRC_BOX && m == RAY_NEWTON_AH && !r.ambiguous)
                        r.hit ? ref_shadowed++ : ref_lit++;
                    n_sh += sh == RAY_SHADOWED, n_lit += sh == RAY_LIT;
                    const char *bad = NULL;
                    if (sh == RAY_SHADOW_UNDECIDED) {
                        n_und++;
                        if (!r.hit && !r.ambiguous)
                            und_lit++;
                    } else if (r.ambiguous) {
                        exempt++;
                        if (r.hit && !r.near_box && sh == RAY_LIT)
                            bad = "lit, ambiguous, but a root away from the box faces";
                    } else if ((sh == RAY_SHADOWED) != r.hit) {
                        bad = r.hit ? "lit where the reference has a root"
                                    : "shadowed where the reference has no root";
                    }
                    if (bad) {
                        if (failures < 10)
                            printf("%s %s %s pixel %zu: %s\n", name, SRC_NAME[j],
                                   ray_method_name((ray_method_t)m), i, bad);
                        failures++;
                    }
                }
                assert_int_equal(n_sh, st.shadowed);
                assert_int_equal(n_und, st.shadow_undecided);
                assert_int_equal(st.shadow_rays, st.hits);
                if (und_lit * 1000 > UNDECIDED_PERMILLE * st.hits) {
                    printf("%s %s %s: %zu undecided shadows where the reference is lit\n", name,
                           SRC_NAME[j], ray_method_name((ray_method_t)m), und_lit);
                    failures++;
                }
                double primary = (double)(st.tape_evals - st.shadow_evals);
                printf("%-15s %-7s %-13s %5llu %6zu %6zu %6zu %6zu %6zu %9.1f %9.2f\n", name,
                       SRC_NAME[j], ray_method_name((ray_method_t)m),
                       (unsigned long long)st.hits, n_sh, n_lit, n_und, und_lit, exempt,
                       (double)st.tape_evals / ((double)size * size),
                       primary > 0 ? (double)st.shadow_evals / primary : 0.0);
                ray_image_free(&img);
            }
        /* not vacuous: the light casts shadows and leaves light */
        if (ref_shadowed == 0 || ref_lit == 0) {
            printf("%s: the reference has %zu shadowed and %zu lit hits\n", name, ref_shadowed,
                   ref_lit);
            failures++;
        }
        rref_free(ref);
        oct_free(tree);
        scene_free(&s);
    }
    rref_thread_cleanup();
    assert_int_equal(failures, 0);
}

static void assert_same_image(const ray_image_t *a, const ray_image_t *b, const char *what)
{
    size_t n = (size_t)a->width * a->height;
    if (memcmp(a->shadow, b->shadow, n) || memcmp(a->rgb, b->rgb, 3 * n) ||
        memcmp(a->hit, b->hit, n) || memcmp(a->t, b->t, n * sizeof *a->t) ||
        memcmp(a->normal, b->normal, 3 * n * sizeof *a->normal))
        fail_msg("%s: the buffers differ", what);
}

/* Threads, leaf tapes and the .vti, on a polynomial and on the CSG union. */
static void test_shadows_threads_tapes_vti(void **state)
{
    (void)state;
    const char *names[] = {"gumdrop", "csg-64-spheres"};
    const int size = tu_image_size(48);
    for (size_t k = 0; k < sizeof names / sizeof *names; k++) {
        scene_t s;
        tu_load_scene(names[k], &s);
        ivoct_error_t err;
        ivoct_error_clear(&err);
        ray_camera_t cam;
        double light[3];
        camera_and_light(&s, size, &cam, light);
        oct_tree_t *tree = tu_scene_octree(&s);
        ray_image_t one, two;
        ray_stats_t st1, st2;
        render(&s, &cam, tree, NULL, RAY_NEWTON_AH, light, 1, &one, &st1);
        render(&s, &cam, tree, NULL, RAY_NEWTON_AH, light, 2, &two, &st2);
        assert_same_image(&one, &two, names[k]);
        assert_int_equal(st1.shadow_evals, st2.shadow_evals);
        assert_true(st1.shadowed > 0 && st1.shadowed < st1.hits);
        if (tape_has_choices(s.tape)) {
            /* leaf tapes need the light's margin too */
            double margin = fmax(ray_tape_margin(&cam, s.box), ray_light_tape_margin(light, s.box));
            oct_leaf_tapes_t *lt = NULL;
            assert_int_equal(oct_leaf_tapes_build(tree, s.tape, margin, 1.0, &lt, &err), 0);
            ray_image_t with;
            ray_stats_t stw;
            render(&s, &cam, tree, lt, RAY_NEWTON_AH, light, 2, &with, &stw);
            for (size_t i = 0; i < (size_t)size * size; i++)
                if (with.hit[i] != one.hit[i] || with.shadow[i] != one.shadow[i])
                    fail_msg("%s pixel %zu: leaf tapes change the hit or the shadow", names[k],
                             i);
            printf("%s: leaf tapes: %llu shadow tape passes, scene's tape %llu\n", names[k],
                   (unsigned long long)stw.shadow_evals, (unsigned long long)st1.shadow_evals);
            ray_image_free(&with);
            oct_leaf_tapes_free(lt);
        }
        /* the .vti: the shadow array (0/1) and the light as field data */
        size_t len = 0;
        char *buf = NULL;
        FILE *f = open_memstream(&buf, &len);
        assert_non_null(f);
        assert_int_equal(ray_write_vti(f, &one, &cam, "newton-ah", &err), 0);
        fclose(f);
        assert_non_null(strstr(buf, "Name=\"shadow\""));
        assert_non_null(strstr(buf, "Name=\"light\""));
        free(buf);
        ray_image_free(&one);
        ray_image_free(&two);
        oct_free(tree);
        scene_free(&s);
    }
}

/* ray_opts_t.any_root against the full search and the reference. */
static void test_any_root(void **state)
{
    (void)state;
    uint64_t rng = tu_seed(0x5eedULL);
    const int rays = tu_scale() < 1 ? 40 : 200;
    size_t roots = 0, misses = 0, failures = 0;
    for (size_t k = 0; k < TU_N_COMPARISON; k++) {
        scene_t s;
        tu_load_scene(tu_comparison_surfaces[k], &s);
        rref_t *ref = rref_new(s.tape);
        assert_non_null(ref);
        tape_ws_t *ws = tape_ws_new(s.tape->n);
        assert_non_null(ws);
        for (int r = 0; r < rays; r++) {
            /* from a point outside the box through a random point of it */
            double o[3], p[3], d[3], len = 0;
            for (int a = 0; a < 3; a++) {
                double lo = s.box[2 * a], hi = s.box[2 * a + 1], w = hi - lo;
                p[a] = tu_lerp(lo, hi, tu_uniform(&rng));
                o[a] = tu_lerp(lo - w, hi + w, tu_uniform(&rng));
                if (a == 0)
                    o[a] = hi + w; /* outside on x */
                d[a] = p[a] - o[a];
                len += d[a] * d[a];
            }
            for (int a = 0; a < 3; a++)
                d[a] /= sqrt(len);
            double t0, t1;
            if (!ray_clip_box(s.box, o, d, &t0, &t1))
                continue;
            for (int m = 0; m < RAY_METHOD_COUNT; m++) {
                if (!ray_method_certified((ray_method_t)m))
                    continue;
                ray_opts_t full, any;
                ray_opts_default(&full);
                any = full;
                any.any_root = 1;
                ray_result_t rf, ra;
                ray_find_root(s.tape, ws, (ray_method_t)m, &full, o, d, t0, t1, &rf);
                ray_find_root(s.tape, ws, (ray_method_t)m, &any, o, d, t0, t1, &ra);
                const char *bad = NULL;
                if ((ra.kind == RAY_MISS) != (rf.kind == RAY_MISS))
                    bad = "the any-hit search and the full one disagree on hit/miss";
                else if (ra.kind == RAY_HIT_ROOT) {
                    rref_result_t q;
                    rref_ray(ref, o, d, ra.t_lo, ra.t_hi, &q);
                    if (!q.hit && !q.ambiguous)
                        bad = "no root of the reference in the any-hit bracket";
                    else if (!(rf.t <= ra.t_hi))
                        bad = "the first hit lies after the any-hit bracket";
                    roots++;
                    if (ra.evals > rf.evals)
                        bad = "the any-hit search took more passes than the full one";
                }
                misses += ra.kind == RAY_MISS;
                /* the ray in pieces */
                int nseg = 1 + r % RAY_MAX_SEGMENTS, which = -2;
                double c0[RAY_MAX_SEGMENTS], c1[RAY_MAX_SEGMENTS];
                for (int j = 0; j < nseg; j++) {
                    c0[j] = j ? c1[j - 1] : t0;
                    c1[j] = j + 1 < nseg ? tu_lerp(c0[j], t1, tu_uniform(&rng) * 2.0 / (nseg - j)) : t1;
                }
                ray_result_t rn, rna;
                ray_find_root_n(s.tape, ws, (ray_method_t)m, &full, o, d, nseg, c0, c1, &rn, &which);
                ray_find_root_n(s.tape, ws, (ray_method_t)m, &any, o, d, nseg, c0, c1, &rna, NULL);
                int tangent = rn.kind == RAY_HIT_TANGENT || rf.kind == RAY_HIT_TANGENT ||
                              rn.kind == RAY_HIT_BUDGET || rf.kind == RAY_HIT_BUDGET;
                if (!bad && !tangent && (rn.kind == RAY_MISS) != (rf.kind == RAY_MISS))
                    bad = "in pieces, another hit/miss than in one segment";
                else if (!bad && rn.kind == RAY_HIT_ROOT && rf.kind == RAY_HIT_ROOT &&
                         !(fabs(rn.t - rf.t) <= 1e-12 * fabs(rf.t)))
                    bad = "in pieces, another root than in one segment";
                else if (!bad && rn.kind != RAY_MISS &&
                         !(which >= 0 && c0[which] <= rn.t_lo && rn.t_lo <= c1[which]))
                    bad = "which is not the segment that holds the bracket's start";
                else if (!bad && (rna.kind == RAY_MISS) != (rn.kind == RAY_MISS))
                    bad = "in pieces, the any-hit search and the full one disagree on hit/miss";
                if (bad) {
                    if (failures < 10)
                        printf("%s %s ray %d: %s (any: kind %d [%.17g, %.17g]; full: kind %d "
                               "t %.17g)\n",
                               tu_comparison_surfaces[k], ray_method_name((ray_method_t)m), r,
                               bad, ra.kind, ra.t_lo, ra.t_hi, rf.kind, rf.t);
                    failures++;
                }
            }
        }
        tape_ws_free(ws);
        rref_free(ref);
        scene_free(&s);
    }
    rref_thread_cleanup();
    printf("any-hit: %zu proven roots, %zu misses\n", roots, misses);
    assert_true(roots > 0 && misses > 0);
    assert_int_equal(failures, 0);
}

/* The shadow ray's end lies before the hit on the primary ray, by 2^-20 t. */
static void test_shadow_origin(void **state)
{
    (void)state;
    const double eye[3] = {3, -1, 2}, d[3] = {-0.6, 0.0, -0.8};
    for (double t = 1e-3; t < 1e4; t *= 3.7) {
        double q[3], p[3];
        double tq = ray_shadow_origin(eye, d, t, q);
        assert_true(tq < t && tq >= t - 0x1.1p-20 * t);
        ray_point(eye, d, tq, p);
        assert_memory_equal(p, q, sizeof p);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_shadow_origin),
        cmocka_unit_test(test_any_root),
        cmocka_unit_test(test_shadows_threads_tapes_vti),
        cmocka_unit_test(test_shadows_against_reference),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
