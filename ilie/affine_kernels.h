/* ivoct — the affine pass over a tape in structure-of-arrays form (internal to
 * ilie/; see affine.h for the layout and README.md for the arithmetic).
 *
 * Included once by each affine_kernels_<target>.c, which defines KERNEL_TARGET
 * and is compiled with that target's flags (as expr/kernels.h is); everything
 * here is static except the table ilie_lanes_<target> (affine.h).
 *
 * The operations that dominate polynomial and CSG tapes (neg, add, sub, mul,
 * sqr, integer powers, min and max) run as loops over the lanes that compute
 * exactly what affine.c's aa_ functions compute on their common path: the same
 * IEEE operations in the same order, written without branches so that they
 * vectorise.  A lane that leaves the common path (an empty or unbounded
 * operand, a form that overflows, an empty intersection with the interval
 * result) is marked, and the scalar aa_ function recomputes it from its
 * operands.  Every other operation calls the scalar aa_ function lane by lane.
 * So every lane holds what the scalar arithmetic gives: the target and the
 * vector width change nothing but speed. */
#include <float.h>
#include <math.h>
#include <stdint.h>

#include "../expr/lanes.h"
#include "affine.h"

#ifndef KERNEL_TARGET
#error "affine_kernels.h is included by affine_kernels_<target>.c, which defines KERNEL_TARGET"
#endif

#define KCAT_(a, b) a##_##b
#define KCAT(a, b) KCAT_(a, b)
#define K(name) KCAT(name, KERNEL_TARGET)
#define KSTR_(a) #a
#define KSTR(a) KSTR_(a)

#define B ILIE_BATCH
#define U 0x1p-53 /* unit roundoff, as in affine.c */

/* Before each lane loop of an operation: its output slot is never one of its
 * operand slots (operands come before the clause), so the loop has no
 * dependence between lanes.  Said to the compiler because with seven arrays
 * out and up to fourteen in, the run-time alias checks it would otherwise
 * need exceed its limit and the loop stays scalar. */
#if defined(__clang__)
#define K_LANES _Pragma("clang loop vectorize(assume_safety)")
#elif defined(__GNUC__)
#define K_LANES _Pragma("GCC ivdep")
#else
#define K_LANES
#endif

/* array c of slot i */
#define AR(S, i, c) ((S) + ((size_t)(i) * A_ARRAYS + (size_t)(c)) * B)

static inline aa_t k_get(const double *S, uint32_t i, size_t k)
{
    aa_t a;
    for (int c = 0; c < 4; c++)
        a.x[c] = AR(S, i, A_X0 + c)[k];
    a.e = AR(S, i, A_E)[k];
    a.v = iv_make(AR(S, i, A_VLO)[k], AR(S, i, A_VHI)[k]);
    return a;
}

static inline void k_put(double *S, uint32_t i, size_t k, const aa_t *z)
{
    for (int c = 0; c < 4; c++)
        AR(S, i, A_X0 + c)[k] = z->x[c];
    AR(S, i, A_E)[k] = z->e;
    AR(S, i, A_VLO)[k] = z->v.lo;
    AR(S, i, A_VHI)[k] = z->v.hi;
}

/* Lane k of clause i, operands in slots ia and ib, by the scalar arithmetic of
 * affine.c (op TAPE_OP_COUNT: no information, operands not read). */
