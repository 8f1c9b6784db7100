/* ivoct — the evaluators' pieces, internal to expr/.
 *
 *   eval.c            workspaces, the public evaluators (tape.h), the SIMD
 *                     dispatch, the ray evaluator
 *   kernels.h         the structure-of-arrays passes over a tape, written once
 *                     in C11 and compiled once per SIMD target by
 *   kernels_<target>.c  (portable, and on x86-64 avx2 and avx512: the same
 *                     source with the target's -m flags, so every path does
 *                     the same IEEE operations in the same order and gives the
 *                     same bits; only the vector width differs)
 *
 * A slot of the structure-of-arrays passes is a set of arrays of
 * TAPE_BATCH doubles, one entry per lane: the point pass has one (the value),
 * the interval pass two (lo, hi), the gradient pass eight (lo, hi of the
 * value and of each partial), the point + gradient pass four (the value and
 * each partial).  Lane counts given to a kernel are multiples
 * of KERNEL_ALIGN (eval.c pads a batch with copies of its first lane), so the
 * lane loops have no scalar remainder, except for batches of fewer lanes,
 * which run as they are. */
#ifndef IVOCT_EVAL_INTERNAL_H
#define IVOCT_EVAL_INTERNAL_H

#include <stddef.h>

#include "tape.h"

#define KERNEL_ALIGN 8

/* The gradient pass's arrays within a slot, in this order. */
enum { G_VLO, G_VHI, G_XLO, G_XHI, G_YLO, G_YHI, G_ZLO, G_ZHI, G_ARRAYS };
/* The ray pass's: the value, the derivative along the direction, the
 * rounding magnitude (tape_eval_ray); fewer than G_ARRAYS, so the ray pass
 * uses the gradient pass's buffer. */
enum { R_VLO, R_VHI, R_DLO, R_DHI, R_MAG, R_ARRAYS };
/* The point + gradient pass's: the value and the three partials, doubles
 * (tape_eval_point_grad); it also uses the gradient pass's buffer. */
enum { P_V, P_X, P_Y, P_Z, P_ARRAYS };

/* Inputs of a pass: for boxes x.lo, x.hi, y.lo, y.hi, z.lo, z.hi; for
 * points x, y, z in the first three. */
typedef const double *const kernel_in_t[6];

typedef struct tape_kernels {
    const char *name; /* the IVOCT_SIMD name */
    /* values into S (slot i at S + i * TAPE_BATCH) */
    void (*point)(const tape_t *t, double *S, size_t nl, kernel_in_t in);
    /* enclosures into LO, HI (slot i at + i * TAPE_BATCH) */
    void (*interval)(const tape_t *t, double *LO, double *HI, size_t nl, kernel_in_t in);
    /* enclosures and gradients into G, t->n + 2 slots: array c of slot i at
     * G + (i * G_ARRAYS + c) * TAPE_BATCH, the value's (c = G_VLO, G_VHI) in
     * slot i itself, partial j's (j = 1, 2, 3: dx, dy, dz) in slot src[3 i + j - 1]
     * (kernels.h says why); deps[i]: the variables clause i depends on (bit 0
     * x, 1 y, 2 z), from tape_deps */
    void (*grad)(const tape_t *t, const uint8_t *deps, double *G, uint32_t *src, size_t nl,
                 kernel_in_t in);
    /* values and partials at points into P (array c of slot i at
     * P + (i * P_ARRAYS + c) * TAPE_BATCH), deps as for grad; points as for
     * point */
    void (*point_grad)(const tape_t *t, const uint8_t *deps, double *P, size_t nl,
                       kernel_in_t in);
    /* along rays: array c of slot i at R + (i * R_ARRAYS + c) * TAPE_BATCH;
     * lane k's box in in, its direction's components in dir_rho[0..2][k] and
     * its rounding radii rho in dir_rho[3..5][k] (see tape_eval_ray) */
    void (*ray)(const tape_t *t, double *R, size_t nl, kernel_in_t in, kernel_in_t dir_rho);
    /* the inputs of a ray pass over lanes T = [tl[k], th[k]] into in (12
     * arrays of TAPE_BATCH: the box, then the direction, then the rounding
     * radii; see tape_eval_ray) */
    void (*ray_inputs)(size_t nl, const double o[3], const double d[3], const double *tl,
                       const double *th, double *in);
    /* Batches of fewer lanes than this go to the point, interval and ray
     * passes padded to exactly this many, which those passes run through a copy
     * compiled for that count (kernels.h, "Short batches"); 0: as they are. */
    size_t short_lanes;
    /* Batches of at most this many lanes (half of short_lanes, where it pays)
     * go padded to exactly this many, through a copy compiled for it; 0: none. */
    size_t short_half;
} tape_kernels_t;

