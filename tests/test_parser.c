/* The expression compiler (expr/parse.c, expr/dag.c): precedence, folding,
 * sharing, rewrites, every error message with its position, the limits, and
 * named subexpressions.  Values are checked with a small point evaluator
 * written here, so these tests do not depend on expr/eval.c. */
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

#include "../expr/tape.h"

/* ---- helpers ----------------------------------------------------------------------- */

/* M_PI and M_E are not C11 */
#define PI_D 3.14159265358979323846
#define E_D 2.71828182845904523536

static int is_unary(uint32_t op) { return op >= TAPE_NEG && op <= TAPE_ABS; }
static int is_binary(uint32_t op) { return op >= TAPE_ADD && op <= TAPE_MAX; }

/* The tape invariants: operands before their users, unused operand fields 0,
 * every clause but the last used (no dead code), no two identical clauses
 * (sharing), POWI exponents as tape.h says. */
static void check_tape(const tape_t *t)
{
    assert_non_null(t);
    assert_true(t->n >= 1);
    unsigned char *used = calloc(t->n, 1);
    assert_non_null(used);
    for (uint32_t i = 0; i < t->n; i++) {
        const tape_clause_t *c = &t->clauses[i];
        assert_true(c->op < TAPE_OP_COUNT);
        if (is_unary(c->op) || is_binary(c->op)) {
            assert_true(c->a < i);
            used[c->a] = 1;
        } else {
            assert_int_equal(c->a, 0);
        }
        if (is_binary(c->op)) {
            assert_true(c->b < i);
            used[c->b] = 1;
        } else {
            assert_int_equal(c->b, 0);
        }
        if (c->op == TAPE_POWI) {
            double n = c->c.lo;
            assert_true(n == floor(n) && (fabs(n) >= 3 || n == -1 || n == -2));
        }
        if (c->op == TAPE_POWR)
            assert_true(c->c.lo != floor(c->c.lo));
        if (t->n <= 2000)
            for (uint32_t j = 0; j < i; j++)
                assert_false(memcmp(&t->clauses[j], c, sizeof *c) == 0);
    }
    for (uint32_t i = 0; i + 1 < t->n; i++)
        assert_true(used[i]);
    free(used);
}

/* Plain double evaluation of a tape at one point (constants at their
 * midpoint): enough to check the structure against hand-computed values. */
static double peval(const tape_t *t, double x, double y, double z)
{
    double *v = malloc(t->n * sizeof *v);
    assert_non_null(v);
    for (uint32_t i = 0; i < t->n; i++) {
        const tape_clause_t *c = &t->clauses[i];
        double a = is_unary(c->op) || is_binary(c->op) ? v[c->a] : 0;
        double b = is_binary(c->op) ? v[c->b] : 0;
        double r = 0;
        switch ((tape_op_t)c->op) {
        case TAPE_CONST: r = 0.5 * c->c.lo + 0.5 * c->c.hi; break;
        case TAPE_X: r = x; break;
        case TAPE_Y: r = y; break;
        case TAPE_Z: r = z; break;
        case TAPE_NEG: r = -a; break;
        case TAPE_SQR: r = a * a; break;
        case TAPE_POWI:
        case TAPE_POWR: r = pow(a, c->c.lo); break;
        case TAPE_SQRT: r = sqrt(a); break;
        case TAPE_EXP: r = exp(a); break;
        case TAPE_LOG: r = log(a); break;
        case TAPE_SIN: r = sin(a); break;
        case TAPE_COS: r = cos(a); break;
        case TAPE_TAN: r = tan(a); break;
        case TAPE_ATAN: r = atan(a); break;
        case TAPE_ABS: r = fabs(a); break;
        case TAPE_ADD: r = a + b; break;
        case TAPE_SUB: r = a - b; break;
        case TAPE_MUL: r = a * b; break;
        case TAPE_DIV: r = a / b; break;
        case TAPE_MIN: r = fmin(a, b); break;
        case TAPE_MAX: r = fmax(a, b); break;
        case TAPE_OP_COUNT: fail();
        }
        v[i] = r;
    }
    double r = v[t->n - 1];
    free(v);
    return r;
}

static tape_t *compile_ok(const char *text)
{
    tape_t *t = NULL;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    if (tape_compile(text, &t, &err) != 0) {
        char buf[1024];
        fail_msg("cannot compile '%.200s': %s", text, ivoct_error_format(&err, buf, sizeof buf));
    }
    check_tape(t);
    return t;
}

