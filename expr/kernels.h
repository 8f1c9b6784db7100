/* ivoct — the structure-of-arrays passes over a tape (see eval_internal.h).
 *
 * Included once by each kernels_<target>.c, which defines KERNEL_TARGET and is
 * compiled with that target's flags; everything here is static except the
 * table tape_kernels_<target> (and the short passes where they are compiled
 * apart: KERNEL_SHORT_APART below).  Each clause runs one loop over the lanes; the
 * cheap interval operations (add, sub, mul, sqr, min, max, abs, integer
 * powers) are inline and branch-free, so the compiler vectorises those loops
 * at the target's width; the others call the scalar iv_ functions lane by
 * lane.  Every lane computes exactly what the scalar iv_ operation computes
 * (same operations, same order): the vector width changes nothing but speed. */
#include <string.h>

#include "eval_internal.h"
#include "lanes.h"

#ifndef KERNEL_TARGET
#error "kernels.h is included by kernels_<target>.c, which defines KERNEL_TARGET"
#endif

#define KCAT_(a, b) a##_##b
#define KCAT(a, b) KCAT_(a, b)
#define K(name) KCAT(name, KERNEL_TARGET)
#define KSTR_(a) #a
#define KSTR(a) KSTR_(a)

#define B TAPE_BATCH
_Static_assert(TAPE_BATCH <= IV_LANES_MAX, "lanes.h takes at most IV_LANES_MAX lanes");

/* ---- interval lanes ------------------------------------------------------------ */

/* iv_abs, branch-free (the same bounds). */
static inline iv_t k_abs(iv_t a)
{
    int pos = a.lo >= 0, neg = a.hi <= 0; /* branch-free: no && or || below */
    double top = -a.lo > a.hi ? -a.lo : a.hi;
    iv_t r = {pos ? a.lo : neg ? -a.hi : 0.0, pos ? a.hi : neg ? -a.lo : top};
    int empty = iv_is_empty(a);
    r.lo = empty ? NAN : r.lo;
    r.hi = empty ? NAN : r.hi;
    return r;
}

/* iv_min and iv_max, branch-free (the same bounds). */
static inline iv_t k_min(iv_t a, iv_t b)
{
    int empty = (int)iv_is_empty(a) | (int)iv_is_empty(b);
    iv_t r = {a.lo < b.lo ? a.lo : b.lo, a.hi < b.hi ? a.hi : b.hi};
    r.lo = empty ? NAN : r.lo;
    r.hi = empty ? NAN : r.hi;
    return r;
}

static inline iv_t k_max(iv_t a, iv_t b)
{
    int empty = (int)iv_is_empty(a) | (int)iv_is_empty(b);
    iv_t r = {a.lo > b.lo ? a.lo : b.lo, a.hi > b.hi ? a.hi : b.hi};
    r.lo = empty ? NAN : r.lo;
    r.hi = empty ? NAN : r.hi;
    return r;
}

#define IV(lo, hi, k) iv_make((lo)[k], (hi)[k])

/* Clause j is a constant that is one finite double, in *c: a product by it
 * takes iv_mul_point, the same bits as iv_mul in three fifths of the work. */
static inline int k_point_const(const tape_t *t, uint32_t j, double *c)
{
    const tape_clause_t *k = &t->clauses[j];
    *c = k->c.lo;
    return k->op == TAPE_CONST && k->c.lo == k->c.hi && isfinite(k->c.lo);
}

/* o = c x lane by lane, c finite (iv_mul_point): a loop per sign of c, so
 * that the sign rules are worked out once */
#define LANES_MUL_POINT(s)                                                                   \
    for (size_t k = 0; k < nl; k++) {                                                        \
        iv_t r = iv_mul_point_sign(c, IV(xl, xh, k), s);                                     \
        ol[k] = r.lo, oh[k] = r.hi;                                                          \
    }
static inline void lanes_mul_point(double *restrict ol, double *restrict oh, double c,
                                   const double *xl, const double *xh, size_t nl)
{
    if (c > 0)
        LANES_MUL_POINT(1)
    else if (c < 0)
        LANES_MUL_POINT(-1)
    else
        LANES_MUL_POINT(0)
}

/* a product, by a constant when a factor is one (k_point_const) */
#define LANES_MUL()                                                                          \
    do {                                                                                     \
        double pc_;                                                                          \
        if (k_point_const(t, c->a, &pc_))                                                    \
            lanes_mul_point(ol, oh, pc_, bl, bh, nl);                                        \
        else if (k_point_const(t, c->b, &pc_))                                               \
            lanes_mul_point(ol, oh, pc_, al, ah, nl);                                        \
        else                                                                                 \
            LANES_BINARY(iv_mul);                                                            \
    } while (0)
#define LANES_UNARY(fn)                                                                      \
    for (size_t k = 0; k < nl; k++) {                                                        \
        iv_t r_ = fn(IV(al, ah, k));                                                         \
        ol[k] = r_.lo, oh[k] = r_.hi;                                                        \
    }
#define LANES_BINARY(fn)                                                                     \
    for (size_t k = 0; k < nl; k++) {                                                        \
        iv_t r_ = fn(IV(al, ah, k), IV(bl, bh, k));                                          \
        ol[k] = r_.lo, oh[k] = r_.hi;                                                        \
    }

static inline void K(interval_n)(const tape_t *t, double *LO, double *HI, size_t nl,
                                 kernel_in_t in)
{
    for (uint32_t i = 0; i < t->n; i++) {
        const tape_clause_t *c = &t->clauses[i];
        double *restrict ol = LO + (size_t)i * B, *restrict oh = HI + (size_t)i * B;
        const double *al = LO + (size_t)c->a * B, *ah = HI + (size_t)c->a * B;
        const double *bl = LO + (size_t)c->b * B, *bh = HI + (size_t)c->b * B;
        switch ((tape_op_t)c->op) {
        case TAPE_CONST:
            for (size_t k = 0; k < nl; k++) ol[k] = c->c.lo, oh[k] = c->c.hi;
            break;
        case TAPE_X: memcpy(ol, in[0], nl * sizeof *ol), memcpy(oh, in[1], nl * sizeof *oh); break;
        case TAPE_Y: memcpy(ol, in[2], nl * sizeof *ol), memcpy(oh, in[3], nl * sizeof *oh); break;
        case TAPE_Z: memcpy(ol, in[4], nl * sizeof *ol), memcpy(oh, in[5], nl * sizeof *oh); break;
        case TAPE_NEG: for (size_t k = 0; k < nl; k++) ol[k] = -ah[k], oh[k] = -al[k]; break;
        case TAPE_SQR: LANES_UNARY(iv_sqr); break;
        case TAPE_POWI: {
            int n = (int)c->c.lo;
            if (n >= 3) {
                iv_powi_lanes(al, ah, nl, (unsigned)n, ol, oh);
            } else {
                for (size_t k = 0; k < nl; k++) {
                    iv_t r = iv_powi(IV(al, ah, k), n);
                    ol[k] = r.lo, oh[k] = r.hi;
                }
            }
            break;
        }
        case TAPE_POWR:
            for (size_t k = 0; k < nl; k++) {
                iv_t r = iv_powr(IV(al, ah, k), c->c.lo);
                ol[k] = r.lo, oh[k] = r.hi;
            }
            break;
        case TAPE_SQRT: LANES_UNARY(iv_sqrt); break;
        case TAPE_EXP: LANES_UNARY(iv_exp); break;
        case TAPE_LOG: LANES_UNARY(iv_log); break;
        case TAPE_SIN: LANES_UNARY(iv_sin); break;
        case TAPE_COS: LANES_UNARY(iv_cos); break;
        case TAPE_TAN: LANES_UNARY(iv_tan); break;
        case TAPE_ATAN: LANES_UNARY(iv_atan); break;
        case TAPE_ABS: LANES_UNARY(k_abs); break;
        case TAPE_ADD:
            for (size_t k = 0; k < nl; k++)
                ol[k] = iv_add_down(al[k], bl[k]), oh[k] = iv_add_up(ah[k], bh[k]);
            break;
        case TAPE_SUB:
            for (size_t k = 0; k < nl; k++)
                ol[k] = iv_add_down(al[k], -bh[k]), oh[k] = iv_add_up(ah[k], -bl[k]);
            break;
        case TAPE_MUL: LANES_MUL(); break;
        case TAPE_DIV: LANES_BINARY(iv_div); break;
        case TAPE_MIN: LANES_BINARY(k_min); break;
        case TAPE_MAX: LANES_BINARY(k_max); break;
        case TAPE_OP_COUNT: break;
        }
    }
}

/* ---- point lanes ------------------------------------------------------------------ */