/* deps[i] for every clause of t: bit 0, 1, 2 when clause i depends on x, y,
 * z (so its partial in that variable may be non-zero). */
void tape_deps(const tape_t *t, uint8_t *deps);

extern const tape_kernels_t tape_kernels_portable;
#ifdef IVOCT_SIMD_X86
extern const tape_kernels_t tape_kernels_avx2;
extern const tape_kernels_t tape_kernels_avx512;
#endif

/* ---- forward-mode rules, shared by the gradient kernels and the ray
 * evaluator -------------------------------------------------------------------
 * Each slot carries f and its partials as intervals.  Where an operation is
 * not differentiable (abs at 0, min/max at a tie) the partials enclose every
 * one-sided derivative, which is what the Lipschitz test needs. */

static inline iv_t fm_mul_add(iv_t p, iv_t q, iv_t r, iv_t s)
{
    return iv_add(iv_mul(p, q), iv_mul(r, s));
}

/* an undefined branch makes the result undefined */
static inline iv_t fm_hull_or_empty(iv_t a, iv_t b)
{
    int empty = (int)iv_is_empty(a) | (int)iv_is_empty(b);
    iv_t r = {a.lo < b.lo ? a.lo : b.lo, a.hi > b.hi ? a.hi : b.hi};
    r.lo = empty ? NAN : r.lo;
    r.hi = empty ? NAN : r.hi;
    return r;
}

/* min/max: -1 when a is certainly selected, 1 when b is, 0 when undecided */
static inline int fm_pick_min(iv_t a, iv_t b) { return a.hi <= b.lo ? -1 : b.hi <= a.lo ? 1 : 0; }
static inline int fm_pick_max(iv_t a, iv_t b) { return a.lo >= b.hi ? -1 : b.lo >= a.hi ? 1 : 0; }

/* ---- rounding magnitudes of the ray pass (non-negative bounds, rounded up) */
static inline double mag_of(iv_t a)
{
    /* (one double select per condition: so the lane loops vectorise) */
    double l = fabs(a.lo), h = fabs(a.hi), m = l > h ? l : h;
    m = a.lo != a.lo ? INFINITY : m;
    return a.hi != a.hi ? INFINITY : m;
}
/* x * y rounded up, x, y >= 0; exactly 0 when a factor is 0 (also times +inf:
 * a zero bound means the term is exactly 0, see iv_mul_bound) */
static inline double mag_mul(double x, double y)
{
    double p = iv_up(x * y); /* (selects, not ||: so the lane loops vectorise) */
    p = x == 0 ? 0.0 : p;
    return y == 0 ? 0.0 : p;
}
/* x + y rounded up: iv_add_up (exact when a term is 0), written with one
 * select per condition so that the lane loops vectorise */
static inline double mag_add(double x, double y)
{
    double s = x + y, u = iv_up(s);
    u = x == 0 ? s : u;
    return y == 0 ? s : u;
}
/* x / y rounded up, x, y >= 0; y = 0 (a divisor that may vanish) gives +inf */
static inline double mag_div(double x, double y)
{
    double r = x / y;
    return x == 0 ? 0.0 : r == r ? iv_up(r) : INFINITY;
}
/* A unary op's value over a and an enclosure of its derivative there (over
 * the points where it is differentiable; see interval.h), for the chain
 * rule. */
static inline void fm_unary(tape_op_t op, iv_t c, iv_t a, iv_t *v, iv_t *d)
{
    switch (op) {
    case TAPE_SQR:
        *v = iv_sqr(a), *d = iv_add(a, a);
        break;
    case TAPE_POWI: {
        int n = (int)c.lo;
        *v = iv_powi(a, n), *d = iv_mul(iv_point((double)n), iv_powi(a, n - 1));
        break;
    }
    case TAPE_POWR:
        /* d/dx x^r = r x^r / x, valid for x > 0, where x^r is defined */
        *v = iv_powr(a, c.lo), *d = iv_mul(iv_point(c.lo), iv_div(*v, a));
        break;
    case TAPE_SQRT: *v = iv_sqrt(a), *d = iv_dsqrt(a); break;
    case TAPE_EXP: *v = iv_exp(a), *d = *v; break;
    case TAPE_LOG: *v = iv_log(a), *d = iv_dlog(a); break;
    case TAPE_SIN: *v = iv_sin(a), *d = iv_cos(a); break;
    case TAPE_COS: *v = iv_cos(a), *d = iv_neg(iv_sin(a)); break;
    case TAPE_TAN: *v = iv_tan(a), *d = iv_dtan(a); break;
    case TAPE_ATAN: *v = iv_atan(a), *d = iv_datan(a); break;
    case TAPE_ABS: *v = iv_abs(a), *d = iv_dabs(a); break;
    default: *v = *d = iv_entire(); break;
    }
}

#endif