static void k_scalar(double *S, tape_op_t op, const tape_clause_t *cl, uint32_t i, uint32_t ia,
                     uint32_t ib, size_t k)
{
    aa_t a, b, z;
    if (op != TAPE_OP_COUNT)
        a = k_get(S, ia, k), b = k_get(S, ib, k);
    switch (op) {
    case TAPE_NEG: aa_neg(&z, &a); break;
    case TAPE_SQR: aa_sqr(&z, &a); break;
    case TAPE_POWI: aa_powi(&z, &a, cl->c.lo); break;
    case TAPE_POWR: aa_powr(&z, &a, cl->c.lo); break;
    case TAPE_SQRT: aa_sqrt(&z, &a); break;
    case TAPE_EXP: aa_exp(&z, &a); break;
    case TAPE_LOG: aa_log(&z, &a); break;
    case TAPE_SIN: aa_sin(&z, &a); break;
    case TAPE_COS: aa_cos(&z, &a); break;
    case TAPE_TAN: aa_tan(&z, &a); break;
    case TAPE_ATAN: aa_atan(&z, &a); break;
    case TAPE_ABS: aa_abs(&z, &a); break;
    case TAPE_ADD: aa_add(&z, &a, &b); break;
    case TAPE_SUB: aa_sub(&z, &a, &b); break;
    case TAPE_MUL: aa_mul(&z, &a, &b); break;
    case TAPE_DIV: aa_div(&z, &a, &b); break;
    case TAPE_MIN: aa_min(&z, &a, &b); break;
    case TAPE_MAX: aa_max(&z, &a, &b); break;
    default: aa_from_iv(&z, iv_entire()); break;
    }
    k_put(S, i, k, &z);
}

/* affine.c's finish() on its common path: the form's range [x0 − R, x0 + R]
 * intersected with the interval result [vl, vh], into *ol, *oh.  Nonzero when
 * finish() would leave that path: the interval result is empty, the form is
 * not finite (it falls back to the interval), or the intersection is empty.
 * (The flags are selects of 64-bit integers, as wide as the doubles: flags
 * made of C's int-valued comparisons keep gcc 12 from vectorising the loop.) */
static inline int64_t k_finish(double x0, double x1, double x2, double x3, double e,
                               double vl, double vh, double *ol, double *oh)
{
    double s = fabs(x1) + fabs(x2) + fabs(x3) + e;
    double R = aa_fin_up(s);
    double lo = iv_down(x0 - R), hi = iv_up(x0 + R);
    lo = lo > vl ? lo : vl;
    hi = hi < vh ? hi : vh;
    *ol = lo, *oh = hi;
    int64_t slow = vl != vl ? 1 : 0;
    slow = vh != vh ? 1 : slow;
    slow = fabs(x0) + s <= DBL_MAX ? slow : 1;
    return lo > hi ? 1 : slow;
}

/* A slot's arrays by name: the centre, the noise coefficients, the error term
 * and the enclosure [lo, hi] of every lane's form. */
typedef struct {
    const double *x0, *x1, *x2, *x3, *e, *lo, *hi;
} k_in_t;
typedef struct {
    double *x0, *x1, *x2, *x3, *e, *lo, *hi;
} k_out_t;

/* A clause's output slot o and operand slots a, b. */
typedef struct {
    k_out_t o;
    k_in_t a, b;
} k_slots_t;

static inline k_in_t k_in(const double *S, uint32_t i)
{
    k_in_t r = {AR(S, i, A_X0), AR(S, i, A_X1), AR(S, i, A_X2), AR(S, i, A_X3),
                AR(S, i, A_E),  AR(S, i, A_VLO), AR(S, i, A_VHI)};
    return r;
}

static inline k_slots_t k_slots(double *S, uint32_t i, uint32_t ia, uint32_t ib)
{
    k_slots_t p = {{AR(S, i, A_X0), AR(S, i, A_X1), AR(S, i, A_X2), AR(S, i, A_X3),
                    AR(S, i, A_E), AR(S, i, A_VLO), AR(S, i, A_VHI)},
                   k_in(S, ia), k_in(S, ib)};
    return p;
}

/* aa_neg: exact. */
static void k_neg(k_slots_t p, size_t nl)
{
    k_in_t a = p.a;
    k_out_t o = p.o;
    K_LANES
    for (size_t k = 0; k < nl; k++) {
        o.x0[k] = -a.x0[k], o.x1[k] = -a.x1[k], o.x2[k] = -a.x2[k], o.x3[k] = -a.x3[k];
        o.e[k] = a.e[k], o.lo[k] = -a.hi[k], o.hi[k] = -a.lo[k];
    }
}

