/* ivoct — rigorous interval arithmetic on doubles: the out-of-line operations.
 *
 * Every bound is computed in round-to-nearest and then pushed outward (see
 * iv_down / iv_up in interval.h and "Rigorous rounding" in expr/README.md).
 * The FPU rounding mode is never read or changed.
 */
#include "interval.h"

#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- libm error bounds --------------------------------------------------------
 * glibc documents the largest error it has observed for each function in the
 * manual ("Known Maximum Errors in Math Functions"), generated from
 * sysdeps/x86_64/fpu/libm-test-ulps.  For x86_64 double, round-to-nearest,
 * glibc 2.36 (Debian 12):
 *
 *     function   documented ulps   we assume
 *     exp        1                 1
 *     log        1                 1
 *     pow        1                 1
 *     sin        1                 1
 *     cos        1                 1
 *     tan        0 (not listed)    1   (never assume correct rounding)
 *     atan       1                 1
 *
 * Each result is widened by the assumed bound plus one ulp, counted in ulps of
 * the exact result and after the rounding of the widening itself.  libm_lo /
 * libm_hi subtract d = 3 |y| 2^-52 + 3 * 2^-1074, i.e. at least 3 ulps of y
 * (the additive term covers results in or near the subnormal range).  The
 * subtraction y - d, rounded to nearest, errs by at most half an ulp of y
 * when its result stays in y's binade, so the bound moves by at least 2.5
 * ulps of y; when it crosses into the next binade up (|y| near the top of its
 * binade, where d is nearly 6 ulps) it errs by at most one ulp of y and the
 * bound still moves by 5 ulps of y.  An exact value within E ulps of y has an
 * ulp of at most that of y, or twice it when it lies in the next binade up
 * (which needs |y| near the top of its binade): either way the move covers
 * E = 1 documented ulp plus one ulp of margin. */
#define LIBM_REL 0x3p-52   /* (1 documented + 1 margin + 1 for the rounding) * 2^-52 */
#define LIBM_ABS 0x3p-1074 /* the same in subnormal ulps */

/* Lower bound of an exact value whose libm approximation is y.  +inf (overflow
 * of a value that may be just below DBL_MAX) becomes a bound below DBL_MAX. */
static inline double libm_lo(double y)
{
    y = y == INFINITY ? DBL_MAX : y;
    return y - (fabs(y) * LIBM_REL + LIBM_ABS);
}

static inline double libm_hi(double y)
{
    y = y == -INFINITY ? -DBL_MAX : y;
    return y + (fabs(y) * LIBM_REL + LIBM_ABS);
}

/* Smallest double above pi/2 (M_PI_2 = 0x1.921fb54442d18p0 is below pi/2). */
#define PI_2_UP 0x1.921fb54442d19p0
/* The nearest doubles to pi and pi/2; used only for conservative searches. */
#define PI_RN 0x1.921fb54442d18p1
#define PI_2_RN 0x1.921fb54442d18p0

/* Beyond this magnitude trig arguments are not reduced here: the result is
 * the whole range.  Below it the reduction error is far inside the margin of
 * may_contain. */
#define TRIG_BIG 0x1p50

/* ---- construction -------------------------------------------------------------- */
iv_t iv_hull(iv_t a, iv_t b)
{
    if (iv_is_empty(a))
        return b;
    if (iv_is_empty(b))
        return a;
    iv_t r = {a.lo < b.lo ? a.lo : b.lo, a.hi > b.hi ? a.hi : b.hi};
    return r;
}

/* iv_from_decimal.
 *
 * Accepted syntax: [+-] digits [. digits] [(e|E) [+-] digits], with at least
 * one digit in the mantissa (".5" and "5." are accepted); nothing else (no
 * spaces, hex, inf or nan).
 *
 * Method: the significant digits are copied into a buffer as an integer
 * mantissa with a decimal exponent ("123e-3" for "0.123") and converted with
 * strtod, which glibc rounds correctly; writing no decimal point keeps the
 * conversion independent of the locale.  Literals with more than KEEP
 * significant digits keep the first KEEP and, when a non-zero digit was
 * dropped, a final sticky '1': any double's halfway points have at most 767
 * significant digits, so the rounding is the same as for the full literal.
 * Then the double d is printed exactly (glibc's printf prints every digit of
 * a double exactly; 767 significant digits suffice) and its digits are
 * compared with the literal's.  Equal: the result is [d, d].  Otherwise the
 * comparison tells on which side of d the literal lies, and the result is d
 * and its neighbour on that side: the tightest enclosure.
 *
 * Literals whose magnitude rounds to infinity (e.g. "1e400") are rejected
 * (false): a scene constant that large is an error, and rejecting it keeps
 * every constant finite.  Literals below the subnormal range give [0, 2^-1074]
 * (or its negative). */