/* x^n by squaring, lanes innermost: much cheaper than pow() for the small
 * exponents of polynomial surfaces, and as accurate for a non-rigorous
 * evaluator */
static inline void k_point_powi(double *restrict o, const double *restrict a, size_t nl, int n)
{
    unsigned m = n < 0 ? 0u - (unsigned)n : (unsigned)n;
    double x[B];
    for (size_t k = 0; k < nl; k++)
        o[k] = 1.0, x[k] = a[k];
    for (; m; m >>= 1) {
        if (m & 1u)
            for (size_t k = 0; k < nl; k++) o[k] *= x[k];
        for (size_t k = 0; k < nl; k++) x[k] *= x[k];
    }
    if (n < 0)
        for (size_t k = 0; k < nl; k++) o[k] = 1.0 / o[k];
}

static inline void K(point_n)(const tape_t *t, double *S, size_t nl, kernel_in_t in)
{
    for (uint32_t i = 0; i < t->n; i++) {
        const tape_clause_t *c = &t->clauses[i];
        double *restrict o = S + (size_t)i * B;
        const double *a = S + (size_t)c->a * B, *b = S + (size_t)c->b * B;
        switch ((tape_op_t)c->op) {
        case TAPE_CONST: {
            double v = iv_mid(c->c);
            for (size_t k = 0; k < nl; k++) o[k] = v;
            break;
        }
        case TAPE_X: memcpy(o, in[0], nl * sizeof *o); break;
        case TAPE_Y: memcpy(o, in[1], nl * sizeof *o); break;
        case TAPE_Z: memcpy(o, in[2], nl * sizeof *o); break;
        case TAPE_NEG: for (size_t k = 0; k < nl; k++) o[k] = -a[k]; break;
        case TAPE_SQR: for (size_t k = 0; k < nl; k++) o[k] = a[k] * a[k]; break;
        case TAPE_POWI: k_point_powi(o, a, nl, (int)c->c.lo); break;
        case TAPE_POWR: for (size_t k = 0; k < nl; k++) o[k] = pow(a[k], c->c.lo); break;
        case TAPE_SQRT: for (size_t k = 0; k < nl; k++) o[k] = sqrt(a[k]); break;
        case TAPE_EXP: for (size_t k = 0; k < nl; k++) o[k] = exp(a[k]); break;
        case TAPE_LOG: for (size_t k = 0; k < nl; k++) o[k] = log(a[k]); break;
        case TAPE_SIN: for (size_t k = 0; k < nl; k++) o[k] = sin(a[k]); break;
        case TAPE_COS: for (size_t k = 0; k < nl; k++) o[k] = cos(a[k]); break;
        case TAPE_TAN: for (size_t k = 0; k < nl; k++) o[k] = tan(a[k]); break;
        case TAPE_ATAN: for (size_t k = 0; k < nl; k++) o[k] = atan(a[k]); break;
        case TAPE_ABS: for (size_t k = 0; k < nl; k++) o[k] = fabs(a[k]); break;
        case TAPE_ADD: for (size_t k = 0; k < nl; k++) o[k] = a[k] + b[k]; break;
        case TAPE_SUB: for (size_t k = 0; k < nl; k++) o[k] = a[k] - b[k]; break;
        case TAPE_MUL: for (size_t k = 0; k < nl; k++) o[k] = a[k] * b[k]; break;
        case TAPE_DIV: for (size_t k = 0; k < nl; k++) o[k] = a[k] / b[k]; break;
        /* NaN (undefined) propagates, unlike fmin/fmax */
        case TAPE_MIN:
            for (size_t k = 0; k < nl; k++) o[k] = a[k] != a[k] ? a[k] : (a[k] < b[k] ? a[k] : b[k]);
            break;
        case TAPE_MAX:
            for (size_t k = 0; k < nl; k++) o[k] = a[k] != a[k] ? a[k] : (a[k] > b[k] ? a[k] : b[k]);
            break;
        case TAPE_OP_COUNT: break;
        }
    }
}

/* ---- interval + gradient lanes ------------------------------------------------------
 * A slot's value lives in its own arrays; each of its partials (component c =
 * 1, 2, 3: dx, dy, dz) in the arrays of component c of the slot src[3 i + c - 1]
 * names: its own when the clause computes it, an operand's when the partial
 * is that operand's unchanged (a sum with an operand that has no such
 * partial, a constant subtracted), the zero slot (just past the tape,
 * zeroed once a pass) when it is exactly [0, 0], and the unit slot (after it,
 * its partials set to 1 once a pass) when it is exactly [1, 1] (a variable's
 * own, and the sums that carry it).  So a sum of terms in other variables (the
 * CSG scenes' spheres) or a constant added copies nothing and writes no zeros.
 * Reading a partial where it lives is reading what a copy would hold.  A
 * factor [1, 1] is skipped: where x' is [1, 1], the chain rule's s x' (s =
 * n x^(n-1) for x^n, 2x for x^2) and the product rule's y x' (x y, c x) are s
 * and y themselves, where iv_mul would widen them by its rounding. */

/* A slot as an operand: p[0] its value's lower bounds, p[c] the lower bounds
 * of its partial c; each upper bound array B doubles after; src its row of
 * src (where its partials live); bit c - 1 of unit set when partial c is
 * exactly [1, 1] (it lives in the unit slot). */
typedef struct gview {
    const double *p[4];
    const uint32_t *src;
    unsigned unit;
} gview_t;

#define GSLOT(G, s) ((G) + (size_t)(s) * G_ARRAYS * B)
#define GLO(p, c) ((p) + (size_t)(2 * (c)) * B)
#define GHI(p, c) ((p) + (size_t)(2 * (c) + 1) * B)

static inline gview_t g_view(const double *G, const uint32_t *src, uint32_t s, uint32_t one)
{
    gview_t v = {{GSLOT(G, s), NULL, NULL, NULL}, src + 3 * (size_t)s, 0};
    for (int c = 1; c < 4; c++) {
        uint32_t at = v.src[c - 1];
        v.p[c] = GLO(GSLOT(G, at), c);
        v.unit |= (unsigned)(at == one) << (c - 1);
    }
    return v;
}

static inline iv_grad_t g_load(const gview_t *g, size_t k)
{
    iv_grad_t r = {{g->p[0][k], g->p[0][k + B]},
                   {g->p[1][k], g->p[1][k + B]},
                   {g->p[2][k], g->p[2][k + B]},
                   {g->p[3][k], g->p[3][k + B]}};
    return r;
}

/* every component into o, slot i's own arrays (src[3 i ..] set by the caller) */
static inline void g_store(double *o, size_t k, iv_grad_t r)
{
    o[G_VLO * B + k] = r.v.lo, o[G_VHI * B + k] = r.v.hi;
    o[G_XLO * B + k] = r.dx.lo, o[G_XHI * B + k] = r.dx.hi;
    o[G_YLO * B + k] = r.dy.lo, o[G_YHI * B + k] = r.dy.hi;
    o[G_ZLO * B + k] = r.dz.lo, o[G_ZHI * B + k] = r.dz.hi;
}

/* value v, gradient s * grad(a) */
static inline iv_grad_t g_scale(iv_t v, iv_t s, iv_grad_t a)
{
    iv_grad_t r = {v, iv_mul(s, a.dx), iv_mul(s, a.dy), iv_mul(s, a.dz)};
    return r;
}

/* (a/b)' = (a' - (a/b) b') / b */
static inline iv_grad_t g_div(iv_grad_t a, iv_grad_t b)
{
    iv_t q = iv_div(a.v, b.v);
    iv_grad_t r = {q, iv_div(iv_sub(a.dx, iv_mul(q, b.dx)), b.v),
                   iv_div(iv_sub(a.dy, iv_mul(q, b.dy)), b.v),
                   iv_div(iv_sub(a.dz, iv_mul(q, b.dz)), b.v)};
    return r;
}

static inline iv_grad_t g_unary(tape_op_t op, iv_t c, iv_grad_t a)
{
    iv_t v, d;
    fm_unary(op, c, a.v, &v, &d);
    return g_scale(v, d, a);
}

/* The cheap ops of the gradient pass run one loop per component (value, dx,
 * dy, dz) over that component's arrays, like the interval pass, so they
 * vectorise; the others go lane by lane through the rules above. */

/* Which partials of a slot can be non-zero: bit c - 1 for component c (dx,
 * dy, dz), from the variables the clause depends on (eval.c,
 * tape_deps).  A partial outside the mask is exactly [0, 0]: it lives in the
 * zero slot, and the rules skip the products and sums with it (a sum with an
 * exact 0 and a product by [0, 0] are exact, up to the sign of a zero). */
