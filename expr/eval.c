/* ivoct — evaluators over a tape: point, interval, interval + gradient.
 *
 * Every evaluator makes one pass over the tape per chunk of TAPE_LANES boxes,
 * and for each clause runs a loop over the lanes.  The loops have a constant
 * trip count (short chunks are padded with copies of their first lane), so the
 * compiler unrolls and vectorises them; the switch on the op is paid once per
 * clause, not once per box.  Slots are laid out clause-major:
 * slot[i * TAPE_LANES + lane]. */
#include <stdlib.h>
#include <string.h>

#include "tape.h"

#define L TAPE_LANES

struct tape_ws {
    uint32_t max_clauses;
    double *point;    /* max_clauses * L */
    iv_t *iv;         /* max_clauses * L */
    iv_grad_t *grad;  /* max_clauses * L */
    iv_t *dir;        /* max_clauses * L: directional derivatives (tape_eval_ray) */
    double *mag;      /* max_clauses * L: rounding magnitudes (tape_eval_ray) */
};

tape_ws_t *tape_ws_new(uint32_t max_clauses)
{
    tape_ws_t *ws = calloc(1, sizeof *ws);
    if (!ws)
        return NULL;
    if (max_clauses == 0)
        max_clauses = 1;
    ws->max_clauses = max_clauses;
    ws->point = malloc((size_t)max_clauses * L * sizeof *ws->point);
    ws->iv = malloc((size_t)max_clauses * L * sizeof *ws->iv);
    ws->grad = malloc((size_t)max_clauses * L * sizeof *ws->grad);
    ws->dir = malloc((size_t)max_clauses * L * sizeof *ws->dir);
    ws->mag = malloc((size_t)max_clauses * L * sizeof *ws->mag);
    if (!ws->point || !ws->iv || !ws->grad || !ws->dir || !ws->mag) {
        tape_ws_free(ws);
        return NULL;
    }
    return ws;
}

void tape_ws_free(tape_ws_t *ws)
{
    if (!ws)
        return;
    free(ws->point);
    free(ws->iv);
    free(ws->grad);
    free(ws->dir);
    free(ws->mag);
    free(ws);
}

/* ---- point ------------------------------------------------------------------ */

/* x^n by squaring, lanes innermost: much cheaper than pow() for the small
 * exponents of polynomial surfaces, and as accurate for a non-rigorous
 * evaluator */
static void point_powi(double *restrict o, const double *a, int n)
{
    unsigned m = n < 0 ? 0u - (unsigned)n : (unsigned)n;
    double r[L], x[L];
    for (int k = 0; k < L; k++)
        r[k] = 1.0, x[k] = a[k];
    for (; m; m >>= 1) {
        if (m & 1u)
            for (int k = 0; k < L; k++) r[k] *= x[k];
        for (int k = 0; k < L; k++) x[k] *= x[k];
    }
    for (int k = 0; k < L; k++)
        o[k] = n < 0 ? 1.0 / r[k] : r[k];
}