/* aa_add, and aa_sub as a + (−b) (x − y and x + (−y) are the same IEEE
 * operation, and so are iv_sub and iv_add of the negated interval). */
static void k_add(k_slots_t p, size_t nl, int sub, int64_t *restrict slow)
{
    const double sg = sub ? -1.0 : 1.0;
    k_in_t a = p.a, b = p.b;
    k_out_t o = p.o;
    /* the interval of b, or of −b = [−b.hi, −b.lo] */
    const double *bl = sub ? b.hi : b.lo, *bh = sub ? b.lo : b.hi;
    K_LANES
    for (size_t k = 0; k < nl; k++) {
        /* sg * v is exact: a sign flip or nothing */
        double vl = iv_add_down(a.lo[k], sg * bl[k]), vh = iv_add_up(a.hi[k], sg * bh[k]);
        double x0 = a.x0[k] + sg * b.x0[k], x1 = a.x1[k] + sg * b.x1[k];
        double x2 = a.x2[k] + sg * b.x2[k], x3 = a.x3[k] + sg * b.x3[k];
        double s = 0.0;
        s += fabs(x0);
        s += fabs(x1);
        s += fabs(x2);
        s += fabs(x3);
        double e = aa_fin_up(a.e[k] + b.e[k] + U * s);
        o.x0[k] = x0, o.x1[k] = x1, o.x2[k] = x2, o.x3[k] = x3, o.e[k] = e;
        slow[k] = k_finish(x0, x1, x2, x3, e, vl, vh, &o.lo[k], &o.hi[k]);
    }
}

/* aa_mul (see affine.c for the error terms). */
static void k_mul(k_slots_t p, size_t nl, int64_t *restrict slow)
{
    k_in_t a = p.a, b = p.b;
    k_out_t o = p.o;
    K_LANES
    for (size_t k = 0; k < nl; k++) {
        iv_t v = iv_mul(iv_make(a.lo[k], a.hi[k]), iv_make(b.lo[k], b.hi[k]));
        double x0 = a.x0[k], x1 = a.x1[k], x2 = a.x2[k], x3 = a.x3[k];
        double y0 = b.x0[k], y1 = b.x1[k], y2 = b.x2[k], y3 = b.x3[k];
        double ex = a.e[k], ey = b.e[k];
        double X1 = fabs(x1), X2 = fabs(x2), X3 = fabs(x3);
        double Y1 = fabs(y1), Y2 = fabs(y2), Y3 = fabs(y3);
        double q1 = x1 * y1, q2 = x2 * y2, q3 = x3 * y3;
        double aq = fabs(q1) + fabs(q2) + fabs(q3);
        double p0 = x0 * y0;
        double c0 = p0 + 0.5 * (q1 + q2 + q3);
        double s1 = x0 * y1, t1 = y0 * x1, s2 = x0 * y2, t2 = y0 * x2;
        double s3 = x0 * y3, t3 = y0 * x3;
        double c1 = s1 + t1, c2 = s2 + t2, c3 = s3 + t3;
        double rnd = 0.0;
        rnd += fabs(s1) + fabs(t1);
        rnd += fabs(s2) + fabs(t2);
        rnd += fabs(s3) + fabs(t3);
        double off = X1 * (Y2 + Y3) + X2 * (Y1 + Y3) + X3 * (Y1 + Y2);
        double e = fabs(x0) * ey + fabs(y0) * ex + 0.5 * aq + off + ex * (Y1 + Y2 + Y3 + ey) +
                   ey * (X1 + X2 + X3);
        e += U * (fabs(p0) + fabs(c0)) + 2.0 * U * aq + 2.0 * U * rnd;
        e = aa_fin_up(e);
        o.x0[k] = c0, o.x1[k] = c1, o.x2[k] = c2, o.x3[k] = c3, o.e[k] = e;
        int64_t unbounded = ex <= DBL_MAX ? 0 : 1;
        unbounded = ey <= DBL_MAX ? unbounded : 1;
        slow[k] = k_finish(c0, c1, c2, c3, e, v.lo, v.hi, &o.lo[k], &o.hi[k]) | unbounded;
    }
}

