/* Property test of expr/interval.c against MPFI at 256 bits.
 *
 * For every operation, COUNT random operand tuples (10^6, times the
 * environment's IVOCT_TEST_SCALE, default 1; seed IVOCT_SEED) are evaluated in
 * doubles and by the oracle; the double result must contain the oracle's.
 * The oracle's result encloses the exact range (MPFI rounds outward), so an
 * overestimate there can only make the test stricter, never let a bad
 * enclosure pass.
 *
 * Set-based semantics (IEEE 1788): an operation is taken over the part of its
 * operands where it is defined.  The reference is therefore computed on the
 * intersection with the domain; when that is empty the double result must be
 * empty.  MPFI has no empty set and no real semantics for infinite bounds
 * (0 * inf), for division by an interval holding 0 or for log at 0, so the
 * reference is computed on a subset of the operands that avoids those cases;
 * containing the image of a subset is necessary, and the subsets reach so far
 * that unbounded images still force infinite bounds:
 *
 *  - an infinite bound is replaced by +-2^(2^20), far beyond DBL_MAX;
 *  - an open domain end at 0 (log, negative powers, division) is replaced by
 *    +-2^-(2^20), so log, 1/x, x^-n there lie far beyond every double;
 *  - division by b holding 0 is the hull of the divisions by the two pieces
 *    b ∩ [2^-(2^20), inf) and b ∩ (-inf, -2^-(2^20)];
 *  - sin, cos, tan (and dtan) of an operand with an infinite bound or wider
 *    than a period: the exact range is known ([-1,1], resp. the whole line and
 *    [1, inf)); MPFI is not asked (it would reduce 2^(2^20) modulo pi).
 *
 * Functions MPFI 1.5 lacks (powi, powr, min, max, the derivative helpers) are
 * referenced with MPFR directed roundings on monotone pieces, or with MPFI
 * expressions in which each variable occurs once.  The costly functions use
 * pooled endpoints (see run_pooled).
 *
 * Tightness: where both results are finite, the distance in doubles between
 * each bound and MPFI's bound rounded outward to double is measured, printed
 * (worst and mean per operation) and asserted (tight_limit, in_scope): at
 * most TIGHT_ULPS for + - * / sqr sqrt.
 *
 * Also: exact expectations (sqr([-2,3]).lo == 0, division by [0,0] is empty,
 * empty propagates through every operation...), iv_from_decimal against
 * mpfi_set_str, and the error record's formatting.
 */
#include <float.h>
#include <limits.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <cmocka.h>
#include <mpfi.h>

#include "../expr/error.h"
#include "../expr/interval.h"
#include "support/testutil.h"

#define PREC 256
#define COUNT 1000000 /* operand tuples per operation and run (times IVOCT_TEST_SCALE) */
#define TIGHT_ULPS 4 /* + - * / sqr sqrt: excess over MPFI's rounded-out bounds (3 by the analysis at tight_limit) */
#define SEED 0x1f2e3d4c5b6a7988ull
#define HALF_PI 0x1.921fb54442d18p0 /* nearest double to pi/2 */

typedef enum {
    OP_ADD, OP_SUB, OP_NEG, OP_MUL, OP_DIV, OP_SQR, OP_POWI, OP_POWR, OP_SQRT, OP_EXP,
    OP_LOG, OP_SIN, OP_COS, OP_TAN, OP_ATAN, OP_ABS, OP_MIN, OP_MAX, OP_HULL,
    OP_DSQRT, OP_DLOG, OP_DTAN, OP_DATAN, OP_DABS, OP_COUNT
} op_t;

static const char *const op_name[OP_COUNT] = {
    "add", "sub", "neg", "mul", "div", "sqr", "powi", "powr", "sqrt", "exp",
    "log", "sin", "cos", "tan", "atan", "abs", "min", "max", "hull",
    "dsqrt", "dlog", "dtan", "datan", "dabs"};

enum { REF_IV, REF_EMPTY, REF_ANY };

/* ---- oracle state -------------------------------------------------------------- */
static mpfr_t BIG, TINY, fa, fb, fc, fd, fe;
static mpfr_t EDGE; /* pooled log, powr: f at the domain end TINY, rounded outward */
static mpfi_t A, B, R, T;

static int setup(void **state)
{
    (void)state;
    mpfr_inits2(PREC, BIG, TINY, EDGE, fa, fb, fc, fd, fe, (mpfr_ptr)0);
    mpfi_init2(A, PREC);
    mpfi_init2(B, PREC);
    mpfi_init2(R, PREC);
    mpfi_init2(T, PREC);
    mpfr_set_ui_2exp(BIG, 1, 1L << 20, MPFR_RNDN);
    mpfr_set_si_2exp(TINY, 1, -(1L << 20), MPFR_RNDN);
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    mpfr_clears(BIG, TINY, EDGE, fa, fb, fc, fd, fe, (mpfr_ptr)0);
    mpfi_clear(A);
    mpfi_clear(B);
    mpfi_clear(R);
    mpfi_clear(T);
    mpfr_free_cache();
    return 0;
}

static void fr_clip(mpfr_t o, double x)
{
    if (x == INFINITY)
        mpfr_set(o, BIG, MPFR_RNDN);
    else if (x == -INFINITY)
        mpfr_neg(o, BIG, MPFR_RNDN);
    else
        mpfr_set_d(o, x, MPFR_RNDN);
}

/* o = [lo, hi] with infinite ends clipped (lo <= hi) */
static void iv_clip2(mpfi_t o, double lo, double hi)
{
    fr_clip(fa, lo);
    fr_clip(fb, hi);
    mpfi_interv_fr(o, fa, fb);
}

static void iv_clip(mpfi_t o, iv_t a) { iv_clip2(o, a.lo, a.hi); }

/* o = a ∩ [TINY, inf) (lo_open: a ∩ (0, inf) approximated from inside), or
 * a ∩ [0, inf); returns 0 when that is empty. */
static int clip_pos(mpfi_t o, iv_t a, int open)
{
    if (open ? !(a.hi > 0.0) : !(a.hi >= 0.0))
        return 0;
    fr_clip(fb, a.hi);
    if (a.lo > 0.0)
        mpfr_set_d(fa, a.lo, MPFR_RNDN);
    else if (open)
        mpfr_set(fa, TINY, MPFR_RNDN);
    else
        mpfr_set_zero(fa, 1);
    if (mpfr_cmp(fa, fb) > 0) /* a.hi below TINY */
        mpfr_set(fa, fb, MPFR_RNDN);
    mpfi_interv_fr(o, fa, fb);
    return 1;
}

static int clip_neg(mpfi_t o, iv_t a, int open)
{
    if (open ? !(a.lo < 0.0) : !(a.lo <= 0.0))
        return 0;
    fr_clip(fa, a.lo);
    if (a.hi < 0.0)
        mpfr_set_d(fb, a.hi, MPFR_RNDN);
    else if (open)
        mpfr_neg(fb, TINY, MPFR_RNDN);
    else
        mpfr_set_zero(fb, -1);
    if (mpfr_cmp(fa, fb) > 0)
        mpfr_set(fb, fa, MPFR_RNDN);
    mpfi_interv_fr(o, fa, fb);
    return 1;
}

/* R = hull(R, [lo, hi]) where have says whether R holds anything yet */
static void hull_into(int *have, mpfr_t lo, mpfr_t hi)
{
    mpfi_interv_fr(T, lo, hi);
    if (*have)
        mpfi_union(R, R, T);
    else
        mpfi_set(R, T);
    *have = 1;
}

/* x^n on a sign-constant piece [x0, x1] (monotone there): hull of the ends,
 * each rounded outward, into R */
