/* Modal intervals (modal/modal.h) against their definitions.
 *
 * Kaucher arithmetic: for random and edge-case operands of every class pair
 * (P, -P, Z, Dual Z, proper and improper, with zero bounds), the result of
 * each operation is checked against the semantic extension of x∘y computed
 * in MPFR from its definition, not from Kaucher's table:
 *   Z = [min_{xp} max_{xi} x∘y, max_{xp} min_{xi} x∘y]
 * (xp over the sets of the proper operands, xi over the improper ones; for
 * both proper the range, for both improper [max, min]).  For + - * / with
 * x∘y linear in x for fixed y and monotone in y for fixed x, the inner
 * max/min is at an end of its set and the outer min/max at an end or at 0
 * (where the two linear pieces cross).  The outer-rounded result must hold
 * it in the modal order, the inner-rounded one lie in it, both within a few
 * ulps (which also tells a wrong table entry from rounding).
 *
 * One-variable functions likewise ([min, max] of phi over the set, dual for
 * improper operands, with MPFR values at the ends and interior extrema); the
 * lattice (meet, join, inclusion, dual) by its order properties; the tape
 * functions on cases whose answer follows from the theory (incidences,
 * statuses of uninterpretable and unsupported cases). */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include <cmocka.h>
#include <mpfr.h>

#include "../modal/modal.h"
#include "support/testutil.h"

#define PREC 256
#define PI 3.14159265358979323846

/* ---- operands --------------------------------------------------------------- */
static const double edge[] = {0.0, -0.0, 1.0, -1.0, 2.0, -2.0, 0.5, -0.5, 3.0, -3.0,
                              1e-300, -1e-300, 0x1p-1074, -0x1p-1074, 1e10, -1e10,
                              0.1, -0.1, 7.25, -7.25};
#define N_EDGE (sizeof edge / sizeof edge[0])

static double rand_value(uint64_t *rng)
{
    uint64_t k = tu_next(rng) % 4;
    if (k == 0)
        return edge[tu_next(rng) % N_EDGE];
    double u = tu_uniform(rng) * 2 - 1;
    double e = (double)((int)(tu_next(rng) % 40) - 20);
    return k == 1 ? 8 * u : ldexp(u, (int)e);
}

static mod_t rand_mod(uint64_t *rng)
{
    return mod_make(rand_value(rng), rand_value(rng));
}

static int klass(mod_t a)
{
    if (a.lo >= 0 && a.hi >= 0)
        return 0;
    if (a.lo <= 0 && a.hi <= 0)
        return 1;
    return a.lo < 0 ? 2 : 3;
}

/* ---- the semantic reference of a binary operation --------------------------- */
enum { OP_ADD, OP_SUB, OP_MUL, OP_DIV };

static void op_mpfr(int op, mpfr_t r, double x, double y, mpfr_rnd_t rnd)
{
    mpfr_t X, Y;
    mpfr_init2(X, PREC);
    mpfr_init2(Y, PREC);
    mpfr_set_d(X, x, MPFR_RNDN);
    mpfr_set_d(Y, y, MPFR_RNDN);
    switch (op) {
    case OP_ADD: mpfr_add(r, X, Y, rnd); break;
    case OP_SUB: mpfr_sub(r, X, Y, rnd); break;
    case OP_MUL: mpfr_mul(r, X, Y, rnd); break;
    default: mpfr_div(r, X, Y, rnd); break;
    }
    mpfr_clear(X);
    mpfr_clear(Y);
}

/* candidate points of a set: its ends, and 0 when inside (if with_zero) */
static int candidates(iv_t s, int with_zero, double c[3])
{
    int n = 0;
    c[n++] = s.lo;
    c[n++] = s.hi;
    if (with_zero && s.lo < 0 && s.hi > 0)
        c[n++] = 0.0;
    return n;
}

/* The semantic extension of x∘y over the modal operands (a the x, b the y),
 * computed at PREC bits with rounding rnd (each bound directed by rnd, so
 * with MPFR_RNDD and MPFR_RNDU the exact bounds lie between the two). */
