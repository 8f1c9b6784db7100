/* ivoct — rigorous interval arithmetic on doubles (prefix iv_).
 *
 * Guarantee of every operation: the result encloses the exact real range of the
 * operation over the operands (IEEE 1788 set-based semantics: over the part of
 * the operands where the operation is defined).  Strategy (see expr/README.md):
 * each bound is computed in the default round-to-nearest mode and then pushed
 * outward by at least one ulp (iv_down / iv_up); the FPU mode is never switched.
 * Library transcendentals are pushed out by glibc's documented error bound plus
 * one ulp.  Build with -ffp-contract=off and without -ffast-math.
 *
 * Conventions:
 *  - an interval is {lo, hi} with lo <= hi; bounds may be -inf / +inf;
 *  - the empty set (an operation defined nowhere on its operands, e.g.
 *    sqrt([-2,-1])) is {NaN, NaN}; every operation maps empty to empty;
 *  - no operation produces NaN from non-empty operands: where IEEE arithmetic
 *    would (0*inf, inf-inf), the bound is taken from the real semantics or the
 *    result is widened to the whole line [-inf, +inf].
 *  - lo is never +inf and hi never -inf in a result (overflow rounds outward to
 *    +-DBL_MAX on the inner side).
 */
#ifndef IVOCT_INTERVAL_H
#define IVOCT_INTERVAL_H

#include <float.h>
#include <math.h>
#include <stdbool.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct iv {
    double lo, hi;
} iv_t;

/* A box in space: the cell of the octree or the argument of an evaluation. */
typedef struct iv_box {
    iv_t x, y, z;
} iv_box_t;

/* A value with its gradient, each an interval (forward-mode differentiation). */
typedef struct iv_grad {
    iv_t v, dx, dy, dz;
} iv_grad_t;

/* ---- directed rounding by widening ------------------------------------------
 * x is the round-to-nearest result of an operation whose exact value is r.
 * iv_down(x) <= r and iv_up(x) >= r: subtracting |x|*2^-52 (>= one ulp of x,
 * computed exactly because it is a power-of-two scaling, or rounded up to the
 * smallest subnormal at least) plus the smallest subnormal covers the
 * half-ulp rounding error with margin, including at 0 and in the subnormal
 * range.  +inf as a lower bound means "overflowed above DBL_MAX": it becomes
 * DBL_MAX; likewise -inf as an upper bound.  NaN stays NaN.  Branch-free so
 * that loops over lanes vectorise. */
static inline double iv_down(double x)
{
    double y = x - (fabs(x) * 0x1p-52 + 0x1p-1074);
    return x == INFINITY ? DBL_MAX : y;
}

static inline double iv_up(double x)
{
    double y = x + (fabs(x) * 0x1p-52 + 0x1p-1074);
    return x == -INFINITY ? -DBL_MAX : y;
}

/* ---- construction and queries ---------------------------------------------- */
static inline iv_t iv_make(double lo, double hi) { iv_t r = {lo, hi}; return r; }
static inline iv_t iv_point(double x) { iv_t r = {x, x}; return r; }
static inline iv_t iv_empty(void) { iv_t r = {NAN, NAN}; return r; }
static inline iv_t iv_entire(void) { iv_t r = {-INFINITY, INFINITY}; return r; }
static inline bool iv_is_empty(iv_t a) { return (a.lo != a.lo) | (a.hi != a.hi); }
/* false for the empty set */
static inline bool iv_contains(iv_t a, double x) { return a.lo <= x && x <= a.hi; }
static inline double iv_mid(iv_t a) { return 0.5 * a.lo + 0.5 * a.hi; }
/* width rounded up */
static inline double iv_width(iv_t a) { return iv_up(a.hi - a.lo); }
/* smallest interval holding both; empty operands are ignored */
iv_t iv_hull(iv_t a, iv_t b);
/* The real number denoted by a decimal literal, enclosed (exact when representable).
 * Returns false when text is not a finite number. */
bool iv_from_decimal(const char *text, iv_t *out);

/* ---- arithmetic --------------------------------------------------------------
 * Cheap operations are inline so the tape evaluators can vectorise over lanes. */
/* x + y rounded down / up, exact (not widened) when a term is 0.  Keeping
 * exact zeros exact matters for speed as much as for tightness: a widened zero
 * is a subnormal, and products of subnormals cost ~100 cycles each on x86 (the
 * gradient of a constant is [0,0] and flows through every product rule). */
static inline double iv_add_down(double x, double y)
{
    double s = x + y;
    return ((x == 0) | (y == 0)) ? s : iv_down(s);
}