#define KEEP 800

static int cmp_digits(const char *x, size_t nx, int sticky_x, const char *y, size_t ny)
{
    /* x, y: significant digits without leading or trailing zeros, same
     * decimal exponent.  Returns the sign of value(x) - value(y). */
    size_t n = nx < ny ? nx : ny;
    int c = memcmp(x, y, n);
    if (c != 0)
        return c < 0 ? -1 : 1;
    if (nx > ny || sticky_x)
        return 1;
    if (ny > nx)
        return -1;
    return 0;
}

bool iv_from_decimal(const char *text, iv_t *out)
{
    if (text == NULL || out == NULL)
        return false;
    const char *p = text;
    bool neg = false;
    if (*p == '+' || *p == '-') {
        neg = *p == '-';
        p++;
    }
    /* pass 1: syntax, and where the digits are */
    const char *mant = p;
    long long nint = 0, nfrac = 0;
    while (isdigit((unsigned char)*p)) {
        p++;
        nint++;
    }
    if (*p == '.') {
        p++;
        while (isdigit((unsigned char)*p)) {
            p++;
            nfrac++;
        }
    }
    if (nint + nfrac == 0)
        return false;
    const char *mant_end = p;
    long long e10 = 0;
    if (*p == 'e' || *p == 'E') {
        p++;
        bool eneg = false;
        if (*p == '+' || *p == '-') {
            eneg = *p == '-';
            p++;
        }
        if (!isdigit((unsigned char)*p))
            return false;
        while (isdigit((unsigned char)*p)) {
            if (e10 < 1000000000LL) /* saturate: strtod sees 0 or inf either way */
                e10 = e10 * 10 + (*p - '0');
            p++;
        }
        if (eneg)
            e10 = -e10;
    }
    if (*p != '\0')
        return false;

    /* pass 2: significant digits.  value = 0.D1D2... * 10^k */
    char dig[KEEP + 1];
    size_t nd = 0;
    int sticky = 0;
    long long k = nint + e10;
    bool leading = true;
    for (const char *q = mant; q < mant_end; q++) {
        if (*q == '.')
            continue;
        if (leading && *q == '0') {
            k--;
            continue;
        }
        leading = false;
        if (nd < KEEP)
            dig[nd++] = *q;
        else if (*q != '0')
            sticky = 1;
    }
    /* trailing zeros go, except before a sticky digit, which must stay in place */
    while (!sticky && nd > 0 && dig[nd - 1] == '0')
        nd--;
    if (nd == 0 && !sticky) { /* the literal is zero */
        *out = iv_point(0.0);
        return true;
    }

    /* the double nearest to the literal's magnitude */
    char buf[KEEP + 2 + 32];
    memcpy(buf, dig, nd);
    size_t nb = nd;
    long long eb = k - (long long)nd;
    if (sticky) {
        buf[nb++] = '1';
        eb--;
    }
    snprintf(buf + nb, sizeof buf - nb, "e%lld", eb);
    double d = strtod(buf, NULL);
    if (isinf(d))
        return false;

    /* compare the literal with d exactly */
    int cmp;
    if (d == 0.0) {
        cmp = 1;
    } else {
        char pr[KEEP + 40];
        snprintf(pr, sizeof pr, "%.*e", KEEP - 20, d);
        /* pr = "D.DDDD...e[+-]XX" */
        char pd[KEEP];
        size_t np = 0;
        const char *q = pr;
        for (; *q != 'e'; q++)
            if (*q != '.')
                pd[np++] = *q;
        long long kp = strtoll(q + 1, NULL, 10) + 1;
        while (np > 0 && pd[np - 1] == '0')
            np--;
        if (k != kp)
            cmp = k < kp ? -1 : 1;
        else
            cmp = cmp_digits(dig, nd, sticky, pd, np);
    }
    /* here |literal| vs d: cmp < 0 means |literal| < d */
    double lo = d, hi = d;
    if (cmp > 0)
        hi = nextafter(d, INFINITY);
    else if (cmp < 0)
        lo = nextafter(d, 0.0);
    *out = neg ? iv_make(-hi, -lo) : iv_make(lo, hi);
    return true;
}

/* ---- arithmetic ---------------------------------------------------------------- */