static unsigned count_op(const tape_t *t, tape_op_t op)
{
    unsigned k = 0;
    for (uint32_t i = 0; i < t->n; i++)
        k += t->clauses[i].op == (uint32_t)op;
    return k;
}

/* ---- precedence and associativity ------------------------------------------------- */

static void test_precedence(void **state)
{
    (void)state;
    static const struct {
        const char *text;
        double x, y, z, want;
        int exact; /* every operand, step and result a double: +, -, *, / and
                    * integer powers of small integers and halves, min, max */
    } cases[] = {
        {"1+2*3", 0, 0, 0, 7, 1},
        {"(1+2)*3", 0, 0, 0, 9, 1},
        {"2^3^2", 0, 0, 0, 512, 1},       /* right-associative: 2^9 */
        {"(2^3)^2", 0, 0, 0, 64, 1},
        {"x^y^z", 2, 3, 2, 512, 0},
        {"-x^2", 3, 0, 0, -9, 1},         /* -(x^2) */
        {"(-x)^2", 3, 0, 0, 9, 1},
        {"-2^2", 0, 0, 0, -4, 1},
        {"2^-x", 1, 0, 0, 0.5, 0},        /* 2^(-x) */
        {"2^-x^2", 2, 0, 0, 1.0 / 16, 0}, /* 2^(-(x^2)) */
        {"-x^-2", 2, 0, 0, -0.25, 1},
        {"x-y-z", 1, 2, 3, -4, 1},        /* left-associative */
        {"x-y+z", 1, 2, 3, 2, 1},
        {"x/y/z", 8, 2, 2, 2, 1},
        {"x/y*z", 8, 2, 2, 8, 1},
        {"2*x^2", 3, 0, 0, 18, 1},
        {"x*y^2", 2, 3, 0, 18, 1},
        {"-x*y", 2, 3, 0, -6, 1},
        {"x*-y", 2, 3, 0, -6, 1},
        {"x - -y", 2, 3, 0, 5, 1},
        {"--x", 2, 0, 0, 2, 1},
        {"+x", 2, 0, 0, 2, 1},
        {"- + - x", 2, 0, 0, 2, 1},
        {"1 - 2 * 3 ^ 2 / 6", 0, 0, 0, -2, 1},
        {"x\n+\ty\r\n*  z", 1, 2, 3, 7, 1},
        {"1e-3*1e3", 0, 0, 0, 1, 0},
        {".5 + 1.5E+1 + 2.", 0, 0, 0, 17.5, 1},
        {"2^10", 0, 0, 0, 1024, 1},
        {"x^3 - x^-1", 2, 0, 0, 7.5, 1},
        {"x^0.5 + x^1.5", 4, 0, 0, 10, 0},
        {"x^y", 9, 0.5, 0, 3, 0},
        {"min(x, y) + max(x, y)*10", 3, 5, 0, 53, 1},
        {"min(max(x, y), z)", 1, 5, 3, 3, 1},
        {"abs(-x) + sqrt(y) + exp(0) + log(e)", 2, 9, 0, 7, 0},
        {"sin(pi/2) + cos(0) + tan(0) + 4*atan(1)", 0, 0, 0, 2 + PI_D, 0},
        {"e^x", 2, 0, 0, E_D * E_D, 0},
        {"((((x))))", 7, 0, 0, 7, 1},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        tape_t *t = compile_ok(cases[i].text);
        double got = peval(t, cases[i].x, cases[i].y, cases[i].z);
        if (cases[i].exact ? !(got == cases[i].want)
                           : !(fabs(got - cases[i].want) <= 1e-12 * fmax(1, fabs(cases[i].want))))
            fail_msg("'%s' at (%g,%g,%g): %.17g, want %.17g%s", cases[i].text, cases[i].x,
                     cases[i].y, cases[i].z, got, cases[i].want, cases[i].exact ? " exactly" : "");
        /* an exact constant expression (no x, y, z) folds to one constant, the
         * point itself (dag.c keeps points where the double result is exact) */
        if (cases[i].exact && !strpbrk(cases[i].text, "xyz") &&
            !(t->n == 1 && t->clauses[0].op == TAPE_CONST &&
              t->clauses[0].c.lo == cases[i].want && t->clauses[0].c.hi == cases[i].want))
            fail_msg("'%s' folds to %u clauses, the last [%.17g, %.17g]: want the point %.17g",
                     cases[i].text, t->n, t->clauses[t->n - 1].c.lo, t->clauses[t->n - 1].c.hi,
                     cases[i].want);
        tape_free(t);
    }
}

