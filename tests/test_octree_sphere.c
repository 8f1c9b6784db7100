/* The unit sphere, where everything about the octree can be computed exactly.
 *
 * scenes/sphere.ini: f = x^2 + y^2 + z^2 - 1 in [-1.05, 1.05]^3, built at depths
 * 4..8 (4..7 under IVOCT_ASAN) with "interval" and "interval,lipschitz".  The
 * cells of depth d are cubes of edge h = 2.1 / 2^d and diagonal diag = h sqrt 3.
 *
 * An independent classification of every cell of depth d, from its bounds
 * only (oct_coord, as the builder uses): with dmin, dmax the smallest and
 * largest |p| over the closed cell and a margin eps = 1e-9 for rounding,
 *   crossed   dmin^2 < 1 - eps and dmax^2 > 1 + eps: the cell holds points
 *             inside and outside the sphere, so (being connected) points of
 *             it: it MUST be a surface leaf (the octree's guarantee);
 *   clear     dmin^2 > 1 + eps or dmax^2 < 1 - eps: no point of the sphere;
 *             f is a single-use expression (each of x, y, z appears once), so
 *             its interval evaluation is the exact range up to outward
 *             rounding (far below eps): the interval test decides such a cell
 *             and it must NOT be a leaf;
 *   touching  the rest (the sphere within rounding of the cell's boundary):
 *             either way.
 * So n_crossed <= leaves <= n_crossed + n_touching, and the leaf set is
 * checked cell by cell, not only counted.
 *
 * Every leaf lies within its own diagonal of the sphere: its box meets the
 * shell 1 - diag <= |p| <= 1 + diag (checked on each leaf's box, from
 * oct_leaf_box, with the rounding margin on the side of passing only when
 * the exact answer passes by more than the margin's worth).
 *
 * Bounds on the leaf count from geometry alone, also checked:
 *   upper: every leaf meets the sphere (above), so it lies entirely in the
 *     shell of half-width diag around it; leaves have disjoint interiors, so
 *     leaves * h^3 <= vol(shell) = 4pi/3 ((1 + diag)^3 - max(0, 1 - diag)^3).
 *   lower: the leaves cover the sphere (area 4pi).  A leaf lies in its
 *     circumscribed ball of radius rho = diag / 2, and a ball of radius rho < 1
 *     meets the unit sphere in a cap of area at most 2pi (1 - sqrt(1 - rho^2))
 *     (the cap of half-angle theta has area 2pi(1 - cos theta); the largest
 *     theta, over the ball's centre distance s, is at s = sqrt(1 - rho^2),
 *     where cos theta = sqrt(1 - rho^2)).  So
 *     leaves >= 4pi / (2pi (1 - sqrt(1 - rho^2))) = 2 / (1 - sqrt(1 - rho^2)).
 * These are loose (a factor ~3 each side at depth 8) but independent of any
 * cell enumeration. */
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
#include "support/testutil.h"

#define EPS 1e-9
#define PI 3.14159265358979323846

/* smallest and largest square of a coordinate over [a, b] */
static void axis_sq(double a, double b, double *lo, double *hi)
{
    double a2 = a * a, b2 = b * b;
    *lo = a <= 0 && 0 <= b ? 0.0 : fmin(a2, b2);
    *hi = fmax(a2, b2);
}