static inline double dn0(double x) /* iv_down for a value known to be >= 0 */
{
    double y = iv_down(x);
    return y < 0.0 ? 0.0 : y;
}

static inline double up0(double x) /* iv_up for a value known to be <= 0 */
{
    double y = iv_up(x);
    return y > 0.0 ? -0.0 : y;
}


/* Quotients below never see 0/0 or inf/inf: in each case the divisor bound is
 * finite and non-zero, or the dividend bound is finite (x/inf = 0 is then the
 * right limit). */
iv_t iv_div(iv_t a, iv_t b)
{
    if (iv_is_empty(a) || iv_is_empty(b))
        return iv_empty();
    if (b.lo > 0.0) {
        if (a.lo >= 0.0)
            return iv_make(dn0(a.lo / b.hi), iv_up(a.hi / b.lo));
        if (a.hi <= 0.0)
            return iv_make(iv_down(a.lo / b.lo), up0(a.hi / b.hi));
        return iv_make(iv_down(a.lo / b.lo), iv_up(a.hi / b.lo));
    }
    if (b.hi < 0.0) {
        if (a.lo >= 0.0)
            return iv_make(iv_down(a.hi / b.hi), up0(a.lo / b.lo));
        if (a.hi <= 0.0)
            return iv_make(dn0(a.hi / b.lo), iv_up(a.lo / b.hi));
        return iv_make(iv_down(a.hi / b.hi), iv_up(a.lo / b.hi));
    }
    /* 0 in b: the quotient is taken over b \ {0} */
    if (b.lo == 0.0 && b.hi == 0.0)
        return iv_empty();
    if (a.lo == 0.0 && a.hi == 0.0)
        return iv_point(0.0);
    if (b.lo == 0.0) { /* b = [0, h], h > 0: divisor in (0, h] */
        if (a.lo > 0.0)
            return iv_make(dn0(a.lo / b.hi), INFINITY);
        if (a.lo == 0.0)
            return iv_make(0.0, INFINITY);
        if (a.hi < 0.0)
            return iv_make(-INFINITY, up0(a.hi / b.hi));
        if (a.hi == 0.0)
            return iv_make(-INFINITY, 0.0);
        return iv_entire();
    }
    if (b.hi == 0.0) { /* b = [l, 0], l < 0: divisor in [l, 0) */
        if (a.lo > 0.0)
            return iv_make(-INFINITY, up0(a.lo / b.lo));
        if (a.lo == 0.0)
            return iv_make(-INFINITY, 0.0);
        if (a.hi < 0.0)
            return iv_make(dn0(a.hi / b.lo), INFINITY);
        if (a.hi == 0.0)
            return iv_make(0.0, INFINITY);
        return iv_entire();
    }
    /* 0 strictly inside b, a != [0,0]: the two half-line pieces (or more)
     * cover the whole line */
    return iv_entire();
}


/* m^k for m >= 0 rounded down (up), k >= 1, by binary exponentiation: every
 * partial product is rounded in the same direction and multiplication of
 * non-negative numbers is monotone, so the result stays a bound.  0 * inf
 * cannot occur: the base and the accumulator are both >= 1 or both <= 1
 * (except an accumulator of 1), and 0 is returned before the loop. */
static double pow_dn(double m, unsigned k)
{
    if (m == 0.0)
        return 0.0;
    double r = 1.0, base = m;
    for (;;) {
        if (k & 1u)
            r = dn0(r * base);
        k >>= 1;
        if (k == 0)
            return r;
        base = dn0(base * base);
    }
}

static double pow_up(double m, unsigned k)
{
    if (m == 0.0)
        return 0.0;
    double r = 1.0, base = m;
    for (;;) {
        if (k & 1u)
            r = iv_up(r * base);
        k >>= 1;
        if (k == 0)
            return r;
        base = iv_up(base * base);
    }
}

static iv_t powi_pos(iv_t a, unsigned k)
{
    if (k == 0)
        return iv_point(1.0);
    if (k == 1)
        return a;
    if (k == 2)
        return iv_sqr(a);
    if (k & 1u) { /* odd: increasing */
        double lo = a.lo >= 0.0 ? pow_dn(a.lo, k) : -pow_up(-a.lo, k);
        double hi = a.hi >= 0.0 ? pow_up(a.hi, k) : -pow_dn(-a.hi, k);
        return iv_make(lo, hi);
    }
    /* even: monotone in |x| */
    double mlo, mhi;
    if (a.lo >= 0.0) {
        mlo = a.lo;
        mhi = a.hi;
    } else if (a.hi <= 0.0) {
        mlo = -a.hi;
        mhi = -a.lo;
    } else {
        mlo = 0.0;
        mhi = -a.lo > a.hi ? -a.lo : a.hi;
    }
    return iv_make(pow_dn(mlo, k), pow_up(mhi, k));
}

