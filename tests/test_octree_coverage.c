/* The octree misses no piece of surface: checked against dense sampling, an
 * independent method.
 *
 * For every scene file, built at a modest depth D with the tests "interval"
 * and "interval,lipschitz", and with "interval,lipschitz,ilie" and refine
 * (early leaves, 2% of the box's edge; coarser leaves are expanded):
 *
 *  1. Sign changes.  f is sampled on the grid of depth D+2 (4 samples per leaf
 *     edge), at exactly the cell-bound coordinates oct_coord(lo, hi, i, D+2), so
 *     a sample on a cell face is exactly on it.  The sign of a sample comes from
 *     tape_eval_point, except where |f| is tiny (below 1e-9 times the largest
 *     |f| sampled): there it comes from the MPFI oracle (256 bits), with both
 *     ends of the tape's interval constants (a NaN sample is taken as
 *     undefined and skipped, which can only weaken the check); a sample whose
 *     MPFI sign is not certified (the interval holds 0, or the two ends of the
 *     constants disagree) may be a zero itself.  Every scene's f is continuous
 *     in its box (polynomials; sqrt, abs, exp and min of continuous functions;
 *     the bretzel's denominator is >= 1), so a sign change is a zero.  Then:
 *       - wherever the sign changes between two neighbouring samples along x,
 *         y or z, the segment between them holds a zero, so it must lie in a
 *         surface leaf.  The segment lies in one closed max-depth cell along
 *         its own axis (samples are at multiples of 1/4 of a cell) and on up to
 *         2 cells along each other axis (when it lies on a face or an edge); at
 *         least one of them must be covered by a surface leaf;
 *       - a possible zero sample must lie in a surface leaf (one of the up to
 *         8 closed max-depth cells holding the point).
 *     Coverage is looked up in a bitmap of max-depth cells built from the
 *     leaves list (coarser leaves expanded), not through the tree's nodes.
 *
 *  2. Zero lines without sign change, which sampling cannot see: the z-axis of
 *     the crosscap, the three axes of the Steiner surface, the z-axis of the
 *     Whitney umbrella (whose handle z < 0 has no sign change).  Many points
 *     on them (random, and every cell bound) must lie in surface leaves.
 *
 *  3. Empty cells (found by walking the nodes from nodes[0]): an OCT_INSIDE /
 *     OCT_OUTSIDE cell must have that sign at its centre (MPFI-certified; the
 *     centre is skipped when MPFI cannot certify it); an OCT_UNDEFINED cell
 *     must have f undefined at its centre.
 *
 *  4. The same checks on three surfaces that end at the edge of f's domain
 *     (sqrt, log), where empty cells are also OCT_UNDEFINED.  Every function
 *     here is continuous where defined, so a sign change between two defined
 *     samples is a zero.
 *
 * The machinery is tests/support/coverage.c (shared with the stability suite).
 *
 * IVOCT_ASAN=1 runs at depth 4 instead of 5; IVOCT_TEST_SCALE >= 4 at depth 6. */
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
#include "../scene/scene.h"
#include "support/coverage.h"
#include "support/mpfi_tape.h"
#include "support/testutil.h"

static int depth_for_run(void)
{
    if (tu_sanitizer_build())
        return 4;
    return tu_scale() >= 4 ? 6 : 5;
}

static const char *base_name(const char *path)
{
    const char *s = strrchr(path, '/');
    return s ? s + 1 : path;
}

/* Checks 1-3 on a scene, for the four test lists; returns the empty cells found
 * undefined. */
static long check_loaded(const scene_t *s, const char *name, int depth)
{
    cov_line_t lines[3];
    int n_lines = 0;
    if (!strcmp(name, "crosscap.ini")) {
        lines[n_lines++] = (cov_line_t){2, -INFINITY, INFINITY};
    } else if (!strcmp(name, "steiner-roman.ini")) {
        for (int a = 0; a < 3; a++)
            lines[n_lines++] = (cov_line_t){a, -INFINITY, INFINITY};
    } else if (!strcmp(name, "whitney-umbrella.ini")) {
        lines[n_lines++] = (cov_line_t){2, -INFINITY, 0.0}; /* the handle */
        lines[n_lines++] = (cov_line_t){2, 0.0, INFINITY};
    }
    cov_summary_t sum;
    cov_check_all(s->tape, s->box, name, depth, COV_CFG_ALL, lines, n_lines, &sum);
    /* not vacuous: every scene's surface crosses its box, and most of the box
     * is decided empty with a certifiable sign */
    assert_true(sum.min_segments > 0);
    assert_true(sum.min_empty_checked > 0);
    return sum.undefined;
}

static void check_scene(const char *path, int depth)
{
    scene_t s;
    tu_load_scene(path, &s);
    check_loaded(&s, base_name(path), depth);
    scene_free(&s);
}

static void test_every_scene(void **state)
{
    (void)state;
    char **paths;
    int n = tu_scene_files(&paths);
    int depth = depth_for_run();
    int seen_lines = 0;
    for (int i = 0; i < n; i++) {
        const char *b = base_name(paths[i]);
        seen_lines += !strcmp(b, "crosscap.ini") || !strcmp(b, "steiner-roman.ini") ||
                      !strcmp(b, "whitney-umbrella.ini");
        check_scene(paths[i], depth);
    }
    assert_int_equal(seen_lines, 3);
    tu_free_list(paths, n);
}

/* Surfaces that end at the edge of f's domain: cells where f is defined
 * nowhere must be OCT_UNDEFINED (and f undefined at their centres), and the
 * surface must still be covered up to the domain's edge.  f is continuous
 * where defined, so a sign change between two defined samples is a zero. */
static void test_domain_edges(void **state)
{
    (void)state;
    static const struct {
        const char *f;
        double box[6];
    } cases[] = {
        {"sqrt(x) + y^2 + z^2 - 0.5", {-1, 1, -1, 1, -1, 1}},
        {"log(x) + y^2 + z^2", {-1, 2, -1, 1, -1, 1}},
        {"sqrt(1 - x^2 - y^2 - z^2) - 0.5", {-1.5, 1.5, -1.5, 1.5, -1.5, 1.5}},
    };
    int depth = depth_for_run();
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        scene_t s;
        ivoct_error_t err;
        ivoct_error_clear(&err);
        if (scene_from_expr(cases[i].f, cases[i].box, &s, &err) != 0)
            fail_msg("%s: %s", cases[i].f, err.msg);
        long undefined = check_loaded(&s, cases[i].f, depth);
        assert_true(undefined > 0); /* not vacuous */
        scene_free(&s);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_scene),
        cmocka_unit_test(test_domain_edges),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