static void powi_piece(int *have, int n, mpfr_t x0, mpfr_t x1)
{
    mpfr_pow_si(fc, x0, n, MPFR_RNDD);
    mpfr_pow_si(fd, x1, n, MPFR_RNDD);
    mpfr_min(fc, fc, fd, MPFR_RNDD);
    mpfr_pow_si(fd, x0, n, MPFR_RNDU);
    mpfr_pow_si(fe, x1, n, MPFR_RNDU);
    mpfr_max(fd, fd, fe, MPFR_RNDU);
    hull_into(have, fc, fd);
}

/* The reference for op into R; returns REF_IV, REF_EMPTY (the exact image is
 * empty: the double result must be empty) or REF_ANY (no real value to
 * enclose, e.g. a derivative over a set where f is nowhere differentiable:
 * only validity is checked). */
static int reference(op_t op, iv_t a, iv_t b, int n, double r)
{
    int have = 0;
    if (op == OP_HULL) { /* empty operands are ignored */
        if (iv_is_empty(a) && iv_is_empty(b))
            return REF_EMPTY;
        if (iv_is_empty(a))
            iv_clip(R, b);
        else if (iv_is_empty(b))
            iv_clip(R, a);
        else {
            iv_clip(A, a);
            iv_clip(B, b);
            mpfi_union(R, A, B);
        }
        return REF_IV;
    }
    if (iv_is_empty(a) || ((op == OP_ADD || op == OP_SUB || op == OP_MUL || op == OP_DIV ||
                            op == OP_MIN || op == OP_MAX) &&
                           iv_is_empty(b)))
        return REF_EMPTY;
    switch (op) {
    case OP_ADD:
        iv_clip(A, a);
        iv_clip(B, b);
        mpfi_add(R, A, B);
        return REF_IV;
    case OP_SUB:
        iv_clip(A, a);
        iv_clip(B, b);
        mpfi_sub(R, A, B);
        return REF_IV;
    case OP_NEG:
        iv_clip(A, a);
        mpfi_neg(R, A);
        return REF_IV;
    case OP_MUL:
        iv_clip(A, a);
        iv_clip(B, b);
        mpfi_mul(R, A, B);
        return REF_IV;
    case OP_DIV:
        iv_clip(A, a);
        if (clip_pos(B, b, 1)) {
            mpfi_div(T, A, B);
            mpfi_set(R, T);
            have = 1;
        }
        if (clip_neg(B, b, 1)) {
            mpfi_div(T, A, B);
            if (have)
                mpfi_union(R, R, T);
            else
                mpfi_set(R, T);
            have = 1;
        }
        return have ? REF_IV : REF_EMPTY;
    case OP_SQR:
        iv_clip(A, a);
        mpfi_sqr(R, A);
        return REF_IV;
    case OP_POWI:
        if (n == 0) {
            mpfi_set_si(R, 1);
            return REF_IV;
        }
        if (clip_neg(A, a, n < 0)) {
            mpfr_set(fa, &A->left, MPFR_RNDN);
            mpfr_set(fb, &A->right, MPFR_RNDN);
            powi_piece(&have, n, fa, fb);
        }
        if (clip_pos(A, a, n < 0)) {
            mpfr_set(fa, &A->left, MPFR_RNDN);
            mpfr_set(fb, &A->right, MPFR_RNDN);
            powi_piece(&have, n, fa, fb);
        }
        return have ? REF_IV : REF_EMPTY;
    case OP_POWR:
        /* x^r, r not an integer: domain x >= 0 (r > 0), x > 0 (r < 0);
         * monotone there */
        if (!clip_pos(A, a, r < 0.0))
            return REF_EMPTY;
        mpfr_set_d(fe, r, MPFR_RNDN);
        if (r > 0.0) {
            mpfr_pow(fc, &A->left, fe, MPFR_RNDD);
            mpfr_pow(fd, &A->right, fe, MPFR_RNDU);
        } else {
            mpfr_pow(fc, &A->right, fe, MPFR_RNDD);
            mpfr_pow(fd, &A->left, fe, MPFR_RNDU);
        }
        hull_into(&have, fc, fd);
        return REF_IV;
    case OP_SQRT:
        if (!clip_pos(A, a, 0))
            return REF_EMPTY;
        mpfi_sqrt(R, A);
        return REF_IV;
    case OP_EXP:
        iv_clip(A, a);
        mpfi_exp(R, A);
        return REF_IV;
    case OP_LOG:
        if (!clip_pos(A, a, 1))
            return REF_EMPTY;
        mpfi_log(R, A);
        return REF_IV;
    case OP_SIN:
    case OP_COS:
        if (isinf(a.lo) || isinf(a.hi)) {
            mpfi_interv_si(R, -1, 1);
            return REF_IV;
        }
        mpfi_interv_d(A, a.lo, a.hi);
        if (op == OP_SIN)
            mpfi_sin(R, A);
        else
            mpfi_cos(R, A);
        return REF_IV;
    case OP_TAN:
        if (isinf(a.lo) || isinf(a.hi)) {
            mpfr_neg(fa, BIG, MPFR_RNDN);
            mpfi_interv_fr(R, fa, BIG);
            return REF_IV;
        }
        mpfi_interv_d(A, a.lo, a.hi);
        mpfi_tan(R, A); /* a pole inside gives [-inf, +inf] */
        return REF_IV;
    case OP_ATAN:
        iv_clip(A, a);
        mpfi_atan(R, A);
        return REF_IV;
    case OP_ABS:
        iv_clip(A, a);
        mpfi_abs(R, A);
        return REF_IV;
    case OP_MIN:
    case OP_MAX:
        /* exact on the bounds */
        fr_clip(fa, a.lo);
        fr_clip(fb, b.lo);
        fr_clip(fc, a.hi);
        fr_clip(fd, b.hi);
        if (op == OP_MIN) {
            mpfr_min(fa, fa, fb, MPFR_RNDN);
            mpfr_min(fb, fc, fd, MPFR_RNDN);
        } else {
            mpfr_max(fa, fa, fb, MPFR_RNDN);
            mpfr_max(fb, fc, fd, MPFR_RNDN);
        }
        mpfi_interv_fr(R, fa, fb);
        return REF_IV;
    case OP_HULL:
    case OP_DSQRT: /* 1/(2 sqrt x) over a ∩ (0, inf) */
        if (!(a.hi >= 0.0))
            return REF_EMPTY;
        if (!clip_pos(A, a, 1))
            return REF_ANY; /* a ∩ [0,inf) = {0}: not differentiable anywhere */
        mpfi_sqrt(T, A);
        mpfi_mul_ui(T, T, 2);
        mpfi_inv(R, T);
        return REF_IV;
    case OP_DLOG:
        if (!clip_pos(A, a, 1))
            return REF_EMPTY;
        mpfi_inv(R, A);
        return REF_IV;
    case OP_DTAN:
        if (isinf(a.lo) || isinf(a.hi)) {
            mpfr_set_ui(fa, 1, MPFR_RNDN);
            mpfi_interv_fr(R, fa, BIG);
            return REF_IV;
        }
        mpfi_interv_d(A, a.lo, a.hi);
        mpfi_tan(T, A);
        mpfi_sqr(T, T);
        mpfi_add_ui(R, T, 1);
        return REF_IV;
    case OP_DATAN:
        iv_clip(A, a);
        mpfi_sqr(T, A);
        mpfi_add_ui(T, T, 1);
        mpfi_inv(R, T);
        return REF_IV;
    case OP_DABS: {
        /* sign(x) over a \ {0} */
        int lo = a.lo < 0.0 ? -1 : 1, hi = a.hi > 0.0 ? 1 : -1;
        if (a.lo == 0.0 && a.hi == 0.0)
            return REF_ANY;
        mpfi_interv_si(R, lo, hi);
        return REF_IV;
    }
    case OP_COUNT:
        break;
    }
    return REF_ANY;
}