static void reference(int op, mod_t a, mod_t b, mpfr_rnd_t rnd, mpfr_t lo, mpfr_t hi)
{
    iv_t sa = mod_set(a), sb = mod_set(b);
    int pa = a.lo <= a.hi, pb = b.lo <= b.hi;
    mpfr_t v, inner_lo, inner_hi;
    mpfr_inits2(PREC, v, inner_lo, inner_hi, (mpfr_ptr)0);
    double ca[3], cb[3];
    if (pa == pb) {
        /* all corners; proper: [min, max], improper: [max, min] */
        int na = candidates(sa, 0, ca), nb = candidates(sb, 0, cb);
        int first = 1;
        for (int i = 0; i < na; i++)
            for (int j = 0; j < nb; j++) {
                op_mpfr(op, v, ca[i], cb[j], rnd);
                if (first) {
                    mpfr_set(lo, v, rnd);
                    mpfr_set(hi, v, rnd);
                    first = 0;
                } else if (pa) {
                    mpfr_min(lo, lo, v, rnd);
                    mpfr_max(hi, hi, v, rnd);
                } else {
                    mpfr_max(lo, lo, v, rnd);
                    mpfr_min(hi, hi, v, rnd);
                }
            }
    } else {
        /* one proper operand p (outer quantifier of f*: min over p of max over
         * i for lo, max over p of min over i for hi) */
        int p_is_a = pa;
        iv_t sp = p_is_a ? sa : sb, si = p_is_a ? sb : sa;
        double cp[3], ci[3];
        int np = candidates(sp, 1, cp), ni = candidates(si, 0, ci);
        for (int i = 0; i < np; i++) {
            for (int j = 0; j < ni; j++) {
                double x = p_is_a ? cp[i] : ci[j], y = p_is_a ? ci[j] : cp[i];
                op_mpfr(op, v, x, y, rnd);
                if (j == 0) {
                    mpfr_set(inner_lo, v, rnd);
                    mpfr_set(inner_hi, v, rnd);
                } else {
                    mpfr_max(inner_lo, inner_lo, v, rnd); /* max over xi */
                    mpfr_min(inner_hi, inner_hi, v, rnd); /* min over xi */
                }
            }
            if (i == 0) {
                mpfr_set(lo, inner_lo, rnd);
                mpfr_set(hi, inner_hi, rnd);
            } else {
                mpfr_min(lo, lo, inner_lo, rnd);
                mpfr_max(hi, hi, inner_hi, rnd);
            }
        }
    }
    mpfr_clears(v, inner_lo, inner_hi, (mpfr_ptr)0);
}

static mod_t apply(int op, mod_t a, mod_t b, mod_round_t r)
{
    switch (op) {
    case OP_ADD: return mod_add(a, b, r);
    case OP_SUB: return mod_sub(a, b, r);
    case OP_MUL: return mod_mul(a, b, r);
    default: return mod_div(a, b, r);
    }
}

/* |x - ref| within a few ulps of ref (the widening of iv_down / iv_up is
 * about 2^-52 |x| plus the smallest subnormal, per rounding) */
static int close_to(double x, mpfr_t ref)
{
    double rd = mpfr_get_d(ref, MPFR_RNDN);
    if (!isfinite(rd)) /* an overflowed bound: DBL_MAX or inf on its side */
        return fabs(x) >= DBL_MAX && (x > 0) == (rd > 0);
    mpfr_t d;
    mpfr_init2(d, PREC);
    mpfr_set_d(d, x, MPFR_RNDN);
    mpfr_sub(d, d, ref, MPFR_RNDN);
    mpfr_abs(d, d, MPFR_RNDN);
    double tol = 0x1p-49 * fabs(mpfr_get_d(ref, MPFR_RNDN)) + 0x1p-1068;
    int ok = mpfr_cmp_d(d, tol) <= 0;
    mpfr_clear(d);
    return ok;
}

static const char *opname[] = {"add", "sub", "mul", "div"};