static void point_chunk(const tape_t *t, double *restrict S, const double *x,
                        const double *y, const double *z)
{
    for (uint32_t i = 0; i < t->n; i++) {
        const tape_clause_t *c = &t->clauses[i];
        double *restrict o = S + (size_t)i * L;
        const double *a = S + (size_t)c->a * L, *b = S + (size_t)c->b * L;
        switch ((tape_op_t)c->op) {
        case TAPE_CONST: {
            double v = iv_mid(c->c);
            for (int k = 0; k < L; k++) o[k] = v;
            break;
        }
        case TAPE_X: for (int k = 0; k < L; k++) o[k] = x[k]; break;
        case TAPE_Y: for (int k = 0; k < L; k++) o[k] = y[k]; break;
        case TAPE_Z: for (int k = 0; k < L; k++) o[k] = z[k]; break;
        case TAPE_NEG: for (int k = 0; k < L; k++) o[k] = -a[k]; break;
        case TAPE_SQR: for (int k = 0; k < L; k++) o[k] = a[k] * a[k]; break;
        case TAPE_POWI: point_powi(o, a, (int)c->c.lo); break;
        case TAPE_POWR: for (int k = 0; k < L; k++) o[k] = pow(a[k], c->c.lo); break;
        case TAPE_SQRT: for (int k = 0; k < L; k++) o[k] = sqrt(a[k]); break;
        case TAPE_EXP: for (int k = 0; k < L; k++) o[k] = exp(a[k]); break;
        case TAPE_LOG: for (int k = 0; k < L; k++) o[k] = log(a[k]); break;
        case TAPE_SIN: for (int k = 0; k < L; k++) o[k] = sin(a[k]); break;
        case TAPE_COS: for (int k = 0; k < L; k++) o[k] = cos(a[k]); break;
        case TAPE_TAN: for (int k = 0; k < L; k++) o[k] = tan(a[k]); break;
        case TAPE_ATAN: for (int k = 0; k < L; k++) o[k] = atan(a[k]); break;
        case TAPE_ABS: for (int k = 0; k < L; k++) o[k] = fabs(a[k]); break;
        case TAPE_ADD: for (int k = 0; k < L; k++) o[k] = a[k] + b[k]; break;
        case TAPE_SUB: for (int k = 0; k < L; k++) o[k] = a[k] - b[k]; break;
        case TAPE_MUL: for (int k = 0; k < L; k++) o[k] = a[k] * b[k]; break;
        case TAPE_DIV: for (int k = 0; k < L; k++) o[k] = a[k] / b[k]; break;
        /* NaN (undefined) propagates, unlike fmin/fmax */
        case TAPE_MIN:
            for (int k = 0; k < L; k++) o[k] = a[k] != a[k] ? a[k] : (a[k] < b[k] ? a[k] : b[k]);
            break;
        case TAPE_MAX:
            for (int k = 0; k < L; k++) o[k] = a[k] != a[k] ? a[k] : (a[k] > b[k] ? a[k] : b[k]);
            break;
        case TAPE_OP_COUNT: break;
        }
    }
}

void tape_eval_point(const tape_t *t, tape_ws_t *ws, size_t n, const double *x,
                     const double *y, const double *z, double *out)
{
    for (size_t base = 0; base < n; base += L) {
        size_t m = n - base < L ? n - base : L;
        double cx[L], cy[L], cz[L];
        for (size_t k = 0; k < L; k++) {
            size_t j = base + (k < m ? k : 0);
            cx[k] = x[j], cy[k] = y[j], cz[k] = z[j];
        }
        point_chunk(t, ws->point, cx, cy, cz);
        const double *r = ws->point + (size_t)(t->n - 1) * L;
        memcpy(out + base, r, m * sizeof *out);
    }
}

/* ---- interval --------------------------------------------------------------- */

