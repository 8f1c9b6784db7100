/* ivoct — reduced affine arithmetic with rigorous rounding (see affine.h, README.md).
 *
 * Rounding.  Every coefficient is computed in round-to-nearest and kept as the
 * double it rounded to; the difference to the exact value is bounded by
 * 2^-53 |computed| (+ 2^-1075 for a product that underflows) per operation,
 * and those bounds go into the error term.  The error term itself is an
 * expression in non-negative doubles (sums, and products whose factors are
 * leaves or sums), evaluated in round-to-nearest and then passed through
 * aa_fin_up:
 *   - each + or × loses at most a factor (1 + 2^-53); an expression at most
 *     ~400 operations deep loses less than (1 + 2^-53)^400 < 1 + 2^-44.4, and
 *     s (1 + 2^-44) rounded (twice) is above s (1 + 2^-44.4);
 *   - each product loses at most 2^-1075 to underflow; the added 2^-1040
 *     (less its own rounding) covers 2^34 of them.
 * A value used only as a centre (the shift of sqr, the β of an approximation)
 * needs no accounting: any double is a valid centre, the error term bounds the
 * distance to it.  Interval quantities (function values at the ends of a range,
 * the remainder of an approximation) come from the rigorous iv_* operations.
 *
 * Overflow.  A form whose coefficients are not all finite (inf, NaN) is replaced
 * by the interval fallback, which is unbounded when the interval is.
 */
#include "affine.h"

#include <float.h>
#include <math.h>

#define U 0x1p-53 /* unit roundoff */

/* ---- helpers ------------------------------------------------------------------ */

static inline void set_empty(aa_t *z)
{
    z->x[0] = z->x[1] = z->x[2] = z->x[3] = 0.0;
    z->e = 0.0;
    z->v = iv_empty();
}

static inline int bounded(const aa_t *a)
{
    return a->e <= DBL_MAX;
}

void aa_from_iv(aa_t *z, iv_t v)
{
    z->x[1] = z->x[2] = z->x[3] = 0.0;
    if (iv_is_empty(v)) {
        set_empty(z);
        return;
    }
    z->v = v;
    if (v.lo >= -DBL_MAX && v.hi <= DBL_MAX) {
        double m = 0.5 * v.lo + 0.5 * v.hi;
        double d = fmax(m - v.lo, v.hi - m);
        z->x[0] = m;
        /* a rounded difference is 0 only when exact */
        z->e = d > 0.0 ? iv_up(d) : 0.0;
        if (z->e <= DBL_MAX)
            return;
    }
    z->x[0] = 0.0;
    z->e = INFINITY;
}

/* Intersect z->v with w (both enclose the values at every point where the
 * quantity is defined, so an empty intersection means: defined nowhere). */
static inline void narrow(aa_t *z, iv_t w)
{
    if (iv_is_empty(z->v) || iv_is_empty(w)) {
        set_empty(z);
        return;
    }
    double lo = z->v.lo > w.lo ? z->v.lo : w.lo;
    double hi = z->v.hi < w.hi ? z->v.hi : w.hi;
    if (lo > hi)
        set_empty(z);
    else
        z->v = iv_make(lo, hi);
}

/* Last step of every operation: v is the interval result of the operation;
 * fall back to it when the form overflowed (or is NaN), else keep v inside
 * the form's range. */
static inline void finish(aa_t *z, iv_t v)
{
    if (iv_is_empty(v)) {
        set_empty(z);
        return;
    }
    double s = fabs(z->x[1]) + fabs(z->x[2]) + fabs(z->x[3]) + z->e;
    if (!(fabs(z->x[0]) + s <= DBL_MAX)) { /* false on inf and NaN */
        aa_from_iv(z, v);
        return;
    }
    double R = aa_fin_up(s);
    z->v = iv_make(iv_down(z->x[0] - R), iv_up(z->x[0] + R));
    narrow(z, v);
}

/* ---- leaves ------------------------------------------------------------------- */

void aa_const(aa_t *z, iv_t c)
{
    aa_from_iv(z, c);
}

