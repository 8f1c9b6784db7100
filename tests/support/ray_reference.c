/* The high-precision reference for ray casting: see ray_reference.h. */
#include "ray_reference.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#include <mpfr.h>

#include "../../ray/ray.h"

#define PREC RREF_PREC
#define DMAX RREF_MAX_DEGREE

/* ---- polynomials in t ------------------------------------------------------------ */

typedef struct poly {
    int deg; /* -1 for the zero polynomial */
    mpfr_t c[DMAX + 1];
} poly_t;

static void poly_init(poly_t *p)
{
    for (int k = 0; k <= DMAX; k++)
        mpfr_init2(p->c[k], PREC);
    p->deg = -1;
}

static void poly_clear(poly_t *p)
{
    for (int k = 0; k <= DMAX; k++)
        mpfr_clear(p->c[k]);
}

static void poly_trim(poly_t *p)
{
    while (p->deg >= 0 && mpfr_zero_p(p->c[p->deg]))
        p->deg--;
}

static void poly_copy(poly_t *r, const poly_t *a)
{
    r->deg = a->deg;
    for (int k = 0; k <= a->deg; k++)
        mpfr_set(r->c[k], a->c[k], MPFR_RNDN);
}

static void poly_add(poly_t *r, const poly_t *a, const poly_t *b, int sub)
{
    int d = a->deg > b->deg ? a->deg : b->deg;
    for (int k = 0; k <= d; k++) {
        if (k <= a->deg)
            mpfr_set(r->c[k], a->c[k], MPFR_RNDN);
        else
            mpfr_set_zero(r->c[k], 1);
        if (k <= b->deg) {
            if (sub)
                mpfr_sub(r->c[k], r->c[k], b->c[k], MPFR_RNDN);
            else
                mpfr_add(r->c[k], r->c[k], b->c[k], MPFR_RNDN);
        }
    }
    r->deg = d;
    poly_trim(r);
}

static int poly_mul(poly_t *r, const poly_t *a, const poly_t *b, mpfr_t tmp)
{
    if (a->deg < 0 || b->deg < 0) {
        r->deg = -1;
        return 0;
    }
    int d = a->deg + b->deg;
    if (d > DMAX)
        return -1;
    poly_t out;
    poly_init(&out);
    for (int k = 0; k <= d; k++)
        mpfr_set_zero(out.c[k], 1);
    for (int i = 0; i <= a->deg; i++)
        for (int j = 0; j <= b->deg; j++) {
            mpfr_mul(tmp, a->c[i], b->c[j], MPFR_RNDN);
            mpfr_add(out.c[i + j], out.c[i + j], tmp, MPFR_RNDN);
        }
    out.deg = d;
    poly_copy(r, &out);
    poly_clear(&out);
    poly_trim(r);
    return 0;
}

/* p(x) by Horner */
static void poly_eval(mpfr_t out, const poly_t *p, const mpfr_t x)
{
    mpfr_set_zero(out, 1);
    for (int k = p->deg; k >= 0; k--) {
        mpfr_mul(out, out, x, MPFR_RNDN);
        mpfr_add(out, out, p->c[k], MPFR_RNDN);
    }
}

static void poly_deriv(poly_t *r, const poly_t *p)
{
    for (int k = 1; k <= p->deg; k++)
        mpfr_mul_si(r->c[k - 1], p->c[k], k, MPFR_RNDN);
    r->deg = p->deg - 1;
    poly_trim(r);
}

/* Is the tape a polynomial we can expand (ops, degree; with exact_consts,
 * constants that are doubles)? */
