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
    if (!ws->point || !ws->iv || !ws->grad) {
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
    free(ws);
}

iv_t tape_ws_slot(const tape_ws_t *ws, uint32_t i, unsigned lane)
{
    return ws->iv[(size_t)i * L + lane];
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

static void interval_chunk(const tape_t *t, iv_t *restrict S, const iv_box_t *box)
{
    for (uint32_t i = 0; i < t->n; i++) {
        const tape_clause_t *c = &t->clauses[i];
        iv_t *restrict o = S + (size_t)i * L;
        const iv_t *a = S + (size_t)c->a * L, *b = S + (size_t)c->b * L;
        switch ((tape_op_t)c->op) {
        case TAPE_CONST: for (int k = 0; k < L; k++) o[k] = c->c; break;
        case TAPE_X: for (int k = 0; k < L; k++) o[k] = box[k].x; break;
        case TAPE_Y: for (int k = 0; k < L; k++) o[k] = box[k].y; break;
        case TAPE_Z: for (int k = 0; k < L; k++) o[k] = box[k].z; break;
        case TAPE_NEG: for (int k = 0; k < L; k++) o[k] = iv_neg(a[k]); break;
        case TAPE_SQR: for (int k = 0; k < L; k++) o[k] = iv_sqr(a[k]); break;
        case TAPE_POWI: {
            int n = (int)c->c.lo;
            for (int k = 0; k < L; k++) o[k] = iv_powi(a[k], n);
            break;
        }
        case TAPE_POWR: for (int k = 0; k < L; k++) o[k] = iv_powr(a[k], c->c.lo); break;
        case TAPE_SQRT: for (int k = 0; k < L; k++) o[k] = iv_sqrt(a[k]); break;
        case TAPE_EXP: for (int k = 0; k < L; k++) o[k] = iv_exp(a[k]); break;
        case TAPE_LOG: for (int k = 0; k < L; k++) o[k] = iv_log(a[k]); break;
        case TAPE_SIN: for (int k = 0; k < L; k++) o[k] = iv_sin(a[k]); break;
        case TAPE_COS: for (int k = 0; k < L; k++) o[k] = iv_cos(a[k]); break;
        case TAPE_TAN: for (int k = 0; k < L; k++) o[k] = iv_tan(a[k]); break;
        case TAPE_ATAN: for (int k = 0; k < L; k++) o[k] = iv_atan(a[k]); break;
        case TAPE_ABS: for (int k = 0; k < L; k++) o[k] = iv_abs(a[k]); break;
        case TAPE_ADD: for (int k = 0; k < L; k++) o[k] = iv_add(a[k], b[k]); break;
        case TAPE_SUB: for (int k = 0; k < L; k++) o[k] = iv_sub(a[k], b[k]); break;
        case TAPE_MUL: for (int k = 0; k < L; k++) o[k] = iv_mul(a[k], b[k]); break;
        case TAPE_DIV: for (int k = 0; k < L; k++) o[k] = iv_div(a[k], b[k]); break;
        case TAPE_MIN: for (int k = 0; k < L; k++) o[k] = iv_min(a[k], b[k]); break;
        case TAPE_MAX: for (int k = 0; k < L; k++) o[k] = iv_max(a[k], b[k]); break;
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

void tape_eval_interval(const tape_t *t, tape_ws_t *ws, size_t n, const iv_box_t *box,
                        iv_t *out)
{
    for (size_t base = 0; base < n; base += L) {
        size_t m = n - base < L ? n - base : L;
        iv_box_t chunk[L];
        fill_chunk(chunk, box + base, m);
        interval_chunk(t, ws->iv, chunk);
        memcpy(out + base, ws->iv + (size_t)(t->n - 1) * L, m * sizeof *out);
    }
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

static inline iv_grad_t g_min(iv_grad_t a, iv_grad_t b)
{
    int pick = a.v.hi <= b.v.lo ? -1 : b.v.hi <= a.v.lo ? 1 : 0;
    return g_select(iv_min(a.v, b.v), a, b, pick);
}

static inline iv_grad_t g_max(iv_grad_t a, iv_grad_t b)
{
    int pick = a.v.lo >= b.v.hi ? -1 : b.v.lo >= a.v.hi ? 1 : 0;
    return g_select(iv_max(a.v, b.v), a, b, pick);
}

static iv_grad_t g_unary(tape_op_t op, iv_t c, iv_grad_t a)
{
    iv_t v, d;
    switch (op) {
    case TAPE_SQR:
        v = iv_sqr(a.v), d = iv_add(a.v, a.v);
        break;
    case TAPE_POWI: {
        int n = (int)c.lo;
        v = iv_powi(a.v, n), d = iv_mul(iv_point((double)n), iv_powi(a.v, n - 1));
        break;
    }
    case TAPE_POWR:
        /* d/dx x^r = r x^r / x, valid for x > 0, where x^r is defined */
        v = iv_powr(a.v, c.lo), d = iv_mul(iv_point(c.lo), iv_div(v, a.v));
        break;
    case TAPE_SQRT: v = iv_sqrt(a.v), d = iv_dsqrt(a.v); break;
    case TAPE_EXP: v = iv_exp(a.v), d = v; break;
    case TAPE_LOG: v = iv_log(a.v), d = iv_dlog(a.v); break;
    case TAPE_SIN: v = iv_sin(a.v), d = iv_cos(a.v); break;
    case TAPE_COS: v = iv_cos(a.v), d = iv_neg(iv_sin(a.v)); break;
    case TAPE_TAN: v = iv_tan(a.v), d = iv_dtan(a.v); break;
    case TAPE_ATAN: v = iv_atan(a.v), d = iv_datan(a.v); break;
    case TAPE_ABS: v = iv_abs(a.v), d = iv_dabs(a.v); break;
    default: v = d = iv_entire(); break;
    }
    return g_scale(v, d, a);
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