/* aa_sqr. */
static void k_sqr(k_slots_t p, size_t nl, int64_t *restrict slow)
{
    k_in_t a = p.a;
    k_out_t o = p.o;
    K_LANES
    for (size_t k = 0; k < nl; k++) {
        iv_t v = iv_sqr(iv_make(a.lo[k], a.hi[k]));
        double x0 = a.x0[k], x1 = a.x1[k], x2 = a.x2[k], x3 = a.x3[k], ex = a.e[k];
        double R = fabs(x1) + fabs(x2) + fabs(x3) + ex;
        double h = 0.5 * (R * R);
        double Rup = aa_fin_up(R);
        /* fmax of affine.c: the same value wherever this lane stays on the
         * common path (both operands are then numbers) */
        double w = iv_up(iv_up(Rup * Rup) - h);
        double quad = h > w ? h : w;
        double p0 = x0 * x0;
        double t = 2.0 * x0;
        double c0 = p0 + h, c1 = t * x1, c2 = t * x2, c3 = t * x3;
        double r = fabs(p0) + fabs(c0) + fabs(c1) + fabs(c2) + fabs(c3);
        double e = aa_fin_up(fabs(t) * ex + quad + U * r);
        o.x0[k] = c0, o.x1[k] = c1, o.x2[k] = c2, o.x3[k] = c3, o.e[k] = e;
        int64_t odd = ex <= DBL_MAX ? 0 : 1;
        odd = w != w ? 1 : odd;
        slow[k] = k_finish(c0, c1, c2, c3, e, v.lo, v.hi, &o.lo[k], &o.hi[k]) | odd;
    }
}

/* aa_min (is_max = 0) and aa_max where the affine difference d = a − b
 * decides the branch (its range on one side of 0, where correlated terms have
 * cancelled): the chosen operand, its enclosure narrowed by the interval
 * result.  An undecided branch (the kink's chord), an empty operand, and the
 * exits of d's own computation (k_add's, as aa_sub) go to the scalar
 * function.  The selects compare doubles and stay one condition each: flags
 * built from C's int comparisons keep gcc 12 from vectorising the loop. */
static void k_minmax(k_slots_t p, size_t nl, int is_max, int64_t *restrict slow)
{
    /* d = aa_sub(a, b) into scratch arrays, its lanes' flags into slow */
    double d[A_ARRAYS][B];
    k_slots_t dp = {{d[A_X0], d[A_X1], d[A_X2], d[A_X3], d[A_E], d[A_VLO], d[A_VHI]}, p.a, p.b};
    k_add(dp, nl, 1, slow);
    k_in_t a = p.a, b = p.b;
    k_out_t o = p.o;
    const double *dl = d[A_VLO], *dh = d[A_VHI];
    /* min takes a where d <= 0 and b where d >= 0; max the other way round:
     * with σ = ±1, a where σ·d's upper end is <= 0, b where its lower end is >= 0 */
    K_LANES
    for (size_t k = 0; k < nl; k++) {
        /* v: iv_min or iv_max of non-empty operands */
        double al = a.lo[k], ah = a.hi[k], bl = b.lo[k], bh = b.hi[k];
        double vl = is_max ? (al > bl ? al : bl) : (al < bl ? al : bl);
        double vh = is_max ? (ah > bh ? ah : bh) : (ah < bh ? ah : bh);
        double up = is_max ? -dl[k] : dh[k], down = is_max ? -dh[k] : dl[k]; /* σ·d */
        int take_a = up <= 0.0;
        int64_t odd = slow[k];
        odd = take_a ? odd : (down >= 0.0 ? odd : 1);
        double cl = take_a ? al : bl, ch = take_a ? ah : bh;
        /* narrow() by v */
        double lo = cl > vl ? cl : vl, hi = ch < vh ? ch : vh;
        odd = lo > hi ? 1 : odd;
        odd = al != al ? 1 : odd;
        odd = ah != ah ? 1 : odd;
        odd = bl != bl ? 1 : odd;
        odd = bh != bh ? 1 : odd;
        o.x0[k] = take_a ? a.x0[k] : b.x0[k], o.x1[k] = take_a ? a.x1[k] : b.x1[k];
        o.x2[k] = take_a ? a.x2[k] : b.x2[k], o.x3[k] = take_a ? a.x3[k] : b.x3[k];
        o.e[k] = take_a ? a.e[k] : b.e[k], o.lo[k] = lo, o.hi[k] = hi;
        slow[k] = odd;
    }
}