static void check_binary(int op, mod_t a, mod_t b, long *count)
{
    mod_t o = apply(op, a, b, MOD_OUTER), in = apply(op, a, b, MOD_INNER);
    if (op == OP_DIV) {
        iv_t sb = mod_set(b);
        if (!(sb.lo > 0 || sb.hi < 0)) {
            /* undefined: 0 in Set(B) */
            assert_true(mod_is_nan(o) && mod_is_nan(in));
            return;
        }
    }
    mpfr_t dlo, dhi, ulo, uhi;
    mpfr_inits2(PREC, dlo, dhi, ulo, uhi, (mpfr_ptr)0);
    reference(op, a, b, MPFR_RNDD, dlo, dhi); /* each below the exact bound */
    reference(op, a, b, MPFR_RNDU, ulo, uhi); /* each above */
    /* outer: o.lo <= exact lo <= ulo, o.hi >= exact hi >= dhi */
    int ok_outer = mpfr_cmp_d(ulo, o.lo) >= 0 && mpfr_cmp_d(dhi, o.hi) <= 0;
    /* inner: in.lo >= exact lo >= dlo, in.hi <= exact hi <= uhi */
    int ok_inner = mpfr_cmp_d(dlo, in.lo) <= 0 && mpfr_cmp_d(uhi, in.hi) >= 0;
    int tight = close_to(o.lo, dlo) && close_to(o.hi, dhi) && close_to(in.lo, dlo) &&
                close_to(in.hi, dhi);
    if (!ok_outer || !ok_inner || !tight)
        fail_msg("%s [%a,%a] [%a,%a]: outer [%a,%a] inner [%a,%a] reference [%a,%a]%s%s%s",
                 opname[op], a.lo, a.hi, b.lo, b.hi, o.lo, o.hi, in.lo, in.hi,
                 mpfr_get_d(dlo, MPFR_RNDN), mpfr_get_d(dhi, MPFR_RNDN),
                 ok_outer ? "" : " (outer does not hold it)",
                 ok_inner ? "" : " (inner not inside)", tight ? "" : " (not tight)");
    mpfr_clears(dlo, dhi, ulo, uhi, (mpfr_ptr)0);
    (*count)++;
}

static void test_kaucher_against_definition(void **state)
{
    (void)state;
    uint64_t rng = tu_seed(20261202);
    long pairs[4][4] = {{0}}, count = 0;
    /* every pair of edge-built intervals (all class pairs, zero bounds) */
    for (size_t i = 0; i < N_EDGE; i += 2)
        for (size_t j = 1; j < N_EDGE; j += 3)
            for (size_t k = 0; k < N_EDGE; k += 3)
                for (size_t l = 1; l < N_EDGE; l += 2) {
                    mod_t a = mod_make(edge[i], edge[j]), b = mod_make(edge[k], edge[l]);
                    for (int op = 0; op < 4; op++)
                        check_binary(op, a, b, &count);
                    pairs[klass(a)][klass(b)]++;
                }
    long n = (long)(200000 * tu_scale());
    for (long t = 0; t < n; t++) {
        mod_t a = rand_mod(&rng), b = rand_mod(&rng);
        for (int op = 0; op < 4; op++)
            check_binary(op, a, b, &count);
        pairs[klass(a)][klass(b)]++;
    }
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++)
            assert_true(pairs[i][j] > 100); /* every row and column of the table */
    printf("%ld operations checked against the semantic definition\n", count);
}

/* ---- functions of one variable ------------------------------------------------ */
enum { U_SQR, U_POWI, U_SQRT, U_EXP, U_LOG, U_ATAN, U_SIN, U_COS, U_N };

static void u_mpfr(int f, int n, mpfr_t r, double x, mpfr_rnd_t rnd)
{
    mpfr_t X;
    mpfr_init2(X, PREC);
    mpfr_set_d(X, x, MPFR_RNDN);
    switch (f) {
    case U_SQR: mpfr_sqr(r, X, rnd); break;
    case U_POWI: mpfr_pow_si(r, X, n, rnd); break;
    case U_SQRT: mpfr_sqrt(r, X, rnd); break;
    case U_EXP: mpfr_exp(r, X, rnd); break;
    case U_LOG: mpfr_log(r, X, rnd); break;
    case U_ATAN: mpfr_atan(r, X, rnd); break;
    case U_SIN: mpfr_sin(r, X, rnd); break;
    default: mpfr_cos(r, X, rnd); break;
    }
    mpfr_clear(X);
}

static mod_t u_apply(int f, int n, mod_t a, mod_round_t r)
{
    switch (f) {
    case U_SQR: return mod_sqr(a, r);
    case U_POWI: return mod_powi(a, n, r);
    case U_SQRT: return mod_sqrt(a, r);
    case U_EXP: return mod_exp(a, r);
    case U_LOG: return mod_log(a, r);
    case U_ATAN: return mod_atan(a, r);
    case U_SIN: return mod_sin(a, r);
    default: return mod_cos(a, r);
    }
}

