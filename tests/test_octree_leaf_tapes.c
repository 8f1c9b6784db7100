/* The pruned tape of every leaf (octree.h, oct_leaf_tapes_build) against MPFI,
 * and the renders that use them.
 *
 * For every scene: the octree at a small depth, the leaf tapes with a margin;
 * for leaves of every depth, points of the leaf box grown by the margin
 * (corners, centre, random points) are evaluated in MPFI with the root tape
 * and with the leaf's tape.  Property: where the root tape is defined, the
 * leaf tape is defined too and the two 256-bit enclosures meet (they enclose
 * the same real number), at either end of the interval constants; no leaf
 * tape is longer than the root tape.  On the CSG scene the leaf tapes must
 * be short (pruning is what they are for).  Then the scenes whose tapes have
 * choices are rendered with and without leaf tapes: every pixel must agree on
 * hit or miss and on the hit, to the root finders' certified tolerance. */
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
#include "support/mpfi_tape.h"
#include "support/testutil.h"

/* Do the enclosures of f by both tapes at p meet, at this end of the constants?
 * -1: the root tape is undefined at p (nothing to check). */
static int same_value(const tape_t *root, const tape_t *leaf, const double p[3],
                      oracle_const_t end)
{
    mpfi_t a, b;
    mpfi_init2(a, ORACLE_PREC);
    mpfi_init2(b, ORACLE_PREC);
    int ok = -1;
    if (oracle_eval(root, p, end, a, NULL) == 0) {
        ok = oracle_eval(leaf, p, end, b, NULL) == 0;
        if (ok) {
            mpfi_t c;
            mpfi_init2(c, ORACLE_PREC);
            mpfi_intersect(c, a, b);
            ok = !mpfi_is_empty(c);
            mpfi_clear(c);
        }
    }
    mpfi_clear(a);
    mpfi_clear(b);
    return ok;
}

typedef struct {
    long leaves, points, pruned_leaves;
    double clauses; /* sum of the leaf tapes' lengths over the leaves checked */
} counts_t;

static void check_leaf(const char *name, const oct_tree_t *tree, const tape_t *root,
                       const tape_t *leaf, uint32_t i, double margin, uint64_t *rng,
                       counts_t *c)
{
    if (leaf->n > root->n)
        fail_msg("%s: leaf %u has a tape of %u clauses, longer than the root's %u", name, i,
                 leaf->n, root->n);
    iv_box_t b = oct_leaf_box(tree, &tree->leaves[i]);
    iv_box_t g = {{b.x.lo - margin, b.x.hi + margin},
                  {b.y.lo - margin, b.y.hi + margin},
                  {b.z.lo - margin, b.z.hi + margin}};
    for (int k = 0; k < 16; k++) {
        double p[3]; /* corners of the grown box, its centre, its faces, inside */
        tu_box_point(&g, k, rng, p);
        for (int e = 0; e < 2; e++) {
            int ok = same_value(root, leaf, p, e ? ORACLE_CONST_HI : ORACLE_CONST_LO);
            if (ok == 0)
                fail_msg("%s: leaf %u (tape of %u clauses): f differs at (%.17g, %.17g, %.17g)",
                         name, i, leaf->n, p[0], p[1], p[2]);
            c->points += ok == 1;
        }
    }
    c->leaves++;
    c->pruned_leaves += leaf != root && leaf->n < root->n;
    c->clauses += leaf->n;
}