/* ---- folding, sharing, rewrites ---------------------------------------------------- */

static void test_folding(void **state)
{
    (void)state;
    tape_t *t = compile_ok("2*3+1");
    assert_int_equal(t->n, 1);
    assert_int_equal(t->clauses[0].op, TAPE_CONST);
    assert_true(t->clauses[0].c.lo <= 7 && 7 <= t->clauses[0].c.hi);
    /* exact folds keep points: the ops of interval.h widen even exact results */
    assert_true(t->clauses[0].c.lo == 7 && t->clauses[0].c.hi == 7);
    tape_free(t);

    /* 0.1*3 encloses the real 3/10 (neither 0.1 nor 0.3 is a double) */
    t = compile_ok("0.1*3");
    assert_int_equal(t->n, 1);
    assert_int_equal(t->clauses[0].op, TAPE_CONST);
    mpq_t q, b;
    mpq_inits(q, b, NULL);
    mpq_set_ui(q, 3, 10);
    mpq_set_d(b, t->clauses[0].c.lo);
    assert_true(mpq_cmp(b, q) < 0);
    mpq_set_d(b, t->clauses[0].c.hi);
    assert_true(mpq_cmp(b, q) > 0);
    mpq_clears(q, b, NULL);
    tape_free(t);

    /* folding under a variable: only the constant part folds */
    t = compile_ok("x + 2*3");
    assert_int_equal(t->n, 3);
    assert_int_equal(count_op(t, TAPE_CONST), 1);
    tape_free(t);
    t = compile_ok("-(2)");
    assert_int_equal(t->n, 1);
    assert_true(t->clauses[0].c.lo == -2 && t->clauses[0].c.hi == -2);
    tape_free(t);
    t = compile_ok("0^0 + x^0"); /* 0^0 = 1 by convention; x^0 = 1: x is defined everywhere */
    assert_int_equal(t->n, 1);
    assert_true(t->clauses[0].c.lo == 2 && t->clauses[0].c.hi == 2);
    tape_free(t);
    /* a constant defined nowhere folds to the empty set, not to a number */
    t = compile_ok("sqrt(-1)");
    assert_int_equal(t->n, 1);
    assert_true(isnan(t->clauses[0].c.lo) && isnan(t->clauses[0].c.hi));
    tape_free(t);
}

static void test_constants_pi_e(void **state)
{
    (void)state;
    mpfr_t lo, hi, one;
    mpfr_inits2(256, lo, hi, one, (mpfr_ptr)0);
    tape_t *t = compile_ok("pi");
    assert_int_equal(t->n, 1);
    iv_t c = t->clauses[0].c;
    mpfr_const_pi(lo, MPFR_RNDD);
    mpfr_const_pi(hi, MPFR_RNDU);
    assert_true(mpfr_cmp_d(lo, c.lo) > 0 && mpfr_cmp_d(hi, c.hi) < 0);
    assert_true(c.hi == nextafter(c.lo, INFINITY)); /* tight */
    tape_free(t);
    t = compile_ok("e");
    c = t->clauses[0].c;
    mpfr_set_ui(one, 1, MPFR_RNDN);
    mpfr_exp(lo, one, MPFR_RNDD);
    mpfr_exp(hi, one, MPFR_RNDU);
    assert_true(mpfr_cmp_d(lo, c.lo) > 0 && mpfr_cmp_d(hi, c.hi) < 0);
    assert_true(c.hi == nextafter(c.lo, INFINITY));
    tape_free(t);
    mpfr_clears(lo, hi, one, (mpfr_ptr)0);
}