void aa_var(aa_t *z, int k, double c, double r, iv_t b)
{
    if (!(r > 0.0 && r <= DBL_MAX)) {
        aa_from_iv(z, b);
        return;
    }
    z->x[0] = c;
    z->x[1] = z->x[2] = z->x[3] = 0.0;
    z->x[1 + k] = r;
    z->e = 0.0;
    z->v = b;
}

/* ---- linear operations -------------------------------------------------------- */

void aa_neg(aa_t *z, const aa_t *a)
{
    for (int i = 0; i < 4; i++)
        z->x[i] = -a->x[i];
    z->e = a->e;
    z->v = iv_neg(a->v);
}

void aa_add(aa_t *z, const aa_t *a, const aa_t *b)
{
    iv_t v = iv_add(a->v, b->v);
    double s = 0.0;
    for (int i = 0; i < 4; i++) {
        z->x[i] = a->x[i] + b->x[i];
        s += fabs(z->x[i]);
    }
    z->e = aa_fin_up(a->e + b->e + U * s);
    finish(z, v);
}

void aa_sub(aa_t *z, const aa_t *a, const aa_t *b)
{
    iv_t v = iv_sub(a->v, b->v);
    double s = 0.0;
    for (int i = 0; i < 4; i++) {
        z->x[i] = a->x[i] - b->x[i];
        s += fabs(z->x[i]);
    }
    z->e = aa_fin_up(a->e + b->e + U * s);
    finish(z, v);
}

/* z = al·a + be ± de (de >= 0 an upper bound). */
static void lin(aa_t *z, const aa_t *a, double al, double be, double de)
{
    double p0 = al * a->x[0];
    z->x[0] = p0 + be;
    z->x[1] = al * a->x[1];
    z->x[2] = al * a->x[2];
    z->x[3] = al * a->x[3];
    double r = fabs(p0) + fabs(z->x[0]) + fabs(z->x[1]) + fabs(z->x[2]) + fabs(z->x[3]);
    z->e = aa_fin_up(fabs(al) * a->e + de + U * r);
}

/* ---- multiplication -------------------------------------------------------------
 * x̂ŷ = x0 y0 + x0 Y + y0 X + XY with X = Σ xi εi + ex η1, Y likewise.
 * x0 Y and y0 X are linear up to |x0| ey + |y0| ex.  In XY the diagonal
 * Σ xi yi εi² lies in [Σ min(0, xi yi), Σ max(0, xi yi)]: centre Σ xi yi / 2,
 * radius Σ |xi yi| / 2; the rest (xi yj εi εj for i ≠ j, and the η terms) is
 * bounded by Σ_{i≠j} |xi||yj| + ex (Ry + ey) + ey Rx, Rx = Σ |xi|. */
void aa_mul(aa_t *z, const aa_t *a, const aa_t *b)
{
    iv_t v = iv_mul(a->v, b->v);
    if (iv_is_empty(v) || !bounded(a) || !bounded(b)) {
        aa_from_iv(z, v);
        return;
    }
    const double *x = a->x, *y = b->x;
    double ex = a->e, ey = b->e;
    double X1 = fabs(x[1]), X2 = fabs(x[2]), X3 = fabs(x[3]);
    double Y1 = fabs(y[1]), Y2 = fabs(y[2]), Y3 = fabs(y[3]);
    double q1 = x[1] * y[1], q2 = x[2] * y[2], q3 = x[3] * y[3];
    double aq = fabs(q1) + fabs(q2) + fabs(q3);
    double p0 = x[0] * y[0];
    z->x[0] = p0 + 0.5 * (q1 + q2 + q3);
    double rnd = 0.0;
    for (int i = 1; i < 4; i++) {
        double s = x[0] * y[i], t = y[0] * x[i];
        z->x[i] = s + t;
        rnd += fabs(s) + fabs(t);
    }
    double off = X1 * (Y2 + Y3) + X2 * (Y1 + Y3) + X3 * (Y1 + Y2);
    double e = fabs(x[0]) * ey + fabs(y[0]) * ex + 0.5 * aq + off + ex * (Y1 + Y2 + Y3 + ey) +
               ey * (X1 + X2 + X3);
    /* rounding: x0 y0 and the centre sum (u each), the diagonal sum and its
     * products (2u Σ|qi| is more than γ3/2 + u), each linear coefficient
     * (2u (|s| + |t|) covers the two products and their sum) */
    e += U * (fabs(p0) + fabs(z->x[0])) + 2.0 * U * aq + 2.0 * U * rnd;
    z->e = aa_fin_up(e);
    finish(z, v);
}

