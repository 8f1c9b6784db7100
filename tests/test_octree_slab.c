/* ILIE slabs of the octree's leaves against an independent search for the
 * surface.
 *
 * For leaves with a slab (all of them, or an even spread of 400 in a large
 * tree): sample f on a 5x5x5 grid inside the leaf; where
 * two neighbouring samples have opposite signs, bisect the segment between
 * them down to a few ulps; the two ends then have opposite signs certified by
 * MPFI, so a point of the surface lies between them.  That segment must meet
 * the slab {p : d_lo <= n.p <= d_hi}, and come within the leaf's error bound
 * of the slab's mid-plane.  Products n.p are computed exactly in MPFR. */
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
#include "support/mpfi_tape.h"
#include "support/testutil.h"

enum { GRID = 5, MAX_LEAVES_CHECKED = 400 };

/* sign of f at p from the double interval evaluator on the point box: -1,
 * +1, or 0 when the enclosure holds 0 or f is undefined.  Used for the search
 * only; the segments found are certified with MPFI (oracle_sign). */
static int fast_sign(const tape_t *t, tape_ws_t *ws, const double p[3])
{
    iv_box_t b = {iv_point(p[0]), iv_point(p[1]), iv_point(p[2])};
    iv_t F;
    tape_eval_interval(t, ws, 1, &b, &F);
    return F.lo > 0 ? 1 : F.hi < 0 ? -1 : 0;
}

/* certified sign of f at p: -1, +1, or 0 (undecided or undefined) */
static int oracle_sign(const tape_t *t, const double p[3], mpfi_t v)
{
    int s = 0;
    for (int which = 0; which < 2; which++) {
        if (oracle_eval(t, p, which ? ORACLE_CONST_HI : ORACLE_CONST_LO, v, NULL))
            return 0;
        int sw = mpfi_is_strictly_pos(v) ? 1 : mpfi_is_strictly_neg(v) ? -1 : 0;
        if (sw == 0 || (which && sw != s))
            return 0;
        s = sw;
    }
    return s;
}

/* n.p exactly (3 products and 2 sums of doubles fit in 256 bits) */
static void dot(mpfr_t out, const double n[3], const double p[3])
{
    mpfr_t t;
    mpfr_init2(t, 256);
    mpfr_set_d(out, 0, MPFR_RNDN);
    for (int k = 0; k < 3; k++) {
        mpfr_set_d(t, n[k], MPFR_RNDN);
        mpfr_mul_d(t, t, p[k], MPFR_RNDN);
        mpfr_add(out, out, t, MPFR_RNDN);
    }
    mpfr_clear(t);
}

typedef struct {
    long leaves_with_slab, segments, uncertified;
} counts_t;

/* The segment [a, b] holds a zero of f: check it against the leaf's slab. */
static void check_segment(const oct_tree_t *tree, uint32_t leaf, const double a[3],
                          const double b[3], const char *what)
{
    const oct_slab_t *sl = &tree->slabs[leaf];
    mpfr_t da, db, lo, hi, mid, dist, bound;
    mpfr_inits2(256, da, db, lo, hi, mid, dist, bound, (mpfr_ptr)0);
    dot(da, sl->n, a);
    dot(db, sl->n, b);
    if (mpfr_cmp(da, db) > 0)
        mpfr_swap(da, db);
    /* the segment's n.p range [da, db] must meet [d_lo, d_hi] */
    mpfr_set_d(lo, sl->d_lo, MPFR_RNDN);
    mpfr_set_d(hi, sl->d_hi, MPFR_RNDN);
    if (mpfr_cmp(db, lo) < 0 || mpfr_cmp(da, hi) > 0) {
        mpfr_printf("%s: leaf %u: surface between n.p = %.20Rg and %.20Rg, slab [%.17g, %.17g]\n",
                    what, leaf, da, db, sl->d_lo, sl->d_hi);
        fail();
    }
    /* distance to the mid-plane, |n.p - mid| / |n| with |n| >= 1 - 1e-15, at
     * the closest point of the segment, within the error bound */
    mpfr_add(mid, lo, hi, MPFR_RNDN);
    mpfr_div_2ui(mid, mid, 1, MPFR_RNDN);
    if (mpfr_cmp(db, mid) < 0)
        mpfr_sub(dist, mid, db, MPFR_RNDU);
    else if (mpfr_cmp(da, mid) > 0)
        mpfr_sub(dist, da, mid, MPFR_RNDU);
    else
        mpfr_set_ui(dist, 0, MPFR_RNDN);
    mpfr_div_d(dist, dist, 1 - 1e-15, MPFR_RNDU);
    mpfr_set_d(bound, oct_leaf_error_bound(tree, leaf), MPFR_RNDN);
    if (mpfr_cmp(dist, bound) > 0) {
        mpfr_printf("%s: leaf %u: surface %.6Rg from the mid-plane, error bound %.17g\n", what,
                    leaf, dist, oct_leaf_error_bound(tree, leaf));
        fail();
    }
    mpfr_clears(da, db, lo, hi, mid, dist, bound, (mpfr_ptr)0);
}

/* Bisect [a, b] (signs sa = -sb) until the ends are a few ulps apart. */
static void bisect(const tape_t *t, tape_ws_t *ws, double a[3], double b[3], int sa)
{
    for (int it = 0; it < 200; it++) {
        double m[3];
        int moved = 0;
        for (int k = 0; k < 3; k++) {
            m[k] = 0.5 * a[k] + 0.5 * b[k];
            moved |= m[k] != a[k] && m[k] != b[k];
        }
        if (!moved)
            return;
        int sm = fast_sign(t, ws, m);
        if (sm == 0)
            return; /* a zero (or undecided) at m: [a, b] still holds a zero */
        if (sm == sa)
            memcpy(a, m, sizeof m);
        else
            memcpy(b, m, sizeof m);
    }
}