#define HAS(mask, c) ((mask) >> ((c) - 1) & 1u)

/* The clause being computed: its own arrays o, its row of src, the slot
 * numbers of itself and of the zero slot. */
typedef struct gout {
    double *o;
    uint32_t *src;
    uint32_t self, zero;
} gout_t;

/* o = a + b, a - b (sign -1), componentwise; ma, mb the operands' masks */
static void g_lanes_add(const gout_t *out, const gview_t *a, const gview_t *b, size_t nl,
                        int sign, unsigned ma, unsigned mb)
{
    for (int c = 0; c < 4; c++) {
        double *restrict ol = GLO(out->o, c), *restrict oh = GHI(out->o, c);
        const double *al = a->p[c], *ah = al + B, *bl = b->p[c], *bh = bl + B;
        if (c > 0 && !(HAS(ma, c) && HAS(mb, c))) {
            if (HAS(ma, c)) {
                out->src[c - 1] = a->src[c - 1];
            } else if (HAS(mb, c) && sign > 0) {
                out->src[c - 1] = b->src[c - 1];
            } else if (HAS(mb, c)) {
                for (size_t k = 0; k < nl; k++) ol[k] = -bh[k], oh[k] = -bl[k];
                out->src[c - 1] = out->self;
            } else {
                out->src[c - 1] = out->zero;
            }
            continue;
        }
        if (sign > 0)
            for (size_t k = 0; k < nl; k++)
                ol[k] = iv_add_down(al[k], bl[k]), oh[k] = iv_add_up(ah[k], bh[k]);
        else
            for (size_t k = 0; k < nl; k++)
                ol[k] = iv_add_down(al[k], -bh[k]), oh[k] = iv_add_up(ah[k], -bl[k]);
        if (c > 0)
            out->src[c - 1] = out->self;
    }
}

/* o = p q lane by lane; q itself when p_unit (p is [1, 1]) */
static void lanes_mul(double *restrict ol, double *restrict oh, const double *pl,
                      const double *ph, const double *ql, const double *qh, int p_unit,
                      size_t nl)
{
    if (p_unit) {
        memcpy(ol, ql, nl * sizeof *ol);
        memcpy(oh, qh, nl * sizeof *oh);
        return;
    }
    for (size_t k = 0; k < nl; k++) {
        iv_t v = iv_mul(IV(pl, ph, k), IV(ql, qh, k));
        ol[k] = v.lo, oh[k] = v.hi;
    }
}

/* the partials of o = s * the partials of a (g_scale; o's value is set by
 * the caller); ma: a's mask */
static void g_lanes_scale(const gout_t *out, const double *sl, const double *sh,
                          const gview_t *a, size_t nl, unsigned ma)
{
    for (int c = 1; c < 4; c++) {
        if (!HAS(ma, c)) {
            out->src[c - 1] = out->zero;
            continue;
        }
        double *ol = GLO(out->o, c), *oh = GHI(out->o, c);
        const double *al = a->p[c], *ah = al + B;
        out->src[c - 1] = out->self;
        if (HAS(a->unit, c))
            lanes_mul(ol, oh, al, ah, sl, sh, 1, nl); /* s itself */
        else
            lanes_mul(ol, oh, sl, sh, al, ah, 0, nl);
    }
}

/* o = p q + r s lane by lane (fm_mul_add: the product rule a' b + a b') in three
 * loops (in one, gcc gives up on vectorising); a factor p or s that is [1, 1]
 * (p_unit, s_unit) is skipped */
static void lanes_mul_add(double *restrict ol, double *restrict oh, const double *pl,
                          const double *ph, const double *ql, const double *qh,
                          const double *rl, const double *rh, const double *sl,
                          const double *sh, int p_unit, int s_unit, size_t nl)
{
    double al[B], ah[B], bl[B], bh[B];
    const double *xl = ql, *xh = qh, *yl = rl, *yh = rh;
    if (!p_unit) {
        lanes_mul(al, ah, pl, ph, ql, qh, 0, nl);
        xl = al, xh = ah;
    }
    if (!s_unit) {
        lanes_mul(bl, bh, rl, rh, sl, sh, 0, nl);
        yl = bl, yh = bh;
    }
    for (size_t k = 0; k < nl; k++)
        ol[k] = iv_add_down(xl[k], yl[k]), oh[k] = iv_add_up(xh[k], yh[k]);
}

/* o = c x, c a finite constant (k_point_const), either factor; mx: x's mask.
 * What g_lanes_mul gives, bit for bit: c's partials are not in any mask, so
 * each partial of x is a single product by c (c itself where it is [1, 1]). */
static void g_lanes_mul_point(const gout_t *out, double c, const gview_t *x, size_t nl,
                              unsigned mx)
{
    for (int j = 1; j < 4; j++) {
        double *restrict ol = GLO(out->o, j), *restrict oh = GHI(out->o, j);
        out->src[j - 1] = out->self;
        if (!HAS(mx, j))
            out->src[j - 1] = out->zero;
        else if (HAS(x->unit, j))
            for (size_t k = 0; k < nl; k++)
                ol[k] = oh[k] = c;
        else
            lanes_mul_point(ol, oh, c, x->p[j], x->p[j] + B, nl);
    }
    lanes_mul_point(GLO(out->o, 0), GHI(out->o, 0), c, x->p[0], x->p[0] + B, nl);
}

/* the product rule (g_mul); a partial of one operand alone is a single
 * product */
static void g_lanes_mul(const gout_t *out, const gview_t *a, const gview_t *b, size_t nl,
                        unsigned ma, unsigned mb)
{
    const double *avl = a->p[0], *avh = avl + B, *bvl = b->p[0], *bvh = bvl + B;
    for (int c = 1; c < 4; c++) {
        double *restrict ol = GLO(out->o, c), *restrict oh = GHI(out->o, c);
        const double *adl = a->p[c], *adh = adl + B, *bdl = b->p[c], *bdh = bdl + B;
        out->src[c - 1] = out->self;
        if (!(HAS(ma, c) && HAS(mb, c))) {
            if (!HAS(ma, c) && !HAS(mb, c)) {
                out->src[c - 1] = out->zero;
                continue;
            }
            /* a' b or a b' (b' = [1, 1]: a itself) */
            if (HAS(ma, c))
                lanes_mul(ol, oh, adl, adh, bvl, bvh, HAS(a->unit, c), nl);
            else if (HAS(b->unit, c))
                lanes_mul(ol, oh, bdl, bdh, avl, avh, 1, nl);
            else
                lanes_mul(ol, oh, avl, avh, bdl, bdh, 0, nl);
            continue;
        }
        lanes_mul_add(ol, oh, adl, adh, bvl, bvh, avl, avh, bdl, bdh, HAS(a->unit, c),
                      HAS(b->unit, c), nl);
    }
    double *restrict ol = GLO(out->o, 0), *restrict oh = GHI(out->o, 0);
    for (size_t k = 0; k < nl; k++) {
        iv_t r = iv_mul(IV(avl, avh, k), IV(bvl, bvh, k));
        ol[k] = r.lo, oh[k] = r.hi;
    }
}

/* x^2 (g_sqr): the value, and 2x times the partials */
static void g_lanes_sqr(const gout_t *out, const gview_t *a, size_t nl, unsigned ma)
{
    const double *avl = a->p[0], *avh = avl + B;
    double sl[B], sh[B];
    for (size_t k = 0; k < nl; k++) {
        iv_t s2 = iv_add(IV(avl, avh, k), IV(avl, avh, k));
        sl[k] = s2.lo, sh[k] = s2.hi;
    }
    g_lanes_scale(out, sl, sh, a, nl, ma);
    double *restrict ol = GLO(out->o, 0), *restrict oh = GHI(out->o, 0);
    for (size_t k = 0; k < nl; k++) {
        iv_t r = iv_sqr(IV(avl, avh, k));
        ol[k] = r.lo, oh[k] = r.hi;
    }
}

/* x^n, n >= 3 (fm_unary's rule): the value, and n x^(n-1) times the partials */
static void g_lanes_powi(const gout_t *out, const gview_t *a, size_t nl, unsigned n,
                         unsigned ma)
{
    const double *avl = a->p[0], *avh = avl + B;
    double sl[B], sh[B];
    if (n - 1 == 2) {
        for (size_t k = 0; k < nl; k++) {
            iv_t r = iv_sqr(IV(avl, avh, k));
            sl[k] = r.lo, sh[k] = r.hi;
        }
    } else {
        iv_powi_lanes(avl, avh, nl, n - 1, sl, sh);
    }
    iv_t nn = iv_point((double)n);
    for (size_t k = 0; k < nl; k++) {
        iv_t r = iv_mul(nn, IV(sl, sh, k));
        sl[k] = r.lo, sh[k] = r.hi;
    }
    g_lanes_scale(out, sl, sh, a, nl, ma);
    iv_powi_lanes(avl, avh, nl, n, GLO(out->o, 0), GHI(out->o, 0));
}