/* x̂² = x0² + 2 x0 X + X², X² ∈ [0, R²] with R = Σ|xi| + e: the centre moves
 * up by R²/2 and the remainder is at most R²/2 (tighter than a product). */
void aa_sqr(aa_t *z, const aa_t *a)
{
    iv_t v = iv_sqr(a->v);
    if (iv_is_empty(v) || !bounded(a)) {
        aa_from_iv(z, v);
        return;
    }
    const double *x = a->x;
    double R = fabs(x[1]) + fabs(x[2]) + fabs(x[3]) + a->e;
    double h = 0.5 * (R * R); /* the shift: any double will do */
    double Rup = aa_fin_up(R);
    double quad = fmax(h, iv_up(iv_up(Rup * Rup) - h)); /* >= |X² − h| */
    double p0 = x[0] * x[0];
    double t = 2.0 * x[0];
    z->x[0] = p0 + h;
    z->x[1] = t * x[1];
    z->x[2] = t * x[2];
    z->x[3] = t * x[3];
    double r = fabs(p0) + fabs(z->x[0]) + fabs(z->x[1]) + fabs(z->x[2]) + fabs(z->x[3]);
    z->e = aa_fin_up(fabs(t) * a->e + quad + U * r);
    finish(z, v);
}

/* ---- nonlinear unary functions ----------------------------------------------------
 * A function g on the argument range [l, h] (the interval v of the argument,
 * restricted to g's domain) is replaced by α u + β ± δ: α is a double chosen
 * for tightness (the chord slope: the Chebyshev choice for convex or concave
 * g), and [β − δ, β + δ] encloses the range of φ(u) = g(u) − α u over [l, h],
 * computed rigorously:
 *   - where g is convex on a piece [pl, ph], φ is convex: its maximum is at an
 *     end, and it lies above its tangent at any point ξ of the piece, so
 *     min φ >= inf over [pl, ph] of φ(ξ) + φ'(ξ)(u − ξ), evaluated in interval
 *     arithmetic.  ξ approximates the critical point g'(ξ) = α (the tangent is
 *     then nearly flat and the bound nearly exact); mirrored for concave g;
 *   - sin, cos, tan (inflections anywhere): second-order Taylor at the
 *     midpoint m with α = g'(m): φ(u) ∈ φ(m) + (g'(m) − α)(u − m) + g''([l,h])/2 (u − m)²;
 *   - abs, min, max (piecewise linear with one kink at 0): φ is piecewise
 *     linear, its range is the hull of φ at l, 0, h.
 * When δ is not smaller than the radius of the interval result, or anything
 * overflows, the interval fallback is used instead (it is then at least as
 * tight). */

typedef enum { F_EXP, F_LOG, F_SQRT, F_RECIP, F_POWI, F_POWR, F_ATAN, F_SIN, F_COS, F_TAN } fkind_t;

typedef struct {
    fkind_t k;
    int n;    /* F_POWI */
    double r; /* F_POWR */
} fn_t;

static iv_t fval(const fn_t *f, iv_t u)
{
    switch (f->k) {
    case F_EXP: return iv_exp(u);
    case F_LOG: return iv_log(u);
    case F_SQRT: return iv_sqrt(u);
    case F_RECIP: return iv_div(iv_point(1.0), u);
    case F_POWI: return iv_powi(u, f->n);
    case F_POWR: return iv_powr(u, f->r);
    case F_ATAN: return iv_atan(u);
    case F_SIN: return iv_sin(u);
    case F_COS: return iv_cos(u);
    case F_TAN: return iv_tan(u);
    }
    return iv_entire();
}

