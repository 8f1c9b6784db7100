/* The tape evaluators, operation by operation, against the MPFI oracle; and the
 * properties of batching (a box's result does not depend on its batch); and
 * the conventions of the point + gradient evaluator. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "../expr/tape.h"
#include "support/mpfi_tape.h"
#include "support/testutil.h"

static tape_t *compile(const char *text)
{
    tape_t *t = NULL;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    if (tape_compile(text, &t, &err) != 0) {
        char buf[1024];
        fail_msg("cannot compile '%s': %s", text, ivoct_error_format(&err, buf, sizeof buf));
    }
    return t;
}

/* Each expression exercises one operation (or a composition that stresses
 * it); min_defined is the share of points at which it must be defined for the
 * check not to be vacuous. */
static const struct {
    const char *text;
    double min_defined;
} EXPRS[] = {
    {"x + y", 1}, {"x - y", 1}, {"x * y", 1}, {"x / y", 0.9}, {"-x", 1},
    {"x^2", 1}, {"x^3", 1}, {"x^4", 1}, {"x^7", 1}, {"x^-1", 0.9}, {"x^-2", 0.9},
    {"x^-3", 0.9}, {"x^2.5", 0.4}, {"x^-0.5", 0.4}, {"x^y", 0.4}, {"sqrt(x)", 0.4},
    {"exp(x)", 1}, {"log(x)", 0.4}, {"sin(x)", 1}, {"cos(x)", 1}, {"tan(x)", 1},
    {"atan(x)", 1}, {"abs(x)", 1}, {"min(x, y)", 1}, {"max(x, y)", 1},
    {"0.1*x + pi - e", 1}, {"sin(x*y) + cos(z)^2", 1}, {"exp(-(x^2+y^2)) - 0.5", 1},
    {"sqrt(x^2+y^2+z^2) - 1", 1}, {"abs(x) + abs(y) - min(z, x*y)", 1},
    {"(x*y - z) / (1 + x^2)", 1}, {"tan(x/3) * atan(y*z)", 1},
    {"log(1 + x^2) - max(y, -z)", 1}, {"x*y*z - (x+y+z)^3", 1},
};

static void test_each_operation(void **state)
{
    (void)state;
    static const double boxes[][6] = {
        {-4, 4, -4, 4, -4, 4},
        {0.5, 3, -2, 2, 0.25, 1},
        {-1e3, 1e3, -1e3, 1e3, -1e3, 1e3},
        {-1e-3, 1e-3, -1e-3, 1e-3, -1e-3, 1e-3},
        {1e6, 1e6 + 4, -1, 1, 1e15, 1e15 + 1e3},
    };
    uint64_t rng = tu_seed(7);
    long nbox = (long)(2000 * tu_scale());
    for (size_t e = 0; e < sizeof EXPRS / sizeof EXPRS[0]; e++) {
        tape_t *t = compile(EXPRS[e].text);
        long checked = 0, total = 0;
        for (size_t b = 0; b < sizeof boxes / sizeof boxes[0]; b++) {
            oracle_stats_t st;
            if (oracle_check_tape(t, boxes[b], nbox, 2, &rng, &st) != 0)
                fail_msg("%s on box %zu: %s", EXPRS[e].text, b, st.failure);
            checked += st.checked;
            total += st.checked + st.skipped;
            /* the plain double point + gradient evaluator, near the oracle */
            if (oracle_check_point_grad(t, boxes[b], nbox, &rng, &st) != 0)
                fail_msg("%s on box %zu, point gradient: %s", EXPRS[e].text, b, st.failure);
        }
        printf("%-36s %7ld of %7ld points defined and enclosed\n", EXPRS[e].text, checked,
               total);
        /* boxes 1, 4 are positive in x; the rest straddle 0 */
        assert_true(checked >= EXPRS[e].min_defined * 0.9 * (double)total);
        tape_free(t);
    }
}

/* A box's enclosure does not depend on the batch it is evaluated in. */
static void test_batches_are_independent(void **state)
{
    (void)state;
    tape_t *t = compile("x^4 + (y^2+z^2)^2 - min(x*y, z) + sqrt(abs(x)) - 2");
    tape_ws_t *ws = tape_ws_new(t->n);
    enum { N = 29 };
    iv_box_t boxes[N];
    uint64_t rng = 99;
    for (int i = 0; i < N; i++) {
        double c[3], w = tu_uniform(&rng);
        for (int k = 0; k < 3; k++)
            c[k] = 4 * tu_uniform(&rng) - 2;
        boxes[i] = (iv_box_t){{c[0], c[0] + w}, {c[1], c[1] + w}, {c[2], c[2] + w}};
    }
    iv_t all[N];
    iv_grad_t gall[N];
    double px[N], py[N], pz[N], pall[N];
    for (int i = 0; i < N; i++)
        px[i] = boxes[i].x.lo, py[i] = boxes[i].y.lo, pz[i] = boxes[i].z.lo;
    tape_eval_interval(t, ws, N, boxes, all);
    tape_eval_grad(t, ws, N, boxes, gall);
    tape_eval_point(t, ws, N, px, py, pz, pall);
    for (int i = 0; i < N; i++) {
        iv_t one;
        iv_grad_t gone;
        double pone;
        tape_eval_interval(t, ws, 1, &boxes[i], &one);
        tape_eval_grad(t, ws, 1, &boxes[i], &gone);
        tape_eval_point(t, ws, 1, &px[i], &py[i], &pz[i], &pone);
        assert_memory_equal(&one, &all[i], sizeof one);
        assert_memory_equal(&gone, &gall[i], sizeof gone);
        assert_memory_equal(&pone, &pall[i], sizeof pone);
        /* the value part of the gradient evaluation is the interval evaluation */
        assert_memory_equal(&gone.v, &one, sizeof one);
    }
    tape_ws_free(ws);
    tape_free(t);
}