static int is_polynomial(const tape_t *t, int exact_consts)
{
    int *deg = calloc(t->n ? t->n : 1, sizeof *deg);
    if (!deg)
        return 0;
    int ok = 1;
    for (uint32_t i = 0; i < t->n && ok; i++) {
        const tape_clause_t *c = &t->clauses[i];
        switch ((tape_op_t)c->op) {
        case TAPE_CONST: ok = !exact_consts || c->c.lo == c->c.hi; deg[i] = 0; break;
        case TAPE_X: case TAPE_Y: case TAPE_Z: deg[i] = 1; break;
        case TAPE_NEG: deg[i] = deg[c->a]; break;
        case TAPE_SQR: deg[i] = 2 * deg[c->a]; break;
        case TAPE_POWI: ok = c->c.lo >= 0; deg[i] = (int)c->c.lo * deg[c->a]; break;
        case TAPE_ADD: case TAPE_SUB:
            deg[i] = deg[c->a] > deg[c->b] ? deg[c->a] : deg[c->b];
            break;
        case TAPE_MUL: deg[i] = deg[c->a] + deg[c->b]; break;
        default: ok = 0; break;
        }
        if (deg[i] > DMAX)
            ok = 0;
    }
    free(deg);
    return ok;
}

int rref_supported(const tape_t *t) { return is_polynomial(t, 1); }

int rref_supported_at_ends(const tape_t *t) { return is_polynomial(t, 0); }

/* g(t) = f(o + t d) into out, with slots (t->n of them) as scratch. */
static void tape_poly(const tape_t *t, rref_end_t end, poly_t *slot, const double o[3],
                      const double d[3], poly_t *out, mpfr_t tmp)
{
    for (uint32_t i = 0; i < t->n; i++) {
        const tape_clause_t *c = &t->clauses[i];
        poly_t *r = &slot[i];
        switch ((tape_op_t)c->op) {
        case TAPE_CONST:
            mpfr_set_d(r->c[0], end == RREF_CONST_HI ? c->c.hi : c->c.lo, MPFR_RNDN);
            r->deg = 0;
            poly_trim(r);
            break;
        case TAPE_X: case TAPE_Y: case TAPE_Z: {
            int k = (int)c->op - TAPE_X;
            mpfr_set_d(r->c[0], o[k], MPFR_RNDN);
            mpfr_set_d(r->c[1], d[k], MPFR_RNDN);
            r->deg = 1;
            poly_trim(r);
            break;
        }
        case TAPE_NEG:
            poly_copy(r, &slot[c->a]);
            for (int k = 0; k <= r->deg; k++)
                mpfr_neg(r->c[k], r->c[k], MPFR_RNDN);
            break;
        case TAPE_SQR: poly_mul(r, &slot[c->a], &slot[c->a], tmp); break;
        case TAPE_POWI: {
            int n = (int)c->c.lo;
            r->deg = 0;
            mpfr_set_ui(r->c[0], 1, MPFR_RNDN);
            for (int k = 0; k < n; k++)
                poly_mul(r, r, &slot[c->a], tmp);
            break;
        }
        case TAPE_ADD: poly_add(r, &slot[c->a], &slot[c->b], 0); break;
        case TAPE_SUB: poly_add(r, &slot[c->a], &slot[c->b], 1); break;
        case TAPE_MUL: poly_mul(r, &slot[c->a], &slot[c->b], tmp); break;
        default: break;
        }
    }
    poly_copy(out, &slot[t->n - 1]);
}

/* ---- real roots ---------------------------------------------------------------------- */

typedef struct roots {
    int n;
    mpfr_t r[DMAX + 2];
} roots_t;

static void roots_init(roots_t *R)
{
    for (int k = 0; k < DMAX + 2; k++)
        mpfr_init2(R->r[k], PREC);
    R->n = 0;
}

static void roots_clear(roots_t *R)
{
    for (int k = 0; k < DMAX + 2; k++)
        mpfr_clear(R->r[k]);
}

static void roots_add(roots_t *R, const mpfr_t x)
{
    if (R->n > 0 && mpfr_equal_p(R->r[R->n - 1], x))
        return;
    mpfr_set(R->r[R->n++], x, MPFR_RNDN);
}

/* The root of p in [u, v] where p(u), p(v) have opposite signs and p is
 * monotone: safeguarded Newton (bisection when a step leaves the bracket). */
