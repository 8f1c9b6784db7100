/* ivoct — ILIE: the tape evaluated in affine arithmetic per cell, and the
 * queries on the result (see ilie.h and README.md). */
#include "ilie.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "affine.h"

#define U 0x1p-53

struct ilie_ws {
    uint32_t cap; /* clauses */
    double *S;    /* cap slots of the affine pass (affine.h) */
};

static size_t slots_bytes(uint32_t clauses)
{
    return (size_t)clauses * A_ARRAYS * ILIE_BATCH * sizeof(double);
}

static double *slots_new(uint32_t clauses) { return malloc(slots_bytes(clauses)); }

size_t ilie_ws_bytes(uint32_t max_clauses)
{
    return sizeof(struct ilie_ws) + slots_bytes(max_clauses ? max_clauses : 1);
}

ilie_ws_t *ilie_ws_new(uint32_t max_clauses)
{
    ilie_ws_t *ws = malloc(sizeof *ws);
    if (!ws)
        return NULL;
    ws->cap = max_clauses ? max_clauses : 1;
    ws->S = slots_new(ws->cap);
    if (!ws->S) {
        free(ws);
        return NULL;
    }
    return ws;
}

void ilie_ws_free(ilie_ws_t *ws)
{
    if (!ws)
        return;
    free(ws->S);
    free(ws);
}

static int reserve(ilie_ws_t *ws, uint32_t n)
{
    if (n <= ws->cap)
        return 0;
    double *S = slots_new(n);
    if (!S)
        return -1;
    free(ws->S);
    ws->S = S;
    ws->cap = n;
    return 0;
}

/* The lane functions of the SIMD path in use (expr/'s choice, tape_simd_name). */
static const ilie_lanes_t *lanes_in_use(void)
{
#ifdef IVOCT_SIMD_X86
    const char *name = tape_simd_name();
    if (!strcmp(name, ilie_lanes_avx512.name))
        return &ilie_lanes_avx512;
    if (!strcmp(name, ilie_lanes_avx2.name))
        return &ilie_lanes_avx2;
#endif
    return &ilie_lanes_portable;
}

/* Centre and noise radius of a cell side: c the rounded midpoint (inside
 * [lo, hi] since rounding is monotone), r >= max(c − lo, hi − c) exactly:
 * a rounded difference is 0 only when it is exactly 0, else pushed up. */
static void frame(iv_t b, double *c, double *r)
{
    if (!(b.lo <= b.hi && b.lo >= -DBL_MAX && b.hi <= DBL_MAX)) {
        *c = 0.0;
        *r = 0.0;
        return;
    }
    *c = 0.5 * b.lo + 0.5 * b.hi;
    double d = fmax(*c - b.lo, b.hi - *c);
    *r = d > 0.0 ? iv_up(d) : 0.0;
    if (!(*r <= DBL_MAX))
        *r = 0.0;
}

static void set_no_info(ilie_t *l, iv_t J)
{
    for (int k = 0; k < 3; k++)
        l->a[k] = 0.0;
    l->J = J;
}

/* From the form f0 + Σ fk εk + e η with εk = (p_k − c_k)/r_k to
 * a·(p − c) + J: a_k = fk/r_k rounded, a normal double, so the rounding
 * |fk/r_k − a_k| <= u|a_k|, times |p_k − c_k| <= r_k, goes into J.  A side
 * with r_k = 0, or a quotient that overflows or is subnormal, keeps fk εk in J
 * (|εk| <= 1).  (No product here may round to a subnormal: that costs a
 * microcode assist of ~100 cycles on x86.) */
static void to_ilie(const aa_t *f, const double c[3], const double r[3], ilie_t *l)
{
    for (int k = 0; k < 3; k++) {
        l->c[k] = c[k];
        l->r[k] = r[k];
    }
    if (iv_is_empty(f->v)) {
        set_no_info(l, iv_empty());
        return;
    }
    if (!(f->e <= DBL_MAX)) {
        set_no_info(l, f->v);
        return;
    }
    double extra = 0.0;
    for (int k = 0; k < 3; k++) {
        double fk = f->x[1 + k];
        double ak = r[k] > 0.0 ? fk / r[k] : 0.0;
        if (fabs(ak) >= DBL_MIN && fabs(ak) <= DBL_MAX) {
            l->a[k] = ak;
            extra += U * (fabs(ak) * r[k]);
        } else {
            l->a[k] = 0.0;
            extra += fabs(fk);
        }
    }
    double e = aa_fin_up(f->e + extra);
    l->J = iv_make(iv_down(f->x[0] - e), iv_up(f->x[0] + e));
}