static void interval_chunk(const tape_t *t, iv_t *restrict S, int nl, const iv_box_t *box)
{
    for (uint32_t i = 0; i < t->n; i++) {
        const tape_clause_t *c = &t->clauses[i];
        iv_t *restrict o = S + (size_t)i * L;
        const iv_t *a = S + (size_t)c->a * L, *b = S + (size_t)c->b * L;
        switch ((tape_op_t)c->op) {
        case TAPE_CONST: for (int k = 0; k < nl; k++) o[k] = c->c; break;
        case TAPE_X: for (int k = 0; k < nl; k++) o[k] = box[k].x; break;
        case TAPE_Y: for (int k = 0; k < nl; k++) o[k] = box[k].y; break;
        case TAPE_Z: for (int k = 0; k < nl; k++) o[k] = box[k].z; break;
        case TAPE_NEG: for (int k = 0; k < nl; k++) o[k] = iv_neg(a[k]); break;
        case TAPE_SQR: for (int k = 0; k < nl; k++) o[k] = iv_sqr(a[k]); break;
        case TAPE_POWI: {
            int n = (int)c->c.lo;
            for (int k = 0; k < nl; k++) o[k] = iv_powi(a[k], n);
            break;
        }
        case TAPE_POWR: for (int k = 0; k < nl; k++) o[k] = iv_powr(a[k], c->c.lo); break;
        case TAPE_SQRT: for (int k = 0; k < nl; k++) o[k] = iv_sqrt(a[k]); break;
        case TAPE_EXP: for (int k = 0; k < nl; k++) o[k] = iv_exp(a[k]); break;
        case TAPE_LOG: for (int k = 0; k < nl; k++) o[k] = iv_log(a[k]); break;
        case TAPE_SIN: for (int k = 0; k < nl; k++) o[k] = iv_sin(a[k]); break;
        case TAPE_COS: for (int k = 0; k < nl; k++) o[k] = iv_cos(a[k]); break;
        case TAPE_TAN: for (int k = 0; k < nl; k++) o[k] = iv_tan(a[k]); break;
        case TAPE_ATAN: for (int k = 0; k < nl; k++) o[k] = iv_atan(a[k]); break;
        case TAPE_ABS: for (int k = 0; k < nl; k++) o[k] = iv_abs(a[k]); break;
        case TAPE_ADD: for (int k = 0; k < nl; k++) o[k] = iv_add(a[k], b[k]); break;
        case TAPE_SUB: for (int k = 0; k < nl; k++) o[k] = iv_sub(a[k], b[k]); break;
        case TAPE_MUL: for (int k = 0; k < nl; k++) o[k] = iv_mul(a[k], b[k]); break;
        case TAPE_DIV: for (int k = 0; k < nl; k++) o[k] = iv_div(a[k], b[k]); break;
        case TAPE_MIN: for (int k = 0; k < nl; k++) o[k] = iv_min(a[k], b[k]); break;
        case TAPE_MAX: for (int k = 0; k < nl; k++) o[k] = iv_max(a[k], b[k]); break;
        case TAPE_OP_COUNT: break;
        }
    }
}

/* Copy up to L boxes into a full chunk, padding with the first. */
static void fill_chunk(iv_box_t *chunk, const iv_box_t *box, size_t m)
{
    for (size_t k = 0; k < L; k++)
        chunk[k] = box[k < m ? k : 0];
}

/* The choices of the m boxes of the chunk just evaluated into S (see
 * tape_eval_interval_choices); comparisons with an empty (NaN) operand are
 * false, so nothing is decided there. */
static void chunk_choices(const tape_t *t, const iv_t *S, size_t m, uint8_t *choices)
{
    memset(choices, TAPE_CHOICE_BOTH, m * t->n);
    for (uint32_t i = 0; i < t->n; i++) {
        const tape_clause_t *c = &t->clauses[i];
        const iv_t *a = S + (size_t)c->a * L, *b = S + (size_t)c->b * L;
        uint8_t *out = choices + i;
        switch ((tape_op_t)c->op) {
        case TAPE_MIN:
            for (size_t k = 0; k < m; k++)
                out[k * t->n] = a[k].hi <= b[k].lo   ? TAPE_CHOICE_A
                                : b[k].hi <= a[k].lo ? TAPE_CHOICE_B
                                                     : TAPE_CHOICE_BOTH;
            break;
        case TAPE_MAX:
            for (size_t k = 0; k < m; k++)
                out[k * t->n] = a[k].lo >= b[k].hi   ? TAPE_CHOICE_A
                                : b[k].lo >= a[k].hi ? TAPE_CHOICE_B
                                                     : TAPE_CHOICE_BOTH;
            break;
        case TAPE_ABS:
            for (size_t k = 0; k < m; k++)
                out[k * t->n] = a[k].lo >= 0   ? TAPE_CHOICE_A
                                : a[k].hi <= 0 ? TAPE_CHOICE_NEG_A
                                               : TAPE_CHOICE_BOTH;
            break;
        default:
            break;
        }
    }
}