/* A point box gives a tight enclosure of the point value, holding the
 * double evaluation. */
static void test_point_box_is_tight(void **state)
{
    (void)state;
    tape_t *t = compile("4*(x^4 + (y^2+z^2)^2) + 17*x^2*(y^2+z^2) - 20*(x^2+y^2+z^2) + 17");
    tape_ws_t *ws = tape_ws_new(t->n);
    uint64_t rng = 5;
    for (int i = 0; i < 1000; i++) {
        double p[3];
        for (int k = 0; k < 3; k++)
            p[k] = 4 * tu_uniform(&rng) - 2;
        iv_box_t b = {{p[0], p[0]}, {p[1], p[1]}, {p[2], p[2]}};
        iv_t r;
        double v;
        tape_eval_interval(t, ws, 1, &b, &r);
        tape_eval_point(t, ws, 1, &p[0], &p[1], &p[2], &v);
        assert_true(r.lo <= v && v <= r.hi);
        /* a few dozen roundings of terms of size <= ~700: width well under 1e-11 */
        assert_true(r.hi - r.lo < 1e-11);
    }
    tape_ws_free(ws);
    tape_free(t);
}

/* A product by a constant takes iv_mul_point in the passes (expr/kernels.h):
 * the interval pass and the gradient pass give what iv_mul gives, bit for
 * bit, over boxes of every sign (zeros, points, both orders of the factors,
 * a constant that is not one double). */
static int same_iv_bits(iv_t a, iv_t b) { return memcmp(&a, &b, sizeof a) == 0; }

static void test_products_by_constants(void **state)
{
    (void)state;
    tape_t *t = compile("8*x*y*z + y*(-3) - 0*z + 0.1*x");
    tape_ws_t *ws = tape_ws_new(t->n);
    assert_non_null(ws);
    enum { N = 300 };
    iv_box_t box[N];
    iv_t v[N];
    iv_grad_t g[N];
    uint64_t rng = tu_seed(12);
    for (int i = 0; i < N; i++) {
        iv_t *axis[3] = {&box[i].x, &box[i].y, &box[i].z};
        for (int k = 0; k < 3; k++) {
            uint64_t u = tu_next(&rng);
            double a = 8 * tu_uniform(&rng) - 4, b = u % 5 == 0 ? a : 8 * tu_uniform(&rng) - 4;
            a = u % 7 == 0 ? 0.0 : u % 11 == 0 ? -0.0 : a;
            b = u % 13 == 0 ? 0.0 : b;
            *axis[k] = (iv_t){a < b ? a : b, a < b ? b : a};
        }
    }
    tape_eval_interval(t, ws, N, box, v);
    tape_eval_grad(t, ws, N, box, g);
    iv_t c01;
    assert_true(iv_from_decimal("0.1", &c01));
    for (int i = 0; i < N; i++) {
        iv_t x = box[i].x, y = box[i].y, z = box[i].z;
        iv_t p = iv_mul(iv_mul(iv_mul(iv_point(8), x), y), z);
        iv_t f = iv_add(iv_sub(iv_add(p, iv_mul(y, iv_point(-3))), iv_mul(iv_point(0), z)),
                        iv_mul(c01, x));
        assert_true(same_iv_bits(v[i], f));
        assert_true(same_iv_bits(g[i].v, f));
        /* d/dz = 8xy (z's own partial is [1, 1]), d/dy = 8xz - 3 (0*z is [0, 0]) */
        iv_t xy8 = iv_mul(iv_mul(iv_point(8), x), y);
        assert_true(same_iv_bits(g[i].dz, xy8));
        iv_t x8 = iv_mul(iv_point(8), x);
        iv_t dy = iv_add(iv_mul(x8, z), iv_point(-3));
        assert_true(g[i].dy.lo <= dy.lo && dy.hi <= g[i].dy.hi);
    }
    tape_ws_free(ws);
    tape_free(t);
}

/* A partial that is exactly [1, 1] (a variable's own, through sums) is not
 * multiplied in: the partial of a product by a variable is the other factor
 * itself, bit for bit, not that factor widened by iv_mul's rounding. */
