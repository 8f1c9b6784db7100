/* oct_leaf_make (octree/cell.c): the leaf's key says its depth and code, and its
 * float enclosure is the double one rounded outward, tightly.
 *
 * For every double x tried as f_lo (f_hi), the leaf's f_lo is the largest float
 * <= x (f_hi: the smallest float >= x), checked with the C library's nextafterf
 * as the reference: f_lo <= x < nextafterf(f_lo, +inf) where f_lo is finite.
 * The doubles: zeros of both signs, the float and double subnormal ranges, the
 * float range's ends and beyond (overflow to an infinite bound only outward),
 * the infinities, NaN (stays NaN), and random bit patterns of every exponent;
 * the depth and code of keys at depths 0..21; oct_unmorton and oct_morton;
 * oct_coord against its definition lo + (hi - lo)·ldexp(i, -depth). */
#define _POSIX_C_SOURCE 200809L
#include <float.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "../octree/octree.h"
#include "support/testutil.h"

/* f is the largest float <= x (down) or the smallest float >= x (up) */
static void assert_outward(double x, float f, int up)
{
    if (isnan(x)) {
        assert_true(isnan(f));
        return;
    }
    if (up) {
        assert_true((double)f >= x);
        if (f != -INFINITY) /* the next float below must be below x */
            assert_true((double)nextafterf(f, -INFINITY) < x);
    } else {
        assert_true((double)f <= x);
        if (f != INFINITY)
            assert_true((double)nextafterf(f, INFINITY) > x);
    }
}

static void check(double x)
{
    oct_leaf_t l = oct_leaf_make(5, 3, x, x);
    assert_outward(x, l.f_lo, 0);
    assert_outward(x, l.f_hi, 1);
    /* the sign of a zero bound: -0 <= 0 and 0 >= -0 are both right; the point
     * is that an exact float is kept as it is */
    if ((double)(float)x == x && !isnan(x)) {
        assert_true(l.f_lo == (float)x);
        assert_true(l.f_hi == (float)x);
    }
}

static void test_edges(void **state)
{
    (void)state;
    const double xs[] = {
        0.0, -0.0, 1.0, -1.0, 0.1, -0.1, 1.0 / 3, -1.0 / 3,
        FLT_TRUE_MIN, -FLT_TRUE_MIN, (double)FLT_TRUE_MIN / 2, -(double)FLT_TRUE_MIN / 2,
        FLT_TRUE_MIN * 1.5, -FLT_TRUE_MIN * 1.5, FLT_MIN, -FLT_MIN, FLT_MIN * (1 - 0x1p-30),
        DBL_TRUE_MIN, -DBL_TRUE_MIN, DBL_MIN, -DBL_MIN,
        FLT_MAX, -FLT_MAX, (double)FLT_MAX * (1 + 0x1p-30), -(double)FLT_MAX * (1 + 0x1p-30),
        (double)FLT_MAX * 2, -(double)FLT_MAX * 2, DBL_MAX, -DBL_MAX,
        INFINITY, -INFINITY, NAN,
    };
    for (size_t i = 0; i < sizeof xs / sizeof xs[0]; i++)
        check(xs[i]);
    /* beyond the float range: the outer bound is infinite, the inner one FLT_MAX */
    oct_leaf_t l = oct_leaf_make(0, 0, (double)FLT_MAX * 2, (double)FLT_MAX * 2);
    assert_true(l.f_lo == FLT_MAX && l.f_hi == INFINITY);
    l = oct_leaf_make(0, 0, -(double)FLT_MAX * 2, -(double)FLT_MAX * 2);
    assert_true(l.f_lo == -INFINITY && l.f_hi == -FLT_MAX);
    /* between 0 and the least subnormal: outward to it, inward to a zero */
    l = oct_leaf_make(0, 0, (double)FLT_TRUE_MIN / 2, (double)FLT_TRUE_MIN / 2);
    assert_true(l.f_lo == 0 && l.f_hi == FLT_TRUE_MIN);
    l = oct_leaf_make(0, 0, -(double)FLT_TRUE_MIN / 2, -(double)FLT_TRUE_MIN / 2);
    assert_true(l.f_lo == -FLT_TRUE_MIN && l.f_hi == 0);
}