static void test_every_scene(void **state)
{
    (void)state;
    char **paths;
    int n = tu_scene_files(&paths);
    assert_true(n >= 19);
    uint64_t rng = tu_seed(20261201);
    int depth = tu_sanitizer_build() ? 4 : 5, with_choices = 0;
    for (int s = 0; s < n; s++) {
        scene_t sc;
        tu_load_scene(paths[s], &sc);
        oct_params_t p = {0};
        p.depth = depth;
        p.tests = OCT_TEST_INTERVAL;
        p.threads = 2;
        oct_tree_t *tree;
        ivoct_error_t err;
        assert_int_equal(oct_build(sc.tape, sc.box, &p, &tree, &err), 0);
        /* a margin far larger than rounding, so that growing the boxes counts */
        double margin = 0x1p-20 * (sc.box[1] - sc.box[0]);
        oct_leaf_tapes_t *lt;
        assert_int_equal(oct_leaf_tapes_build(tree, sc.tape, margin, 1.0, &lt, &err), 0);
        assert_int_equal(lt->n_leaves, tree->n_leaves);
        int choices = tape_has_choices(sc.tape);
        with_choices += choices;
        if (!choices) /* nothing to prune: every leaf has the root tape */
            assert_int_equal(lt->n_tapes, 0);
        counts_t c = {0};
        /* every leaf of a small tree, else a stride through the Morton order */
        uint32_t step = tree->n_leaves / 400 + 1;
        for (uint32_t i = 0; i < tree->n_leaves; i += step) {
            const tape_t *leaf = lt->of_leaf[i];
            if (!choices)
                assert_ptr_equal(leaf->clauses, sc.tape->clauses);
            check_leaf(paths[s], tree, sc.tape, leaf, i, margin, &rng, &c);
        }
        printf("%-32s %7u leaves, %5zu tapes stored, %5ld leaves checked (%ld pruned, mean "
               "%.1f of %u clauses), %6ld points\n",
               paths[s], tree->n_leaves, lt->n_tapes, c.leaves, c.pruned_leaves,
               c.leaves ? c.clauses / (double)c.leaves : 0.0, sc.tape->n, c.points);
        if (strstr(paths[s], "csg-64-spheres")) {
            /* 64 spheres: a leaf of a depth-5 tree meets a few of them */
            assert_true(c.pruned_leaves == c.leaves);
            assert_true(c.clauses / (double)c.leaves < 0.25 * sc.tape->n);
        }
        /* with the probe: either the whole walk, as above, or every leaf the root tape */
        oct_leaf_tapes_t *probed;
        assert_int_equal(oct_leaf_tapes_build(tree, sc.tape, margin, 0.75, &probed, &err), 0);
        if (probed->n_tapes == 0) {
            for (uint32_t i = 0; i < tree->n_leaves; i++)
                assert_ptr_equal(probed->of_leaf[i]->clauses, sc.tape->clauses);
            assert_true(probed->mean_clauses == sc.tape->n);
        } else {
            assert_int_equal(probed->n_tapes, lt->n_tapes);
            for (uint32_t i = 0; i < tree->n_leaves; i++)
                assert_int_equal(probed->of_leaf[i]->n, lt->of_leaf[i]->n);
        }
        /* the CSG union's top levels prune well; the thin shell's abs does not */
        if (strstr(paths[s], "csg-64-spheres"))
            assert_true(probed->n_tapes > 0);
        if (strstr(paths[s], "thin-shell"))
            assert_int_equal(probed->n_tapes, 0);
        oct_leaf_tapes_free(probed);
        oct_leaf_tapes_free(lt);
        oct_free(tree);
        scene_free(&sc);
    }
    assert_true(with_choices >= 2); /* the CSG union and the thin shell at least */
    tu_free_list(paths, n);
}

/* Renders with and without leaf tapes agree. */
static void render_both(const char *name)
{
    scene_t sc;
    tu_load_scene(name, &sc);
    oct_params_t p = {0};
    p.depth = tu_sanitizer_build() ? 5 : 7;
    p.tests = OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ;
    p.threads = 2;
    oct_tree_t *tree;
    ivoct_error_t err;
    assert_int_equal(oct_build(sc.tape, sc.box, &p, &tree, &err), 0);
    int w = tu_sanitizer_build() ? 40 : 120, h = w * 3 / 4;
    ray_camera_t cam;
    assert_int_equal(ray_camera_init(&cam, sc.camera.eye, sc.camera.target, sc.camera.up, sc.camera.fov, w, h, &err), 0);
    oct_leaf_tapes_t *lt;
    assert_int_equal(
        oct_leaf_tapes_build(tree, sc.tape, ray_tape_margin(&cam, sc.box), 1.0, &lt, &err), 0);
    for (int m = 0; m < RAY_METHOD_COUNT; m++) {
        if (!ray_method_certified((ray_method_t)m))
            continue;
        ray_image_t img[2];
        for (int k = 0; k < 2; k++) {
            ray_octree_source_t os;
            ray_source_t src = ray_octree_source(&os, tree);
            os.tapes = k ? lt : NULL;
            ray_render_opts_t ro;
            ray_render_opts_default(&ro);
            ro.method = (ray_method_t)m;
            ro.threads = 2;
            ray_stats_t st;
            assert_int_equal(ray_image_alloc(&img[k], w, h, &err), 0);
            assert_int_equal(ray_render(sc.tape, &cam, &src, &ro, &img[k], &st, &err), 0);
        }
        long hits = 0;
        for (int i = 0; i < w * h; i++) {
            if (img[0].hit[i] != img[1].hit[i])
                fail_msg("%s %s: pixel %d: %s with the root tape, %s with the leaf's", name,
                         ray_method_name((ray_method_t)m), i, img[0].hit[i] ? "hit" : "miss",
                         img[1].hit[i] ? "hit" : "miss");
            if (!img[0].hit[i])
                continue;
            hits++;
            /* both are certified to ro.roots.tol_rel (2^-44) of t */
            double t0 = img[0].t[i], t1 = img[1].t[i];
            if (fabs(t0 - t1) > 0x1p-42 * fmax(fabs(t0), fabs(t1)))
                fail_msg("%s %s: pixel %d: hit at %.17g with the root tape, %.17g with the "
                         "leaf's",
                         name, ray_method_name((ray_method_t)m), i, t0, t1);
        }
        assert_true(hits > w * h / 20); /* the surface is in view */
        ray_image_free(&img[0]);
        ray_image_free(&img[1]);
    }
    oct_leaf_tapes_free(lt);
    oct_free(tree);
    scene_free(&sc);
}

static void test_render_csg(void **state)
{
    (void)state;
    render_both("csg-64-spheres");
}

static void test_render_thin_shell(void **state)
{
    (void)state;
    render_both("thin-shell");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_scene),
        cmocka_unit_test(test_render_csg),
        cmocka_unit_test(test_render_thin_shell),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