static iv_t compute(op_t op, iv_t a, iv_t b, int n, double r)
{
    switch (op) {
    case OP_ADD: return iv_add(a, b);
    case OP_SUB: return iv_sub(a, b);
    case OP_NEG: return iv_neg(a);
    case OP_MUL: return iv_mul(a, b);
    case OP_DIV: return iv_div(a, b);
    case OP_SQR: return iv_sqr(a);
    case OP_POWI: return iv_powi(a, n);
    case OP_POWR: return iv_powr(a, r);
    case OP_SQRT: return iv_sqrt(a);
    case OP_EXP: return iv_exp(a);
    case OP_LOG: return iv_log(a);
    case OP_SIN: return iv_sin(a);
    case OP_COS: return iv_cos(a);
    case OP_TAN: return iv_tan(a);
    case OP_ATAN: return iv_atan(a);
    case OP_ABS: return iv_abs(a);
    case OP_MIN: return iv_min(a, b);
    case OP_MAX: return iv_max(a, b);
    case OP_HULL: return iv_hull(a, b);
    case OP_DSQRT: return iv_dsqrt(a);
    case OP_DLOG: return iv_dlog(a);
    case OP_DTAN: return iv_dtan(a);
    case OP_DATAN: return iv_datan(a);
    case OP_DABS: return iv_dabs(a);
    case OP_COUNT: break;
    }
    return iv_empty();
}

/* ---- operand generator ------------------------------------------------------- */
static double near_half_pi_multiple(uint64_t *s, uint64_t u)
{
    long k;
    if ((u >> 40) % 4 == 0)
        k = (long)((u >> 12) % 2000001) - 1000000; /* far out */
    else
        k = (long)((u >> 12) % 41) - 20;
    double x = (double)k * HALF_PI; /* rounded: the true multiple is within ulps */
    double f = tu_uniform(s);
    switch ((u >> 44) % 6) {
    case 0: return x;
    case 1: return nextafter(x, (u >> 50) & 1 ? INFINITY : -INFINITY);
    case 2: { /* a few ulps */
        int steps = (int)((u >> 50) % 8);
        for (int i = 0; i < steps; i++)
            x = nextafter(x, (u >> 58) & 1 ? INFINITY : -INFINITY);
        return x;
    }
    case 3: return x + ((u >> 50) & 1 ? 1e-12 : -1e-12) * f;
    case 4: return x + ((u >> 50) & 1 ? 1e-6 : -1e-6) * f;
    default: return x + ((u >> 50) & 1 ? 1e-3 : -1e-3) * f;
    }
}

static double gen_double(uint64_t *s, int trig)
{
    uint64_t u = tu_next(s);
    double sign = (u >> 63) ? -1.0 : 1.0;
    double f = tu_uniform(s);
    unsigned cat = (unsigned)(u % 20);
    if (trig && cat >= 14)
        return near_half_pi_multiple(s, u);
    if (trig && cat >= 10)
        return sign * f * ((u >> 8) & 1 ? 1e6 : 1e15);
    switch (cat) {
    case 0: return sign * 0.0;
    case 1: return sign * ldexp(1.0 + f, -1000 + (int)((u >> 20) % 40)); /* ~1e-300 */
    case 2: return sign * ldexp(1.0 + f, 985 + (int)((u >> 20) % 39));   /* ~1e300 */
    case 3: return sign * ldexp((double)((u >> 11) & ((1ull << 52) - 1)), -1074); /* subnormal */
    case 4: return (u >> 20) & 1 ? sign * INFINITY : sign * DBL_MAX;
    case 5: return sign * (double)((u >> 20) % 21);                        /* exact integers */
    case 6: return sign * 10.0 * f;
    case 7: return sign * ldexp(1.0 + f, (int)((u >> 20) % 2098) - 1074);  /* any exponent */
    case 8: return near_half_pi_multiple(s, u);
    case 9: return sign * f * 1e6;
    case 10: return sign * f * 1e15;
    case 11: return sign * f;
    case 12: return sign * ldexp(1.0, (int)((u >> 20) % 64) - 32);         /* powers of two */
    case 13: {
        static const double special[] = {DBL_MIN, DBL_TRUE_MIN, 1.0, 0.5, 2.0, 1e-308,
                                         0x1.fffffffffffffp-1, 0x1.0000000000001p0, 3.0, 0.1};
        return sign * special[(u >> 20) % 10];
    }
    default: return sign * 3.0 * f;
    }
}

static iv_t gen_iv(uint64_t *s, int trig)
{
    uint64_t u = tu_next(s);
    unsigned shape = (unsigned)(u % 64);
    if (shape == 0)
        return iv_empty();
    double x = gen_double(s, trig), y;
    if (shape < 8) {
        y = x; /* point */
    } else if (shape < 30) { /* narrow: relative width 2^-1 .. 2^-52, or a few ulps */
        double w = fabs(x) * ldexp(tu_uniform(s), -(int)((u >> 8) % 53));
        y = (u >> 16) & 1 ? x + w : x - w;
        if (y != y) /* x infinite */
            y = x;
        else if (y == x)
            y = nextafter(x, (u >> 16) & 1 ? INFINITY : -INFINITY);
    } else {
        y = gen_double(s, trig);
    }
    iv_t a = {x < y ? x : y, x < y ? y : x};
    if (a.lo == INFINITY)
        a.lo = DBL_MAX;
    if (a.hi == -INFINITY)
        a.hi = -DBL_MAX;
    return a;
}

static int gen_n(uint64_t *s)
{
    uint64_t u = tu_next(s);
    unsigned c = (unsigned)(u % 100);
    if (c < 70)
        return (int)((u >> 8) % 17) - 8;
    if (c < 90)
        return (int)((u >> 8) % 129) - 64;
    static const int ext[] = {INT_MIN, INT_MAX, INT_MIN + 1, INT_MAX - 1, 1000001, -1000001,
                              999999, -1000000};
    return ext[(u >> 8) % 8];
}

static double gen_r(uint64_t *s)
{
    uint64_t u = tu_next(s);
    static const double special[] = {0.5, -0.5, 1.0 / 3.0, -1.0 / 3.0, 2.5, -2.5, 1e-3, -1e-3,
                                     100.5, -100.5, 0x1.0000000000001p0, 1e-300};
    if (u % 4 == 0)
        return special[(u >> 8) % 12];
    double r = (double)((int)((u >> 8) % 13) - 6) + tu_uniform(s);
    if (r == floor(r))
        r += 0.5;
    return r;
}

/* ---- checking ------------------------------------------------------------------- */
static int64_t ord(double x)
{
    int64_t i;
    memcpy(&i, &x, sizeof i);
    return i < 0 ? INT64_MIN - i : i;
}

typedef struct {
    long checked, empty, tight_n, wide; /* wide: a bound more than 16 ulps out */
    int64_t worst_lo, worst_hi; /* ulps between our bound and MPFI's rounded outward */
    double sum;
} stats_t;

static int binary(op_t op)
{
    return op == OP_ADD || op == OP_SUB || op == OP_MUL || op == OP_DIV || op == OP_MIN ||
           op == OP_MAX || op == OP_HULL;
}

static void fail_case(op_t op, iv_t a, iv_t b, int n, double r, iv_t res, const char *why,
                      uint64_t seed, long i)
{
    char ref[600] = "";
    mpfr_snprintf(ref, sizeof ref, "[%.25Rg, %.25Rg]", &R->left, &R->right);
    fail_msg("%s: %s\n  a = [%a, %a]  b = [%a, %a]  n = %d  r = %a\n  result = [%a, %a]\n"
             "  reference = %s\n  (seed %#llx, case %ld)",
             op_name[op], why, a.lo, a.hi, b.lo, b.hi, n, r, res.lo, res.hi, ref,
             (unsigned long long)seed, i);
}

static int basic_op(op_t op)
{
    return op == OP_ADD || op == OP_SUB || op == OP_MUL || op == OP_DIV || op == OP_SQR ||
           op == OP_SQRT;
}