/* aa_powi for an integer 3 <= n <= 64: convex_approx of affine.c for x^n on the
 * argument's range [l, h] (one convex piece for even n; for odd n one concave
 * piece when h <= 0, one convex piece when l >= 0), with the chord slope α, the
 * critical point ξ of x^n − αx approximated as affine.c does (fxi: sqrt, cbrt or
 * pow of |α/n|), and apply() and lin() of the result.  Odd n across 0 (two
 * pieces), a flat range and every fallback are left to the scalar aa_powi. */
static void k_powi(k_slots_t p, size_t nl, unsigned n, int64_t *restrict slow)
{
    k_in_t A = p.a;
    k_out_t o = p.o;
    const double *al = A.lo, *ah = A.hi;
    const int odd = n & 1u;
    const double nd = (double)n;
    const double cvx_above = odd ? 0.0 : -INFINITY; /* x^n is convex where x > this */
    const double straddle_below = odd ? 0.0 : -INFINITY; /* two pieces: l < this < h */
    /* v = x^n over the range; x^n at its ends; the same at ξ, and x^(n−1) */
    double vl[B], vh[B], gll[B], glh[B], ghl[B], ghh[B], alpha[B], xi[B];
    double fl[B], fh[B], dl[B], dh[B];
    iv_powi_lanes(al, ah, nl, n, vl, vh);
    iv_powi_lanes(al, al, nl, n, gll, glh);
    iv_powi_lanes(ah, ah, nl, n, ghl, ghh);
    /* the slope and ξ (libm, lane by lane; ξ only affects tightness) */
    for (size_t k = 0; k < nl; k++) {
        double l = al[k], h = ah[k];
        double mgl = 0.5 * gll[k] + 0.5 * glh[k], mgh = 0.5 * ghl[k] + 0.5 * ghh[k];
        double a = (mgh - mgl) / (h - l);
        double sg = h <= 0.0 ? -1.0 : 1.0;
        double x = sg * (n == 3   ? sqrt(fabs(a / 3.0))
                         : n == 4 ? cbrt(fabs(a / 4.0))
                                  : pow(fabs(a / nd), 1.0 / (double)(n - 1)));
        if (x != x)
            x = 0.5 * l + 0.5 * h;
        alpha[k] = a;
        xi[k] = x < l ? l : x > h ? h : x;
    }
    iv_powi_lanes(xi, xi, nl, n, fl, fh);
    if (n - 1 >= 3) {
        iv_powi_lanes(xi, xi, nl, n - 1, dl, dh);
    } else {
        for (size_t k = 0; k < nl; k++) {
            iv_t q = iv_sqr(iv_point(xi[k]));
            dl[k] = q.lo, dh[k] = q.hi;
        }
    }
    /* piece(): φ(u) = u^n − αu at the ends (Pl, Ph), and its tangent bound at ξ,
     * T = φ(ξ) + φ'(ξ)·([l, h] − ξ) with φ(ξ) = Px, φ'(ξ) = D.  The products go
     * through arrays before they are summed, as in expr/kernels.h: with a sum
     * of an iv_mul in the same loop gcc 12 folds iv_mul's empty test into
     * iv_add's zero test and gives up on the loop. */
    double m1l[B], m1h[B], m2l[B], m2h[B], m3l[B], m3h[B], m4l[B], m4h[B];
    for (size_t k = 0; k < nl; k++) {
        iv_t ia = iv_point(alpha[k]), X = iv_point(xi[k]);
        iv_t m1 = iv_mul(ia, iv_point(al[k])), m2 = iv_mul(ia, iv_point(ah[k]));
        iv_t m3 = iv_mul(ia, X), m4 = iv_mul(iv_point(nd), iv_make(dl[k], dh[k]));
        m1l[k] = m1.lo, m1h[k] = m1.hi, m2l[k] = m2.lo, m2h[k] = m2.hi;
        m3l[k] = m3.lo, m3h[k] = m3.hi, m4l[k] = m4.lo, m4h[k] = m4.hi;
    }
    double pll[B], plh[B], phl[B], phh[B], pxl[B], pxh[B], Dl[B], Dh[B], Wl[B], Wh[B];
    for (size_t k = 0; k < nl; k++) {
        iv_t ia = iv_point(alpha[k]), X = iv_point(xi[k]);
        iv_t Pl = iv_sub(iv_make(gll[k], glh[k]), iv_make(m1l[k], m1h[k]));
        iv_t Ph = iv_sub(iv_make(ghl[k], ghh[k]), iv_make(m2l[k], m2h[k]));
        iv_t Px = iv_sub(iv_make(fl[k], fh[k]), iv_make(m3l[k], m3h[k]));
        iv_t D = iv_sub(iv_make(m4l[k], m4h[k]), ia);
        iv_t W = iv_sub(iv_make(al[k], ah[k]), X);
        pll[k] = Pl.lo, plh[k] = Pl.hi, phl[k] = Ph.lo, phh[k] = Ph.hi;
        pxl[k] = Px.lo, pxh[k] = Px.hi, Dl[k] = D.lo, Dh[k] = D.hi, Wl[k] = W.lo, Wh[k] = W.hi;
    }
    for (size_t k = 0; k < nl; k++) { /* D·W into m1 */
        iv_t m5 = iv_mul(iv_make(Dl[k], Dh[k]), iv_make(Wl[k], Wh[k]));
        m1l[k] = m5.lo, m1h[k] = m5.hi;
    }
    K_LANES
    for (size_t k = 0; k < nl; k++) {
        double l = al[k], h = ah[k], a = alpha[k];
        iv_t Pl = iv_make(pll[k], plh[k]), Ph = iv_make(phl[k], phh[k]);
        iv_t T = iv_add(iv_make(pxl[k], pxh[k]), iv_make(m1l[k], m1h[k]));
        /* (one condition per select: combined ones keep gcc 12 from
         * vectorising the loop) */
        int64_t odd_path = Pl.lo >= -DBL_MAX ? 0 : 1;
        odd_path = Pl.hi <= DBL_MAX ? odd_path : 1;
        odd_path = Ph.lo >= -DBL_MAX ? odd_path : 1;
        odd_path = Ph.hi <= DBL_MAX ? odd_path : 1;
        odd_path = T.lo >= -DBL_MAX ? odd_path : 1;
        odd_path = T.hi <= DBL_MAX ? odd_path : 1;
        /* convex: even n, or odd n on l >= 0 (h > 0 here); a comparison of
         * doubles rather than an int keeps the loop vectorised */
        int cvx = h > cvx_above;
        double m = cvx ? T.lo : Pl.lo < Ph.lo ? Pl.lo : Ph.lo;
        double M = cvx ? (Pl.hi > Ph.hi ? Pl.hi : Ph.hi) : T.hi;
        /* apply(): β ± δ, and lin() */
        double be = 0.5 * m + 0.5 * M;
        double du = iv_up(M - be), dd = iv_up(be - m);
        double de = du > dd ? du : dd; /* fmax: both are numbers on this path */
        double x0 = A.x0[k];
        double p0 = a * x0;
        double c0 = p0 + be, c1 = a * A.x1[k], c2 = a * A.x2[k], c3 = a * A.x3[k];
        double r = fabs(p0) + fabs(c0) + fabs(c1) + fabs(c2) + fabs(c3);
        double e = aa_fin_up(fabs(a) * A.e[k] + de + U * r);
        o.x0[k] = c0, o.x1[k] = c1, o.x2[k] = c2, o.x3[k] = c3, o.e[k] = e;
        /* the scalar path's other exits: an unbounded operand, an unbounded or
         * flat range, odd n across 0, a slope that is not a number, δ not
         * finite or no tighter than the interval */
        odd_path = A.e[k] <= DBL_MAX ? odd_path : 1;
        odd_path = l >= -DBL_MAX ? odd_path : 1;
        odd_path = h <= DBL_MAX ? odd_path : 1;
        odd_path = h > l ? odd_path : 1;
        odd_path = l < straddle_below ? (h > 0.0 ? 1 : odd_path) : odd_path;
        odd_path = a >= -DBL_MAX ? odd_path : 1;
        odd_path = a <= DBL_MAX ? odd_path : 1;
        odd_path = de <= DBL_MAX ? odd_path : 1;
        odd_path = de >= 0.5 * vh[k] - 0.5 * vl[k] ? 1 : odd_path;
        slow[k] = k_finish(c0, c1, c2, c3, e, vl[k], vh[k], &o.lo[k], &o.hi[k]) | odd_path;
    }
}