static void test_sharing(void **state)
{
    (void)state;
    tape_t *t = compile_ok("x^2+x^2"); /* x, sqr, add(sqr, sqr) */
    assert_int_equal(t->n, 3);
    assert_int_equal(count_op(t, TAPE_SQR), 1);
    assert_int_equal(t->clauses[2].a, t->clauses[2].b);
    tape_free(t);
    t = compile_ok("x*y + y*x"); /* commutative operands are ordered */
    assert_int_equal(t->n, 4);
    tape_free(t);
    t = compile_ok("min(x, y) - min(y, x) + max(z, 1) * max(1, z)");
    assert_int_equal(count_op(t, TAPE_MIN), 1);
    assert_int_equal(count_op(t, TAPE_MAX), 1);
    assert_int_equal(count_op(t, TAPE_CONST), 1);
    tape_free(t);
    t = compile_ok("(x+y)*(x+y) + sin(x+y)");
    assert_int_equal(count_op(t, TAPE_ADD), 2);
    assert_int_equal(count_op(t, TAPE_SQR), 1);
    tape_free(t);
    t = compile_ok("x - y"); /* not commutative: order kept */
    assert_int_equal(t->clauses[t->clauses[2].a].op, TAPE_X);
    tape_free(t);
}

static void test_rewrites(void **state)
{
    (void)state;
    static const struct {
        const char *text;
        tape_op_t last;  /* op of the result clause */
        double param;    /* its exponent, for POWI / POWR */
        uint32_t n;      /* clauses */
    } cases[] = {
        {"x*x", TAPE_SQR, 0, 2},
        {"x^2", TAPE_SQR, 0, 2},
        {"x^(1+1)", TAPE_SQR, 0, 2},
        {"(-x)*(-x)", TAPE_SQR, 0, 2},
        {"x^3", TAPE_POWI, 3, 2},
        {"x^-1", TAPE_POWI, -1, 2},
        {"x^-2", TAPE_POWI, -2, 2},
        {"x^1024", TAPE_POWI, 1024, 2},
        {"x^(6/2)", TAPE_POWI, 3, 2},
        {"x^0.5", TAPE_POWR, 0.5, 2},
        {"x^-2.5", TAPE_POWR, -2.5, 2},
        {"x^y", TAPE_EXP, 0, 5},     /* exp(y*log(x)) */
        {"x^(1/3)", TAPE_EXP, 0, 5}, /* 1/3 is not a double */
        {"e^x", TAPE_EXP, 0, 2},
        {"x^1", TAPE_X, 0, 1},
        {"x^0", TAPE_CONST, 0, 1},
        {"--x", TAPE_X, 0, 1},
        {"x+0", TAPE_X, 0, 1},
        {"1*x", TAPE_X, 0, 1},
        {"x/1", TAPE_X, 0, 1},
        {"0-x", TAPE_NEG, 0, 2},
        {"min(x, x)", TAPE_X, 0, 1},
        {"abs(-x)", TAPE_ABS, 0, 2},
        /* kept as written: rewriting would change where f is defined */
        {"x-x", TAPE_SUB, 0, 2},
        {"x/x", TAPE_DIV, 0, 2},
        {"sqrt(x)^2", TAPE_SQR, 0, 3},
        {"sqrt(x)^0", TAPE_ADD, 0, 6}, /* 0*sqrt(x) + 1: 1 where sqrt(x) is defined */
        {"(1/x)^0", TAPE_ADD, 0, 6},
        {"x*0", TAPE_MUL, 0, 3},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        tape_t *t = compile_ok(cases[i].text);
        const tape_clause_t *r = &t->clauses[t->n - 1];
        if (r->op != (uint32_t)cases[i].last || t->n != cases[i].n)
            fail_msg("'%s': %u clauses ending in %s, want %u ending in %s", cases[i].text, t->n,
                     tape_op_name((tape_op_t)r->op), cases[i].n, tape_op_name(cases[i].last));
        if (r->op == TAPE_POWI || r->op == TAPE_POWR)
            assert_true(r->c.lo == cases[i].param && r->c.hi == cases[i].param);
        tape_free(t);
    }
    tape_t *t = compile_ok("x^y");
    assert_int_equal(count_op(t, TAPE_LOG), 1);
    assert_int_equal(count_op(t, TAPE_MUL), 1);
    tape_free(t);
    t = compile_ok("x^0");
    assert_true(t->clauses[0].c.lo == 1 && t->clauses[0].c.hi == 1);
    tape_free(t);
}

/* ---- errors ------------------------------------------------------------------------ */

static void expect_error(const char *text, int line, int col, const char *msg)
{
    tape_t *t = (tape_t *)1;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    int rc = tape_compile(text, &t, &err);
    if (rc == 0)
        fail_msg("'%.100s' compiled, expected %d:%d: %s", text, line, col, msg);
    assert_null(t);
    if (err.line != line || err.col != col || strcmp(err.msg, msg) != 0)
        fail_msg("'%.100s': got %d:%d: %s\n  want %d:%d: %s", text, err.line, err.col, err.msg, line,
                 col, msg);
}