static iv_t fder(const fn_t *f, iv_t u)
{
    switch (f->k) {
    case F_EXP: return iv_exp(u);
    case F_LOG: return iv_dlog(u);
    case F_SQRT: return iv_dsqrt(u);
    case F_RECIP: return iv_neg(iv_div(iv_point(1.0), iv_sqr(u)));
    case F_POWI: return iv_mul(iv_point((double)f->n), iv_powi(u, f->n - 1));
    /* r x^r / x: exact as a formula, where r − 1 would be rounded */
    case F_POWR: return iv_mul(iv_point(f->r), iv_div(iv_powr(u, f->r), u));
    case F_ATAN: return iv_datan(u);
    case F_SIN: return iv_cos(u);
    case F_COS: return iv_neg(iv_sin(u));
    case F_TAN: return iv_dtan(u);
    }
    return iv_entire();
}

static iv_t fder2(const fn_t *f, iv_t u)
{
    switch (f->k) {
    case F_SIN: return iv_neg(iv_sin(u));
    case F_COS: return iv_neg(iv_cos(u));
    case F_TAN: {
        iv_t t = iv_tan(u); /* (tan)'' = 2 tan (1 + tan²) */
        return iv_mul(iv_add(t, t), iv_add(iv_point(1.0), iv_sqr(t)));
    }
    default: return iv_entire();
    }
}

/* An approximation (only tightness depends on it) of the point of the piece
 * (negative side when neg) where g' = al. */
static double fxi(const fn_t *f, double al, int neg)
{
    double s = neg ? -1.0 : 1.0;
    switch (f->k) {
    case F_EXP: return log(al);
    case F_LOG: return 1.0 / al;
    case F_SQRT: return 0.25 / (al * al);
    case F_RECIP: return s / sqrt(-al);
    case F_POWI: /* (al/n)^(1/(n-1)); sqrt and cbrt for the common cubes and 4th powers */
        return s * (f->n == 3   ? sqrt(fabs(al / 3.0))
                    : f->n == 4 ? cbrt(fabs(al / 4.0))
                                : pow(fabs(al / f->n), 1.0 / (f->n - 1)));
    case F_POWR: return pow(al / f->r, 1.0 / (f->r - 1.0));
    case F_ATAN: return s * sqrt(1.0 / al - 1.0);
    default: return NAN;
    }
}

static inline int valid(iv_t a)
{
    return a.lo >= -DBL_MAX && a.hi <= DBL_MAX; /* false when empty or unbounded */
}

/* Range [*m, *M] of g(u) − al u over [pl, ph], g convex (cvx) or concave
 * there; gpl, gph enclose g(pl), g(ph). */
static int piece(const fn_t *f, double al, double pl, iv_t gpl, double ph, iv_t gph, int cvx,
                 double *m, double *M)
{
    iv_t ia = iv_point(al);
    iv_t Pl = iv_sub(gpl, iv_mul(ia, iv_point(pl)));
    iv_t Ph = iv_sub(gph, iv_mul(ia, iv_point(ph)));
    double xi = fxi(f, al, ph <= 0.0);
    if (xi != xi)
        xi = 0.5 * pl + 0.5 * ph;
    xi = xi < pl ? pl : xi > ph ? ph : xi;
    iv_t X = iv_point(xi);
    iv_t Px = iv_sub(fval(f, X), iv_mul(ia, X));
    iv_t D = iv_sub(fder(f, X), ia);
    iv_t T = iv_add(Px, iv_mul(D, iv_sub(iv_make(pl, ph), X)));
    if (!valid(Pl) || !valid(Ph) || !valid(T))
        return 0;
    if (cvx) {
        *m = T.lo;
        *M = Pl.hi > Ph.hi ? Pl.hi : Ph.hi;
    } else {
        *M = T.hi;
        *m = Pl.lo < Ph.lo ? Pl.lo : Ph.lo;
    }
    return 1;
}