/* min/max a component at a time, so it vectorises: the value, and each partial
 * that of the operand certainly selected (fm_pick_min, fm_pick_max), else the
 * hull of both (empty if either is).  Every component is computed, masks or
 * not: a partial outside its mask may be empty where the value is (g_unary),
 * and the hull keeps that. */
static inline void g_lanes_select(const gout_t *out, const gview_t *a, const gview_t *b,
                                  size_t nl, int is_max)
{
    const double *avl = a->p[0], *avh = avl + B, *bvl = b->p[0], *bvh = bvl + B;
    for (int c = 1; c < 4; c++) {
        double *restrict ol = GLO(out->o, c), *restrict oh = GHI(out->o, c);
        const double *al = a->p[c], *ah = al + B, *bl = b->p[c], *bh = bl + B;
        /* fm_pick_min/max and fm_hull_or_empty's rules, written as flags and
         * selects: through the -1/0/1 of fm_pick the loop runs 15% slower */
        for (size_t k = 0; k < nl; k++) {
            int pa = is_max ? avl[k] >= bvh[k] : avh[k] <= bvl[k]; /* a certainly selected */
            int pb = is_max ? bvl[k] >= avh[k] : bvh[k] <= avl[k];
            int empty = (al[k] != al[k]) | (ah[k] != ah[k]) | (bl[k] != bl[k]) | (bh[k] != bh[k]);
            double hl = al[k] < bl[k] ? al[k] : bl[k], hh = ah[k] > bh[k] ? ah[k] : bh[k];
            hl = empty ? NAN : hl;
            hh = empty ? NAN : hh;
            ol[k] = pa ? al[k] : pb ? bl[k] : hl;
            oh[k] = pa ? ah[k] : pb ? bh[k] : hh;
        }
        out->src[c - 1] = out->self;
    }
    double *restrict ol = GLO(out->o, 0), *restrict oh = GHI(out->o, 0);
    for (size_t k = 0; k < nl; k++) {
        iv_t v = is_max ? k_max(IV(avl, avh, k), IV(bvl, bvh, k))
                        : k_min(IV(avl, avh, k), IV(bvl, bvh, k));
        ol[k] = v.lo, oh[k] = v.hi;
    }
}

/* slot i computed lane by lane, every component its own */
static void g_own(const gout_t *out)
{
    for (int c = 0; c < 3; c++)
        out->src[c] = out->self;
}

/* G holds t->n + 2 slots: the last two are the zero slot and the unit slot.
 * src: 3 t->n entries (see the top of this section). */
static void K(grad)(const tape_t *t, const uint8_t *deps, double *G, uint32_t *src, size_t nl,
                    kernel_in_t in)
{
    const uint32_t zero = t->n, one = t->n + 1;
    for (int j = G_XLO; j < G_ARRAYS; j++) {
        memset(GSLOT(G, zero) + j * B, 0, nl * sizeof *G);
        for (size_t k = 0; k < nl; k++)
            GSLOT(G, one)[j * B + k] = 1.0;
    }
    for (uint32_t i = 0; i < t->n; i++) {
        const tape_clause_t *c = &t->clauses[i];
        double *o = GSLOT(G, i);
        tape_op_t op = (tape_op_t)c->op;
        const int binary = tape_op_arity(op) == 2;
        const gout_t out = {o, src + 3 * (size_t)i, i, zero};
        gview_t a = {{NULL, NULL, NULL, NULL}, NULL, 0}, b = a;
        if (tape_op_arity(op) >= 1)
            a = g_view(G, src, c->a, one);
        if (binary)
            b = g_view(G, src, c->b, one);
        unsigned ma = deps[c->a], mb = binary ? deps[c->b] : 0;
        switch (op) {
        case TAPE_CONST:
            for (size_t k = 0; k < nl; k++)
                o[G_VLO * B + k] = c->c.lo, o[G_VHI * B + k] = c->c.hi;
            for (int j = 0; j < 3; j++)
                out.src[j] = zero;
            break;
        case TAPE_X:
        case TAPE_Y:
        case TAPE_Z: {
            int axis = op - TAPE_X;
            memcpy(o + G_VLO * B, in[2 * axis], nl * sizeof *o);
            memcpy(o + G_VHI * B, in[2 * axis + 1], nl * sizeof *o);
            for (int j = 0; j < 3; j++)
                out.src[j] = j == axis ? one : zero;
            break;
        }
        case TAPE_NEG:
            for (int j = 0; j < 4; j++) {
                if (j > 0 && !HAS(ma, j)) {
                    out.src[j - 1] = zero;
                    continue;
                }
                double *restrict ol = GLO(o, j), *restrict oh = GHI(o, j);
                const double *al = a.p[j], *ah = al + B;
                for (size_t k = 0; k < nl; k++) ol[k] = -ah[k], oh[k] = -al[k];
                if (j > 0)
                    out.src[j - 1] = i;
            }
            break;
        case TAPE_SQR: g_lanes_sqr(&out, &a, nl, ma); break;
        case TAPE_POWI:
            if ((int)c->c.lo >= 3) {
                g_lanes_powi(&out, &a, nl, (unsigned)(int)c->c.lo, ma);
            } else {
                for (size_t k = 0; k < nl; k++)
                    g_store(o, k, g_unary(op, c->c, g_load(&a, k)));
                g_own(&out);
            }
            break;
        case TAPE_ADD: g_lanes_add(&out, &a, &b, nl, 1, ma, mb); break;
        case TAPE_SUB: g_lanes_add(&out, &a, &b, nl, -1, ma, mb); break;
        case TAPE_MUL: {
            double pc;
            if (k_point_const(t, c->a, &pc))
                g_lanes_mul_point(&out, pc, &b, nl, mb);
            else if (k_point_const(t, c->b, &pc))
                g_lanes_mul_point(&out, pc, &a, nl, ma);
            else
                g_lanes_mul(&out, &a, &b, nl, ma, mb);
            break;
        }
        case TAPE_DIV:
            for (size_t k = 0; k < nl; k++)
                g_store(o, k, g_div(g_load(&a, k), g_load(&b, k)));
            g_own(&out);
            break;
        case TAPE_MIN: g_lanes_select(&out, &a, &b, nl, 0); break;
        case TAPE_MAX: g_lanes_select(&out, &a, &b, nl, 1); break;
        case TAPE_OP_COUNT: break;
        default:
            for (size_t k = 0; k < nl; k++)
                g_store(o, k, g_unary(op, c->c, g_load(&a, k)));
            g_own(&out);
            break;
        }
    }
}

/* ---- point + gradient lanes --------------------------------------------------------
 * Forward mode in plain doubles (tape_eval_point_grad): a slot's value and
 * its three partials, P_ARRAYS arrays of lanes.  The value is computed by the
 * point pass's very operations (so it is tape_eval_point's, bit for bit); the
 * partials by the derivative rules of fm_unary and of the gradient pass.  A
 * partial the clause cannot depend on (deps) is written as 0 and skipped in
 * products, so no 0 * inf makes a NaN there. */
#define PA(p, c) ((p) + (size_t)(c) * B)

/* the partials of o = s * the partials of a (the chain rule) */
static void p_lanes_scale(double *o, const double *s, const double *a, size_t nl, unsigned ma)
{
    for (int c = 1; c < 4; c++) {
        double *restrict od = PA(o, c);
        const double *ad = PA(a, c);
        if (!HAS(ma, c)) {
            memset(od, 0, nl * sizeof *od);
            continue;
        }
        for (size_t k = 0; k < nl; k++) od[k] = s[k] * ad[k];
    }
}

/* o = a + b or a - b (sign -1), the value and each partial */
static void p_lanes_add(double *o, const double *a, const double *b, size_t nl, int sign,
                        unsigned ma, unsigned mb)
{
    for (int c = 0; c < 4; c++) {
        double *restrict od = PA(o, c);
        const double *ad = PA(a, c), *bd = PA(b, c);
        int has_a = c == 0 || HAS(ma, c), has_b = c == 0 || HAS(mb, c);
        if (has_a && has_b) {
            if (sign > 0)
                for (size_t k = 0; k < nl; k++) od[k] = ad[k] + bd[k];
            else
                for (size_t k = 0; k < nl; k++) od[k] = ad[k] - bd[k];
        } else if (has_a) {
            memcpy(od, ad, nl * sizeof *od);
        } else if (has_b) {
            if (sign > 0)
                memcpy(od, bd, nl * sizeof *od);
            else
                for (size_t k = 0; k < nl; k++) od[k] = -bd[k];
        } else {
            memset(od, 0, nl * sizeof *od);
        }
    }
}