/* Where tightness is measured and asserted: finite operands and results and,
 * per operation, the range where the implementation promises a few ulps. */
static int in_scope(op_t op, iv_t a, int n)
{
    double m = fabs(a.lo) > fabs(a.hi) ? fabs(a.lo) : fabs(a.hi);
    switch (op) {
    case OP_SIN:
    case OP_COS:
    case OP_TAN:
    case OP_DTAN:
        return m <= 0x1p20; /* beyond, the extremum/pole margin grows with |x| by design */
    case OP_POWI:
        return n >= -8 && n <= 8; /* repeated rounding: the excess grows with |n| */
    case OP_DABS:
        return a.lo > 0.0 || a.hi < 0.0; /* [-1,1] by contract when 0 is in a */
    default:
        return 1;
    }
}

/* Asserted bound on the excess, counted in doubles between our bound and
 * MPFI's bound rounded outward, in the scope above.  Derived, not fitted
 * (observed worst in parentheses, over several seeds):
 *  - basic operations: round to nearest (1/2 ulp) then iv_down/up (1-2 ulps,
 *    up to 3 just above the subnormal range, where the added 2^-1074 counts):
 *    at most 3 doubles (3);
 *  - libm-based: libm's error (< 1 ulp here) plus 3 |y| 2^-52 (3-6 ulps): at
 *    most ~7.5 ulps of y, and doubles below a power of two are half as wide,
 *    so up to 15 doubles (9);
 *  - composed ones add their steps' relative errors; powi's squarings double
 *    the error so far: x^8 is ~17.5 ulps, x^-8 ~20, so up to 40 doubles (24);
 *    dtan = 1 + tan^2 doubles tan's error (17). */
#define LIBM_ULPS 16
static const int tight_limit[OP_COUNT] = {
    [OP_ADD] = TIGHT_ULPS,  [OP_SUB] = TIGHT_ULPS,  [OP_NEG] = 0,
    [OP_MUL] = TIGHT_ULPS,  [OP_DIV] = TIGHT_ULPS,  [OP_SQR] = TIGHT_ULPS,
    [OP_POWI] = 48,         [OP_POWR] = LIBM_ULPS,  [OP_SQRT] = TIGHT_ULPS,
    [OP_EXP] = LIBM_ULPS,   [OP_LOG] = LIBM_ULPS,   [OP_SIN] = LIBM_ULPS,
    [OP_COS] = LIBM_ULPS,   [OP_TAN] = LIBM_ULPS,   [OP_ATAN] = LIBM_ULPS,
    [OP_ABS] = 0,           [OP_MIN] = 0,           [OP_MAX] = 0,
    [OP_HULL] = 0,          [OP_DSQRT] = 12,        [OP_DLOG] = TIGHT_ULPS,
    [OP_DTAN] = 48,         [OP_DATAN] = 16,        [OP_DABS] = 0,
};

/* Check compute(op, ...) against the reference of the given kind (in R). */
static void check_one(op_t op, iv_t a, iv_t b, int n, double r, int kind, stats_t *st,
                      uint64_t seed, long i)
{
    iv_t res = compute(op, a, b, n, r);
    int res_empty = iv_is_empty(res);
    if (kind == REF_EMPTY) {
        if (!res_empty || !(res.lo != res.lo && res.hi != res.hi))
            fail_case(op, a, b, n, r, res, "result should be empty {NaN, NaN}", seed, i);
        st->empty++;
        return;
    }
    /* a non-empty exact image, or none to speak of: the result is a valid interval */
    if (res_empty || !(res.lo <= res.hi) || res.lo == INFINITY || res.hi == -INFINITY)
        fail_case(op, a, b, n, r, res, "invalid or empty result from non-empty operands", seed,
                  i);
    if (kind == REF_ANY)
        return;
    if (mpfi_nan_p(R))
        fail_case(op, a, b, n, r, res, "oracle returned NaN (test bug)", seed, i);
    if (mpfr_cmp_d(&R->left, res.lo) < 0 || mpfr_cmp_d(&R->right, res.hi) > 0)
        fail_case(op, a, b, n, r, res, "result does not contain the exact range", seed, i);
    st->checked++;
    /* tightness, for finite results of finite operands, where measured */
    if (!isfinite(res.lo) || !isfinite(res.hi) || !isfinite(a.lo) || !isfinite(a.hi))
        return;
    if (binary(op) && !(isfinite(b.lo) && isfinite(b.hi)))
        return;
    if (!in_scope(op, a, n))
        return;
    double rl = mpfr_get_d(&R->left, MPFR_RNDD), rh = mpfr_get_d(&R->right, MPFR_RNDU);
    if (!isfinite(rl) || !isfinite(rh))
        return;
    /* subnormal results: the excess in ulps of 2^-1074 says little for the
     * functions (e.g. 1/x^2 over [DBL_MAX, inf] gives [0, 2^-1024]); kept for
     * the basic operations, which stay within a few ulps there too */
    if (!basic_op(op) && ((rl != 0.0 && fabs(rl) < DBL_MIN) || (rh != 0.0 && fabs(rh) < DBL_MIN)))
        return;
    int64_t dl = ord(rl) - ord(res.lo), dh = ord(res.hi) - ord(rh);
    if (dl > st->worst_lo)
        st->worst_lo = dl;
    if (dh > st->worst_hi)
        st->worst_hi = dh;
    st->sum += (double)dl + (double)dh;
    st->wide += dl > 16 || dh > 16;
    st->tight_n++;
    if (dl > tight_limit[op] || dh > tight_limit[op]) {
        char why[128];
        snprintf(why, sizeof why, "result more than %d ulps wider than MPFI's", tight_limit[op]);
        fail_case(op, a, b, n, r, res, why, seed, i);
    }
}

/* ---- pooled endpoints for the expensive functions ---------------------------
 * For exp, log, atan, powr, sin, cos, tan and dtan an MPFR evaluation costs
 * 5-30 us at 256 bits, too slow for 10^6 intervals per run.  The value of
 * these functions over an interval is decided by their values at the two
 * endpoints (and, for the trig functions, by whether an extremum or a pole
 * lies inside), so the endpoints are drawn from a pool of POOL_CLUSTERS * 4
 * doubles per operation whose MPFI enclosures are computed once; the 10^6
 * intervals are random pairs from the pool (points, pairs within a cluster of
 * nearby values, and arbitrary pairs).  The reference of a monotone function
 * over [x_i, x_j] is then exactly what MPFI returns for it: the enclosure of
 * f(x_i) rounded down and of f(x_j) rounded up.  For sin, cos, tan the cached
 * endpoint values are used only when both endpoints lie well inside one cell
 * between consecutive extrema (poles), with a margin of 1e-9 periods, a
 * million times the rounding error of the double test; in every other case
 * MPFI evaluates the interval itself (or the range is known: [-1,1] resp. the
 * whole line for intervals wider than a period or with an infinite bound). */
#define POOL_CLUSTERS 16384
static long interval_calls; /* trig intervals evaluated by MPFI itself */
#define PI_D 0x1.921fb54442d18p1 /* nearest double to pi */

typedef struct {
    long n;
    double *x;
    mpfr_t *flo, *fhi; /* enclosure of f(x[k]), where f is defined at x[k] */
} pool_t;

static int is_pooled(op_t op)
{
    return op == OP_EXP || op == OP_LOG || op == OP_ATAN || op == OP_POWR || op == OP_SIN ||
           op == OP_COS || op == OP_TAN || op == OP_DTAN;
}

static int is_trig(op_t op) { return op == OP_SIN || op == OP_COS || op == OP_TAN || op == OP_DTAN; }