static inline double iv_add_up(double x, double y)
{
    double s = x + y;
    return ((x == 0) | (y == 0)) ? s : iv_up(s);
}

static inline iv_t iv_add(iv_t a, iv_t b)
{
    iv_t r = {iv_add_down(a.lo, b.lo), iv_add_up(a.hi, b.hi)};
    return r;
}

static inline iv_t iv_sub(iv_t a, iv_t b)
{
    iv_t r = {iv_add_down(a.lo, -b.hi), iv_add_up(a.hi, -b.lo)};
    return r;
}

static inline iv_t iv_neg(iv_t a)
{
    iv_t r = {-a.hi, -a.lo};
    return r;
}

/* A product of two interval bounds.  The only NaN is 0 * inf: the zero is an
 * attained value of its operand, and zero times any real is zero, so the
 * bound is 0 (an infinite bound stands for "unbounded", not for a number). */
static inline double iv_mul_bound(double x, double y)
{
    double r = x * y;
    return r == r ? r : 0.0;
}

/* Multiplication without branches (it dominates the evaluators, and the lanes
 * vectorise only without them: hence & and | rather than && and ||, whose
 * short circuits are branches): the hull of the four end products, widened;
 * a product of operands of known sign keeps that sign exactly. */
static inline iv_t iv_mul(iv_t a, iv_t b)
{
    double p = iv_mul_bound(a.lo, b.lo), q = iv_mul_bound(a.lo, b.hi);
    double r = iv_mul_bound(a.hi, b.lo), s = iv_mul_bound(a.hi, b.hi);
    double lo = p < q ? p : q, lo2 = r < s ? r : s;
    double hi = p > q ? p : q, hi2 = r > s ? r : s;
    lo = iv_down(lo < lo2 ? lo : lo2);
    hi = iv_up(hi > hi2 ? hi : hi2);
    int nonneg = ((a.lo >= 0) & (b.lo >= 0)) | ((a.hi <= 0) & (b.hi <= 0));
    int nonpos = ((a.lo >= 0) & (b.hi <= 0)) | ((a.hi <= 0) & (b.lo >= 0));
    /* (two selects each: gcc if-converts those, not a combined condition) */
    double lo0 = lo < 0 ? 0.0 : lo, hi0 = hi > 0 ? -0.0 : hi;
    lo = nonneg ? lo0 : lo;
    hi = nonpos ? hi0 : hi;
    /* a factor [0,0] makes the product exactly 0 (see iv_add_down) */
    int zero = ((a.lo == 0) & (a.hi == 0)) | ((b.lo == 0) & (b.hi == 0));
    lo = zero ? 0.0 : lo;
    hi = zero ? 0.0 : hi;
    int empty = (int)iv_is_empty(a) | (int)iv_is_empty(b);
    iv_t out = {empty ? NAN : lo, empty ? NAN : hi};
    return out;
}

/* iv_mul(iv_point(c), a), which is iv_mul(a, iv_point(c)), bit for bit, for a
 * finite c whose sign s is given: 1 for c > 0, -1 for c < 0, 0 for c = 0 (of
 * either sign).  A product by a constant of the expression (8*x*y*z).  With
 * one factor a point the four end products are two, c*a.lo and c*a.hi, and
 * with c finite the only NaN is that of an empty a, which the empty rule
 * makes the result anyway; the sign, zero and empty rules are iv_mul's with
 * c's sign known.  A lane loop over a's with s a constant (lanes over one c)
 * is 57 AVX2 instructions a vector where iv_mul's is 92. */
static inline iv_t iv_mul_point_sign(double c, iv_t a, int s)
{
    double p = c * a.lo, q = c * a.hi;
    double lo = iv_down(p < q ? p : q), hi = iv_up(p > q ? p : q);
    int nonneg = s > 0 ? a.lo >= 0 : a.hi <= 0;
    int nonpos = s > 0 ? a.hi <= 0 : a.lo >= 0;
    double lo0 = lo < 0 ? 0.0 : lo, hi0 = hi > 0 ? -0.0 : hi;
    lo = nonneg ? lo0 : lo;
    hi = nonpos ? hi0 : hi;
    int zero = (s == 0) | ((a.lo == 0) & (a.hi == 0));
    lo = zero ? 0.0 : lo;
    hi = zero ? 0.0 : hi;
    int empty = iv_is_empty(a);
    iv_t out = {empty ? NAN : lo, empty ? NAN : hi};
    return out;
}