/* o = a b: the product rule, a partial of one operand alone a single product */
static void p_lanes_mul(double *o, const double *a, const double *b, size_t nl, unsigned ma,
                        unsigned mb)
{
    const double *av = PA(a, 0), *bv = PA(b, 0);
    for (int c = 1; c < 4; c++) {
        double *restrict od = PA(o, c);
        const double *ad = PA(a, c), *bd = PA(b, c);
        if (HAS(ma, c) && HAS(mb, c))
            for (size_t k = 0; k < nl; k++) od[k] = ad[k] * bv[k] + av[k] * bd[k];
        else if (HAS(ma, c))
            for (size_t k = 0; k < nl; k++) od[k] = ad[k] * bv[k];
        else if (HAS(mb, c))
            for (size_t k = 0; k < nl; k++) od[k] = av[k] * bd[k];
        else
            memset(od, 0, nl * sizeof *od);
    }
    double *restrict ov = PA(o, 0);
    for (size_t k = 0; k < nl; k++) ov[k] = av[k] * bv[k];
}

/* o = a / b: (a/b)' = (a' - (a/b) b') / b */
static void p_lanes_div(double *o, const double *a, const double *b, size_t nl, unsigned ma,
                        unsigned mb)
{
    const double *av = PA(a, 0), *bv = PA(b, 0);
    double *restrict ov = PA(o, 0);
    for (size_t k = 0; k < nl; k++) ov[k] = av[k] / bv[k];
    for (int c = 1; c < 4; c++) {
        double *restrict od = PA(o, c);
        const double *ad = PA(a, c), *bd = PA(b, c);
        if (HAS(ma, c) && HAS(mb, c))
            for (size_t k = 0; k < nl; k++) od[k] = (ad[k] - ov[k] * bd[k]) / bv[k];
        else if (HAS(ma, c))
            for (size_t k = 0; k < nl; k++) od[k] = ad[k] / bv[k];
        else if (HAS(mb, c))
            for (size_t k = 0; k < nl; k++) od[k] = -(ov[k] * bd[k]) / bv[k];
        else
            memset(od, 0, nl * sizeof *od);
    }
}

/* min, max: the point pass's value (NaN propagates); the partials of the
 * operand it takes, their mean where the operands tie (the midpoint of the
 * one-sided derivatives the gradient pass hulls there) */
static void p_lanes_minmax(double *o, const double *a, const double *b, size_t nl, int is_min)
{
    const double *av = PA(a, 0), *bv = PA(b, 0);
    double *restrict ov = PA(o, 0);
    signed char pick[B]; /* -1: a, 1: b, 0: tie */
    for (size_t k = 0; k < nl; k++) {
        int a_first = is_min ? av[k] < bv[k] : av[k] > bv[k];
        ov[k] = av[k] != av[k] ? av[k] : a_first ? av[k] : bv[k];
        pick[k] = (signed char)(av[k] != av[k] || a_first ? -1 : av[k] == bv[k] ? 0 : 1);
    }
    for (int c = 1; c < 4; c++) {
        double *restrict od = PA(o, c);
        const double *ad = PA(a, c), *bd = PA(b, c);
        for (size_t k = 0; k < nl; k++)
            od[k] = pick[k] < 0 ? ad[k] : pick[k] > 0 ? bd[k] : 0.5 * (ad[k] + bd[k]);
    }
}

static void K(point_grad)(const tape_t *t, const uint8_t *deps, double *P, size_t nl,
                          kernel_in_t in)
{
    for (uint32_t i = 0; i < t->n; i++) {
        const tape_clause_t *c = &t->clauses[i];
        double *o = P + (size_t)i * P_ARRAYS * B;
        const double *a = P + (size_t)c->a * P_ARRAYS * B, *b = P + (size_t)c->b * P_ARRAYS * B;
        tape_op_t op = (tape_op_t)c->op;
        unsigned ma = deps[c->a], mb = tape_op_arity(op) == 2 ? deps[c->b] : 0;
        double *restrict ov = PA(o, P_V);
        const double *av = PA(a, P_V);
        double s[B]; /* a unary op's derivative, for the chain rule */
        switch (op) {
        case TAPE_CONST: {
            double v = iv_mid(c->c);
            for (size_t k = 0; k < nl; k++) ov[k] = v;
            memset(PA(o, P_X), 0, 3 * B * sizeof *o);
            continue;
        }
        case TAPE_X:
        case TAPE_Y:
        case TAPE_Z: {
            int axis = op - TAPE_X;
            memcpy(ov, in[axis], nl * sizeof *ov);
            for (int j = 0; j < 3; j++) {
                double v = j == axis ? 1.0 : 0.0;
                double *restrict od = PA(o, P_X + j);
                for (size_t k = 0; k < nl; k++) od[k] = v;
            }
            continue;
        }
        case TAPE_NEG:
            for (int j = 0; j < 4; j++) {
                double *restrict od = PA(o, j);
                const double *ad = PA(a, j);
                if (j > 0 && !HAS(ma, j))
                    memset(od, 0, nl * sizeof *od);
                else
                    for (size_t k = 0; k < nl; k++) od[k] = -ad[k];
            }
            continue;
        case TAPE_ADD: p_lanes_add(o, a, b, nl, 1, ma, mb); continue;
        case TAPE_SUB: p_lanes_add(o, a, b, nl, -1, ma, mb); continue;
        case TAPE_MUL: p_lanes_mul(o, a, b, nl, ma, mb); continue;
        case TAPE_DIV: p_lanes_div(o, a, b, nl, ma, mb); continue;
        case TAPE_MIN: p_lanes_minmax(o, a, b, nl, 1); continue;
        case TAPE_MAX: p_lanes_minmax(o, a, b, nl, 0); continue;
        case TAPE_SQR:
            for (size_t k = 0; k < nl; k++) ov[k] = av[k] * av[k], s[k] = av[k] + av[k];
            break;
        case TAPE_POWI: {
            int n = (int)c->c.lo;
            k_point_powi(ov, av, nl, n);
            if (n == 0) {
                memset(s, 0, nl * sizeof *s);
            } else {
                k_point_powi(s, av, nl, n - 1);
                for (size_t k = 0; k < nl; k++) s[k] *= (double)n;
            }
            break;
        }
        case TAPE_POWR:
            for (size_t k = 0; k < nl; k++) ov[k] = pow(av[k], c->c.lo);
            for (size_t k = 0; k < nl; k++) s[k] = c->c.lo * (ov[k] / av[k]);
            break;
        case TAPE_SQRT:
            for (size_t k = 0; k < nl; k++) ov[k] = sqrt(av[k]);
            for (size_t k = 0; k < nl; k++) s[k] = 0.5 / ov[k];
            break;
        case TAPE_EXP:
            for (size_t k = 0; k < nl; k++) ov[k] = s[k] = exp(av[k]);
            break;
        case TAPE_LOG:
            for (size_t k = 0; k < nl; k++) ov[k] = log(av[k]), s[k] = 1.0 / av[k];
            break;
        case TAPE_SIN:
            for (size_t k = 0; k < nl; k++) ov[k] = sin(av[k]), s[k] = cos(av[k]);
            break;
        case TAPE_COS:
            for (size_t k = 0; k < nl; k++) ov[k] = cos(av[k]), s[k] = -sin(av[k]);
            break;
        case TAPE_TAN:
            for (size_t k = 0; k < nl; k++) ov[k] = tan(av[k]), s[k] = 1.0 + ov[k] * ov[k];
            break;
        case TAPE_ATAN:
            for (size_t k = 0; k < nl; k++)
                ov[k] = atan(av[k]), s[k] = 1.0 / (1.0 + av[k] * av[k]);
            break;
        case TAPE_ABS:
            /* at 0 the mean of the one-sided derivatives -1 and 1 */
            for (size_t k = 0; k < nl; k++)
                ov[k] = fabs(av[k]), s[k] = av[k] > 0 ? 1.0 : av[k] < 0 ? -1.0 : 0.0;
            break;
        case TAPE_OP_COUNT: continue;
        }
        p_lanes_scale(o, s, a, nl, ma);
    }
}

/* ---- along rays: value, derivative along the direction, rounding magnitude ------
 * The rules of tape_eval_ray (eval.c, tape.h) lane by lane, each clause one
 * set of lane loops; the cheap operations split into loops that vectorise. */
#define RA(p, c) ((p) + (size_t)(c) * B)