static void refine_root(const poly_t *p, const poly_t *dp, const mpfr_t u, const mpfr_t v,
                        int su, mpfr_t x)
{
    mpfr_t lo, hi, fx, dx, w;
    mpfr_inits2(PREC, lo, hi, fx, dx, w, (mpfr_ptr)0);
    mpfr_set(lo, u, MPFR_RNDN);
    mpfr_set(hi, v, MPFR_RNDN);
    mpfr_add(x, lo, hi, MPFR_RNDN);
    mpfr_div_2ui(x, x, 1, MPFR_RNDN);
    for (int it = 0; it < 400; it++) {
        poly_eval(fx, p, x);
        int s = mpfr_sgn(fx);
        if (s == 0)
            break;
        if ((s > 0) == (su > 0))
            mpfr_set(lo, x, MPFR_RNDN);
        else
            mpfr_set(hi, x, MPFR_RNDN);
        mpfr_sub(w, hi, lo, MPFR_RNDN);
        if (mpfr_get_exp(w) < mpfr_get_exp(hi) - 90 || mpfr_zero_p(w))
            break;
        poly_eval(dx, dp, x);
        int newton_ok = 0;
        if (!mpfr_zero_p(dx)) {
            mpfr_div(dx, fx, dx, MPFR_RNDN);
            mpfr_sub(dx, x, dx, MPFR_RNDN);
            newton_ok = mpfr_greater_p(dx, lo) && mpfr_less_p(dx, hi);
        }
        /* bisect every 4th step so the bracket keeps shrinking */
        if (newton_ok && it % 4 != 3) {
            mpfr_set(x, dx, MPFR_RNDN);
        } else {
            mpfr_add(x, lo, hi, MPFR_RNDN);
            mpfr_div_2ui(x, x, 1, MPFR_RNDN);
        }
    }
    mpfr_clears(lo, hi, fx, dx, w, (mpfr_ptr)0);
}

/* All distinct real roots of p in [a, b], sorted; crit (may be NULL) gets the
 * critical points (roots of p') in [a, b]. */
static void real_roots(const poly_t *p, const mpfr_t a, const mpfr_t b, roots_t *R,
                       roots_t *crit)
{
    R->n = 0;
    if (crit)
        crit->n = 0;
    if (p->deg <= 0)
        return;
    poly_t dp;
    poly_init(&dp);
    poly_deriv(&dp, p);
    roots_t C;
    roots_init(&C);
    real_roots(&dp, a, b, &C, NULL);
    mpfr_t u, v, pu, pv, x;
    mpfr_inits2(PREC, u, v, pu, pv, x, (mpfr_ptr)0);
    mpfr_set(u, a, MPFR_RNDN);
    for (int k = 0; k <= C.n; k++) {
        mpfr_set(v, k < C.n ? C.r[k] : b, MPFR_RNDN);
        poly_eval(pu, p, u);
        poly_eval(pv, p, v);
        int su = mpfr_sgn(pu), sv = mpfr_sgn(pv);
        if (su == 0)
            roots_add(R, u);
        else if (sv != 0 && su != sv) {
            refine_root(p, &dp, u, v, su, x);
            roots_add(R, x);
        }
        if (k == C.n && sv == 0)
            roots_add(R, v);
        mpfr_set(u, v, MPFR_RNDN);
    }
    if (crit) {
        crit->n = 0;
        for (int k = 0; k < C.n; k++)
            roots_add(crit, C.r[k]);
    }
    mpfr_clears(u, v, pu, pv, x, (mpfr_ptr)0);
    roots_clear(&C);
    poly_clear(&dp);
}

/* ---- the reference for one ray ------------------------------------------------------ */

struct rref {
    const tape_t *tape;
    rref_end_t end;
    double length;
    poly_t *slot;
    poly_t p, dp, ddp;
    mpfr_t tmp, a, b, x, y;
    roots_t R, C, C2;
};

rref_t *rref_new(const tape_t *t)
{
    if (!t || t->n == 0 || !rref_supported_at_ends(t))
        return NULL;
    rref_t *c = calloc(1, sizeof *c);
    if (!c)
        return NULL;
    c->slot = malloc(t->n * sizeof *c->slot);
    if (!c->slot) {
        free(c);
        return NULL;
    }
    c->tape = t;
    c->end = RREF_CONST_LO;
    c->length = 1;
    for (uint32_t i = 0; i < t->n; i++)
        poly_init(&c->slot[i]);
    poly_init(&c->p);
    poly_init(&c->dp);
    poly_init(&c->ddp);
    mpfr_inits2(PREC, c->tmp, c->a, c->b, c->x, c->y, (mpfr_ptr)0);
    roots_init(&c->R);
    roots_init(&c->C);
    roots_init(&c->C2);
    return c;
}