/* four nearby doubles: x, a neighbour, a relative step, a tiny absolute step */
static void gen_cluster(uint64_t *s, int trig, double *out)
{
    double x = gen_double(s, trig);
    uint64_t u = tu_next(s);
    if (isinf(x)) {
        out[0] = x;
        out[1] = copysign(DBL_MAX, x);
        out[2] = copysign(1e308, x);
        out[3] = (u & 1) ? -x : copysign(1e300, x);
        return;
    }
    double dir = (u & 1) ? INFINITY : -INFINITY;
    out[0] = x;
    out[1] = nextafter(x, dir);
    double w = fabs(x) * ldexp(tu_uniform(s), -(int)(1 + (u >> 8) % 52));
    out[2] = (u >> 1) & 1 ? x + w : x - w;
    if (out[2] == x)
        out[2] = nextafter(out[1], dir);
    switch ((u >> 16) % 3) {
    case 0: out[3] = x + ((u >> 2) & 1 ? 1e-9 : -1e-9) * tu_uniform(s); break;
    case 1: out[3] = x + ((u >> 2) & 1 ? 1e-300 : -1e-300) * tu_uniform(s); break;
    default: out[3] = x + fabs(x) * 0x1p-20 * tu_uniform(s); break;
    }
}

static void pool_init(pool_t *p, long clusters, uint64_t *s, int trig)
{
    p->n = 4 * clusters;
    p->x = malloc((size_t)p->n * sizeof *p->x);
    p->flo = malloc((size_t)p->n * sizeof *p->flo);
    p->fhi = malloc((size_t)p->n * sizeof *p->fhi);
    assert_non_null(p->x);
    assert_non_null(p->flo);
    assert_non_null(p->fhi);
    for (long c = 0; c < clusters; c++)
        gen_cluster(s, trig, p->x + 4 * c);
    for (long k = 0; k < p->n; k++) {
        mpfr_init2(p->flo[k], PREC);
        mpfr_init2(p->fhi[k], PREC);
    }
}

static void pool_free(pool_t *p)
{
    for (long k = 0; k < p->n; k++) {
        mpfr_clear(p->flo[k]);
        mpfr_clear(p->fhi[k]);
    }
    free(p->x);
    free(p->flo);
    free(p->fhi);
}

/* Enclosure of f at every pool value where f is defined: f rounded down by
 * MPFR (which MPFI's interval functions call for each bound), and its
 * successor at 256 bits unless that rounding was exact. */
static void pool_eval(pool_t *p, op_t op, double r)
{
    mpfr_set_d(fe, r, MPFR_RNDN);
    for (long k = 0; k < p->n; k++) {
        double x = p->x[k];
        if (is_trig(op) && isinf(x))
            continue;
        fr_clip(fa, x);
        mpfr_ptr lo = p->flo[k];
        int t;
        switch (op) {
        case OP_EXP: t = mpfr_exp(lo, fa, MPFR_RNDD); break;
        case OP_LOG:
            if (!(x > 0.0))
                continue;
            t = mpfr_log(lo, fa, MPFR_RNDD);
            break;
        case OP_ATAN: t = mpfr_atan(lo, fa, MPFR_RNDD); break;
        case OP_POWR:
            if (r > 0.0 ? !(x >= 0.0) : !(x > 0.0))
                continue;
            t = mpfr_pow(lo, fa, fe, MPFR_RNDD);
            break;
        case OP_SIN: t = mpfr_sin(lo, fa, MPFR_RNDD); break;
        case OP_COS: t = mpfr_cos(lo, fa, MPFR_RNDD); break;
        default: t = mpfr_tan(lo, fa, MPFR_RNDD); break; /* tan, dtan */
        }
        mpfr_set(p->fhi[k], lo, MPFR_RNDN);
        if (t != 0)
            mpfr_nextabove(p->fhi[k]);
    }
}

/* Both ends strictly inside one cell (k, k+1) of t = (x - offset) / period,
 * by more than 1e-9 (|t| + 1): then no offset + k * period lies between. */
static int same_cell(double lo, double hi, double offset, double period)
{
    if (!(fabs(lo) < 0x1p40 && fabs(hi) < 0x1p40))
        return 0;
    double tl = (lo - offset) / period, th = (hi - offset) / period;
    double m = 1e-9 * (fabs(tl) + fabs(th) + 1.0);
    double k = floor(tl);
    return floor(th) == k && tl - k > m && (k + 1.0) - th > m;
}

/* R = [-big, big] */
static void set_entire(void)
{
    mpfr_neg(fa, BIG, MPFR_RNDN);
    mpfi_interv_fr(R, fa, BIG);
}

/* the reference for op over [x[i], x[j]] (x[i] <= x[j]) from the pool */
static int pooled_reference(op_t op, const pool_t *p, long i, long j, double r)
{
    double lo = p->x[i], hi = p->x[j];
    switch (op) {
    case OP_EXP:
    case OP_ATAN:
        mpfi_interv_fr(R, p->flo[i], p->fhi[j]);
        return REF_IV;
    case OP_LOG: /* over [max(lo, TINY), hi] */
        if (!(hi > 0.0))
            return REF_EMPTY;
        if (lo > 0.0) {
            mpfi_interv_fr(R, p->flo[i], p->fhi[j]);
        } else {
            mpfi_interv_fr(R, EDGE, p->fhi[j]);
        }
        return REF_IV;
    case OP_POWR:
        if (r > 0.0) { /* increasing over [max(lo, 0), hi] */
            if (!(hi >= 0.0))
                return REF_EMPTY;
            if (lo >= 0.0)
                mpfr_set(fc, p->flo[i], MPFR_RNDN);
            else
                mpfr_set_zero(fc, 1);
            mpfi_interv_fr(R, fc, p->fhi[j]);
        } else { /* decreasing over [max(lo, TINY), hi] */
            if (!(hi > 0.0))
                return REF_EMPTY;
            if (lo > 0.0)
                mpfr_set(fd, p->fhi[i], MPFR_RNDN);
            else
                mpfr_set(fd, EDGE, MPFR_RNDN);
            mpfi_interv_fr(R, p->flo[j], fd);
        }
        return REF_IV;
    default:
        break;
    }
    /* sin, cos, tan, dtan */
    int tan_like = op == OP_TAN || op == OP_DTAN;
    if (isinf(lo) || isinf(hi) || hi - lo >= (tan_like ? 3.2 : 7.0)) {
        /* wider than a period (or unbounded): every value, resp. a pole */
        if (op == OP_SIN || op == OP_COS) {
            mpfi_interv_si(R, -1, 1);
        } else if (op == OP_TAN) {
            set_entire();
        } else {
            mpfr_set_ui(fa, 1, MPFR_RNDN);
            mpfi_interv_fr(R, fa, BIG);
        }
        return REF_IV;
    }
    double offset = op == OP_COS ? 0.0 : 0.5 * PI_D; /* extrema of sin, cos; poles of tan */
    if (lo == hi || same_cell(lo, hi, offset, PI_D)) { /* no interior extremum or pole */
        if (tan_like) { /* increasing */
            mpfi_interv_fr(T, p->flo[i], p->fhi[j]);
        } else { /* monotone */
            mpfr_min(fa, p->flo[i], p->flo[j], MPFR_RNDN);
            mpfr_max(fb, p->fhi[i], p->fhi[j], MPFR_RNDN);
            mpfi_interv_fr(T, fa, fb);
        }
    } else {
        interval_calls++;
        mpfi_interv_d(A, lo, hi);
        if (op == OP_SIN)
            mpfi_sin(T, A);
        else if (op == OP_COS)
            mpfi_cos(T, A);
        else
            mpfi_tan(T, A); /* a pole inside gives [-inf, +inf] */
    }
    if (op == OP_DTAN) {
        mpfi_sqr(T, T);
        mpfi_add_ui(R, T, 1);
    } else {
        mpfi_set(R, T);
    }
    return REF_IV;
}

/* a random interval of pool values: *i, *j the indices of its ends; false for
 * the empty interval */