/* Clause j is x, y or z and the direction d is finite (dir_finite): along
 * the ray the clause's derivative is then d's component, the same finite
 * point in every lane (ray_inputs), so a product by it takes iv_mul_point
 * (the same bits as iv_mul) by lane 0's value. */
static inline int r_is_input(const tape_t *t, uint32_t j, int dir_finite)
{
    tape_op_t op = (tape_op_t)t->clauses[j].op;
    return dir_finite && (op == TAPE_X || op == TAPE_Y || op == TAPE_Z);
}

/* o = u(a) along the ray for a unary op u with derivative du (fm_unary's
 * rules), o's value u(a) being set: du * a' and |du| * a's magnitude;
 * a_input: a is x, y or z (r_is_input) */
static void r_lanes_chain(double *o, const double *a, size_t nl, const double *dul,
                          const double *duh, int a_input)
{
    double *restrict dl = RA(o, R_DLO), *restrict dh = RA(o, R_DHI), *restrict m = RA(o, R_MAG);
    const double *adl = RA(a, R_DLO), *adh = RA(a, R_DHI), *am = RA(a, R_MAG);
    if (a_input)
        lanes_mul_point(dl, dh, adl[0], dul, duh, nl);
    else
        for (size_t k = 0; k < nl; k++) {
            iv_t d = iv_mul(IV(dul, duh, k), IV(adl, adh, k));
            dl[k] = d.lo, dh[k] = d.hi;
        }
    for (size_t k = 0; k < nl; k++)
        m[k] = mag_mul(mag_of(IV(dul, duh, k)), am[k]);
}

/* The derivative of a b along the ray, a' b + a b' (lanes_mul_add), with a
 * product by the direction's component where a or b is x, y or z
 * (r_is_input). */
static void r_lanes_product_rule(double *restrict dl, double *restrict dh, const double *a,
                                 const double *b, size_t nl, int a_input, int b_input)
{
    const double *avl = RA(a, R_VLO), *avh = RA(a, R_VHI), *adl = RA(a, R_DLO),
                 *adh = RA(a, R_DHI);
    const double *bvl = RA(b, R_VLO), *bvh = RA(b, R_VHI), *bdl = RA(b, R_DLO),
                 *bdh = RA(b, R_DHI);
    if (!a_input && !b_input) {
        lanes_mul_add(dl, dh, adl, adh, bvl, bvh, avl, avh, bdl, bdh, 0, 0, nl);
        return;
    }
    double xl[B], xh[B], yl[B], yh[B];
    if (a_input)
        lanes_mul_point(xl, xh, adl[0], bvl, bvh, nl);
    else
        lanes_mul(xl, xh, adl, adh, bvl, bvh, 0, nl);
    if (b_input)
        lanes_mul_point(yl, yh, bdl[0], avl, avh, nl);
    else
        lanes_mul(yl, yh, avl, avh, bdl, bdh, 0, nl);
    for (size_t k = 0; k < nl; k++)
        dl[k] = iv_add_down(xl[k], yl[k]), dh[k] = iv_add_up(xh[k], yh[k]);
}

/* x^2 (n = 2) and x^n (n >= 3) along the ray: fm_unary's x^2 (derivative 2x) and x^n
 * (derivative n x^(n-1)) with the interval pass's vector powers */
static void r_lanes_powi(double *o, const double *a, size_t nl, unsigned n, int a_input)
{
    const double *avl = RA(a, R_VLO), *avh = RA(a, R_VHI);
    double *restrict vl = RA(o, R_VLO), *restrict vh = RA(o, R_VHI);
    double sl[B], sh[B];
    if (n == 2) {
        for (size_t k = 0; k < nl; k++) {
            iv_t v = iv_sqr(IV(avl, avh, k)), s2 = iv_add(IV(avl, avh, k), IV(avl, avh, k));
            vl[k] = v.lo, vh[k] = v.hi, sl[k] = s2.lo, sh[k] = s2.hi;
        }
    } else {
        iv_powi_lanes(avl, avh, nl, n, vl, vh);
        if (n - 1 == 2)
            for (size_t k = 0; k < nl; k++) {
                iv_t r = iv_sqr(IV(avl, avh, k));
                sl[k] = r.lo, sh[k] = r.hi;
            }
        else
            iv_powi_lanes(avl, avh, nl, n - 1, sl, sh);
        double pl[B], ph[B];
        memcpy(pl, sl, nl * sizeof *pl);
        memcpy(ph, sh, nl * sizeof *ph);
        lanes_mul_point(sl, sh, (double)n, pl, ph, nl);
    }
    r_lanes_chain(o, a, nl, sl, sh, a_input);
}

/* o = c x along the ray, c a finite constant (k_point_const) of sign s
 * (iv_mul_point_sign), either factor: the general product's bits.  The
 * product rule's other term, c' x = [0, 0] (NaN where x is empty), is added
 * exactly as iv_add_down / iv_add_up add a zero term (0 + y: -0 becomes +0),
 * and likewise the magnitude's. */
static inline void r_lanes_mul_point_sign(double *o, double c, const double *x, size_t nl,
                                          int s)
{
    double *restrict vl = RA(o, R_VLO), *restrict vh = RA(o, R_VHI);
    double *restrict dl = RA(o, R_DLO), *restrict dh = RA(o, R_DHI), *restrict m = RA(o, R_MAG);
    const double *xvl = RA(x, R_VLO), *xvh = RA(x, R_VHI), *xdl = RA(x, R_DLO),
                 *xdh = RA(x, R_DHI), *xm = RA(x, R_MAG);
    const double mc = fabs(c);
    for (size_t k = 0; k < nl; k++) {
        iv_t v = iv_mul_point_sign(c, IV(xvl, xvh, k), s);
        iv_t d = iv_mul_point_sign(c, IV(xdl, xdh, k), s);
        int empty = iv_is_empty(IV(xvl, xvh, k));
        vl[k] = v.lo, vh[k] = v.hi;
        dl[k] = empty ? NAN : 0.0 + d.lo;
        dh[k] = empty ? NAN : 0.0 + d.hi;
        m[k] = 0.0 + mag_mul(mc, xm[k]);
    }
}

static void r_lanes_mul_point(double *o, double c, const double *x, size_t nl)
{
    if (c > 0)
        r_lanes_mul_point_sign(o, c, x, nl, 1);
    else if (c < 0)
        r_lanes_mul_point_sign(o, c, x, nl, -1);
    else
        r_lanes_mul_point_sign(o, c, x, nl, 0);
}

/* o = a + b (add) or a - b along the ray; inlined with add constant, so
 * that the lane loops have no select on it */
static inline void r_lanes_add(double *o, const double *a, const double *b, size_t nl, int add)
{
    double *restrict vl = RA(o, R_VLO), *restrict vh = RA(o, R_VHI);
    double *restrict dl = RA(o, R_DLO), *restrict dh = RA(o, R_DHI), *restrict m = RA(o, R_MAG);
    const double *avl = RA(a, R_VLO), *avh = RA(a, R_VHI), *adl = RA(a, R_DLO),
                 *adh = RA(a, R_DHI), *am = RA(a, R_MAG);
    const double *bvl = RA(b, R_VLO), *bvh = RA(b, R_VHI), *bdl = RA(b, R_DLO),
                 *bdh = RA(b, R_DHI), *bm = RA(b, R_MAG);
    for (size_t k = 0; k < nl; k++) {
        iv_t v = add ? iv_add(IV(avl, avh, k), IV(bvl, bvh, k))
                     : iv_sub(IV(avl, avh, k), IV(bvl, bvh, k));
        vl[k] = v.lo, vh[k] = v.hi;
    }
    for (size_t k = 0; k < nl; k++) {
        iv_t d = add ? iv_add(IV(adl, adh, k), IV(bdl, bdh, k))
                     : iv_sub(IV(adl, adh, k), IV(bdl, bdh, k));
        dl[k] = d.lo, dh[k] = d.hi;
    }
    for (size_t k = 0; k < nl; k++)
        m[k] = mag_add(am[k], bm[k]);
}