/* z = al a + β ± δ from the range [m, M] of g − al u, or the fallback to v. */
static void apply(aa_t *z, const aa_t *a, double al, double m, double M, iv_t v)
{
    double be = 0.5 * m + 0.5 * M;
    double de = fmax(iv_up(M - be), iv_up(be - m));
    if (!(al >= -DBL_MAX && al <= DBL_MAX) || !(de <= DBL_MAX) ||
        de >= 0.5 * v.hi - 0.5 * v.lo) {
        aa_from_iv(z, v);
        return;
    }
    lin(z, a, al, be, de);
    finish(z, v);
}

enum { CONVEX, CONCAVE, CONCAVE_CONVEX, CONVEX_CONCAVE }; /* shapes; split ones at 0 */

/* g of the given shape on [l, h] (inside g's domain); v the interval result. */
static void convex_approx(aa_t *z, const aa_t *a, const fn_t *f, double l, double h, int shape,
                          iv_t v)
{
    if (iv_is_empty(v) || !bounded(a) || !(l >= -DBL_MAX && h <= DBL_MAX && l <= h)) {
        aa_from_iv(z, v);
        return;
    }
    iv_t gl = fval(f, iv_point(l)), gh = h > l ? fval(f, iv_point(h)) : gl;
    double al = h > l ? (iv_mid(gh) - iv_mid(gl)) / (h - l) : iv_mid(fder(f, iv_point(l)));
    if (!(al >= -DBL_MAX && al <= DBL_MAX)) {
        aa_from_iv(z, v);
        return;
    }
    double m, M, m2, M2;
    int ok;
    if (shape == CONVEX || shape == CONCAVE) {
        ok = piece(f, al, l, gl, h, gh, shape == CONVEX, &m, &M);
    } else {
        int left_cvx = shape == CONVEX_CONCAVE;
        if (h <= 0.0) {
            ok = piece(f, al, l, gl, h, gh, left_cvx, &m, &M);
        } else if (l >= 0.0) {
            ok = piece(f, al, l, gl, h, gh, !left_cvx, &m, &M);
        } else {
            iv_t g0 = fval(f, iv_point(0.0));
            ok = piece(f, al, l, gl, 0.0, g0, left_cvx, &m, &M) &&
                 piece(f, al, 0.0, g0, h, gh, !left_cvx, &m2, &M2);
            if (ok) {
                m = m < m2 ? m : m2;
                M = M > M2 ? M : M2;
            }
        }
    }
    if (!ok) {
        aa_from_iv(z, v);
        return;
    }
    apply(z, a, al, m, M, v);
}

/* Second-order Taylor model at the midpoint (sin, cos, tan). */
static void taylor_approx(aa_t *z, const aa_t *a, const fn_t *f, iv_t v)
{
    double l = a->v.lo, h = a->v.hi;
    if (iv_is_empty(v) || !bounded(a) || !(l >= -DBL_MAX && h <= DBL_MAX)) {
        aa_from_iv(z, v);
        return;
    }
    double mid = 0.5 * l + 0.5 * h;
    iv_t Mi = iv_point(mid);
    iv_t D = fder(f, Mi);
    double al = iv_mid(D);
    iv_t ia = iv_point(al);
    iv_t W = iv_sub(iv_make(l, h), Mi);
    iv_t T = iv_sub(fval(f, Mi), iv_mul(ia, Mi));
    T = iv_add(T, iv_mul(iv_sub(D, ia), W));
    T = iv_add(T, iv_mul(iv_mul(iv_point(0.5), fder2(f, iv_make(l, h))), iv_sqr(W)));
    if (!valid(T) || !(al >= -DBL_MAX && al <= DBL_MAX)) {
        aa_from_iv(z, v);
        return;
    }
    apply(z, a, al, T.lo, T.hi, v);
}

/* g piecewise linear with its one kink at 0, l < 0 < h: φ = g − al u is
 * linear on [l, 0] and [0, h], its range the hull of φ(l), φ(0) = g0, φ(h). */