void rref_free(rref_t *c)
{
    if (!c)
        return;
    for (uint32_t i = 0; i < c->tape->n; i++)
        poly_clear(&c->slot[i]);
    free(c->slot);
    poly_clear(&c->p);
    poly_clear(&c->dp);
    poly_clear(&c->ddp);
    mpfr_clears(c->tmp, c->a, c->b, c->x, c->y, (mpfr_ptr)0);
    roots_clear(&c->R);
    roots_clear(&c->C);
    roots_clear(&c->C2);
    free(c);
}

void rref_set_end(rref_t *c, rref_end_t end) { c->end = end; }

void rref_set_length(rref_t *c, double length) { c->length = length; }

void rref_ray(rref_t *c, const double o[3], const double d[3], double t0, double t1,
              rref_result_t *out)
{
    tape_poly(c->tape, c->end, c->slot, o, d, &c->p, c->tmp);
    mpfr_set_d(c->a, t0, MPFR_RNDN);
    mpfr_set_d(c->b, t1, MPFR_RNDN);
    real_roots(&c->p, c->a, c->b, &c->R, &c->C);
    poly_deriv(&c->dp, &c->p);
    poly_deriv(&c->ddp, &c->dp);
    /* L = max |p'| on [t0, t1]: at the ends and the roots of p'' */
    real_roots(&c->ddp, c->a, c->b, &c->C2, NULL);
    double L = 0;
    for (int k = -2; k < c->C2.n; k++) {
        poly_eval(c->y, &c->dp, k == -2 ? c->a : k == -1 ? c->b : c->C2.r[k]);
        L = fmax(L, fabs(mpfr_get_d(c->y, MPFR_RNDN)));
    }
    double thr = 1e-9 * L * c->length;
    out->hit = c->R.n > 0;
    out->r = out->hit ? mpfr_get_d(c->R.r[0], MPFR_RNDN) : NAN;
    out->dp_r = NAN;
    if (out->hit) {
        poly_eval(c->y, &c->dp, c->R.r[0]);
        out->dp_r = fabs(mpfr_get_d(c->y, MPFR_RNDN));
    }
    out->near_double = out->near_box = 0;
    out->gmin = INFINITY;
    out->t_gmin = NAN;
    double g_checked = INFINITY; /* min |g| over the points the ambiguity test looks at */
    for (int e = 0; e < 2; e++) {
        poly_eval(c->y, &c->p, e ? c->b : c->a);
        double g = fabs(mpfr_get_d(c->y, MPFR_RNDN));
        if (g < out->gmin)
            out->gmin = g, out->t_gmin = e ? t1 : t0;
        g_checked = fmin(g_checked, g);
        if (g <= thr)
            out->near_box = 1;
    }
    for (int k = 0; k < c->C.n; k++) {
        poly_eval(c->y, &c->p, c->C.r[k]);
        double g = fabs(mpfr_get_d(c->y, MPFR_RNDN));
        if (g < out->gmin)
            out->gmin = g, out->t_gmin = mpfr_get_d(c->C.r[k], MPFR_RNDN);
        if (c->R.n >= 2 && mpfr_greater_p(c->C.r[k], c->R.r[1]))
            continue; /* past the second root: the first one is isolated */
        g_checked = fmin(g_checked, g);
        if (g <= thr)
            out->near_double = 1;
    }
    out->ambiguous = out->near_double || out->near_box;
    out->graze = L > 0 ? g_checked / L : NAN;
}

int rref_ray_box(rref_t *c, const double box[6], const double o[3], const double d[3],
                 rref_result_t *out)
{
    double t0, t1;
    if (!ray_clip_box(box, o, d, &t0, &t1)) {
        *out = (rref_result_t){0, NAN, NAN, 0, 0, 0, INFINITY, INFINITY, NAN};
        return 0;
    }
    rref_ray(c, o, d, t0, t1, out);
    return 1;
}

void rref_thread_cleanup(void)
{
    mpfr_free_cache();
}