static void test_unary_against_definition(void **state)
{
    (void)state;
    uint64_t rng = tu_seed(777);
    long n = (long)(100000 * tu_scale()), checked = 0, undefined = 0;
    mpfr_t v, lo, hi;
    mpfr_inits2(PREC, v, lo, hi, (mpfr_ptr)0);
    for (long t = 0; t < n; t++) {
        int f = (int)(tu_next(&rng) % U_N);
        int pw = (int)(tu_next(&rng) % 11) - 5;
        mod_t a = mod_make(tu_uniform(&rng) * 8 - 4, tu_uniform(&rng) * 8 - 4);
        if (t % 3 == 0)
            a = mod_make(tu_uniform(&rng) * 0.5 - 0.25, tu_uniform(&rng) * 0.5 - 0.25);
        if (t % 7 == 0)
            a.lo = 0.0;
        iv_t s = mod_set(a);
        int proper = a.lo <= a.hi;
        mod_t o = u_apply(f, pw, a, MOD_OUTER), in = u_apply(f, pw, a, MOD_INNER);
        /* the domain of continuity, and where phi has an interior extremum */
        int defined = 1, with_zero = 0;
        if (f == U_SQRT)
            defined = s.lo >= 0;
        if (f == U_LOG)
            defined = s.lo > 0;
        if (f == U_POWI && pw < 0)
            defined = s.lo > 0 || s.hi < 0;
        if (f == U_SQR || (f == U_POWI && pw > 0 && pw % 2 == 0))
            with_zero = 1;
        if (f == U_SIN || f == U_COS) {
            /* monotone unless the set holds an extremum k pi/2 (sin: odd k; cos: even k) */
            double k0 = ceil(s.lo / (PI / 2) - 1e-9), k1 = floor(s.hi / (PI / 2) + 1e-9);
            int has = 0;
            for (double k = k0; k <= k1; k++)
                if (((long)fabs(k) % 2 == 1) == (f == U_SIN))
                    has = 1;
            if (has) {
                /* not proved monotone: must say undefined */
                assert_true(mod_is_nan(o) && mod_is_nan(in));
                undefined++;
                continue;
            }
            /* far from an extremum (1e-6): must be computed */
            double d = 1;
            for (double k = k0 - 1; k <= k1 + 1; k++)
                if (((long)fabs(k) % 2 == 1) == (f == U_SIN))
                    d = fmin(d, fmin(fabs(s.lo - k * PI / 2), fabs(s.hi - k * PI / 2)));
            if (d < 1e-6 && mod_is_nan(o))
                continue; /* too close to tell: either answer is right */
        }
        if (!defined) {
            assert_true(mod_is_nan(o) && mod_is_nan(in));
            undefined++;
            continue;
        }
        if (mod_is_nan(o) || mod_is_nan(in))
            fail_msg("f%d n=%d [%a,%a]: NaN on a defined case", f, pw, a.lo, a.hi);
        double c[3];
        int nc = candidates(s, with_zero, c);
        for (int dir = 0; dir < 2; dir++) {
            mpfr_rnd_t rnd = dir ? MPFR_RNDU : MPFR_RNDD;
            for (int k = 0; k < nc; k++) {
                u_mpfr(f, pw, v, c[k], rnd);
                if (k == 0) {
                    mpfr_set(lo, v, rnd);
                    mpfr_set(hi, v, rnd);
                } else if (proper) {
                    mpfr_min(lo, lo, v, rnd);
                    mpfr_max(hi, hi, v, rnd);
                } else {
                    mpfr_max(lo, lo, v, rnd);
                    mpfr_min(hi, hi, v, rnd);
                }
            }
            if (dir == 0) { /* RNDD: below the exact bounds */
                if (!(mpfr_cmp_d(hi, o.hi) <= 0 && mpfr_cmp_d(lo, in.lo) <= 0))
                    fail_msg("f%d n=%d [%a,%a]: outer hi %a or inner lo %a wrong", f, pw, a.lo,
                             a.hi, o.hi, in.lo);
                if (!close_to(o.lo, lo) || !close_to(in.hi, hi))
                    fail_msg("f%d n=%d [%a,%a]: not tight", f, pw, a.lo, a.hi);
            } else {        /* RNDU: above */
                if (!(mpfr_cmp_d(lo, o.lo) >= 0 && mpfr_cmp_d(hi, in.hi) >= 0))
                    fail_msg("f%d n=%d [%a,%a]: outer lo %a or inner hi %a wrong", f, pw, a.lo,
                             a.hi, o.lo, in.hi);
            }
        }
        checked++;
    }
    mpfr_clears(v, lo, hi, (mpfr_ptr)0);
    printf("%ld function values checked, %ld undefined cases\n", checked, undefined);
    assert_true(checked > n / 2);
    assert_true(undefined > n / 50);
}