static void kink_approx(aa_t *z, const aa_t *a, double al, double gl, double g0, double gh,
                        iv_t v)
{
    double l = a->v.lo, h = a->v.hi;
    iv_t ia = iv_point(al);
    iv_t Pl = iv_sub(iv_point(gl), iv_mul(ia, iv_point(l)));
    iv_t Ph = iv_sub(iv_point(gh), iv_mul(ia, iv_point(h)));
    if (!valid(Pl) || !valid(Ph) || !bounded(a)) {
        aa_from_iv(z, v);
        return;
    }
    double m = Pl.lo < Ph.lo ? Pl.lo : Ph.lo, M = Pl.hi > Ph.hi ? Pl.hi : Ph.hi;
    m = m < g0 ? m : g0;
    M = M > g0 ? M : g0;
    apply(z, a, al, m, M, v);
}

void aa_exp(aa_t *z, const aa_t *a)
{
    fn_t f = {F_EXP, 0, 0.0};
    convex_approx(z, a, &f, a->v.lo, a->v.hi, CONVEX, iv_exp(a->v));
}

void aa_log(aa_t *z, const aa_t *a)
{
    fn_t f = {F_LOG, 0, 0.0};
    iv_t v = iv_log(a->v);
    if (!(a->v.lo > 0.0)) { /* log unbounded below near 0 */
        aa_from_iv(z, v);
        return;
    }
    convex_approx(z, a, &f, a->v.lo, a->v.hi, CONCAVE, v);
}

/* sqrt is continuous at 0 (unlike its derivative): on [max(l, 0), h] the
 * concave machinery still applies, the tangent being taken inside (0, h]. */
void aa_sqrt(aa_t *z, const aa_t *a)
{
    fn_t f = {F_SQRT, 0, 0.0};
    iv_t v = iv_sqrt(a->v);
    if (!(a->v.hi > 0.0)) {
        aa_from_iv(z, v);
        return;
    }
    convex_approx(z, a, &f, a->v.lo > 0.0 ? a->v.lo : 0.0, a->v.hi, CONCAVE, v);
}

/* 1/b for b bounded away from 0: convex for b > 0, concave for b < 0. */
static void aa_recip(aa_t *z, const aa_t *b)
{
    fn_t f = {F_RECIP, 0, 0.0};
    iv_t v = iv_div(iv_point(1.0), b->v);
    if (b->v.lo > 0.0)
        convex_approx(z, b, &f, b->v.lo, b->v.hi, CONVEX, v);
    else if (b->v.hi < 0.0)
        convex_approx(z, b, &f, b->v.lo, b->v.hi, CONCAVE, v);
    else
        aa_from_iv(z, v);
}

void aa_div(aa_t *z, const aa_t *a, const aa_t *b)
{
    iv_t v = iv_div(a->v, b->v);
    if (iv_is_empty(v) || !(b->v.lo > 0.0 || b->v.hi < 0.0)) {
        aa_from_iv(z, v);
        return;
    }
    aa_t r;
    aa_recip(&r, b);
    aa_mul(z, a, &r);
    narrow(z, v);
}

void aa_powi(aa_t *z, const aa_t *a, double nd)
{
    if (!(fabs(nd) <= 1e6) || nd != floor(nd)) { /* not a tape exponent: say nothing */
        aa_from_iv(z, iv_is_empty(a->v) ? a->v : iv_entire());
        return;
    }
    int n = (int)nd;
    iv_t v = iv_powi(a->v, n);
    double l = a->v.lo, h = a->v.hi;
    fn_t f = {F_POWI, n, 0.0};
    if (n == 1) {
        *z = *a;
    } else if (n == 2) {
        aa_sqr(z, a);
    } else if (n >= 3) {
        /* x^n: convex for n even; odd: concave for x <= 0, convex for x >= 0 */
        convex_approx(z, a, &f, l, h, n % 2 == 0 ? CONVEX : CONCAVE_CONVEX, v);
    } else if (n < 0 && l > 0.0) {
        convex_approx(z, a, &f, l, h, CONVEX, v);
    } else if (n < 0 && h < 0.0) {
        convex_approx(z, a, &f, l, h, n % 2 == 0 ? CONVEX : CONCAVE, v);
    } else {
        aa_from_iv(z, v); /* n = 0, or a negative power of a range holding 0 */
    }
}

/* x^r, r not an integer: defined for x >= 0 when r > 0 (x > 0 when r < 0);
 * convex when r > 1 or r < 0, concave when 0 < r < 1. */