static int pool_pick(const pool_t *p, uint64_t *s, long *i, long *j)
{
    for (;;) {
        uint64_t u = tu_next(s);
        unsigned shape = (unsigned)(u % 64);
        if (shape == 0)
            return 0;
        long c = (long)((u >> 8) % (uint64_t)(p->n / 4));
        long a = 4 * c + (long)((u >> 40) % 4), b;
        if (shape < 8)
            b = a;
        else if (shape < 30)
            b = 4 * c + (long)((u >> 44) % 4);
        else
            b = (long)((u >> 48) % (uint64_t)p->n);
        if (p->x[b] < p->x[a]) {
            long t = a;
            a = b;
            b = t;
        }
        if (p->x[a] == INFINITY || p->x[b] == -INFINITY)
            continue; /* not an interval */
        *i = a;
        *j = b;
        return 1;
    }
}

static void run_pooled(op_t op, long count, uint64_t seed, stats_t *st)
{
    uint64_t s = seed;
    /* powr: a fresh exponent (and pool) for each of 16 batches */
    int batches = op == OP_POWR ? 16 : 1;
    long clusters = POOL_CLUSTERS / batches;
    if (clusters > count / 4 + 4)
        clusters = count / 4 + 4;
    long done = 0;
    for (int bt = 0; bt < batches; bt++) {
        double r = op == OP_POWR ? gen_r(&s) : 0.0;
        pool_t p;
        pool_init(&p, clusters, &s, is_trig(op));
        pool_eval(&p, op, r);
        mpfr_set_d(fe, r, MPFR_RNDN);
        if (op == OP_LOG)
            mpfr_log(EDGE, TINY, MPFR_RNDD);
        else if (op == OP_POWR)
            mpfr_pow(EDGE, TINY, fe, MPFR_RNDU);
        long m = (count - done) / (batches - bt);
        for (long k = 0; k < m; k++, done++) {
            long i, j;
            iv_t e = iv_empty(), a = e;
            int kind = REF_EMPTY;
            if (pool_pick(&p, &s, &i, &j)) {
                a = iv_make(p.x[i], p.x[j]);
                kind = pooled_reference(op, &p, i, j, r);
            }
            check_one(op, a, e, 0, r, kind, st, seed, done);
        }
        pool_free(&p);
    }
}

static void run_direct(op_t op, long count, uint64_t seed, stats_t *st)
{
    uint64_t s = seed;
    for (long i = 0; i < count; i++) {
        iv_t a = gen_iv(&s, 0);
        iv_t b = binary(op) ? gen_iv(&s, 0) : iv_empty();
        int n = op == OP_POWI ? gen_n(&s) : 0;
        check_one(op, a, b, n, 0.0, reference(op, a, b, n, 0.0), st, seed, i);
    }
}

static void run_op(op_t op)
{
    uint64_t seed = tu_seed(SEED) ^ ((uint64_t)op * 0x9e3779b97f4a7c15ull);
    long count = (long)(COUNT * tu_scale());
    if (count < 1)
        count = 1;
    stats_t st = {0, 0, 0, 0, 0, 0, 0.0};
    interval_calls = 0;
    clock_t t0 = clock();
    if (is_pooled(op))
        run_pooled(op, count, seed, &st);
    else
        run_direct(op, count, seed, &st);
    double secs = (double)(clock() - t0) / CLOCKS_PER_SEC;
    /* excess: how many doubles each bound lies beyond MPFI's bound rounded
     * outward, over finite results of finite operands */
    printf("%-6s %8ld cases: %8ld contained, %7ld empty; excess over MPFI: worst lo %lld "
           "hi %lld, mean %.2f ulps, %ld bounds > 16 ulps; %.2f s\n",
           op_name[op], count, st.checked, st.empty, (long long)st.worst_lo,
           (long long)st.worst_hi, st.tight_n ? st.sum / (2.0 * (double)st.tight_n) : 0.0,
           st.wide, secs);
    if (interval_calls)
        printf("       (%ld intervals sent to MPFI whole, the others from pooled endpoints)\n",
               interval_calls);
    /* not vacuous */
    assert_true(st.checked >= count / 4);
}

#define OP_TEST(name, op)                                                                  \
    static void test_##name(void **state)                                                  \
    {                                                                                      \
        (void)state;                                                                       \
        run_op(op);                                                                        \
    }
OP_TEST(add, OP_ADD)
OP_TEST(sub, OP_SUB)
OP_TEST(neg, OP_NEG)
OP_TEST(mul, OP_MUL)
OP_TEST(div, OP_DIV)
OP_TEST(sqr, OP_SQR)
OP_TEST(powi, OP_POWI)
OP_TEST(powr, OP_POWR)
OP_TEST(sqrt, OP_SQRT)
OP_TEST(exp, OP_EXP)
OP_TEST(log, OP_LOG)
OP_TEST(sin, OP_SIN)
OP_TEST(cos, OP_COS)
OP_TEST(tan, OP_TAN)
OP_TEST(atan, OP_ATAN)
OP_TEST(abs, OP_ABS)
OP_TEST(min, OP_MIN)
OP_TEST(max, OP_MAX)
OP_TEST(hull, OP_HULL)
OP_TEST(dsqrt, OP_DSQRT)
OP_TEST(dlog, OP_DLOG)
OP_TEST(dtan, OP_DTAN)
OP_TEST(datan, OP_DATAN)
OP_TEST(dabs, OP_DABS)

/* iv_mul_point(c, a) is iv_mul by the point c, bit for bit, in either order
 * (so test_mul's MPFI reference covers it): COUNT random operands of every
 * shape gen_iv makes, empty and unbounded ones included, and every finite c
 * gen_double makes (zeros of both signs, subnormals, huge). */
static int same_bits(double x, double y) { return memcmp(&x, &y, sizeof x) == 0; }

static void test_mul_point(void **state)
{
    (void)state;
    uint64_t s = tu_seed(SEED) ^ 0x6d756c70ull;
    long count = (long)(COUNT * tu_scale()), compared = 0;
    if (count < 1)
        count = 1;
    for (long i = 0; i < count; i++) {
        double c = gen_double(&s, 0);
        iv_t a = gen_iv(&s, 0);
        if (!isfinite(c))
            continue;
        iv_t r = iv_mul_point(c, a), p = iv_mul(iv_point(c), a), q = iv_mul(a, iv_point(c));
        if (!(same_bits(r.lo, p.lo) && same_bits(r.hi, p.hi) && same_bits(r.lo, q.lo) &&
              same_bits(r.hi, q.hi)))
            fail_msg("iv_mul_point(%a, [%a, %a]) = [%a, %a], iv_mul gives [%a, %a] and "
                     "[%a, %a] (seed %llu, case %ld)",
                     c, a.lo, a.hi, r.lo, r.hi, p.lo, p.hi, q.lo, q.hi,
                     (unsigned long long)tu_seed(SEED), i);
        compared++;
    }
    printf("mul_point %ld cases: %ld bit for bit as iv_mul\n", count, compared);
    assert_true(compared >= count / 2);
}

/* ---- exact expectations ------------------------------------------------------ */
/* iv_dot3 against the exact dot product (MPFR at a precision where every
 * product and sum of doubles is exact): the enclosure holds it, is at most a
 * few ulps of sum |x_i y_i| wide (unbounded only next to the overflow), and
 * is empty only where an operand is not finite or the doubles overflow.  A
 * third of the cases nearly cancel (y_2 chosen so that the sum is about 0),
 * where the bound on the rounding, not the value, carries the enclosure. */