/* ---- lattice ------------------------------------------------------------------- */
static void test_lattice(void **state)
{
    (void)state;
    uint64_t rng = tu_seed(99);
    long n = (long)(100000 * tu_scale());
    for (long t = 0; t < n; t++) {
        mod_t a = rand_mod(&rng), b = rand_mod(&rng), c = rand_mod(&rng);
        mod_t m = mod_meet(a, b), j = mod_join(a, b);
        /* meet is a lower bound, join an upper bound, in the modal order */
        assert_true(mod_subset(m, a) && mod_subset(m, b));
        assert_true(mod_subset(a, j) && mod_subset(b, j));
        /* greatest / least */
        if (mod_subset(c, a) && mod_subset(c, b))
            assert_true(mod_subset(c, m));
        if (mod_subset(a, c) && mod_subset(b, c))
            assert_true(mod_subset(j, c));
        /* dual reverses the order; dual of meet is join of duals */
        assert_true(mod_subset(a, b) == mod_subset(mod_dual(b), mod_dual(a)));
        mod_t dm = mod_dual(m), jd = mod_join(mod_dual(a), mod_dual(b));
        assert_true(dm.lo == jd.lo && dm.hi == jd.hi);
        /* on proper intervals, inclusion is set inclusion */
        mod_t pa = mod_prop(a), pb = mod_prop(b);
        iv_t sa = mod_set(a), sb = mod_set(b);
        assert_true(mod_is_proper(pa) && mod_is_improper(mod_impr(a)));
        assert_true(pa.lo == sa.lo && pa.hi == sa.hi);
        assert_true(mod_subset(pa, pb) == (sb.lo <= sa.lo && sa.hi <= sb.hi));
        /* an improper interval is in a proper one exactly when the sets meet */
        mod_t ia = mod_impr(a);
        assert_true(mod_subset(ia, pb) == (sa.lo <= sb.hi && sb.lo <= sa.hi));
        /* neg is exact and an involution; Kaucher: A - A' = 0 needs A' = Dual A */
        mod_t na = mod_neg(mod_neg(a));
        assert_true(na.lo == a.lo && na.hi == a.hi);
        mod_t z = mod_sub(a, mod_dual(a), MOD_OUTER);
        assert_true(mod_subset(mod_point(0.0), z)); /* [0, 0] inside the outer result */
        /* isotonicity of the rounded product: inner(A*B) ⊆ outer(A'*B') for A ⊆ A' */
        mod_t a2 = mod_join(a, c), b2 = mod_join(b, c);
        mod_t pi = mod_mul(a, b, MOD_INNER), po = mod_mul(a2, b2, MOD_OUTER);
        if (isfinite(po.lo) && isfinite(po.hi))
            assert_true(mod_subset(pi, po));
    }
}

/* ---- tapes ------------------------------------------------------------------- */
static void test_incidences(void **state)
{
    (void)state;
    static const struct {
        const char *f;
        uint64_t inc[3];
    } cases[] = {
        {"x^2 + y^2 + z^2 - 1", {1, 1, 1}},
        {"x*y + x", {2, 1, 0}},
        {"x*x + y", {1, 1, 0}}, /* the compiler makes x*x a square: one use */
        {"(x + 1)^2 * (x + 1) + z", {2, 0, 1}}, /* x + 1 shared, used twice */
        {"sin(x*y) + x", {2, 1, 0}},
        {"2", {0, 0, 0}},
        {"(x + y)*sin(x + y)*exp(x + y)", {3, 3, 0}}, /* x + y shared, three uses */
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        tape_t *t = tu_compile(cases[i].f);
        uint64_t inc[3];
        assert_int_equal(mod_incidences(t, inc), 0);
        for (int k = 0; k < 3; k++)
            if (inc[k] != cases[i].inc[k])
                fail_msg("%s: incidence of %c is %llu, expected %llu", cases[i].f, 'x' + k,
                         (unsigned long long)inc[k], (unsigned long long)cases[i].inc[k]);
        tape_free(t);
    }
}