void aa_powr(aa_t *z, const aa_t *a, double r)
{
    fn_t f = {F_POWR, 0, r};
    iv_t v = iv_powr(a->v, r);
    double l = a->v.lo, h = a->v.hi;
    if (r > 0.0 && r != floor(r) && h > 0.0)
        convex_approx(z, a, &f, l > 0.0 ? l : 0.0, h, r > 1.0 ? CONVEX : CONCAVE, v);
    else if (r < 0.0 && r != floor(r) && l > 0.0)
        convex_approx(z, a, &f, l, h, CONVEX, v);
    else
        aa_from_iv(z, v);
}

/* atan: convex for x <= 0, concave for x >= 0 */
void aa_atan(aa_t *z, const aa_t *a)
{
    fn_t f = {F_ATAN, 0, 0.0};
    convex_approx(z, a, &f, a->v.lo, a->v.hi, CONVEX_CONCAVE, iv_atan(a->v));
}

void aa_sin(aa_t *z, const aa_t *a)
{
    fn_t f = {F_SIN, 0, 0.0};
    taylor_approx(z, a, &f, iv_sin(a->v));
}

void aa_cos(aa_t *z, const aa_t *a)
{
    fn_t f = {F_COS, 0, 0.0};
    taylor_approx(z, a, &f, iv_cos(a->v));
}

void aa_tan(aa_t *z, const aa_t *a)
{
    fn_t f = {F_TAN, 0, 0.0};
    taylor_approx(z, a, &f, iv_tan(a->v));
}

/* ---- abs, min, max ------------------------------------------------------------------ */

void aa_abs(aa_t *z, const aa_t *a)
{
    iv_t v = iv_abs(a->v);
    double l = a->v.lo, h = a->v.hi;
    if (iv_is_empty(v)) {
        set_empty(z);
    } else if (l >= 0.0) {
        *z = *a;
    } else if (h <= 0.0) {
        aa_neg(z, a);
    } else {
        /* chord slope of |u| over [l, h]; |l| = −l exactly */
        kink_approx(z, a, (h + l) / (h - l), -l, 0.0, h, v);
    }
}

/* min(a, b) = b + min(a − b, 0); the branch is decided by the range of the
 * affine difference, where correlated terms cancel. */
void aa_min(aa_t *z, const aa_t *a, const aa_t *b)
{
    iv_t v = iv_min(a->v, b->v);
    if (iv_is_empty(v)) {
        set_empty(z);
        return;
    }
    aa_t d, g;
    aa_sub(&d, a, b);
    if (iv_is_empty(d.v)) {
        set_empty(z); /* a and b are nowhere both defined */
    } else if (d.v.hi <= 0.0) {
        *z = *a;
        narrow(z, v);
    } else if (d.v.lo >= 0.0) {
        *z = *b;
        narrow(z, v);
    } else {
        double l = d.v.lo, h = d.v.hi;
        /* min(u, 0) on [l, h]: chord from (l, l) to (h, 0) */
        kink_approx(&g, &d, -l / (h - l), l, 0.0, 0.0, iv_make(l, 0.0));
        aa_add(z, b, &g);
        narrow(z, v);
    }
}

void aa_max(aa_t *z, const aa_t *a, const aa_t *b)
{
    iv_t v = iv_max(a->v, b->v);
    if (iv_is_empty(v)) {
        set_empty(z);
        return;
    }
    aa_t d, g;
    aa_sub(&d, a, b);
    if (iv_is_empty(d.v)) {
        set_empty(z);
    } else if (d.v.lo >= 0.0) {
        *z = *a;
        narrow(z, v);
    } else if (d.v.hi <= 0.0) {
        *z = *b;
        narrow(z, v);
    } else {
        double l = d.v.lo, h = d.v.hi;
        /* max(u, 0) on [l, h]: chord from (l, 0) to (h, h) */
        kink_approx(&g, &d, h / (h - l), 0.0, 0.0, h, iv_make(0.0, h));
        aa_add(z, b, &g);
        narrow(z, v);
    }
}