static void test_dot3(void **state)
{
    (void)state;
    uint64_t s = tu_seed(SEED) ^ 0x646f7433ull;
    long count = (long)(COUNT * tu_scale()), checked = 0, empty = 0;
    if (count < 1)
        count = 1;
    mpfr_t e, p, S;
    mpfr_inits2(4400, e, p, S, (mpfr_ptr)0);
    for (long i = 0; i < count; i++) {
        double x[3], y[3];
        for (int k = 0; k < 3; k++)
            x[k] = gen_double(&s, 0), y[k] = gen_double(&s, 0);
        if (i % 3 == 0 && x[2] != 0)
            y[2] = -(x[0] * y[0] + x[1] * y[1]) / x[2];
        iv_t r = iv_dot3(x, y);
        int finite = 1;
        for (int k = 0; k < 3; k++)
            finite &= isfinite(x[k]) && isfinite(y[k]);
        if (!finite) {
            if (!iv_is_empty(r))
                fail_msg("iv_dot3 of a non-finite operand = [%a, %a] (seed %llu, case %ld)",
                         r.lo, r.hi, (unsigned long long)tu_seed(SEED), i);
            empty++;
            continue;
        }
        mpfr_set_zero(e, 1);
        mpfr_set_zero(S, 1);
        for (int k = 0; k < 3; k++) {
            mpfr_set_d(p, x[k], MPFR_RNDN);
            mpfr_mul_d(p, p, y[k], MPFR_RNDN); /* exact at this precision */
            mpfr_add(e, e, p, MPFR_RNDN);
            mpfr_abs(p, p, MPFR_RNDN);
            mpfr_add(S, S, p, MPFR_RNDN);
        }
        if (iv_is_empty(r)) {
            /* only where the doubles overflow: sum |x_i y_i| near DBL_MAX */
            if (mpfr_cmp_d(S, 0x1p1020) < 0)
                fail_msg("iv_dot3((%a, %a, %a), (%a, %a, %a)) empty, sum |x_i y_i| = %g "
                         "(seed %llu, case %ld)",
                         x[0], x[1], x[2], y[0], y[1], y[2], mpfr_get_d(S, MPFR_RNDN),
                         (unsigned long long)tu_seed(SEED), i);
            empty++;
            continue;
        }
        /* tight: a few ulps of S wide, or unbounded only next to the overflow */
        double width = mpfr_get_d(S, MPFR_RNDU) * 0x1p-48 + 0x1p-1017;
        int tight = isfinite(r.lo) && isfinite(r.hi) ? r.hi - r.lo <= width
                                                     : mpfr_cmp_d(S, 0x1p1020) >= 0;
        if (mpfr_cmp_d(e, r.lo) < 0 || mpfr_cmp_d(e, r.hi) > 0 || !tight)
            fail_msg("iv_dot3((%a, %a, %a), (%a, %a, %a)) = [%a, %a], exact %a "
                     "(seed %llu, case %ld)",
                     x[0], x[1], x[2], y[0], y[1], y[2], r.lo, r.hi, mpfr_get_d(e, MPFR_RNDN),
                     (unsigned long long)tu_seed(SEED), i);
        checked++;
    }
    mpfr_clears(e, p, S, (mpfr_ptr)0);
    printf("dot3 %ld cases: %ld enclosures checked, %ld empty (not finite)\n", count, checked,
           empty);
    assert_true(checked >= count / 3);
}

static void test_exact_cases(void **state)
{
    (void)state;
    iv_t e = iv_empty(), a = iv_make(-2.0, 3.0), z = iv_point(0.0);
    iv_t r = iv_sqr(a);
    assert_true(r.lo == 0.0 && r.hi >= 9.0);
    assert_true(iv_powi(a, 2).lo == 0.0);
    assert_true(iv_powi(a, 4).lo == 0.0);
    assert_true(iv_is_empty(iv_div(iv_make(1.0, 2.0), z)));
    assert_true(iv_is_empty(iv_div(z, z)));
    r = iv_div(z, iv_make(-1.0, 1.0));
    assert_true(r.lo == 0.0 && r.hi == 0.0);
    r = iv_div(iv_make(1.0, 2.0), iv_make(0.0, 4.0));
    assert_true(r.lo <= 0.25 && r.lo > 0.0 && r.hi == INFINITY);
    r = iv_div(iv_make(1.0, 2.0), iv_make(-1.0, 1.0));
    assert_true(r.lo == -INFINITY && r.hi == INFINITY);
    r = iv_mul(z, iv_make(1.0, INFINITY));
    assert_true(r.lo <= 0.0 && r.hi >= 0.0 && isfinite(r.lo) && isfinite(r.hi));
    r = iv_mul(iv_make(0.0, 1.0), iv_make(1.0, INFINITY));
    assert_true(r.lo == 0.0 && r.hi == INFINITY);
    assert_true(iv_is_empty(iv_powi(z, -2)));
    r = iv_powi(a, 0);
    assert_true(r.lo == 1.0 && r.hi == 1.0);
    r = iv_powi(iv_make(-2.0, -1.0), 3);
    assert_true(r.lo <= -8.0 && r.hi >= -1.0 && r.hi < 0.0);
    assert_true(iv_is_empty(iv_sqrt(iv_make(-2.0, -1.0))));
    r = iv_sqrt(iv_make(-2.0, 4.0));
    assert_true(r.lo == 0.0 && r.hi >= 2.0);
    assert_true(iv_is_empty(iv_log(iv_make(-2.0, 0.0))));
    r = iv_log(iv_make(0.0, 1.0));
    assert_true(r.lo == -INFINITY && r.hi >= 0.0);
    assert_true(iv_is_empty(iv_powr(iv_make(-2.0, -1.0), 0.5)));
    assert_true(iv_is_empty(iv_powr(z, -0.5)));
    r = iv_powr(iv_make(0.0, 4.0), -0.5);
    assert_true(r.lo <= 0.5 && r.hi == INFINITY);
    r = iv_powr(iv_make(-1.0, 2.0), 0.0);
    assert_true(r.lo == 1.0 && r.hi == 1.0);
    assert_true(iv_is_empty(iv_powr(iv_make(-2.0, 0.0), 0.0)));
    r = iv_powr(a, NAN);
    assert_true(r.lo == -INFINITY && r.hi == INFINITY);
    r = iv_powr(iv_make(0.0, 0.0), 2.5);
    assert_true(r.lo == 0.0 && r.hi >= 0.0);
    r = iv_mul(iv_make(-INFINITY, -1.0), iv_make(-INFINITY, 0.0));
    assert_true(r.lo == 0.0 && r.hi == INFINITY);
    r = iv_tan(iv_make(-1.0, 1.0));
    assert_true(r.lo <= tan(-1.0) && r.hi >= tan(1.0) && isfinite(r.lo) && isfinite(r.hi));
    r = iv_dsqrt(iv_make(-1.0, 0.0));
    assert_true(r.lo == 0.0 && r.hi == INFINITY);
    assert_true(iv_is_empty(iv_dlog(iv_make(-1.0, 0.0))));
    r = iv_dtan(iv_make(1.0, 2.0));
    assert_true(r.lo == 1.0 && r.hi == INFINITY);
    r = iv_exp(iv_make(-INFINITY, 0.0));
    assert_true(r.lo == 0.0 && r.hi >= 1.0);
    r = iv_sin(iv_make(0.0, 4.0));
    assert_true(r.hi == 1.0 && r.lo <= sin(4.0));
    r = iv_cos(iv_make(-1.0, 1.0));
    assert_true(r.hi == 1.0);
    r = iv_sin(iv_make(1e300, INFINITY));
    assert_true(r.lo == -1.0 && r.hi == 1.0);
    r = iv_tan(iv_make(1.0, 2.0));
    assert_true(r.lo == -INFINITY && r.hi == INFINITY);
    r = iv_atan(iv_entire());
    assert_true(r.lo >= -0x1.921fb54442d19p0 && r.hi <= 0x1.921fb54442d19p0 &&
                r.hi > HALF_PI);
    r = iv_abs(iv_make(-3.0, 2.0));
    assert_true(r.lo == 0.0 && r.hi == 3.0);
    r = iv_min(iv_make(1.0, 5.0), iv_make(2.0, 3.0));
    assert_true(r.lo == 1.0 && r.hi == 3.0);
    r = iv_max(iv_make(1.0, 5.0), iv_make(2.0, 3.0));
    assert_true(r.lo == 2.0 && r.hi == 5.0);
    r = iv_hull(e, a);
    assert_true(r.lo == -2.0 && r.hi == 3.0);
    r = iv_dabs(iv_make(-1.0, 1.0));
    assert_true(r.lo == -1.0 && r.hi == 1.0);
    r = iv_dsqrt(iv_make(0.0, 4.0));
    assert_true(r.lo <= 0.25 && r.hi == INFINITY);

    /* empty propagates through every operation (hull ignores it) */
    for (int op = 0; op < OP_COUNT; op++) {
        if (op == OP_HULL)
            continue;
        iv_t x = compute((op_t)op, e, a, 3, 0.5);
        if (!(x.lo != x.lo && x.hi != x.hi))
            fail_msg("%s(empty, x) is not empty", op_name[op]);
        if (binary((op_t)op)) {
            x = compute((op_t)op, a, e, 3, 0.5);
            if (!(x.lo != x.lo && x.hi != x.hi))
                fail_msg("%s(x, empty) is not empty", op_name[op]);
        }
    }
    assert_true(iv_is_empty(iv_hull(e, e)));
}