iv_t iv_powi(iv_t a, int n)
{
    if (iv_is_empty(a))
        return iv_empty();
    if (n >= 0)
        return powi_pos(a, (unsigned)n);
    /* 1 / x^|n| over x != 0; |INT_MIN| computed without overflow */
    unsigned k = (unsigned)(-(n + 1)) + 1u;
    return iv_div(iv_point(1.0), powi_pos(a, k));
}

iv_t iv_powr(iv_t a, double r)
{
    if (iv_is_empty(a))
        return iv_empty();
    if (r != r)
        return iv_entire();
    if (r > 0.0) { /* defined on [0, inf), increasing */
        if (a.hi < 0.0)
            return iv_empty();
        double xl = a.lo > 0.0 ? a.lo : 0.0;
        double lo = libm_lo(pow(xl, r));
        double hi = libm_hi(pow(a.hi, r));
        return iv_make(lo < 0.0 ? 0.0 : lo, hi);
    }
    /* r <= 0: defined on (0, inf) (0^0 and 0^-r are undefined) */
    if (a.hi <= 0.0)
        return iv_empty();
    if (r == 0.0)
        return iv_point(1.0);
    double lo = libm_lo(pow(a.hi, r)); /* decreasing */
    double hi = a.lo > 0.0 ? libm_hi(pow(a.lo, r)) : INFINITY;
    return iv_make(lo < 0.0 ? 0.0 : lo, hi);
}

iv_t iv_sqrt(iv_t a)
{
    if (iv_is_empty(a) || a.hi < 0.0)
        return iv_empty();
    /* sqrt is correctly rounded (IEEE 754), so one-ulp widening suffices */
    double lo = a.lo > 0.0 ? dn0(sqrt(a.lo)) : 0.0;
    double hi = a.hi > 0.0 ? iv_up(sqrt(a.hi)) : 0.0;
    return iv_make(lo, hi);
}

/* ---- transcendental functions ---------------------------------------------------- */
iv_t iv_exp(iv_t a)
{
    if (iv_is_empty(a))
        return iv_empty();
    double lo = libm_lo(exp(a.lo));
    return iv_make(lo < 0.0 ? 0.0 : lo, libm_hi(exp(a.hi)));
}

iv_t iv_log(iv_t a)
{
    if (iv_is_empty(a) || a.hi <= 0.0)
        return iv_empty();
    double lo = a.lo > 0.0 ? libm_lo(log(a.lo)) : -INFINITY;
    return iv_make(lo, libm_hi(log(a.hi)));
}

/* Whether some offset + k*period (k integer) may lie in [lo, hi].  Answers
 * true whenever it does, and possibly also when it is merely close.
 *
 * t = (x - offset) / period is computed in round-to-nearest with the doubles
 * nearest to pi and pi/2: each of the (at most) four roundings and constant
 * errors is below 2^-53 relative, so |t - t_exact| < 2^-50 |t| + 2^-52.  The
 * margin |t| 2^-48 + 2^-48 exceeds that with room to spare for the rounding
 * of t +- margin itself, and a k in [t_lo - m, t_hi + m] is then sought.
 * For |x| < TRIG_BIG the margin in x is about |x| 2^-48: near 1e6 that is
 * 4e-9 radians, harmless next to a flat extremum. */
static bool may_contain(double lo, double hi, double offset, double period)
{
    double tlo = (lo - offset) / period;
    double thi = (hi - offset) / period;
    double mlo = fabs(tlo) * 0x1p-48 + 0x1p-48;
    double mhi = fabs(thi) * 0x1p-48 + 0x1p-48;
    return floor(thi + mhi) >= ceil(tlo - mlo);
}

/* sin and cos share the scheme: the hull of the (widened) endpoint values,
 * extended to +-1 when a maximum or minimum may lie inside. */
static iv_t sincos_iv(iv_t a, double (*f)(double), double max_at, double min_at)
{
    if (iv_is_empty(a))
        return iv_empty();
    if (!(a.lo > -TRIG_BIG && a.hi < TRIG_BIG) || a.hi - a.lo >= 2.0 * PI_RN)
        return iv_make(-1.0, 1.0);
    double fl = f(a.lo), fh = f(a.hi);
    double lo = fl < fh ? fl : fh;
    double hi = fl < fh ? fh : fl;
    lo = libm_lo(lo);
    hi = libm_hi(hi);
    if (may_contain(a.lo, a.hi, max_at, 2.0 * PI_RN))
        hi = 1.0;
    if (may_contain(a.lo, a.hi, min_at, 2.0 * PI_RN))
        lo = -1.0;
    return iv_make(lo < -1.0 ? -1.0 : lo, hi > 1.0 ? 1.0 : hi);
}