/* m <= ILIE_BATCH cells: the variables' forms, the pass, the ILIEs.  Lanes are padded
 * to a multiple of 8 with copies of the first cell, so the pass's lane loops
 * have no scalar remainder. */
static void eval_chunk(ilie_pass_fn *pass, const tape_t *t, double *S, size_t m,
                       const iv_box_t *box, ilie_t *out)
{
    double c[ILIE_BATCH][3], r[ILIE_BATCH][3];
    aa_t var[3][ILIE_BATCH], f[ILIE_BATCH];
    size_t nl = m > 8 ? (m + 7) / 8 * 8 : m;
    for (size_t k = 0; k < nl; k++) {
        const iv_box_t *x = &box[k < m ? k : 0];
        const iv_t side[3] = {x->x, x->y, x->z};
        for (int d = 0; d < 3; d++) {
            frame(side[d], &c[k][d], &r[k][d]);
            iv_t b = side[d].lo <= side[d].hi ? side[d] : iv_entire(); /* NaN, reversed */
            aa_var(&var[d][k], d, c[k][d], r[k][d], b);
        }
    }
    pass(t, S, nl, (const aa_t (*)[ILIE_BATCH])var, f);
    for (size_t k = 0; k < m; k++)
        to_ilie(&f[k], c[k], r[k], &out[k]);
}

void ilie_eval(const tape_t *t, ilie_ws_t *ws, size_t n, const iv_box_t *box, ilie_t *out)
{
    int ok = t && ws && t->n > 0 && reserve(ws, t->n) == 0;
    ilie_pass_fn *pass = lanes_in_use()->pass;
    for (size_t base = 0; base < n; base += ILIE_BATCH) {
        size_t m = n - base < ILIE_BATCH ? n - base : ILIE_BATCH;
        if (ok) {
            eval_chunk(pass, t, ws->S, m, box + base, out + base);
            continue;
        }
        for (size_t k = 0; k < m; k++) {
            ilie_t *l = &out[base + k];
            const iv_t side[3] = {box[base + k].x, box[base + k].y, box[base + k].z};
            for (int d = 0; d < 3; d++)
                frame(side[d], &l->c[d], &l->r[d]);
            set_no_info(l, iv_entire());
        }
    }
}

/* ---- queries --------------------------------------------------------------------- */

/* J + Σ a_k (P_k − c_k) in interval arithmetic. */
static iv_t affine_at(const ilie_t *l, const iv_t P[3])
{
    iv_t s = l->J;
    if (iv_is_empty(s))
        return s;
    for (int k = 0; k < 3; k++)
        if (l->a[k] != 0.0)
            s = iv_add(s, iv_mul(iv_point(l->a[k]), iv_sub(P[k], iv_point(l->c[k]))));
    return s;
}

iv_t ilie_at(const ilie_t *l, const double p[3])
{
    const iv_t P[3] = {iv_point(p[0]), iv_point(p[1]), iv_point(p[2])};
    return affine_at(l, P);
}

iv_t ilie_range(const ilie_t *l, const iv_box_t *box)
{
    const iv_t P[3] = {box->x, box->y, box->z};
    return affine_at(l, P);
}

bool ilie_excludes_box(const ilie_t *l, const iv_box_t *box, int *sign)
{
    int s = 0;
    bool ex;
    if (iv_is_empty(l->J)) {
        ex = true; /* f defined nowhere in the cell: no zero */
    } else {
        iv_t R = ilie_range(l, box);
        s = R.lo > 0.0 ? 1 : R.hi < 0.0 ? -1 : 0;
        ex = s != 0;
    }
    if (sign)
        *sign = s;
    return ex;
}

void ilie_excludes_boxes(size_t n, const ilie_t *l, const iv_box_t *box, bool *ex, int *sign)
{
    ilie_excludes_fn *excludes = lanes_in_use()->excludes;
    int64_t code[ILIE_BATCH];
    for (size_t base = 0; base < n; base += ILIE_BATCH) {
        size_t m = n - base < ILIE_BATCH ? n - base : ILIE_BATCH;
        excludes(m, l + base, box + base, code);
        for (size_t k = 0; k < m; k++) {
            int s = code[k] == 2 ? 0 : (int)code[k];
            bool e = code[k] != 0;
            if (code[k] == 3)
                e = ilie_excludes_box(&l[base + k], &box[base + k], &s);
            ex[base + k] = e;
            if (sign)
                sign[base + k] = s;
        }
    }
}