/* ---- decimal literals ---------------------------------------------------------- */
static void expect_decimal(const char *text, int exact)
{
    iv_t r;
    if (!iv_from_decimal(text, &r))
        fail_msg("iv_from_decimal(\"%s\") failed", text);
    mpfi_t x;
    mpfi_init2(x, 1024);
    /* mpfi_set_str encloses the decimal value at 1024 bits */
    if (mpfi_set_str(x, text, 10) != 0)
        fail_msg("mpfi_set_str(\"%s\") failed", text);
    if (mpfr_cmp_d(&x->left, r.lo) < 0 || mpfr_cmp_d(&x->right, r.hi) > 0)
        fail_msg("iv_from_decimal(\"%s\") = [%a, %a] misses the value", text, r.lo, r.hi);
    if (exact && r.lo != r.hi)
        fail_msg("iv_from_decimal(\"%s\") = [%a, %a] should be exact", text, r.lo, r.hi);
    if (!exact && (r.lo == r.hi || nextafter(r.lo, INFINITY) != r.hi))
        fail_msg("iv_from_decimal(\"%s\") = [%a, %a] should be one ulp wide", text, r.lo, r.hi);
    mpfi_clear(x);
}

static void test_from_decimal(void **state)
{
    (void)state;
    iv_t r;
    expect_decimal("0.1", 0);
    expect_decimal("0.5", 1);
    expect_decimal("3", 1);
    expect_decimal("3.0000", 1);
    expect_decimal("003.25e0", 1);
    expect_decimal("-0.1", 0);
    expect_decimal("1e22", 1);  /* 10^22 = 2^22 * 5^22 and 5^22 < 2^53 */
    expect_decimal("1e23", 0);
    expect_decimal("123456789012345678", 0);
    expect_decimal(".5", 1);
    expect_decimal("5.", 1);
    expect_decimal("2.5E-3", 0);
    expect_decimal("0.000244140625", 1); /* 2^-12 */
    expect_decimal("4.9406564584124654e-324", 0);
    expect_decimal("1.7976931348623157e308", 0);
    expect_decimal("179769313486231570814527423731704356798070567525844996598917476803157260780"
                   "028538760589558632766878171540458953514382464234321326889464182768467546703"
                   "537516986049910576551282076245490090389328944075868508455133942304583236903"
                   "222948165808559332123348274797826204144723168738177180919299881250404026184"
                   "124858368",
                   1); /* DBL_MAX exactly */
    expect_decimal("0.1000000000000000055511151231257827021181583404541015625", 1);
    expect_decimal("0.10000000000000000555111512312578270211815834045410156250000001", 0);
    expect_decimal("0.1000000000000000055511151231257827021181583404541015624999999", 0);
    /* a literal longer than the kept digits: the sticky digit decides */
    {
        static char big[2100];
        strcpy(big, "0.5");
        memset(big + 3, '0', 2000);
        big[2003] = '1';
        big[2004] = '\0';
        expect_decimal(big, 0);
        big[2003] = '0';
        expect_decimal(big, 1);
    }
    assert_true(iv_from_decimal("0", &r) && r.lo == 0.0 && r.hi == 0.0);
    assert_true(iv_from_decimal("0e999999999999999999", &r) && r.lo == 0.0 && r.hi == 0.0);
    assert_true(iv_from_decimal("1e-400", &r) && r.lo == 0.0 && r.hi == 0x1p-1074);
    /* out of the double range, or not a decimal literal: rejected */
    assert_false(iv_from_decimal("1e400", &r));
    assert_false(iv_from_decimal("-1e400", &r));
    assert_false(iv_from_decimal("inf", &r));
    assert_false(iv_from_decimal("nan", &r));
    assert_false(iv_from_decimal("0x10", &r));
    assert_false(iv_from_decimal("", &r));
    assert_false(iv_from_decimal(".", &r));
    assert_false(iv_from_decimal("1e", &r));
    assert_false(iv_from_decimal(" 1", &r));
    assert_false(iv_from_decimal("1 ", &r));
    assert_false(iv_from_decimal("1.2.3", &r));
}

/* ---- error records -------------------------------------------------------------- */
static void test_error_format(void **state)
{
    (void)state;
    ivoct_error_t e;
    char buf[1024];
    ivoct_error_clear(&e);
    assert_string_equal(ivoct_error_format(&e, buf, sizeof buf), "");
    ivoct_error_set(&e, "bad %s", "thing");
    assert_string_equal(ivoct_error_format(&e, buf, sizeof buf), "bad thing");
    ivoct_error_at(&e, 3, 7, "expected '%c'", ')');
    assert_string_equal(ivoct_error_format(&e, buf, sizeof buf), "3:7: expected ')'");
    strcpy(e.file, "scene.ini");
    assert_string_equal(ivoct_error_format(&e, buf, sizeof buf), "scene.ini:3:7: expected ')'");
    e.col = 0;
    assert_string_equal(ivoct_error_format(&e, buf, sizeof buf), "scene.ini:3: expected ')'");
    e.line = 0;
    assert_string_equal(ivoct_error_format(&e, buf, sizeof buf), "scene.ini: expected ')'");
    char small[8];
    assert_string_equal(ivoct_error_format(&e, small, sizeof small), "scene.i");
    ivoct_error_set(NULL, "ignored");
    ivoct_error_at(NULL, 1, 1, "ignored");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_exact_cases),
        cmocka_unit_test(test_from_decimal),
        cmocka_unit_test(test_error_format),
        cmocka_unit_test(test_add),
        cmocka_unit_test(test_sub),
        cmocka_unit_test(test_neg),
        cmocka_unit_test(test_mul),
        cmocka_unit_test(test_mul_point),
        cmocka_unit_test(test_dot3),
        cmocka_unit_test(test_div),
        cmocka_unit_test(test_sqr),
        cmocka_unit_test(test_powi),
        cmocka_unit_test(test_powr),
        cmocka_unit_test(test_sqrt),
        cmocka_unit_test(test_exp),
        cmocka_unit_test(test_log),
        cmocka_unit_test(test_sin),
        cmocka_unit_test(test_cos),
        cmocka_unit_test(test_tan),
        cmocka_unit_test(test_atan),
        cmocka_unit_test(test_abs),
        cmocka_unit_test(test_min),
        cmocka_unit_test(test_max),
        cmocka_unit_test(test_hull),
        cmocka_unit_test(test_dsqrt),
        cmocka_unit_test(test_dlog),
        cmocka_unit_test(test_dtan),
        cmocka_unit_test(test_datan),
        cmocka_unit_test(test_dabs),
    };
    return cmocka_run_group_tests_name("interval_mpfi", tests, setup, teardown);
}