void tape_eval_interval_choices(const tape_t *t, tape_ws_t *ws, size_t n, const iv_box_t *box,
                                iv_t *out, uint8_t *choices)
{
    for (size_t base = 0; base < n; base += L) {
        size_t m = n - base < L ? n - base : L;
        iv_box_t chunk[L];
        fill_chunk(chunk, box + base, m);
        interval_chunk(t, ws->iv, L, chunk);
        memcpy(out + base, ws->iv + (size_t)(t->n - 1) * L, m * sizeof *out);
        if (choices)
            chunk_choices(t, ws->iv, m, choices + base * t->n);
    }
}

void tape_eval_interval(const tape_t *t, tape_ws_t *ws, size_t n, const iv_box_t *box,
                        iv_t *out)
{
    tape_eval_interval_choices(t, ws, n, box, out, NULL);
}

/* ---- interval + gradient ------------------------------------------------------
 * Forward mode: each slot carries f and its three partials as intervals.  Where
 * an operation is not differentiable (abs at 0, min/max at a tie) the partials
 * enclose every one-sided derivative, which is what the Lipschitz test needs. */

static const iv_t ZERO = {0.0, 0.0};

static inline iv_grad_t g_scale(iv_t v, iv_t s, iv_grad_t a)
{
    /* value v, gradient s * grad(a) */
    iv_grad_t r = {v, iv_mul(s, a.dx), iv_mul(s, a.dy), iv_mul(s, a.dz)};
    return r;
}

static inline iv_grad_t g_add(iv_grad_t a, iv_grad_t b)
{
    iv_grad_t r = {iv_add(a.v, b.v), iv_add(a.dx, b.dx), iv_add(a.dy, b.dy),
                   iv_add(a.dz, b.dz)};
    return r;
}

static inline iv_grad_t g_sub(iv_grad_t a, iv_grad_t b)
{
    iv_grad_t r = {iv_sub(a.v, b.v), iv_sub(a.dx, b.dx), iv_sub(a.dy, b.dy),
                   iv_sub(a.dz, b.dz)};
    return r;
}

static inline iv_grad_t g_neg(iv_grad_t a)
{
    iv_grad_t r = {iv_neg(a.v), iv_neg(a.dx), iv_neg(a.dy), iv_neg(a.dz)};
    return r;
}

static inline iv_t mul_add(iv_t p, iv_t q, iv_t r, iv_t s)
{
    return iv_add(iv_mul(p, q), iv_mul(r, s));
}