static void expect_inner(const char *f, iv_box_t box, mod_status_t want)
{
    tape_t *t = tu_compile(f);
    iv_t out;
    mod_info_t info;
    mod_status_t st = mod_inner_range(t, &box, &out, &info);
    if (st != want)
        fail_msg("%s: status '%s', expected '%s'", f, mod_status_name(st), mod_status_name(want));
    if (st != MOD_OK)
        assert_true(iv_is_empty(out)); /* nothing claimed */
    tape_free(t);
}

static void test_statuses(void **state)
{
    (void)state;
    iv_box_t u = {{0, 1}, {0, 1}, {0, 1}}, s = {{-1, 1}, {-1, 1}, {-1, 1}};
    /* unsupported operations */
    expect_inner("min(x, y)", u, MOD_UNSUPPORTED);
    expect_inner("max(x, y) + z", u, MOD_UNSUPPORTED);
    expect_inner("abs(x) + y", u, MOD_UNSUPPORTED);
    /* not defined / continuous on the box */
    expect_inner("sqrt(x)", s, MOD_DOMAIN);
    expect_inner("1/x", s, MOD_DOMAIN);
    expect_inner("log(x + y)", u, MOD_DOMAIN);
    expect_inner("sin(4*x)", u, MOD_DOMAIN); /* not monotone: an extremum at pi/8 */
    /* supported and fine */
    expect_inner("x^2 + y^2 + z^2 - 1", s, MOD_OK);
    expect_inner("exp(x) + log(y + 1) + sqrt(z + 1)", u, MOD_OK);
    expect_inner("x*y + x", u, MOD_OK); /* x twice but f monotone in it */
    /* x - x^2: x twice, not monotone on [0, 1]: dualised, x - x^2 becomes
     * [1, 0] - [1, 0] = [1, -1], improper: no inner claim */
    expect_inner("x - x^2 + y*0.001", u, MOD_NO_INNER);
    /* x twice, derivative 2x + 1 > 0: fixed at the ends */
    expect_inner("x*(x + 1) + y", u, MOD_OK);

    /* f* with a multi-incident proper variable in which f is not monotone is
     * interpretable; f** is not (and the other way round) */
    tape_t *t = tu_compile("x*(1 - x) + y");
    mod_t X[3] = {mod_make(0, 1), mod_make(0, 10), mod_make(0, 0)}, out;
    mod_info_t info;
    assert_int_equal(mod_star(t, X, &out, &info), MOD_OK);
    assert_int_equal(info.use[0], MOD_VAR_MULTI);
    assert_int_equal(mod_dstar(t, X, &out, &info), MOD_NOT_INTERPRETABLE);
    assert_int_equal(info.use[0], MOD_VAR_BLOCKING);
    assert_true(mod_is_nan(out));
    X[0] = mod_dual(X[0]);
    assert_int_equal(mod_dstar(t, X, &out, &info), MOD_OK);
    assert_int_equal(mod_star(t, X, &out, &info), MOD_NOT_INTERPRETABLE);
    /* the inner estimate dualises x itself: the range of x(1-x) + y over
     * [0,1] x [0,10] is [0, 10.25]; every value of the estimate must be inside */
    iv_box_t b = {{0, 1}, {0, 10}, {0, 0}};
    iv_t r;
    assert_int_equal(mod_inner_range(t, &b, &r, &info), MOD_OK);
    assert_int_equal(info.use[0], MOD_VAR_DUALISED);
    assert_true(0 <= r.lo && r.lo <= r.hi && r.hi <= 10.25);
    tape_free(t);
}

/* f*(X) and f**(X) under mixed modalities, from their definitions: f(x, y, z)
 * = x*y + exp(z) + x is increasing in each variable over x, y > 0, so in
 * f* = [min_xp max_xi f, max_xp min_xi f] every min over a proper component is
 * at the lower end of its set and every max over an improper one at the upper
 * end of its set: both are the modal lower end X.lo, and likewise for the
 * upper bound; so f*(X) = f**(X) = [f(X.lo, Y.lo, Z.lo), f(X.hi, Y.hi, Z.hi)].
 * x occurs twice: mod_star and mod_dstar must find f monotone in it. */