static void test_random(void **state)
{
    (void)state;
    uint64_t rng = tu_seed(0x1eafULL);
    for (int i = 0; i < 2000000; i++) {
        uint64_t bits = tu_next(&rng);
        if (i & 1) { /* exponents near the float range, where rounding happens */
            uint64_t e = 1023 - 160 + (tu_next(&rng) % 300);
            bits = (bits & 0x800fffffffffffffULL) | e << 52;
        }
        double x;
        memcpy(&x, &bits, sizeof x);
        check(x);
    }
}

static void test_key(void **state)
{
    (void)state;
    uint64_t rng = tu_seed(0x6b6579ULL);
    for (int depth = 0; depth <= OCT_MAX_DEPTH; depth++)
        for (int i = 0; i < 100; i++) {
            uint64_t code = depth ? tu_next(&rng) >> (64 - 3 * depth) : 0;
            oct_leaf_t l = oct_leaf_make(code, depth, -1, 1);
            assert_int_equal(oct_leaf_depth(&l), depth);
            assert_true(oct_leaf_code(&l) == code);
        }
}

/* oct_unmorton against the level-by-level definition (the child number at each
 * level: bit 0 x, bit 1 y, bit 2 z), with bits above 3·depth that it must
 * ignore, and oct_morton's inverse, at depths 0..21 */
static void test_morton(void **state)
{
    (void)state;
    uint64_t rng = tu_seed(0x6d6f72ULL);
    for (int depth = 0; depth <= OCT_MAX_DEPTH; depth++)
        for (int i = 0; i < 20000; i++) {
            uint64_t raw = tu_next(&rng);
            uint32_t x = 0, y = 0, z = 0;
            for (int level = depth - 1; level >= 0; level--) {
                unsigned child = (unsigned)(raw >> (3 * level)) & 7u;
                x = x << 1 | (child & 1u);
                y = y << 1 | (child >> 1 & 1u);
                z = z << 1 | (child >> 2 & 1u);
            }
            uint32_t ix, iy, iz;
            oct_unmorton(raw, depth, &ix, &iy, &iz);
            assert_int_equal(ix, x);
            assert_int_equal(iy, y);
            assert_int_equal(iz, z);
            uint64_t code = oct_morton(ix, iy, iz, depth);
            assert_true(depth == 0 ? code == 0 : code == (raw & (((uint64_t)1 << (3 * depth)) - 1)));
        }
}

/* oct_coord on random boxes of every magnitude and sign, depths 0..21: the
 * ends exactly, lo + (hi - lo)·(i / 2^depth) rounded once (the fraction
 * through ldexp, not oct_coord's exponent bits) and at most hi between, the
 * same double for the same fraction one level deeper, non-decreasing in i. */
static void test_coord(void **state)
{
    (void)state;
    uint64_t rng = tu_seed(0x636f6fULL);
    for (int trial = 0; trial < 2000; trial++) {
        double scale = ldexp(1.0, (int)(tu_next(&rng) % 41) - 20);
        double lo = (2 * tu_uniform(&rng) - 1) * scale;
        double hi = lo + tu_uniform(&rng) * scale + DBL_MIN;
        if (!(lo < hi))
            continue;
        for (int depth = 0; depth <= OCT_MAX_DEPTH; depth++) {
            uint64_t n = (uint64_t)1 << depth;
            assert_true(oct_coord(lo, hi, 0, depth) == lo);
            assert_true(oct_coord(lo, hi, n, depth) == hi);
            assert_true(oct_coord(lo, hi, n + 1, depth) == hi);
            double prev = lo;
            for (int k = 0; k < 40; k++) {
                uint64_t i = k < 20 ? (uint64_t)k * n / 20 : tu_next(&rng) % (n + 1);
                double v = oct_coord(lo, hi, i, depth);
                double def = lo + (hi - lo) * ldexp((double)i, -depth);
                if (i > 0 && i < n)
                    assert_true(v == (def < hi ? def : hi));
                assert_true(lo <= v && v <= hi);
                assert_true(depth == OCT_MAX_DEPTH || oct_coord(lo, hi, 2 * i, depth + 1) == v);
                if (k < 20) { /* the first 20 are increasing in i */
                    assert_true(prev <= v);
                    prev = v;
                }
            }
        }
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_edges),
        cmocka_unit_test(test_random),
        cmocka_unit_test(test_key),
        cmocka_unit_test(test_morton),
        cmocka_unit_test(test_coord),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