static void check_tree(const scene_t *s, const oct_tree_t *tree, const char *what, counts_t *c)
{
    assert_non_null(tree->slabs);
    mpfi_t v;
    mpfi_init2(v, ORACLE_PREC);
    tape_ws_t *ws = tape_ws_new(s->tape->n);
    uint32_t with_slab = 0;
    for (uint32_t i = 0; i < tree->n_leaves; i++)
        with_slab += oct_leaf_has_slab(tree, i) != 0;
    uint32_t stride = with_slab > MAX_LEAVES_CHECKED ? with_slab / MAX_LEAVES_CHECKED : 1;
    for (uint32_t i = 0, seen = 0; i < tree->n_leaves; i++) {
        if (!oct_leaf_has_slab(tree, i) || seen++ % stride != 0)
            continue;
        c->leaves_with_slab++;
        iv_box_t b = oct_leaf_box(tree, &tree->leaves[i]);
        const iv_t ax[3] = {b.x, b.y, b.z};
        static double P[GRID][GRID][GRID][3];
        static int S[GRID][GRID][GRID];
        for (int x = 0; x < GRID; x++)
            for (int y = 0; y < GRID; y++)
                for (int z = 0; z < GRID; z++) {
                    int idx[3] = {x, y, z};
                    for (int k = 0; k < 3; k++) {
                        double u = (double)idx[k] / (GRID - 1);
                        double p = ax[k].lo + (ax[k].hi - ax[k].lo) * u;
                        P[x][y][z][k] = p > ax[k].hi ? ax[k].hi : p;
                    }
                    S[x][y][z] = fast_sign(s->tape, ws, P[x][y][z]);
                }
        for (int x = 0; x < GRID; x++)
            for (int y = 0; y < GRID; y++)
                for (int z = 0; z < GRID; z++)
                    for (int dir = 0; dir < 3; dir++) {
                        int x2 = x + (dir == 0), y2 = y + (dir == 1), z2 = z + (dir == 2);
                        if (x2 >= GRID || y2 >= GRID || z2 >= GRID)
                            continue;
                        int sa = S[x][y][z], sb = S[x2][y2][z2];
                        if (sa * sb >= 0)
                            continue;
                        double a[3], bb[3];
                        memcpy(a, P[x][y][z], sizeof a);
                        memcpy(bb, P[x2][y2][z2], sizeof bb);
                        bisect(s->tape, ws, a, bb, sa);
                        /* the zero between a and b, certified independently */
                        if (oracle_sign(s->tape, a, v) * oracle_sign(s->tape, bb, v) >= 0) {
                            c->uncertified++;
                            continue;
                        }
                        check_segment(tree, i, a, bb, what);
                        c->segments++;
                    }
    }
    mpfi_clear(v);
    tape_ws_free(ws);
}

/* require_early: the tolerance is coarse enough that some leaves must stop early */
static void run(const char *scene, int depth, double refine, int require_early)
{
    scene_t s;
    tu_load_scene(scene, &s);
    ivoct_error_t err;
    ivoct_error_clear(&err);
    oct_params_t p = {.depth = depth,
                      .tests = OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ | OCT_TEST_ILIE,
                      .refine = refine,
                      .threads = 2};
    oct_tree_t *tree;
    assert_int_equal(oct_build(s.tape, s.box, &p, &tree, &err), 0);
    counts_t c = {0, 0, 0};
    char what[128];
    snprintf(what, sizeof what, "%s depth %d refine %g", scene, depth, refine);
    check_tree(&s, tree, what, &c);
    printf("%-40s %7u leaves, %7ld with a slab checked, %7ld surface segments, max error "
           "bound %.3g\n",
           what, tree->n_leaves, c.leaves_with_slab, c.segments, tree->stats.max_error_bound);
    /* not vacuous: slabs exist and the surface was found in them */
    assert_true(c.leaves_with_slab > 0);
    assert_true(c.segments > 0);
    /* the interval and MPFI signs agree but for points within rounding of the surface */
    assert_true(c.uncertified <= c.segments / 100);
    if (refine > 0) {
        if (require_early)
            assert_true(tree->stats.decided_refine > 0);
        /* every early leaf's bound is below the tolerance */
        for (uint32_t i = 0; i < tree->n_leaves; i++)
            if (oct_leaf_depth(&tree->leaves[i]) < depth)
                assert_true(oct_leaf_error_bound(tree, i) < refine);
    }
    oct_free(tree);
    scene_free(&s);
}

static void test_slabs_at_max_depth(void **state)
{
    (void)state;
    const char *scenes[] = {"sphere", "gumdrop", "mcmullen-k3", "chubs", "drop", "tangle-cube",
                            "blobs", "clebsch-cubic"};
    int depth = tu_sanitizer_build() ? 4 : 5;
    for (size_t i = 0; i < sizeof scenes / sizeof *scenes; i++)
        run(scenes[i], depth, 0, 0);
}

static void test_slabs_of_refined_leaves(void **state)
{
    (void)state;
    const char *scenes[] = {"sphere", "gumdrop", "mcmullen-k3", "kusner-schmitt", "bretzel"};
    int depth = tu_sanitizer_build() ? 6 : 7;
    for (size_t i = 0; i < sizeof scenes / sizeof *scenes; i++) {
        /* the sphere's slabs are thin everywhere: early leaves must appear;
         * elsewhere a coarse max depth may leave none, which is not an error */
        run(scenes[i], depth, 1e-2, i == 0);
        run(scenes[i], depth, 1e-3, 0);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_slabs_at_max_depth),
        cmocka_unit_test(test_slabs_of_refined_leaves),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