static inline void K(ray_n)(const tape_t *t, double *R, size_t nl, kernel_in_t in,
                            kernel_in_t dir_rho)
{
    /* (every lane has the same d: ray_inputs) */
    const int dir_finite = nl > 0 && isfinite(dir_rho[0][0]) && isfinite(dir_rho[1][0]) &&
                           isfinite(dir_rho[2][0]);
    for (uint32_t i = 0; i < t->n; i++) {
        const tape_clause_t *c = &t->clauses[i];
        double *o = R + (size_t)i * R_ARRAYS * B;
        const double *a = R + (size_t)c->a * R_ARRAYS * B, *b = R + (size_t)c->b * R_ARRAYS * B;
        double *restrict vl = RA(o, R_VLO), *restrict vh = RA(o, R_VHI);
        double *restrict dl = RA(o, R_DLO), *restrict dh = RA(o, R_DHI);
        double *restrict m = RA(o, R_MAG);
        const double *avl = RA(a, R_VLO), *avh = RA(a, R_VHI), *adl = RA(a, R_DLO),
                     *adh = RA(a, R_DHI), *am = RA(a, R_MAG);
        const double *bvl = RA(b, R_VLO), *bvh = RA(b, R_VHI), *bdl = RA(b, R_DLO),
                     *bdh = RA(b, R_DHI), *bm = RA(b, R_MAG);
        tape_op_t op = (tape_op_t)c->op;
        switch (op) {
        case TAPE_CONST:
            for (size_t k = 0; k < nl; k++)
                vl[k] = c->c.lo, vh[k] = c->c.hi, dl[k] = dh[k] = 0.0, m[k] = 0.0;
            break;
        case TAPE_X:
        case TAPE_Y:
        case TAPE_Z: {
            int axis = op - TAPE_X;
            memcpy(vl, in[2 * axis], nl * sizeof *vl);
            memcpy(vh, in[2 * axis + 1], nl * sizeof *vh);
            memcpy(dl, dir_rho[axis], nl * sizeof *dl);
            memcpy(dh, dir_rho[axis], nl * sizeof *dh);
            memcpy(m, dir_rho[3 + axis], nl * sizeof *m);
            break;
        }
        case TAPE_NEG:
            for (size_t k = 0; k < nl; k++) {
                iv_t v = iv_neg(IV(avl, avh, k)), d = iv_neg(IV(adl, adh, k));
                vl[k] = v.lo, vh[k] = v.hi, dl[k] = d.lo, dh[k] = d.hi, m[k] = am[k];
            }
            break;
        case TAPE_ADD: r_lanes_add(o, a, b, nl, 1); break;
        case TAPE_SUB: r_lanes_add(o, a, b, nl, 0); break;
        case TAPE_MUL: {
            double pc;
            if (k_point_const(t, c->a, &pc)) {
                r_lanes_mul_point(o, pc, b, nl);
                break;
            }
            if (k_point_const(t, c->b, &pc)) {
                r_lanes_mul_point(o, pc, a, nl);
                break;
            }
            for (size_t k = 0; k < nl; k++) {
                iv_t v = iv_mul(IV(avl, avh, k), IV(bvl, bvh, k));
                vl[k] = v.lo, vh[k] = v.hi;
            }
            r_lanes_product_rule(dl, dh, a, b, nl, r_is_input(t, c->a, dir_finite),
                                 r_is_input(t, c->b, dir_finite));
            for (size_t k = 0; k < nl; k++)
                m[k] = mag_add(mag_mul(am[k], mag_of(IV(bvl, bvh, k))),
                               mag_mul(mag_of(IV(avl, avh, k)), bm[k]));
            break;
        }
        case TAPE_DIV:
            /* (a/b)' = (a' - (a/b) b') / b, and its bound over |b| >= mig(b) */
            for (size_t k = 0; k < nl; k++) {
                iv_t bv = IV(bvl, bvh, k);
                iv_t q = iv_div(IV(avl, avh, k), bv);
                iv_t d = iv_div(iv_sub(IV(adl, adh, k), iv_mul(q, IV(bdl, bdh, k))), bv);
                double mig = bv.lo > 0 ? bv.lo : bv.hi < 0 ? -bv.hi : 0.0;
                vl[k] = q.lo, vh[k] = q.hi, dl[k] = d.lo, dh[k] = d.hi;
                m[k] = mag_div(iv_add_up(am[k], mag_mul(mag_of(q), bm[k])), mig);
            }
            break;
        case TAPE_MIN:
        case TAPE_MAX:
            /* the branch certainly selected carries its derivative, else the hull */
            for (size_t k = 0; k < nl; k++) {
                iv_t av = IV(avl, avh, k), bv = IV(bvl, bvh, k);
                iv_t ad = IV(adl, adh, k), bd = IV(bdl, bdh, k);
                int pick = op == TAPE_MIN ? fm_pick_min(av, bv) : fm_pick_max(av, bv);
                iv_t v = op == TAPE_MIN ? iv_min(av, bv) : iv_max(av, bv);
                iv_t d = pick < 0 ? ad : pick > 0 ? bd : fm_hull_or_empty(ad, bd);
                vl[k] = v.lo, vh[k] = v.hi, dl[k] = d.lo, dh[k] = d.hi;
                m[k] = pick < 0 ? am[k] : pick > 0 ? bm[k] : am[k] > bm[k] ? am[k] : bm[k];
            }
            break;
        case TAPE_SQR: r_lanes_powi(o, a, nl, 2, r_is_input(t, c->a, dir_finite)); break;
        case TAPE_OP_COUNT: break;
        default:
            if (op == TAPE_POWI && (int)c->c.lo >= 3) {
                r_lanes_powi(o, a, nl, (unsigned)(int)c->c.lo,
                             r_is_input(t, c->a, dir_finite));
                break;
            }
            for (size_t k = 0; k < nl; k++) {
                iv_t u, du;
                fm_unary(op, c->c, IV(avl, avh, k), &u, &du);
                iv_t d = iv_mul(du, IV(adl, adh, k));
                vl[k] = u.lo, vh[k] = u.hi, dl[k] = d.lo, dh[k] = d.hi;
                m[k] = mag_mul(mag_of(du), am[k]);
            }
            break;
        }
    }
}

/* The inputs of a ray pass (tape_eval_ray, tape.h): lane k's box is the
 * rounded point p~(t) when tl[k] = th[k], else o + T·d enclosed and hulled
 * with p~(tl[k]) and p~(th[k]) (fl(o + fl(t·d)) is monotone in t, so every
 * rounded point of T lies between those); the direction; and the rounding
 * radii rho_i = 2^-51 (|o_i| + 2 max|T| |d_i|), rounded up: twice the largest
 * displacement of a rounded point from the ray over T (two roundings of at
 * most 2^-53 relative each).  The rounded points are tape_ray_point's, its
 * two roundings written out lane by lane. */
static inline void K(ray_inputs_n)(size_t nl, const double o[3], const double d[3],
                                   const double *tl, const double *th, double *in)
{
    double ov[B], dv[B], sl[B], sh[B];
    for (int i = 0; i < 3; i++) {
        double *restrict lo = in + (size_t)(2 * i) * B, *restrict hi = lo + B;
        double *restrict dir = in + (size_t)(6 + i) * B, *restrict rho = in + (size_t)(9 + i) * B;
        const double oi = o[i], di = d[i];
        /* (o and d as arrays, the product and the sum in loops apart: else
         * gcc vectorises neither) */
        for (size_t k = 0; k < nl; k++)
            ov[k] = oi, dv[k] = di;
        if (isfinite(di))
            lanes_mul_point(sl, sh, di, tl, th, nl);
        else
            for (size_t k = 0; k < nl; k++) {
                iv_t s = iv_mul(IV(tl, th, k), IV(dv, dv, k));
                sl[k] = s.lo, sh[k] = s.hi;
            }
        for (size_t k = 0; k < nl; k++) {
            iv_t s = iv_add(IV(ov, ov, k), IV(sl, sh, k));
            sl[k] = s.lo, sh[k] = s.hi;
        }
        for (size_t k = 0; k < nl; k++) {
            double sa = tl[k] * di, sb = th[k] * di; /* tape_ray_point's two roundings */
            double pa = oi + sa, pb = oi + sb;
            iv_t s = iv_make(sl[k], sh[k]);
            double l = pa < pb ? pa : pb, h = pa < pb ? pb : pa;
            l = s.lo < l ? s.lo : l;
            h = s.hi > h ? s.hi : h;
            int point = tl[k] == th[k];
            lo[k] = point ? pa : l;
            hi[k] = point ? pa : h;
        }
        for (size_t k = 0; k < nl; k++) {
            double a = fabs(tl[k]), b = fabs(th[k]), tmax = a > b ? a : b;
            dir[k] = di;
            rho[k] = iv_up(iv_up(fabs(oi) + iv_up(2.0 * tmax * fabs(di))) * 0x1p-51);
        }
    }
}

/* ---- short batches ------------------------------------------------------------------
 * A ray's search asks for 1 to 8 lanes at a time.  Through the passes above,
 * a few lanes run every lane loop's checks and scalar remainder, once per
 * clause and array: most of such a pass.  So on the paths whose
 * KERNEL_SHORT_LANES is not 0 (kernels_<target>.c: where it was measured to pay), the
 * point, interval and ray passes also exist compiled for exactly that many lanes
 * with every helper inlined (flatten), which turns each lane loop into a few
 * vector instructions, and eval.c pads a shorter batch to that count
 * (tape_kernels_t.short_lanes): the lanes are independent, so the padding
 * changes no lane's bits.  (gcc must not unroll those loops into scalar code
 * before vectorising them: expr/CMakeLists.txt.) */