/* The pass: the forms of every clause for lanes 0..nl-1 (nl <= B; a multiple of
 * 8 unless smaller, as ilie.c pads it), from the variables' forms var[d][k];
 * the last clause's forms into f[0..nl-1]. */
static void K(ilie_pass)(const tape_t *t, double *S, size_t nl, const aa_t (*var)[ILIE_BATCH],
                  aa_t *f)
{
    int64_t slow[B]; /* lanes as wide as a double: the flags vectorise with the values */
    for (uint32_t i = 0; i < t->n; i++) {
        const tape_clause_t *cl = &t->clauses[i];
        tape_op_t op = (tape_op_t)cl->op;
        int unary = op >= TAPE_NEG && op <= TAPE_ABS;
        int binary = op >= TAPE_ADD && op <= TAPE_MAX;
        /* a malformed tape (operand not before the clause) gets no information
         * rather than a read of an unwritten slot */
        if ((unary || binary) && (cl->a >= i || (binary && cl->b >= i)))
            op = TAPE_OP_COUNT;
        if (!unary && !binary && op > TAPE_Z) /* not an op at all */
            op = TAPE_OP_COUNT;
        uint32_t ia = op != TAPE_OP_COUNT && (unary || binary) ? cl->a : 0;
        uint32_t ib = op != TAPE_OP_COUNT && binary ? cl->b : ia;
        k_slots_t p = k_slots(S, i, ia, ib);
        int fast = 1;
        switch (op) {
        case TAPE_CONST: {
            aa_t c;
            aa_const(&c, cl->c);
            for (size_t k = 0; k < nl; k++)
                k_put(S, i, k, &c);
            continue;
        }
        case TAPE_X:
        case TAPE_Y:
        case TAPE_Z:
            for (size_t k = 0; k < nl; k++)
                k_put(S, i, k, &var[op - TAPE_X][k]);
            continue;
        case TAPE_NEG: k_neg(p, nl); continue;
        case TAPE_ADD: k_add(p, nl, 0, slow); break;
        case TAPE_SUB: k_add(p, nl, 1, slow); break;
        case TAPE_MUL: k_mul(p, nl, slow); break;
        case TAPE_SQR: k_sqr(p, nl, slow); break;
        case TAPE_MIN: k_minmax(p, nl, 0, slow); break;
        case TAPE_MAX: k_minmax(p, nl, 1, slow); break;
        case TAPE_POWI:
            if (cl->c.lo >= 3.0 && cl->c.lo <= 64.0 && cl->c.lo == floor(cl->c.lo))
                k_powi(p, nl, (unsigned)cl->c.lo, slow);
            else
                fast = 0;
            break;
        default: fast = 0; break;
        }
        for (size_t k = 0; k < nl; k++)
            if (!fast || slow[k])
                k_scalar(S, op, cl, i, ia, ib, k);
    }
    for (size_t k = 0; k < nl; k++)
        f[k] = k_get(S, t->n - 1, k);
}