iv_t iv_sin(iv_t a) { return sincos_iv(a, sin, PI_2_RN, -PI_2_RN); }

iv_t iv_cos(iv_t a) { return sincos_iv(a, cos, 0.0, PI_RN); }

iv_t iv_tan(iv_t a)
{
    if (iv_is_empty(a))
        return iv_empty();
    if (!(a.lo > -TRIG_BIG && a.hi < TRIG_BIG) || a.hi - a.lo >= PI_RN ||
        may_contain(a.lo, a.hi, PI_2_RN, PI_RN))
        return iv_entire();
    /* no pole inside: increasing */
    return iv_make(libm_lo(tan(a.lo)), libm_hi(tan(a.hi)));
}

iv_t iv_atan(iv_t a)
{
    if (iv_is_empty(a))
        return iv_empty();
    double lo = libm_lo(atan(a.lo)), hi = libm_hi(atan(a.hi));
    return iv_make(lo < -PI_2_UP ? -PI_2_UP : lo, hi > PI_2_UP ? PI_2_UP : hi);
}

/* ---- exact operations ------------------------------------------------------------ */
iv_t iv_abs(iv_t a)
{
    if (iv_is_empty(a))
        return iv_empty();
    if (a.lo >= 0.0)
        return a;
    if (a.hi <= 0.0)
        return iv_make(-a.hi, -a.lo);
    return iv_make(0.0, -a.lo > a.hi ? -a.lo : a.hi);
}

/* fmin/fmax would drop a NaN (empty) operand: test emptiness explicitly. */
iv_t iv_min(iv_t a, iv_t b)
{
    if (iv_is_empty(a) || iv_is_empty(b))
        return iv_empty();
    return iv_make(a.lo < b.lo ? a.lo : b.lo, a.hi < b.hi ? a.hi : b.hi);
}

iv_t iv_max(iv_t a, iv_t b)
{
    if (iv_is_empty(a) || iv_is_empty(b))
        return iv_empty();
    return iv_make(a.lo > b.lo ? a.lo : b.lo, a.hi > b.hi ? a.hi : b.hi);
}

/* ---- derivatives ------------------------------------------------------------------ */
iv_t iv_dsqrt(iv_t a)
{
    if (iv_is_empty(a) || a.hi < 0.0)
        return iv_empty();
    if (a.hi == 0.0) /* only x = 0, where the slope is unbounded */
        return iv_make(0.0, INFINITY);
    /* 1/(2 sqrt x), decreasing on (0, hi] */
    double lo = dn0(0.5 / iv_up(sqrt(a.hi)));
    if (a.lo <= 0.0)
        return iv_make(lo, INFINITY);
    double s = iv_down(sqrt(a.lo));
    double hi = s > 0.0 ? iv_up(0.5 / s) : INFINITY;
    return iv_make(lo, hi);
}

iv_t iv_dlog(iv_t a)
{
    if (iv_is_empty(a) || a.hi <= 0.0)
        return iv_empty();
    double lo = dn0(1.0 / a.hi);
    double hi = a.lo > 0.0 ? iv_up(1.0 / a.lo) : INFINITY;
    return iv_make(lo, hi);
}

iv_t iv_dtan(iv_t a)
{
    iv_t t = iv_add(iv_point(1.0), iv_sqr(iv_tan(a)));
    if (iv_is_empty(t))
        return t;
    return iv_make(t.lo < 1.0 ? 1.0 : t.lo, t.hi); /* 1 + tan^2 >= 1 exactly */
}

iv_t iv_datan(iv_t a)
{
    if (iv_is_empty(a))
        return iv_empty();
    iv_t d = iv_div(iv_point(1.0), iv_add(iv_point(1.0), iv_sqr(a)));
    return iv_make(d.lo < 0.0 ? 0.0 : d.lo, d.hi > 1.0 ? 1.0 : d.hi);
}

iv_t iv_dabs(iv_t a)
{
    if (iv_is_empty(a))
        return iv_empty();
    if (a.lo > 0.0)
        return iv_point(1.0);
    if (a.hi < 0.0)
        return iv_point(-1.0);
    return iv_make(-1.0, 1.0);
}