static inline iv_grad_t g_mul(iv_grad_t a, iv_grad_t b)
{
    iv_grad_t r = {iv_mul(a.v, b.v), mul_add(a.dx, b.v, a.v, b.dx),
                   mul_add(a.dy, b.v, a.v, b.dy), mul_add(a.dz, b.v, a.v, b.dz)};
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

static inline iv_t g_hull_or_empty(iv_t a, iv_t b)
{
    /* an undefined branch makes the result undefined */
    return iv_is_empty(a) || iv_is_empty(b) ? iv_empty() : iv_hull(a, b);
}

/* min/max: the branch that is certainly selected carries its gradient; else
 * the hull of both gradients. */
static inline iv_grad_t g_select(iv_t v, iv_grad_t a, iv_grad_t b, int pick)
{
    if (pick < 0) {
        iv_grad_t r = {v, a.dx, a.dy, a.dz};
        return r;
    }
    if (pick > 0) {
        iv_grad_t r = {v, b.dx, b.dy, b.dz};
        return r;
    }
    iv_grad_t r = {v, g_hull_or_empty(a.dx, b.dx), g_hull_or_empty(a.dy, b.dy),
                   g_hull_or_empty(a.dz, b.dz)};
    return r;
}

/* A unary op's value over a and an enclosure of its derivative there (over
 * the points where it is differentiable; see interval.h), for the chain rule
 * of both forward-mode evaluators. */
static inline void unary_vd(tape_op_t op, iv_t c, iv_t a, iv_t *v, iv_t *d)
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

static iv_grad_t g_unary(tape_op_t op, iv_t c, iv_grad_t a)
{
    iv_t v, d;
    unary_vd(op, c, a.v, &v, &d);
    return g_scale(v, d, a);
}

/* min/max: -1 when a is certainly selected, 1 when b is, 0 when undecided */
static inline int pick_min(iv_t a, iv_t b) { return a.hi <= b.lo ? -1 : b.hi <= a.lo ? 1 : 0; }
static inline int pick_max(iv_t a, iv_t b) { return a.lo >= b.hi ? -1 : b.lo >= a.hi ? 1 : 0; }

static inline iv_grad_t g_min(iv_grad_t a, iv_grad_t b)
{
    return g_select(iv_min(a.v, b.v), a, b, pick_min(a.v, b.v));
}

static inline iv_grad_t g_max(iv_grad_t a, iv_grad_t b)
{
    return g_select(iv_max(a.v, b.v), a, b, pick_max(a.v, b.v));
}

static void grad_chunk(const tape_t *t, iv_grad_t *restrict S, const iv_box_t *box)
{
    const iv_t one = {1.0, 1.0};
    for (uint32_t i = 0; i < t->n; i++) {
        const tape_clause_t *c = &t->clauses[i];
        iv_grad_t *restrict o = S + (size_t)i * L;
        const iv_grad_t *a = S + (size_t)c->a * L, *b = S + (size_t)c->b * L;
        tape_op_t op = (tape_op_t)c->op;
        switch (op) {
        case TAPE_CONST:
            for (int k = 0; k < L; k++) o[k] = (iv_grad_t){c->c, ZERO, ZERO, ZERO};
            break;
        case TAPE_X:
            for (int k = 0; k < L; k++) o[k] = (iv_grad_t){box[k].x, one, ZERO, ZERO};
            break;
        case TAPE_Y:
            for (int k = 0; k < L; k++) o[k] = (iv_grad_t){box[k].y, ZERO, one, ZERO};
            break;
        case TAPE_Z:
            for (int k = 0; k < L; k++) o[k] = (iv_grad_t){box[k].z, ZERO, ZERO, one};
            break;
        case TAPE_NEG: for (int k = 0; k < L; k++) o[k] = g_neg(a[k]); break;
        case TAPE_ADD: for (int k = 0; k < L; k++) o[k] = g_add(a[k], b[k]); break;
        case TAPE_SUB: for (int k = 0; k < L; k++) o[k] = g_sub(a[k], b[k]); break;
        case TAPE_MUL: for (int k = 0; k < L; k++) o[k] = g_mul(a[k], b[k]); break;
        case TAPE_DIV: for (int k = 0; k < L; k++) o[k] = g_div(a[k], b[k]); break;
        case TAPE_MIN: for (int k = 0; k < L; k++) o[k] = g_min(a[k], b[k]); break;
        case TAPE_MAX: for (int k = 0; k < L; k++) o[k] = g_max(a[k], b[k]); break;
        case TAPE_OP_COUNT: break;
        default:
            for (int k = 0; k < L; k++) o[k] = g_unary(op, c->c, a[k]);
            break;
        }
    }
}

void tape_eval_grad(const tape_t *t, tape_ws_t *ws, size_t n, const iv_box_t *box,
                    iv_grad_t *out)
{
    for (size_t base = 0; base < n; base += L) {
        size_t m = n - base < L ? n - base : L;
        iv_box_t chunk[L];
        fill_chunk(chunk, box + base, m);
        grad_chunk(t, ws->grad, chunk);
        memcpy(out + base, ws->grad + (size_t)(t->n - 1) * L, m * sizeof *out);
    }
}

/* ---- along a ray -----------------------------------------------------------------
 * Forward mode with one tangent, the direction d of the ray: a slot carries
 * its value (ws->iv), its derivative along d (ws->dir) and a magnitude
 * (ws->mag) bounding |∇u(p)·e| over every e with |e_i| <= rho_i.  The set of
 * those e is a box symmetric about 0, so every set ∇u(X)·e is symmetric too
 * and one non-negative bound per slot carries it, propagated in doubles
 * rounded up — the price of the rounding term is a few double operations per
 * clause instead of the three partials a full gradient would need. */

static inline double mag_of(iv_t a)
{
    double l = fabs(a.lo), h = fabs(a.hi);
    return iv_is_empty(a) ? INFINITY : l > h ? l : h;
}

/* x * y rounded up, x, y >= 0; exactly 0 when a factor is 0 (also times +inf:
 * a zero bound means the term is exactly 0, see iv_mul_bound) */
static inline double mag_mul(double x, double y)
{
    return x == 0 || y == 0 ? 0.0 : iv_up(x * y);
}

/* x / y rounded up, x, y >= 0; y = 0 (a divisor that may vanish) gives +inf */
static inline double mag_div(double x, double y)
{
    double r = x / y;
    return x == 0 ? 0.0 : r == r ? iv_up(r) : INFINITY;
}

static void ray_chunk(const tape_t *t, tape_ws_t *ws, int nl, const iv_box_t *box,
                      const double d[3], const double (*rho)[3])
{
    iv_t *restrict V = ws->iv, *restrict D = ws->dir;
    double *restrict M = ws->mag;
    for (uint32_t i = 0; i < t->n; i++) {
        const tape_clause_t *c = &t->clauses[i];
        const size_t oi = (size_t)i * L, ai = (size_t)c->a * L, bi = (size_t)c->b * L;
        iv_t *v = V + oi, *dv = D + oi;
        double *m = M + oi;
        const iv_t *av = V + ai, *ad = D + ai, *bv = V + bi, *bd = D + bi;
        const double *am = M + ai, *bm = M + bi;
        tape_op_t op = (tape_op_t)c->op;
        switch (op) {
        case TAPE_CONST:
            for (int k = 0; k < nl; k++) v[k] = c->c, dv[k] = ZERO, m[k] = 0.0;
            break;
        case TAPE_X:
            for (int k = 0; k < nl; k++) v[k] = box[k].x, dv[k] = iv_point(d[0]), m[k] = rho[k][0];
            break;
        case TAPE_Y:
            for (int k = 0; k < nl; k++) v[k] = box[k].y, dv[k] = iv_point(d[1]), m[k] = rho[k][1];
            break;
        case TAPE_Z:
            for (int k = 0; k < nl; k++) v[k] = box[k].z, dv[k] = iv_point(d[2]), m[k] = rho[k][2];
            break;
        case TAPE_NEG:
            for (int k = 0; k < nl; k++) v[k] = iv_neg(av[k]), dv[k] = iv_neg(ad[k]), m[k] = am[k];
            break;
        case TAPE_ADD:
            for (int k = 0; k < nl; k++)
                v[k] = iv_add(av[k], bv[k]), dv[k] = iv_add(ad[k], bd[k]),
                m[k] = iv_add_up(am[k], bm[k]);
            break;
        case TAPE_SUB:
            for (int k = 0; k < nl; k++)
                v[k] = iv_sub(av[k], bv[k]), dv[k] = iv_sub(ad[k], bd[k]),
                m[k] = iv_add_up(am[k], bm[k]);
            break;
        case TAPE_MUL:
            for (int k = 0; k < nl; k++) {
                v[k] = iv_mul(av[k], bv[k]);
                dv[k] = mul_add(ad[k], bv[k], av[k], bd[k]);
                m[k] = iv_add_up(mag_mul(am[k], mag_of(bv[k])), mag_mul(mag_of(av[k]), bm[k]));
            }
            break;
        case TAPE_DIV:
            /* (a/b)' = (a' - (a/b) b') / b, and its bound over |b| >= mig(b) */
            for (int k = 0; k < nl; k++) {
                iv_t q = iv_div(av[k], bv[k]);
                v[k] = q;
                dv[k] = iv_div(iv_sub(ad[k], iv_mul(q, bd[k])), bv[k]);
                double mig = bv[k].lo > 0 ? bv[k].lo : bv[k].hi < 0 ? -bv[k].hi : 0.0;
                m[k] = mag_div(iv_add_up(am[k], mag_mul(mag_of(q), bm[k])), mig);
            }
            break;
        case TAPE_MIN:
        case TAPE_MAX:
            /* the branch certainly selected carries its derivative, else the hull */
            for (int k = 0; k < nl; k++) {
                int pick = op == TAPE_MIN ? pick_min(av[k], bv[k]) : pick_max(av[k], bv[k]);
                v[k] = op == TAPE_MIN ? iv_min(av[k], bv[k]) : iv_max(av[k], bv[k]);
                dv[k] = pick < 0 ? ad[k] : pick > 0 ? bd[k] : g_hull_or_empty(ad[k], bd[k]);
                m[k] = pick < 0 ? am[k] : pick > 0 ? bm[k] : am[k] > bm[k] ? am[k] : bm[k];
            }
            break;
        case TAPE_OP_COUNT: break;
        default:
            for (int k = 0; k < nl; k++) {
                iv_t u, du;
                unary_vd(op, c->c, av[k], &u, &du);
                v[k] = u;
                dv[k] = iv_mul(du, ad[k]);
                m[k] = mag_mul(mag_of(du), am[k]);
            }
            break;
        }
    }
}

/* The box of one lane (tape.h): a point T is the rounded point p~(t); a
 * segment is o + T·d enclosed, hulled with p~(T.lo) and p~(T.hi) — fl(o +
 * fl(t·d)) is monotone in t, so every rounded point of T lies between those. */
static void ray_box(const double o[3], const double d[3], iv_t T, iv_box_t *box)
{
    double pa[3], pb[3];
    iv_t *ax = &box->x;
    tape_ray_point(o, d, T.lo, pa);
    if (T.lo == T.hi) {
        for (int i = 0; i < 3; i++)
            ax[i] = iv_point(pa[i]);
        return;
    }
    tape_ray_point(o, d, T.hi, pb);
    for (int i = 0; i < 3; i++) {
        iv_t s = iv_add(iv_point(o[i]), iv_mul(T, iv_point(d[i])));
        double lo = pa[i] < pb[i] ? pa[i] : pb[i], hi = pa[i] < pb[i] ? pb[i] : pa[i];
        ax[i] = iv_make(s.lo < lo ? s.lo : lo, s.hi > hi ? s.hi : hi);
    }
}

void tape_eval_ray(const tape_t *t, tape_ws_t *ws, const double o[3], const double d[3],
                   size_t n, const iv_t *T, iv_t *g, iv_t *dg, double *rnd)
{
    for (size_t base = 0; base < n; base += L) {
        size_t m = n - base < L ? n - base : L;
        iv_box_t chunk[L];
        double rho[L][3];
        for (size_t k = 0; k < m; k++) {
            iv_t Tk = T[base + k];
            ray_box(o, d, Tk, &chunk[k]);
            /* twice the largest displacement of a rounded point from the ray
             * over T: two roundings of at most 2^-53 relative each (tape.h) */
            double tmax = fabs(Tk.lo) > fabs(Tk.hi) ? fabs(Tk.lo) : fabs(Tk.hi);
            for (int i = 0; i < 3; i++)
                rho[k][i] = iv_up(iv_up(fabs(o[i]) + iv_up(2.0 * tmax * fabs(d[i]))) * 0x1p-51);
        }
        const size_t last = (size_t)(t->n - 1) * L;
        if (!dg) {
            interval_chunk(t, ws->iv, (int)m, chunk);
            memcpy(g + base, ws->iv + last, m * sizeof *g);
            continue;
        }
        ray_chunk(t, ws, (int)m, chunk, d, (const double(*)[3])rho);
        memcpy(g + base, ws->iv + last, m * sizeof *g);
        memcpy(dg + base, ws->dir + last, m * sizeof *dg);
        if (rnd)
            memcpy(rnd + base, ws->mag + last, m * sizeof *rnd);
    }
}