/* ilie_excludes_box over lanes: affine_at's J + Σ a_k (P_k − c_k), the same
 * interval operations in the same order.  affine_at skips a component with
 * a_k = 0; here its term iv_mul([0, 0], X) is exactly [0, 0] and adding it
 * changes no bound but the sign of a zero (which no comparison below sees),
 * unless X is empty (a NaN side or centre): such lanes are left to
 * ilie_excludes_box (code 3).  The ILIEs and boxes are read into arrays first
 * (they are structs), and each interval operation writes arrays that the next
 * loop reads: with two of them in one loop gcc 12 folds one's NaN or zero
 * test into the other's and gives up on the loop (see k_powi). */
static void K(ilie_excludes)(size_t nl, const ilie_t *l, const iv_box_t *box, int64_t *code)
{
    double xl[3][B], xh[3][B], tl[3][B], th[3][B], a[3][B], c[3][B], pl[3][B], ph[3][B];
    double sl[B], sh[B];
    for (size_t k = 0; k < nl; k++) {
        sl[k] = l[k].J.lo, sh[k] = l[k].J.hi;
        const iv_t side[3] = {box[k].x, box[k].y, box[k].z};
        for (int d = 0; d < 3; d++) {
            a[d][k] = l[k].a[d], c[d][k] = l[k].c[d];
            pl[d][k] = side[d].lo, ph[d][k] = side[d].hi;
        }
    }
    for (int d = 0; d < 3; d++) {
        for (size_t k = 0; k < nl; k++) {
            iv_t X = iv_sub(iv_make(pl[d][k], ph[d][k]), iv_point(c[d][k]));
            xl[d][k] = X.lo, xh[d][k] = X.hi;
        }
        for (size_t k = 0; k < nl; k++) {
            iv_t T = iv_mul(iv_point(a[d][k]), iv_make(xl[d][k], xh[d][k]));
            tl[d][k] = T.lo, th[d][k] = T.hi;
        }
        for (size_t k = 0; k < nl; k++) {
            iv_t S = iv_add(iv_make(sl[k], sh[k]), iv_make(tl[d][k], th[d][k]));
            sl[k] = S.lo, sh[k] = S.hi;
        }
    }
    for (size_t k = 0; k < nl; k++) {
        int64_t cd = sh[k] < 0.0 ? -1 : 0;
        cd = sl[k] > 0.0 ? 1 : cd; /* ilie_excludes_box tests the lower end first */
        for (int d = 0; d < 3; d++)
            cd = xl[d][k] != xl[d][k] ? 3 : cd;
        cd = l[k].J.lo != l[k].J.lo ? 2 : cd;
        cd = l[k].J.hi != l[k].J.hi ? 2 : cd;
        code[k] = cd;
    }
}

const ilie_lanes_t K(ilie_lanes) = {KSTR(KERNEL_TARGET), K(ilie_pass), K(ilie_excludes)};
