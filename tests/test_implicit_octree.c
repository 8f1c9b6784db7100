/* The octree of a parametric scene holds its parametric points.
 *
 * For every scenes/param-*.ini: the scene is loaded (implicitized by implicit/),
 * its octree built, and 10^4 random points of the patch (u, v rational, the point
 * X(u,v), Y(u,v), Z(u,v) exact from imp_param_eval, then enclosed in MPFR at 256
 * bits, rounded down and up) are each found in a surface leaf: the tree is walked
 * from the root into every child whose closed box meets the point's enclosure,
 * and some path must end at a leaf (none at a cell decided empty).  This checks
 * the whole chain at once: the implicitization (f vanishes on the surface), the
 * tape compiled from f's nested text, and the octree's promise that no cell that
 * holds surface is discarded.  Points of the patch outside the scene's box are not
 * counted.
 */
#include <glob.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>
#include <gmp.h>
#include <mpfr.h>

#include "../implicit/implicit.h"
#include "../octree/octree.h"
#include "../scene/scene.h"
#include "support/testutil.h"

/* The point's enclosure, per axis. */
typedef struct {
    double lo[3], hi[3];
} point_box_t;

/* Does the subtree at node i (cell code, depth) hold a leaf that contains p? */
static int in_surface_leaf(const oct_tree_t *t, uint32_t i, uint64_t code, int depth,
                           const point_box_t *p)
{
    oct_node_t v = t->nodes[i];
    switch (OCT_NODE_KIND(v)) {
    case OCT_LEAF:
        return 1;
    case OCT_EMPTY:
        return 0;
    default:
        break;
    }
    uint32_t first = OCT_NODE_VALUE(v);
    for (uint32_t k = 0; k < 8; k++) {
        uint64_t c = code << 3 | k;
        uint32_t ix, iy, iz;
        oct_unmorton(c, depth + 1, &ix, &iy, &iz);
        iv_box_t b = oct_cell_box(t->box, depth + 1, ix, iy, iz);
        if (p->hi[0] < b.x.lo || p->lo[0] > b.x.hi || p->hi[1] < b.y.lo || p->lo[1] > b.y.hi ||
            p->hi[2] < b.z.lo || p->lo[2] > b.z.hi)
            continue;
        if (in_surface_leaf(t, first + k, c, depth + 1, p))
            return 1;
    }
    return 0;
}

static void check_scene(const char *path, int depth, int want_points)
{
    scene_t s;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    if (scene_load(path, &s, &err)) {
        char buf[1024];
        fail_msg("%s", ivoct_error_format(&err, buf, sizeof buf));
    }
    assert_non_null(s.implicit);
    for (int k = 0; k < 4; k++)
        assert_false(isnan(s.source.patch[k])); /* the shipped scenes give their patch */
    imp_param_t *param;
    int which;
    const char *texts[3] = {s.source.param[0], s.source.param[1], s.source.param[2]};
    assert_int_equal(imp_param_parse(texts, &param, &which, &err), IMP_OK);

    oct_params_t op = s.octree;
    op.depth = depth;
    op.threads = 2;
    oct_tree_t *t;
    if (oct_build(s.tape, s.box, &op, &t, &err))
        fail_msg("%s: %s", path, err.msg);

    mpq_t u, v, xyz[3];
    mpq_inits(u, v, xyz[0], xyz[1], xyz[2], NULL);
    mpfr_t r;
    mpfr_init2(r, 256);
    uint64_t rng = tu_seed(0x9a7a3e7e5ull);
    int inside = 0, outside = 0, poles = 0, missed = 0;
    while (inside < want_points) {
        /* u, v: doubles of the patch, exact rationals */
        double du = s.source.patch[0] + (s.source.patch[1] - s.source.patch[0]) * tu_uniform(&rng);
        double dv = s.source.patch[2] + (s.source.patch[3] - s.source.patch[2]) * tu_uniform(&rng);
        mpq_set_d(u, du);
        mpq_set_d(v, dv);
        if (imp_param_eval(param, u, v, xyz)) {
            poles++;
            assert_true(poles < 100);
            continue;
        }
        point_box_t p;
        for (int k = 0; k < 3; k++) {
            mpfr_set_q(r, xyz[k], MPFR_RNDD);
            p.lo[k] = mpfr_get_d(r, MPFR_RNDD);
            mpfr_set_q(r, xyz[k], MPFR_RNDU);
            p.hi[k] = mpfr_get_d(r, MPFR_RNDU);
        }
        int in_box = 1;
        for (int k = 0; k < 3; k++)
            in_box &= p.lo[k] >= s.box[2 * k] && p.hi[k] <= s.box[2 * k + 1];
        if (!in_box) {
            outside++;
            continue;
        }
        inside++;
        if (!in_surface_leaf(t, 0, 0, 0, &p)) {
            if (missed++ < 5)
                printf("%s: the point of (u, v) = (%.17g, %.17g), (%.17g, %.17g, %.17g), is in "
                       "no surface leaf\n",
                       path, du, dv, p.lo[0], p.lo[1], p.lo[2]);
        }
    }
    printf("%-28s depth %d, %u leaves: %d points of the patch, each in a surface leaf "
           "(%d outside the box, %d at poles), %d missed\n",
           strrchr(path, '/') + 1, depth, t->n_leaves, inside, outside, poles, missed);
    assert_int_equal(missed, 0);
    mpfr_clear(r);
    mpq_clears(u, v, xyz[0], xyz[1], xyz[2], NULL);
    oct_free(t);
    imp_param_free(param);
    scene_free(&s);
}

static void test_points_in_leaves(void **state)
{
    (void)state;
    char pattern[4096];
    snprintf(pattern, sizeof pattern, "%s/scenes/param-*.ini", tu_source_dir());
    glob_t g;
    assert_int_equal(glob(pattern, 0, NULL, &g), 0);
    assert_true(g.gl_pathc >= 6);
    int depth = tu_sanitizer_build() ? 5 : 7;
    for (size_t i = 0; i < g.gl_pathc; i++)
        check_scene(g.gl_pathv[i], depth, 10000);
    globfree(&g);
    mpfr_free_cache();
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_points_in_leaves),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