static void test_errors(void **state)
{
    (void)state;
    static const struct {
        const char *text;
        int line, col;
        const char *msg;
    } cases[] = {
        {"(x+1", 1, 5, "expected ')' to close '(' opened at 1:1"},
        {"x*(y+(z-1)", 1, 11, "expected ')' to close '(' opened at 1:3"},
        {"sin(x", 1, 6, "expected ')' to close '(' opened at 1:4"},
        {"sine(x)", 1, 1, "unknown function 'sine'"},
        {"w + 1", 1, 1, "unknown name 'w'"},
        {"x + ww(1)", 1, 5, "unknown function 'ww'"},
        {"X", 1, 1, "unknown name 'X' (names are case-sensitive: did you mean 'x'?)"},
        {"PI", 1, 1, "unknown name 'PI' (names are case-sensitive: did you mean 'pi'?)"},
        {"Sin(x)", 1, 1, "unknown function 'Sin' (names are case-sensitive: did you mean 'sin'?)"},
        {"x(2)", 1, 1, "'x' is not a function"},
        {"sin x", 1, 5, "expected '(' after function 'sin'"},
        {"min(x)", 1, 6, "min takes 2 arguments"},
        {"max(x, y, z)", 1, 9, "max takes 2 arguments"},
        {"min()", 1, 5, "min takes 2 arguments"},
        {"sin(x, y)", 1, 6, "sin takes 1 argument"},
        {"sin()", 1, 5, "sin takes 1 argument"},
        {"min(x y)", 1, 7, "expected ',' between the arguments of min, found 'y'"},
        {"x)", 1, 2, "unexpected ')'"},
        {"x y", 1, 3, "trailing input after expression"},
        {"x + 1 2", 1, 7, "trailing input after expression"},
        {"", 1, 1, "expected an expression, found end of input"},
        {"   \n  ", 2, 3, "expected an expression, found end of input"},
        {"x +", 1, 4, "expected an expression, found end of input"},
        {"(x * )", 1, 6, "expected an expression, found ')'"},
        {"x * * y", 1, 5, "expected an expression, found '*'"},
        {",", 1, 1, "expected an expression, found ','"},
        {"1e999", 1, 1, "number out of range"},
        {"x + 1e400", 1, 5, "number out of range"},
        {"2x", 1, 2, "expected an operator before 'x' (implicit multiplication is not supported)"},
        {"1e+", 1, 2, "malformed number: expected the digits of an exponent after 'e'"},
        {"2e", 1, 2, "malformed number: expected the digits of an exponent after 'e'"},
        {"1.2.3", 1, 4, "malformed number: unexpected '.'"},
        {"x . y", 1, 3, "malformed number: expected a digit after '.'"},
        {"x # y", 1, 3, "unexpected character '#'"},
        {"x = 1", 1, 3, "unexpected character '='"},
        {"x \x01", 1, 3, "unexpected control character 0x01"},
        {"2 \xcf\x80", 1, 3, "unexpected character '\xcf\x80'"},
        {"x^2000", 1, 2, "integer exponent too large: at most 1024 in absolute value for a variable base"},
        {"x^-1025", 1, 2, "integer exponent too large: at most 1024 in absolute value for a variable base"},
        /* positions in multi-line texts */
        {"x +\n  (y *\n   z", 3, 5, "expected ')' to close '(' opened at 2:3"},
        {"x +\n\n  sine(y)", 3, 3, "unknown function 'sine'"},
        {"x\n)", 2, 1, "unexpected ')'"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        expect_error(cases[i].text, cases[i].line, cases[i].col, cases[i].msg);
}

/* ---- limits -------------------------------------------------------------------------- */

static char *repeat3(const char *pre, size_t npre, const char *mid, const char *post, size_t npost)
{
    size_t lp = strlen(pre), lm = strlen(mid), lq = strlen(post);
    char *s = malloc(lp * npre + lm + lq * npost + 1), *p = s;
    assert_non_null(s);
    for (size_t i = 0; i < npre; i++, p += lp)
        memcpy(p, pre, lp);
    memcpy(p, mid, lm);
    p += lm;
    for (size_t i = 0; i < npost; i++, p += lq)
        memcpy(p, post, lq);
    *p = '\0';
    return s;
}

static void test_nesting(void **state)
{
    (void)state;
    char *s = repeat3("(", 100000, "x", ")", 100000);
    expect_error(s, 1, TAPE_MAX_NESTING + 1, "expression nested deeper than 1000 levels");
    free(s);
    /* exactly at the limit is fine */
    s = repeat3("(", TAPE_MAX_NESTING, "x", ")", TAPE_MAX_NESTING);
    tape_t *t = compile_ok(s);
    assert_int_equal(t->n, 1);
    tape_free(t);
    free(s);
    /* signs and exponents nest too */
    s = repeat3("-", 100000, "x", "", 0);
    expect_error(s, 1, TAPE_MAX_NESTING + 1, "expression nested deeper than 1000 levels");
    free(s);
    s = repeat3("x^", 100000, "x", "", 0);
    expect_error(s, 1, 2 * TAPE_MAX_NESTING + 2, "expression nested deeper than 1000 levels");
    free(s);
    s = repeat3("sin(", 100000, "x", ")", 100000);
    expect_error(s, 1, 4 * TAPE_MAX_NESTING + 4, "expression nested deeper than 1000 levels");
    free(s);
    /* a deep chain that is not nested: x+x+...+x, just under TAPE_MAX_TEXT */
    size_t n = TAPE_MAX_TEXT / 2; /* "x+" * (n-1) + "x" = 2n - 1 bytes */
    s = repeat3("x+", n - 1, "x", "", 0);
    assert_int_equal(strlen(s), TAPE_MAX_TEXT - 1);
    t = compile_ok(s);
    assert_int_equal(t->n, n); /* x, then n-1 distinct sums */
    assert_true(peval(t, 1, 0, 0) == (double)n); /* sums of integers below 2^53: exact */
    tape_free(t);
    free(s);
    /* and a text over the limit is refused */
    s = repeat3("x+", n, "x", "", 0);
    expect_error(s, 1, 1, "expression longer than the limit of 1048576 bytes");
    free(s);
    /* many shared subexpressions: ((x+1)*(x+1)+1)^2 ... */
    s = repeat3("sqrt(1+", 900, "x", ")", 900);
    t = compile_ok(s);
    assert_int_equal(t->n, 1 + 1 + 2 * 900);
    tape_free(t);
    free(s);
}

/* ---- names --------------------------------------------------------------------------- */

static void expect_define_error(tape_compiler_t *tc, const char *name, const char *text, int line,
                                int col, const char *msg)
{
    ivoct_error_t err;
    ivoct_error_clear(&err);
    assert_int_not_equal(tape_compiler_define(tc, name, text, &err), 0);
    if (err.line != line || err.col != col || strcmp(err.msg, msg) != 0)
        fail_msg("define %s = '%s': got %d:%d: %s\n  want %d:%d: %s", name, text, err.line, err.col,
                 err.msg, line, col, msg);
}

static void test_names(void **state)
{
    (void)state;
    tape_compiler_t *tc = tape_compiler_new();
    assert_non_null(tc);
    ivoct_error_t err;
    ivoct_error_clear(&err);
    assert_int_equal(tape_compiler_define(tc, "r2", "x^2 + y^2", &err), 0);
    assert_int_equal(tape_compiler_define(tc, "R_3d", "r2 + z^2", &err), 0);
    assert_int_equal(tape_compiler_define(tc, "_unused", "exp(x) + 1", &err), 0);
    tape_t *t = NULL;
    assert_int_equal(tape_compiler_compile(tc, "sqrt(R_3d) - 1 + r2*0", &t, &err), 0);
    check_tape(t);
    assert_true(peval(t, 1, 2, 2) == 2); /* sqrt(9) - 1 + 0: exact */
    assert_int_equal(count_op(t, TAPE_EXP), 0); /* unused names leave nothing */
    assert_int_equal(count_op(t, TAPE_SQR), 3); /* x^2 y^2 z^2, shared with r2 */
    tape_free(t);
    /* a compiler compiles many texts */
    assert_int_equal(tape_compiler_compile(tc, "z", &t, &err), 0);
    assert_int_equal(t->n, 1);
    tape_free(t);

    /* name errors have no position in the text (line 0) */
    expect_define_error(tc, "r2", "1", 0, 0, "name 'r2' is already defined");
    expect_define_error(tc, "x", "1", 0, 0, "'x' is reserved: it is a variable");
    expect_define_error(tc, "z", "1", 0, 0, "'z' is reserved: it is a variable");
    expect_define_error(tc, "pi", "1", 0, 0, "'pi' is reserved: it is a constant");
    expect_define_error(tc, "e", "1", 0, 0, "'e' is reserved: it is a constant");
    expect_define_error(tc, "sin", "1", 0, 0, "'sin' is reserved: it is a function");
    expect_define_error(tc, "min", "1", 0, 0, "'min' is reserved: it is a function");
    expect_define_error(tc, "2a", "1", 0, 0,
                        "invalid name '2a': a name is a letter or '_' followed by letters, digits or '_'");
    expect_define_error(tc, "a-b", "1", 0, 0,
                        "invalid name 'a-b': a name is a letter or '_' followed by letters, digits or '_'");
    expect_define_error(tc, "", "1", 0, 0,
                        "invalid name '': a name is a letter or '_' followed by letters, digits or '_'");
    /* errors in the text have its positions; a failed definition defines nothing */
    expect_define_error(tc, "s", "r2 +\n w", 2, 2, "unknown name 'w'");
    expect_define_error(tc, "s2", "s + 1", 1, 1, "unknown name 's'");
    /* a name cannot be used before it is defined, nor call itself */
    expect_define_error(tc, "q", "q + 1", 1, 1, "unknown name 'q'");
    assert_int_not_equal(tape_compiler_compile(tc, "r3 + 1", &t, &err), 0);
    assert_string_equal(err.msg, "unknown name 'r3'");
    assert_int_not_equal(tape_compiler_compile(tc, "R2 + 1", &t, &err), 0);
    assert_string_equal(err.msg, "unknown name 'R2' (names are case-sensitive: did you mean 'r2'?)");
    assert_int_not_equal(tape_compiler_compile(tc, "r2(1)", &t, &err), 0);
    assert_string_equal(err.msg, "'r2' is not a function");
    /* names are per compiler */
    assert_int_not_equal(tape_compile("r2", &t, &err), 0);
    assert_string_equal(err.msg, "unknown name 'r2'");
    tape_compiler_free(tc);
    tape_compiler_free(NULL);

    /* many names: the lookup is hashed, and each may use the one before */
    tc = tape_compiler_new();
    char name[32], text[64];
    for (int i = 0; i < 5000; i++) {
        snprintf(name, sizeof name, "v%d", i);
        if (i == 0)
            snprintf(text, sizeof text, "x");
        else
            snprintf(text, sizeof text, "v%d + 1", i - 1);
        assert_int_equal(tape_compiler_define(tc, name, text, &err), 0);
    }
    assert_int_equal(tape_compiler_compile(tc, "v4999", &t, &err), 0);
    check_tape(t);
    assert_true(peval(t, 0, 0, 0) == 4999);
    tape_free(t);
    tape_compiler_free(tc);
}

/* ---- tape utilities ------------------------------------------------------------------ */

static void test_tape_utils(void **state)
{
    (void)state;
    tape_t *t = compile_ok("sin(x)*y + 0.1");
    tape_t *c = tape_clone(t);
    assert_non_null(c);
    assert_int_equal(c->n, t->n);
    assert_ptr_not_equal(c->clauses, t->clauses);
    assert_memory_equal(c->clauses, t->clauses, t->n * sizeof *t->clauses);
    tape_free(t);
    tape_free(c);
    tape_free(NULL);
    assert_null(tape_clone(NULL));
    for (int i = 0; i < TAPE_OP_COUNT; i++) {
        const char *n = tape_op_name((tape_op_t)i);
        assert_string_not_equal(n, "?");
        for (int j = 0; j < i; j++)
            assert_string_not_equal(n, tape_op_name((tape_op_t)j));
    }
    assert_string_equal(tape_op_name(TAPE_SQR), "sqr");
    assert_string_equal(tape_op_name(TAPE_OP_COUNT), "?");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_precedence),  cmocka_unit_test(test_folding),
        cmocka_unit_test(test_constants_pi_e), cmocka_unit_test(test_sharing),
        cmocka_unit_test(test_rewrites),    cmocka_unit_test(test_errors),
        cmocka_unit_test(test_nesting),     cmocka_unit_test(test_names),
        cmocka_unit_test(test_tape_utils),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
