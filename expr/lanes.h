/* ivoct — lane loops shared by the structure-of-arrays passes (C only).
 *
 * Interval operations over arrays of lanes, lanes innermost, that compute for
 * every lane exactly the bounds the scalar iv_ operation of interval.h
 * computes (the same IEEE operations in the same order), written so that the
 * loops vectorise.  They are static inline: each pass (expr/kernels.h,
 * ilie/affine_kernels.h) compiles them once per SIMD path at that path's
 * width.  At most IV_LANES_MAX lanes per call. */
#ifndef IVOCT_EXPR_LANES_H
#define IVOCT_EXPR_LANES_H

#include <math.h>
#include <stddef.h>

#include "interval.h"

#define IV_LANES_MAX 64

static inline double iv_lanes_dn0(double x) /* iv_down of a value known to be >= 0 */
{
    double y = iv_down(x);
    return y < 0.0 ? 0.0 : y;
}

/* m^e (m >= 0, e >= 1) rounded down (up = 0) or up (up = 1) for lanes 0..nl-1:
 * the binary exponentiation of interval.c (pow_dn, pow_up) with the lanes
 * innermost, the same products in the same order, so the same bounds.  m is
 * only read (its first nl lanes); it is not const because gcc 12 takes a const
 * pointer to a local array written for nl lanes as a read of the whole array
 * (-Wmaybe-uninitialized), and zeroing the array for it cost every pass. */
static inline void iv_pow_bound_lanes(double *restrict m, size_t nl, unsigned e, int up,
                                      double *restrict out)
{
    double base[IV_LANES_MAX];
    for (size_t k = 0; k < nl; k++)
        out[k] = 1.0, base[k] = m[k];
    for (;;) {
        if (e & 1u) {
            if (up)
                for (size_t k = 0; k < nl; k++)
                    out[k] = iv_up(out[k] * base[k]);
            else
                for (size_t k = 0; k < nl; k++)
                    out[k] = iv_lanes_dn0(out[k] * base[k]);
        }
        e >>= 1;
        if (e == 0)
            break;
        if (up)
            for (size_t k = 0; k < nl; k++)
                base[k] = iv_up(base[k] * base[k]);
        else
            for (size_t k = 0; k < nl; k++)
                base[k] = iv_lanes_dn0(base[k] * base[k]);
    }
    for (size_t k = 0; k < nl; k++)
        out[k] = m[k] == 0.0 ? 0.0 : out[k];
}

/* iv_pow_bound_lanes with the direction per lane: rounded up where up[k] is
 * 1.0, down where it is -1.0, the same bits.  The product is formed once and
 * moved by up[k] times the widening (iv_up adds it, iv_down subtracts it:
 * exact, the widening being positive), instead of two passes each with its
 * own products: an odd power needs one direction per bound and lane. */
static inline double iv_lanes_round_dir(double p, double up) /* p >= 0 or NaN */
{
    double y = p + up * (fabs(p) * 0x1p-52 + 0x1p-1074);
    double dn = p == INFINITY ? DBL_MAX : y < 0.0 ? 0.0 : y;
    return up > 0.0 ? y : dn; /* iv_up(p), or iv_lanes_dn0(p) */
}
static inline void iv_pow_bound_lanes_dir(double *restrict m, size_t nl, unsigned e,
                                          const double *restrict up, double *restrict out)
{
    double base[IV_LANES_MAX];
    for (size_t k = 0; k < nl; k++)
        out[k] = 1.0, base[k] = m[k];
    for (;;) {
        if (e & 1u)
            for (size_t k = 0; k < nl; k++)
                out[k] = iv_lanes_round_dir(out[k] * base[k], up[k]);
        e >>= 1;
        if (e == 0)
            break;
        for (size_t k = 0; k < nl; k++)
            base[k] = iv_lanes_round_dir(base[k] * base[k], up[k]);
    }
    for (size_t k = 0; k < nl; k++)
        out[k] = m[k] == 0.0 ? 0.0 : out[k];
}

/* iv_powi([al, ah], e) for e >= 3 into [ol, oh], lanes 0..nl-1: odd powers are
 * increasing (the bounds' magnitudes, each raised in the direction its sign
 * needs), even ones monotone in |x| (the magnitudes' range); interval.c,
 * powi_pos.  Empty lanes (NaN) stay empty. */
static inline void iv_powi_lanes(const double *restrict al, const double *restrict ah,
                                 size_t nl, unsigned e, double *restrict ol,
                                 double *restrict oh)
{
    const int odd = e & 1u;
    double ml[IV_LANES_MAX], mh[IV_LANES_MAX], dl[IV_LANES_MAX], uh[IV_LANES_MAX];
    for (size_t k = 0; k < nl; k++) {
        int pos = al[k] >= 0.0, neg = ah[k] <= 0.0;
        double top = -al[k] > ah[k] ? -al[k] : ah[k];
        ml[k] = odd ? fabs(al[k]) : pos ? al[k] : neg ? -ah[k] : 0.0;
        mh[k] = odd ? fabs(ah[k]) : pos ? ah[k] : neg ? -al[k] : top;
    }
    /* an even power's bounds are ml^e down and mh^e up; an odd one's take the
     * other direction where a bound is negative (-|a|^e rounded the other
     * way), one pass per bound with the direction per lane */
    if (odd) {
        double sl[IV_LANES_MAX], sh[IV_LANES_MAX];
        for (size_t k = 0; k < nl; k++) {
            sl[k] = al[k] < 0.0 ? 1.0 : -1.0;
            sh[k] = ah[k] < 0.0 ? -1.0 : 1.0;
        }
        iv_pow_bound_lanes_dir(ml, nl, e, sl, dl);
        iv_pow_bound_lanes_dir(mh, nl, e, sh, uh);
        for (size_t k = 0; k < nl; k++) {
            dl[k] = al[k] < 0.0 ? -dl[k] : dl[k];
            uh[k] = ah[k] < 0.0 ? -uh[k] : uh[k];
        }
    } else {
        iv_pow_bound_lanes(ml, nl, e, 0, dl);
        iv_pow_bound_lanes(mh, nl, e, 1, uh);
    }
    for (size_t k = 0; k < nl; k++) {
        int empty = (al[k] != al[k]) | (ah[k] != ah[k]);
        ol[k] = empty ? NAN : dl[k];
        oh[k] = empty ? NAN : uh[k];
    }
}

#endif