static void check_depth(const scene_t *s, int depth, unsigned tests)
{
    const char *tname = tests & OCT_TEST_LIPSCHITZ ? "interval,lipschitz" : "interval";
    oct_params_t p = {.depth = depth, .tests = tests, .threads = 2};
    oct_tree_t *t;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    if (oct_build(s->tape, s->box, &p, &t, &err) != 0)
        fail_msg("oct_build depth %d: %s", depth, err.msg);
    assert_int_equal(t->depth, depth);

    uint32_t n = 1u << depth;
    size_t ncell = (size_t)n * n * n;
    unsigned char *leaf = calloc(ncell, 1);
    assert_non_null(leaf);

    /* 1. each leaf within its diagonal of the sphere */
    double h = 2.1 / n, diag = h * sqrt(3.0);
    double worst = 0; /* largest distance from a leaf box to the sphere */
    for (uint32_t l = 0; l < t->n_leaves; l++) {
        const oct_leaf_t *lf = &t->leaves[l];
        assert_int_equal(oct_leaf_depth(lf), depth); /* no refine: leaves only at the max depth */
        uint32_t ix, iy, iz;
        oct_unmorton(oct_leaf_code(lf), oct_leaf_depth(lf), &ix, &iy, &iz);
        size_t at = ((size_t)iz * n + iy) * n + ix;
        assert_int_equal(leaf[at], 0); /* no two leaves on one cell */
        leaf[at] = 1;
        iv_box_t b = oct_leaf_box(t, lf);
        double lo[3], hi[3];
        axis_sq(b.x.lo, b.x.hi, &lo[0], &hi[0]);
        axis_sq(b.y.lo, b.y.hi, &lo[1], &hi[1]);
        axis_sq(b.z.lo, b.z.hi, &lo[2], &hi[2]);
        double dmin = sqrt(lo[0] + lo[1] + lo[2]), dmax = sqrt(hi[0] + hi[1] + hi[2]);
        double ldiag = sqrt((b.x.hi - b.x.lo) * (b.x.hi - b.x.lo) +
                            (b.y.hi - b.y.lo) * (b.y.hi - b.y.lo) +
                            (b.z.hi - b.z.lo) * (b.z.hi - b.z.lo));
        double dist = dmin > 1 ? dmin - 1 : dmax < 1 ? 1 - dmax : 0.0;
        if (dist > worst)
            worst = dist;
        if (!(dist <= ldiag * (1 + 1e-12)))
            fail_msg("depth %d [%s]: leaf %u [%.17g,%.17g]x[%.17g,%.17g]x[%.17g,%.17g] is %.17g "
                     "from the sphere, more than its diagonal %.17g",
                     depth, tname, l, b.x.lo, b.x.hi, b.y.lo, b.y.hi, b.z.lo, b.z.hi, dist, ldiag);
    }

    /* 2. the independent classification of every cell */
    double *sqlo[3], *sqhi[3];
    for (int a = 0; a < 3; a++) {
        sqlo[a] = malloc(n * sizeof(double));
        sqhi[a] = malloc(n * sizeof(double));
        assert_non_null(sqlo[a]);
        assert_non_null(sqhi[a]);
        for (uint32_t i = 0; i < n; i++)
            axis_sq(oct_coord(s->box[2 * a], s->box[2 * a + 1], i, depth),
                    oct_coord(s->box[2 * a], s->box[2 * a + 1], (uint64_t)i + 1, depth),
                    &sqlo[a][i], &sqhi[a][i]);
    }
    uint64_t crossed = 0, touching = 0, missing = 0, extra = 0;
    for (uint32_t iz = 0; iz < n; iz++)
        for (uint32_t iy = 0; iy < n; iy++)
            for (uint32_t ix = 0; ix < n; ix++) {
                double d2min = sqlo[0][ix] + sqlo[1][iy] + sqlo[2][iz];
                double d2max = sqhi[0][ix] + sqhi[1][iy] + sqhi[2][iz];
                int is_leaf = leaf[((size_t)iz * n + iy) * n + ix];
                if (d2min < 1 - EPS && d2max > 1 + EPS) {
                    crossed++;
                    if (!is_leaf && missing++ < 5)
                        printf("depth %d [%s]: cell (%u,%u,%u) crossed by the sphere is not a leaf\n",
                               depth, tname, ix, iy, iz);
                } else if (d2min > 1 + EPS || d2max < 1 - EPS) {
                    if (is_leaf && extra++ < 5)
                        printf("depth %d [%s]: cell (%u,%u,%u) clear of the sphere is a leaf\n",
                               depth, tname, ix, iy, iz);
                } else {
                    touching++;
                }
            }
    for (int a = 0; a < 3; a++) {
        free(sqlo[a]);
        free(sqhi[a]);
    }

    /* 3. the geometric bounds */
    double rho2 = 0.75 * h * h;
    double lower = 2 / (1 - sqrt(1 - rho2));
    double in = fmax(0.0, 1 - diag);
    double upper = 4 * PI / 3 * ((1 + diag) * (1 + diag) * (1 + diag) - in * in * in) / (h * h * h);

    printf("depth %d %-19s leaves %8u  crossed %8llu  touching %4llu  area bound >= %9.0f  "
           "shell bound <= %9.0f  max leaf-sphere distance %.3g (diag %.3g)\n",
           depth, tname, t->n_leaves, (unsigned long long)crossed, (unsigned long long)touching,
           lower, upper, worst, diag);
    fflush(stdout);
    assert_int_equal(missing, 0);
    assert_int_equal(extra, 0);
    assert_true(crossed <= t->n_leaves && t->n_leaves <= crossed + touching);
    assert_true(lower <= (double)t->n_leaves && (double)t->n_leaves <= upper);
    assert_true(lower <= (double)crossed && (double)crossed <= upper);
    /* the tape is single use: kept leaves touch the sphere up to rounding */
    assert_true(worst <= 1e-9);
    /* leaves only at the max depth, and the stats say so */
    assert_int_equal(t->stats.leaves_by_depth[depth], t->n_leaves);
    free(leaf);
    oct_free(t);
}

static void test_sphere(void **state)
{
    (void)state;
    scene_t s;
    tu_load_scene("sphere", &s);
    /* the premise of the exact classification: a cube box centred on the sphere */
    for (int a = 0; a < 3; a++) {
        assert_true(s.box[2 * a] == -1.05);
        assert_true(s.box[2 * a + 1] == 1.05);
    }
    int max_depth = tu_sanitizer_build() ? 7 : 8;
    for (int d = 4; d <= max_depth; d++) {
        check_depth(&s, d, OCT_TEST_INTERVAL);
        check_depth(&s, d, OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ);
    }
    scene_free(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sphere),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