#ifndef KERNEL_SHORT_LANES
#error "kernels_<target>.c defines KERNEL_SHORT_LANES: 0 or KERNEL_ALIGN (see tape_kernels_t)"
#endif
/* The short passes compiled apart: KERNEL_SHORT_APART (kernels_<target>.c) says
 * that they are defined, with external linkage, in a unit of their own,
 * kernels_<target>short.c, which defines KERNEL_SHORT_UNIT too and gets only
 * them.  That unit is compiled with the flag that keeps gcc from unrolling
 * their 4- and 8-iteration loops into scalar code (expr/CMakeLists.txt), and the
 * general passes are not: on avx2 the flag made the 64-lane point pass 1.3x
 * slower (chubs).  Otherwise they are static, here. */
#ifndef KERNEL_SHORT_APART
#define KERNEL_SHORT_APART 0
#endif
#ifndef KERNEL_SHORT_UNIT
#define KERNEL_SHORT_UNIT 0
#endif
#if KERNEL_SHORT_UNIT && !KERNEL_SHORT_APART
#error "kernels_<target>short.c defines KERNEL_SHORT_APART too"
#endif
#if KERNEL_SHORT_APART
#define KERNEL_SHORT_LINKAGE
#else
#define KERNEL_SHORT_LINKAGE static
#endif
/* Here: the short passes' bodies (else only their declarations). */
#define KERNEL_SHORT_HERE (!KERNEL_SHORT_APART || KERNEL_SHORT_UNIT)
#if defined(__GNUC__)
#define KERNEL_FLATTEN __attribute__((flatten))
#else
#define KERNEL_FLATTEN
#endif
#if KERNEL_SHORT_LANES
#if KERNEL_SHORT_APART
void K(point_short)(const tape_t *t, double *S, kernel_in_t in);
void K(interval_short)(const tape_t *t, double *LO, double *HI, kernel_in_t in);
void K(ray_short)(const tape_t *t, double *R, kernel_in_t in, kernel_in_t dir_rho);
void K(ray_inputs_short)(const double o[3], const double d[3], const double *tl,
                         const double *th, double *in);
#endif
#if KERNEL_SHORT_HERE

KERNEL_FLATTEN KERNEL_SHORT_LINKAGE void
K(point_short)(const tape_t *t, double *S, kernel_in_t in)
{
    K(point_n)(t, S, KERNEL_SHORT_LANES, in);
}

KERNEL_FLATTEN KERNEL_SHORT_LINKAGE void
K(interval_short)(const tape_t *t, double *LO, double *HI, kernel_in_t in)
{
    K(interval_n)(t, LO, HI, KERNEL_SHORT_LANES, in);
}

KERNEL_FLATTEN KERNEL_SHORT_LINKAGE void
K(ray_short)(const tape_t *t, double *R, kernel_in_t in, kernel_in_t dir_rho)
{
    K(ray_n)(t, R, KERNEL_SHORT_LANES, in, dir_rho);
}

KERNEL_FLATTEN KERNEL_SHORT_LINKAGE void
K(ray_inputs_short)(const double o[3], const double d[3],
                    const double *tl, const double *th, double *in)
{
    K(ray_inputs_n)(KERNEL_SHORT_LANES, o, d, tl, th, in);
}
#endif /* KERNEL_SHORT_HERE */
#endif /* KERNEL_SHORT_LANES */

/* Half a short batch.  Where KERNEL_SHORT_HALF is not 0 (kernels_avx512.c,
 * kernels_avx2.c), the same passes also exist for exactly that many lanes, and
 * eval.c pads a batch of at most that many to it: on avx2 one 256-bit vector
 * instead of two; on avx512 half a vector, which a CPU that runs a 512-bit
 * operation as two 256-bit halves (AMD's Zen 4) runs in less time than the
 * whole one (three quarters, measured: expr/README.md).  The lanes are
 * independent: the bits are the same. */
#ifndef KERNEL_SHORT_HALF
#error "kernels_<target>.c defines KERNEL_SHORT_HALF: 0 or half of KERNEL_SHORT_LANES"
#endif
#if KERNEL_SHORT_HALF
#if KERNEL_SHORT_APART
void K(point_half)(const tape_t *t, double *S, kernel_in_t in);
void K(interval_half)(const tape_t *t, double *LO, double *HI, kernel_in_t in);
void K(ray_half)(const tape_t *t, double *R, kernel_in_t in, kernel_in_t dir_rho);
void K(ray_inputs_half)(const double o[3], const double d[3], const double *tl,
                        const double *th, double *in);
#endif
#if KERNEL_SHORT_HERE
KERNEL_FLATTEN KERNEL_SHORT_LINKAGE void
K(point_half)(const tape_t *t, double *S, kernel_in_t in)
{
    K(point_n)(t, S, KERNEL_SHORT_HALF, in);
}

KERNEL_FLATTEN KERNEL_SHORT_LINKAGE void
K(interval_half)(const tape_t *t, double *LO, double *HI, kernel_in_t in)
{
    K(interval_n)(t, LO, HI, KERNEL_SHORT_HALF, in);
}

KERNEL_FLATTEN KERNEL_SHORT_LINKAGE void
K(ray_half)(const tape_t *t, double *R, kernel_in_t in, kernel_in_t dir_rho)
{
    K(ray_n)(t, R, KERNEL_SHORT_HALF, in, dir_rho);
}

KERNEL_FLATTEN KERNEL_SHORT_LINKAGE void
K(ray_inputs_half)(const double o[3], const double d[3],
                   const double *tl, const double *th, double *in)
{
    K(ray_inputs_n)(KERNEL_SHORT_HALF, o, d, tl, th, in);
}
#endif /* KERNEL_SHORT_HERE */
#endif /* KERNEL_SHORT_HALF */

#if !KERNEL_SHORT_UNIT /* the short unit has the short passes only */

static void K(point)(const tape_t *t, double *S, size_t nl, kernel_in_t in)
{
#if KERNEL_SHORT_HALF
    if (nl == KERNEL_SHORT_HALF) {
        K(point_half)(t, S, in);
        return;
    }
#endif
#if KERNEL_SHORT_LANES
    if (nl == KERNEL_SHORT_LANES) {
        K(point_short)(t, S, in);
        return;
    }
#endif
    K(point_n)(t, S, nl, in);
}

static void K(interval)(const tape_t *t, double *LO, double *HI, size_t nl, kernel_in_t in)
{
#if KERNEL_SHORT_HALF
    if (nl == KERNEL_SHORT_HALF) {
        K(interval_half)(t, LO, HI, in);
        return;
    }
#endif
#if KERNEL_SHORT_LANES
    if (nl == KERNEL_SHORT_LANES) {
        K(interval_short)(t, LO, HI, in);
        return;
    }
#endif
    K(interval_n)(t, LO, HI, nl, in);
}

static void K(ray)(const tape_t *t, double *R, size_t nl, kernel_in_t in, kernel_in_t dir_rho)
{
#if KERNEL_SHORT_HALF
    if (nl == KERNEL_SHORT_HALF) {
        K(ray_half)(t, R, in, dir_rho);
        return;
    }
#endif
#if KERNEL_SHORT_LANES
    if (nl == KERNEL_SHORT_LANES) {
        K(ray_short)(t, R, in, dir_rho);
        return;
    }
#endif
    K(ray_n)(t, R, nl, in, dir_rho);
}

static void K(ray_inputs)(size_t nl, const double o[3], const double d[3], const double *tl,
                          const double *th, double *in)
{
#if KERNEL_SHORT_HALF
    if (nl == KERNEL_SHORT_HALF) {
        K(ray_inputs_half)(o, d, tl, th, in);
        return;
    }
#endif
#if KERNEL_SHORT_LANES
    if (nl == KERNEL_SHORT_LANES) {
        K(ray_inputs_short)(o, d, tl, th, in);
        return;
    }
#endif
    K(ray_inputs_n)(nl, o, d, tl, th, in);
}

const tape_kernels_t K(tape_kernels) = {KSTR(KERNEL_TARGET), K(point),      K(interval),
                                        K(grad),             K(point_grad), K(ray),
                                        K(ray_inputs),       KERNEL_SHORT_LANES,
                                        KERNEL_SHORT_HALF};
#endif /* !KERNEL_SHORT_UNIT */