static void test_grad_skips_unit_factors(void **state)
{
    (void)state;
    tape_t *t = compile("(x + 2) * y + 3 * z");
    tape_ws_t *ws = tape_ws_new(t->n);
    assert_non_null(ws);
    enum { N = 100 };
    iv_box_t box[N];
    iv_grad_t g[N];
    uint64_t rng = tu_seed(11);
    for (int i = 0; i < N; i++) {
        iv_t *axis[3] = {&box[i].x, &box[i].y, &box[i].z};
        for (int k = 0; k < 3; k++) {
            double a = 8 * tu_uniform(&rng) - 4, b = 8 * tu_uniform(&rng) - 4;
            *axis[k] = (iv_t){a < b ? a : b, a < b ? b : a};
        }
    }
    tape_eval_grad(t, ws, N, box, g);
    for (int i = 0; i < N; i++) {
        /* d/dx = y, d/dy = x + 2 (enclosed by the sum's rounding), d/dz = 3 */
        iv_t x2 = iv_add(box[i].x, iv_point(2));
        assert_true(g[i].dx.lo == box[i].y.lo && g[i].dx.hi == box[i].y.hi);
        assert_true(g[i].dy.lo == x2.lo && g[i].dy.hi == x2.hi);
        assert_true(g[i].dz.lo == 3 && g[i].dz.hi == 3);
    }
    tape_ws_free(ws);
    tape_free(t);
}

/* Outside its domain f is empty; partly outside, the defined part is enclosed. */
static void test_set_based_domains(void **state)
{
    (void)state;
    tape_t *t = compile("sqrt(x) + log(y)");
    tape_ws_t *ws = tape_ws_new(t->n);
    iv_box_t none = {{-2, -1}, {1, 2}, {0, 0}};
    iv_box_t part = {{-2, 4}, {1, 2}, {0, 0}};
    iv_t r;
    tape_eval_interval(t, ws, 1, &none, &r);
    assert_true(iv_is_empty(r));
    tape_eval_interval(t, ws, 1, &part, &r);
    assert_false(iv_is_empty(r));
    assert_true(r.lo <= 0.0 && r.hi >= 2.0 + log(2.0));
    iv_grad_t g;
    tape_eval_grad(t, ws, 1, &none, &g);
    assert_true(iv_is_empty(g.v));
    tape_ws_free(ws);
    tape_free(t);
}

/* tape_eval_point_grad where the rules choose: abs at 0 and min/max at a tie
 * give the mean of the one-sided partials; a partial f does not depend on is
 * exactly 0 even where the value is infinite; undefined is NaN. */
static void test_point_grad_conventions(void **state)
{
    (void)state;
    static const struct {
        const char *text;
        double x, y, z, v, dx, dy, dz;
    } C[] = {
        {"abs(x) + y", 0, 2, 0, 2, 0, 1, 0},
        {"abs(x - y)", 3, 1, 0, 2, 1, -1, 0},
        {"min(x, y)", 1, 1, 5, 1, 0.5, 0.5, 0},
        {"max(2*x, y)", 1, 2, 0, 2, 1, 0.5, 0},
        {"min(x, y)", 1, 2, 0, 1, 1, 0, 0},
        {"max(x, y*z)", 1, 2, 3, 6, 0, 3, 2},
        {"x*y^2 + z/y", 2, 1, 3, 5, 1, 1, 1},
        {"exp(x)*sin(y)", 0, 0, 0, 0, 0, 1, 0},
        {"y/x + z", 0, 0, 1, NAN, NAN, INFINITY, 1},
        {"z^3 + 1/x", 0, 0, 2, INFINITY, -INFINITY, 0, 12},
        {"sqrt(x) + y", -1, 1, 0, NAN, NAN, 1, 0},
    };
    for (size_t i = 0; i < sizeof C / sizeof C[0]; i++) {
        tape_t *t = compile(C[i].text);
        tape_ws_t *ws = tape_ws_new(t->n);
        assert_non_null(ws);
        tape_point_grad_t q;
        tape_eval_point_grad(t, ws, 1, &C[i].x, &C[i].y, &C[i].z, &q);
        double got[4] = {q.v, q.dx, q.dy, q.dz}, want[4] = {C[i].v, C[i].dx, C[i].dy, C[i].dz};
        for (int k = 0; k < 4; k++)
            if (!(got[k] == want[k] || (isnan(got[k]) && isnan(want[k]))))
                fail_msg("%s at (%g, %g, %g): component %d is %.17g, expected %.17g",
                         C[i].text, C[i].x, C[i].y, C[i].z, k, got[k], want[k]);
        tape_ws_free(ws);
        tape_free(t);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_each_operation),
        cmocka_unit_test(test_batches_are_independent),
        cmocka_unit_test(test_point_box_is_tight),
        cmocka_unit_test(test_grad_skips_unit_factors),
        cmocka_unit_test(test_products_by_constants),
        cmocka_unit_test(test_set_based_domains),
        cmocka_unit_test(test_point_grad_conventions),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