static void f_mpfr(mpfr_t r, double a, double b, double c, mpfr_rnd_t rnd)
{
    mpfr_t A, B, C;
    mpfr_inits2(PREC, A, B, C, (mpfr_ptr)0);
    mpfr_set_d(A, a, MPFR_RNDN);
    mpfr_set_d(B, b, MPFR_RNDN);
    mpfr_set_d(C, c, MPFR_RNDN);
    mpfr_mul(B, A, B, rnd); /* exact at PREC bits */
    mpfr_exp(C, C, rnd);
    mpfr_add(r, B, C, rnd);
    mpfr_add(r, r, A, rnd);
    mpfr_clears(A, B, C, (mpfr_ptr)0);
}

static void test_semantic_mixed_modalities(void **state)
{
    (void)state;
    tape_t *t = tu_compile("x*y + exp(z) + x");
    uint64_t rng = tu_seed(1234);
    mpfr_t lo, hi;
    mpfr_inits2(PREC, lo, hi, (mpfr_ptr)0);
    long n = (long)(20000 * tu_scale()), modes[2] = {0, 0};
    for (long i = 0; i < n; i++) {
        mod_t X[3];
        for (int k = 0; k < 3; k++) {
            double u = tu_uniform(&rng) * 3 + (k == 2 ? -1.5 : 0.1);
            double v = tu_uniform(&rng) * 3 + (k == 2 ? -1.5 : 0.1);
            X[k] = mod_make(u, v);
        }
        modes[X[0].lo > X[0].hi]++;
        mod_t s, ds;
        mod_info_t info;
        assert_int_equal(mod_star(t, X, &s, &info), MOD_OK);
        assert_int_equal(info.use[0], MOD_VAR_MONOTONE);
        assert_int_equal(mod_dstar(t, X, &ds, &info), MOD_OK);
        f_mpfr(lo, X[0].lo, X[1].lo, X[2].lo, MPFR_RNDD);
        f_mpfr(hi, X[0].hi, X[1].hi, X[2].hi, MPFR_RNDU);
        /* outer: s.lo <= f*.lo, s.hi >= f*.hi (lo here is below f*.lo only by
         * 2^-256 relative, so compare with the rounded-up value) */
        mpfr_t lou, hid;
        mpfr_inits2(PREC, lou, hid, (mpfr_ptr)0);
        f_mpfr(lou, X[0].lo, X[1].lo, X[2].lo, MPFR_RNDU);
        f_mpfr(hid, X[0].hi, X[1].hi, X[2].hi, MPFR_RNDD);
        if (!(mpfr_cmp_d(lou, s.lo) >= 0 && mpfr_cmp_d(hid, s.hi) <= 0))
            fail_msg("f* [%a,%a]x[%a,%a]x[%a,%a]: [%a,%a] does not hold the definition", X[0].lo,
                     X[0].hi, X[1].lo, X[1].hi, X[2].lo, X[2].hi, s.lo, s.hi);
        if (!(mpfr_cmp_d(lo, ds.lo) <= 0 && mpfr_cmp_d(hi, ds.hi) >= 0))
            fail_msg("f** [%a,%a]x[%a,%a]x[%a,%a]: [%a,%a] not inside the definition", X[0].lo,
                     X[0].hi, X[1].lo, X[1].hi, X[2].lo, X[2].hi, ds.lo, ds.hi);
        double rl = mpfr_get_d(lo, MPFR_RNDN), rh = mpfr_get_d(hi, MPFR_RNDN);
        assert_true(fabs(s.lo - rl) <= 1e-13 * (fabs(rl) + 1) &&
                    fabs(s.hi - rh) <= 1e-13 * (fabs(rh) + 1)); /* tight: optimal */
        assert_true(fabs(ds.lo - s.lo) <= 1e-13 * (fabs(s.lo) + 1) &&
                    fabs(ds.hi - s.hi) <= 1e-13 * (fabs(s.hi) + 1));
        mpfr_clears(lou, hid, (mpfr_ptr)0);
    }
    assert_true(modes[0] > n / 4 && modes[1] > n / 4);
    mpfr_clears(lo, hi, (mpfr_ptr)0);
    tape_free(t);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_kaucher_against_definition),
        cmocka_unit_test(test_unary_against_definition),
        cmocka_unit_test(test_lattice),
        cmocka_unit_test(test_incidences),
        cmocka_unit_test(test_statuses),
        cmocka_unit_test(test_semantic_mixed_modalities),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