/* x · 2^k rounded once, as ldexp: the product by the power of two where 2^k is
 * a normal double (one IEEE multiplication, rounded once like ldexp: the libm
 * call stood out in profiles of builds with slabs), ldexp elsewhere. */
static double scale2(double x, int k)
{
    if (k < -1022 || k > 1023)
        return ldexp(x, k);
    uint64_t bits = (uint64_t)(k + 1023) << 52;
    double p;
    memcpy(&p, &bits, sizeof p);
    return x * p;
}

/* frexp's exponent of a finite x > 0: x = m · 2^ex with m in [1/2, 1). */
static int exponent_of(double x)
{
    int ex;
    if (!(x >= DBL_MIN)) {
        frexp(x, &ex);
        return ex;
    }
    uint64_t bits;
    memcpy(&bits, &x, sizeof bits);
    return (int)((bits >> 52) & 0x7ff) - 1022;
}

/* |a| = 2^ex · Nb, with B[k] enclosing a_k 2^-ex: scaled by a power of two so
 * that squaring neither overflows nor underflows (max |a_k 2^-ex| is in
 * [1/2, 1)).  The scaling is exact except for components that become
 * subnormal, whose rounding B[k] encloses.  Returns 0 when a = 0. */
static int scaled_norm(const ilie_t *l, iv_t B[3], iv_t *Nb, int *ex)
{
    double amax = fmax(fabs(l->a[0]), fmax(fabs(l->a[1]), fabs(l->a[2])));
    if (!(amax > 0.0 && amax <= DBL_MAX))
        return 0;
    *ex = exponent_of(amax);
    iv_t s = iv_point(0.0);
    for (int k = 0; k < 3; k++) {
        double b = scale2(l->a[k], -*ex);
        B[k] = scale2(b, *ex) == l->a[k] ? iv_point(b) : iv_make(iv_down(b), iv_up(b));
        s = iv_add(s, iv_sqr(B[k]));
    }
    *Nb = iv_sqrt(s);
    return Nb->lo > 0.0;
}

/* [lo, hi] · 2^k, outward (the scaling rounds only on underflow and overflow). */
static iv_t iv_scale2(iv_t a, int k)
{
    return iv_make(iv_down(scale2(a.lo, k)), iv_up(scale2(a.hi, k)));
}

double ilie_thickness(const ilie_t *l)
{
    if (iv_is_empty(l->J))
        return 0.0;
    iv_t B[3], Nb;
    int ex;
    double w = iv_width(l->J);
    if (!scaled_norm(l, B, &Nb, &ex) || !(w <= DBL_MAX))
        return INFINITY;
    /* w / (Nb 2^ex) */
    return iv_up(scale2(iv_up(w / Nb.lo), -ex));
}

/* For p in the cell with 0 ∈ a·(p − c) + J, write â = a/|a| (exact):
 *   n·p = n·c + â·(p − c) + (n − â)·(p − c),
 *   â·(p − c) ∈ −J/|a|,   |(n − â)·(p − c)| <= Σ |n_k − â_k| r_k,
 * each part enclosed in interval arithmetic. */
void ilie_slab(const ilie_t *l, double n[3], double *d_lo, double *d_hi)
{
    n[0] = n[1] = n[2] = 0.0;
    if (iv_is_empty(l->J)) {
        *d_lo = INFINITY, *d_hi = -INFINITY;
        return;
    }
    iv_t B[3], Nb;
    int ex;
    if (!scaled_norm(l, B, &Nb, &ex)) {
        int may = iv_contains(l->J, 0.0);
        *d_lo = may ? -INFINITY : INFINITY;
        *d_hi = may ? INFINITY : -INFINITY;
        return;
    }
    double s2 = 0.0;
    for (int k = 0; k < 3; k++)
        s2 += iv_mid(B[k]) * iv_mid(B[k]);
    double nb = sqrt(s2); /* the double normal: its accuracy only affects tightness */
    iv_t S = iv_scale2(iv_div(iv_neg(l->J), Nb), -ex); /* −J/|a| */
    double E = 0.0;
    for (int k = 0; k < 3; k++) {
        n[k] = iv_mid(B[k]) / nb;
        iv_t ah = iv_div(B[k], Nb); /* â_k */
        double dk = fmax(iv_up(fabs(n[k] - ah.lo)), iv_up(fabs(ah.hi - n[k])));
        E += dk * l->r[k];
        S = iv_add(S, iv_mul(iv_point(n[k]), iv_point(l->c[k])));
    }
    E = aa_fin_up(E);
    S = iv_add(S, iv_make(-E, E));
    *d_lo = S.lo;
    *d_hi = S.hi;
}