/* iv_mul_point_sign with c's sign worked out: iv_mul by the finite point c */
static inline iv_t iv_mul_point(double c, iv_t a)
{
    return iv_mul_point_sign(c, a, (c > 0) - (c < 0));
}

/* An enclosure of the dot product x·y of two vectors of 3 doubles, from its
 * value in doubles and a bound on that value's error (not from interval
 * products: a dozen double operations).  s = fl(fl(fl(x0 y0) + fl(x1 y1)) +
 * fl(x2 y2)) is within gamma_3 S + 3 eta of x·y, S = sum |x_i y_i|,
 * gamma_3 = 3u / (1 - 3u), u = 2^-53, eta = 2^-1074 for the products'
 * underflow (Higham, "Accuracy and Stability of Numerical Algorithms",
 * §3.1); the sum S~ of the |fl(x_i y_i)| computed likewise is at least
 * (1 - 3u) S - 3 eta, so 2^-51 S~ + 2^-1020 bounds the error with room for
 * its own rounding.  NaN bounds (empty) when an operand is not finite or the
 * products overflow. */
static inline iv_t iv_dot3(const double x[3], const double y[3])
{
    double p0 = x[0] * y[0], p1 = x[1] * y[1], p2 = x[2] * y[2];
    double s = (p0 + p1) + p2;
    double e = ((fabs(p0) + fabs(p1)) + fabs(p2)) * 0x1p-51 + 0x1p-1020;
    if (!isfinite(s) || !isfinite(e))
        return iv_make(NAN, NAN);
    return iv_make(iv_add_down(s, -e), iv_add_up(s, e));
}

/* The upper end of iv_sqr(a) from the magnitude m = max(|a.lo|, |a.hi|) of a
 * non-empty a (NaN gives NaN): m^2 rounded up, exactly 0 for m = 0.  For the
 * callers that need only that end (a Lipschitz bound, a cell's diagonal).
 * iv_sqr writes the same two steps apart: in the kernels' lane loops gcc
 * vectorises that form with 3 % fewer instructions per interval pass. */
static inline double iv_sqr_hi(double m) { return m == 0 ? 0.0 : iv_up(m * m); }

/* x^2, never negative; exactly [0,0] for [0,0] (so that 1/x^2 there is empty). */
static inline iv_t iv_sqr(iv_t a)
{
    double m = fabs(a.lo) > fabs(a.hi) ? fabs(a.lo) : fabs(a.hi);
    double mig = a.lo >= 0 ? a.lo : a.hi <= 0 ? -a.hi : 0.0;
    double lo = iv_down(mig * mig), hi = iv_up(m * m);
    lo = lo < 0 ? 0.0 : lo;
    hi = m == 0 ? 0.0 : hi;
    int empty = iv_is_empty(a);
    iv_t out = {empty ? NAN : lo, empty ? NAN : hi};
    return out;
}

iv_t iv_div(iv_t a, iv_t b);        /* 0 in b: hull over b \ {0}; b = [0,0]: empty */
iv_t iv_powi(iv_t a, int n);        /* x^n, n any int; even n never negative; n < 0 as 1/x^-n */
iv_t iv_powr(iv_t a, double r);     /* x^r for real r: defined for x > 0 (x >= 0 when r > 0) */
iv_t iv_sqrt(iv_t a);               /* over a ∩ [0, inf) */
iv_t iv_exp(iv_t a);
iv_t iv_log(iv_t a);                /* over a ∩ (0, inf); 0 in a gives lo = -inf */
iv_t iv_sin(iv_t a);
iv_t iv_cos(iv_t a);
iv_t iv_tan(iv_t a);                /* a pole possibly inside a: [-inf, +inf] */
iv_t iv_atan(iv_t a);
iv_t iv_abs(iv_t a);
iv_t iv_min(iv_t a, iv_t b);
iv_t iv_max(iv_t a, iv_t b);

/* Derivative enclosures used by forward-mode differentiation: an interval
 * holding f'(x) for every x in a where f is differentiable (whole line where
 * f' is unbounded on a). */
iv_t iv_dsqrt(iv_t a);              /* 1/(2 sqrt x) */
iv_t iv_dlog(iv_t a);               /* 1/x over x > 0 */
iv_t iv_dtan(iv_t a);               /* 1 + tan^2 x */
iv_t iv_datan(iv_t a);              /* 1/(1+x^2) */
iv_t iv_dabs(iv_t a);               /* sign(x): [-1,1] when 0 in a */

#ifdef __cplusplus
}
#endif
#endif
