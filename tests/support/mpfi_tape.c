/* Test oracle: tape evaluation in MPFI at a point, forward-mode gradient. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "mpfi_tape.h"
#include "testutil.h"

typedef struct {
    mpfi_t v, d[3];
} slot_t;

static void slot_init(slot_t *s)
{
    mpfi_init2(s->v, ORACLE_PREC);
    for (int k = 0; k < 3; k++)
        mpfi_init2(s->d[k], ORACLE_PREC);
}

static void slot_clear(slot_t *s)
{
    mpfi_clear(s->v);
    for (int k = 0; k < 3; k++)
        mpfi_clear(s->d[k]);
}

static void slot_set(slot_t *o, const slot_t *a)
{
    mpfi_set(o->v, a->v);
    for (int k = 0; k < 3; k++)
        mpfi_set(o->d[k], a->d[k]);
}

/* o.d = s * a.d */
static void scale_grad(slot_t *o, mpfi_t s, const slot_t *a)
{
    for (int k = 0; k < 3; k++)
        mpfi_mul(o->d[k], s, a->d[k]);
}

/* sign of a - b: -1, +1, or 0 when undecided (a tie: not differentiable) */
static int compare(mpfi_srcptr a, mpfi_srcptr b, mpfi_ptr tmp)
{
    mpfi_sub(tmp, a, b);
    if (mpfi_is_strictly_neg(tmp))
        return -1;
    if (mpfi_is_strictly_pos(tmp))
        return 1;
    return 0;
}

/* The evaluation at a point given in MPFI (the leaves take P exactly). */
static int eval_at(const tape_t *t, mpfi_t P[3], oracle_const_t which, mpfi_t value,
                   mpfi_t grad[3])
{
    slot_t *S = malloc(t->n * sizeof *S);
    mpfi_t s, u;
    mpfi_init2(s, ORACLE_PREC);
    mpfi_init2(u, ORACLE_PREC);
    int bad = 0;
    for (uint32_t i = 0; i < t->n && !bad; i++) {
        const tape_clause_t *c = &t->clauses[i];
        slot_t *o = &S[i];
        slot_init(o);
        const slot_t *a = &S[c->a], *b = &S[c->b];
        for (int k = 0; k < 3; k++)
            mpfi_set_ui(o->d[k], 0);
        switch ((tape_op_t)c->op) {
        case TAPE_CONST:
            mpfi_set_d(o->v, which == ORACLE_CONST_LO ? c->c.lo : c->c.hi);
            break;
        case TAPE_X:
        case TAPE_Y:
        case TAPE_Z: {
            int k = (int)c->op - TAPE_X;
            mpfi_set(o->v, P[k]);
            mpfi_set_ui(o->d[k], 1);
            break;
        }
        case TAPE_NEG:
            mpfi_neg(o->v, a->v);
            for (int k = 0; k < 3; k++)
                mpfi_neg(o->d[k], a->d[k]);
            break;
        case TAPE_SQR:
            mpfi_sqr(o->v, a->v);
            mpfi_mul_ui(s, a->v, 2);
            scale_grad(o, s, a);
            break;
        case TAPE_POWI: {
            long n = (long)c->c.lo;
            /* x^n by repeated multiplication; n < 0 as 1/x^-n */
            unsigned long m = (unsigned long)(n < 0 ? -n : n);
            mpfi_set_ui(u, 1);
            for (unsigned long j = 0; j + 1 < m; j++)
                mpfi_mul(u, u, a->v); /* u = x^(m-1) */
            mpfi_mul(o->v, u, a->v);  /* x^m */
            if (n < 0) {
                if (mpfi_has_zero(a->v)) {
                    bad = 1;
                    break;
                }
                /* d/dx x^-m = -m x^(-m-1) = -m x^(m-1) / (x^m)^2 */
                mpfi_sqr(s, o->v);
                mpfi_div(s, u, s);
                mpfi_mul_si(s, s, -(long)m);
                mpfi_ui_div(o->v, 1, o->v);
            } else {
                mpfi_mul_ui(s, u, m);
            }
            scale_grad(o, s, a);
            break;
        }
        case TAPE_POWR: {
            double r = c->c.lo;
            if (!mpfi_is_strictly_pos(a->v)) {
                bad = 1; /* x^r at 0 or below: undefined or not differentiable */
                break;
            }
            mpfi_log(u, a->v);
            mpfi_mul_d(u, u, r);
            mpfi_exp(o->v, u);
            mpfi_div(s, o->v, a->v);
            mpfi_mul_d(s, s, r);
            scale_grad(o, s, a);
            break;
        }
        case TAPE_SQRT:
            if (!mpfi_is_strictly_pos(a->v)) {
                bad = !mpfi_is_zero(a->v) || grad;
                mpfi_set_ui(o->v, 0);
                break;
            }
            mpfi_sqrt(o->v, a->v);
            mpfi_mul_ui(s, o->v, 2);
            mpfi_ui_div(s, 1, s);
            scale_grad(o, s, a);
            break;
        case TAPE_EXP:
            mpfi_exp(o->v, a->v);
            scale_grad(o, o->v, a);
            break;
        case TAPE_LOG:
            if (!mpfi_is_strictly_pos(a->v)) {
                bad = 1;
                break;
            }
            mpfi_log(o->v, a->v);
            mpfi_ui_div(s, 1, a->v);
            scale_grad(o, s, a);
            break;
        case TAPE_SIN:
            mpfi_sin(o->v, a->v);
            mpfi_cos(s, a->v);
            scale_grad(o, s, a);
            break;
        case TAPE_COS:
            mpfi_cos(o->v, a->v);
            mpfi_sin(s, a->v);
            mpfi_neg(s, s);
            scale_grad(o, s, a);
            break;
        case TAPE_TAN:
            mpfi_tan(o->v, a->v);
            mpfi_sqr(s, o->v);
            mpfi_add_ui(s, s, 1);
            scale_grad(o, s, a);
            break;
        case TAPE_ATAN:
            mpfi_atan(o->v, a->v);
            mpfi_sqr(s, a->v);
            mpfi_add_ui(s, s, 1);
            mpfi_ui_div(s, 1, s);
            scale_grad(o, s, a);
            break;
        case TAPE_ABS:
            mpfi_abs(o->v, a->v);
            if (mpfi_is_strictly_pos(a->v))
                mpfi_set_si(s, 1);
            else if (mpfi_is_strictly_neg(a->v))
                mpfi_set_si(s, -1);
            else {
                bad = grad != NULL;
                mpfi_set_ui(s, 0);
            }
            scale_grad(o, s, a);
            break;
        case TAPE_ADD:
            mpfi_add(o->v, a->v, b->v);
            for (int k = 0; k < 3; k++)
                mpfi_add(o->d[k], a->d[k], b->d[k]);
            break;
        case TAPE_SUB:
            mpfi_sub(o->v, a->v, b->v);
            for (int k = 0; k < 3; k++)
                mpfi_sub(o->d[k], a->d[k], b->d[k]);
            break;
        case TAPE_MUL:
            mpfi_mul(o->v, a->v, b->v);
            for (int k = 0; k < 3; k++) {
                mpfi_mul(s, a->d[k], b->v);
                mpfi_mul(u, a->v, b->d[k]);
                mpfi_add(o->d[k], s, u);
            }
            break;
        case TAPE_DIV:
            if (mpfi_has_zero(b->v)) {
                bad = 1;
                break;
            }
            mpfi_div(o->v, a->v, b->v);
            for (int k = 0; k < 3; k++) {
                mpfi_mul(s, o->v, b->d[k]);
                mpfi_sub(s, a->d[k], s);
                mpfi_div(o->d[k], s, b->v);
            }
            break;
        case TAPE_MIN:
        case TAPE_MAX: {
            int cmp = compare(a->v, b->v, s);
            if (cmp == 0) {
                /* a tie: the value is either; the gradient is not defined */
                slot_set(o, a);
                bad = grad != NULL;
                break;
            }
            int pick_a = (c->op == TAPE_MIN) == (cmp < 0);
            slot_set(o, pick_a ? a : b);
            break;
        }
        case TAPE_OP_COUNT:
            bad = 1;
            break;
        }
        if (!bad && mpfi_nan_p(o->v))
            bad = 1;
        if (bad) {
            for (uint32_t j = 0; j <= i; j++)
                slot_clear(&S[j]);
            break;
        }
    }
    if (!bad) {
        mpfi_set(value, S[t->n - 1].v);
        if (grad)
            for (int k = 0; k < 3; k++) {
                mpfi_set(grad[k], S[t->n - 1].d[k]);
                if (mpfi_nan_p(grad[k]))
                    bad = 1;
            }
        for (uint32_t j = 0; j < t->n; j++)
            slot_clear(&S[j]);
    }
    mpfi_clear(s);
    mpfi_clear(u);
    free(S);
    return bad;
}

int oracle_eval(const tape_t *t, const double p[3], oracle_const_t which, mpfi_t value,
                mpfi_t grad[3])
{
    mpfi_t P[3];
    for (int k = 0; k < 3; k++) {
        mpfi_init2(P[k], ORACLE_PREC);
        mpfi_set_d(P[k], p[k]);
    }
    int bad = eval_at(t, P, which, value, grad);
    for (int k = 0; k < 3; k++)
        mpfi_clear(P[k]);
    return bad;
}

int oracle_eval_ray(const tape_t *t, const double o[3], const double d[3], double tt,
                    oracle_const_t which, mpfi_t value, mpfi_t dvalue, mpfi_t grad[3])
{
    mpfi_t P[3];
    for (int k = 0; k < 3; k++) {
        mpfi_init2(P[k], ORACLE_PREC);
        mpfi_set_d(P[k], d[k]);
        mpfi_mul_d(P[k], P[k], tt);
        mpfi_add_d(P[k], P[k], o[k]);
    }
    int bad = eval_at(t, P, which, value, grad);
    if (!bad) {
        mpfi_set_ui(dvalue, 0);
        for (int k = 0; k < 3; k++) {
            mpfi_mul_d(P[k], grad[k], d[k]);
            mpfi_add(dvalue, dvalue, P[k]);
        }
    }
    for (int k = 0; k < 3; k++)
        mpfi_clear(P[k]);
    return bad;
}

int oracle_contained(mpfi_t v, iv_t d)
{
    if (iv_is_empty(d))
        return 0;
    mpfr_t l, r;
    mpfr_init2(l, ORACLE_PREC);
    mpfr_init2(r, ORACLE_PREC);
    mpfi_get_left(l, v);
    mpfi_get_right(r, v);
    int ok = mpfr_cmp_d(l, d.lo) >= 0 && mpfr_cmp_d(r, d.hi) <= 0;
    mpfr_clear(l);
    mpfr_clear(r);
    return ok;
}

int oracle_check_tape(const tape_t *t, const double box[6], long nbox, int points_per_box,
                      uint64_t *rng, oracle_stats_t *st)
{
    memset(st, 0, sizeof *st);
    tape_ws_t *ws = tape_ws_new(t->n);
    mpfi_t v, g[3];
    mpfi_init2(v, ORACLE_PREC);
    for (int k = 0; k < 3; k++)
        mpfi_init2(g[k], ORACLE_PREC);
    enum { BATCH = TAPE_BATCH + 13 }; /* two passes, the second short and padded */
    int fail = ws == NULL;
    for (long done = 0; done < nbox && !fail; done += BATCH) {
        iv_box_t boxes[BATCH];
        iv_t F[BATCH];
        iv_grad_t G[BATCH];
        for (int i = 0; i < BATCH; i++)
            boxes[i] = tu_random_subbox(box, rng);
        tape_eval_interval(t, ws, BATCH, boxes, F);
        tape_eval_grad(t, ws, BATCH, boxes, G);
        /* a short batch (1 to 8 boxes: padded, and on some paths run by a pass
         * compiled for 8 lanes) gives each box the bits the long one gave it */
        int nshort = 1 + (int)((done / BATCH) % 8);
        iv_t Fs[8];
        tape_eval_interval(t, ws, (size_t)nshort, boxes + BATCH - nshort, Fs);
        for (int i = 0; i < nshort && !fail; i++)
            if (memcmp(&Fs[i], &F[BATCH - nshort + i], sizeof Fs[i]) != 0 &&
                !(iv_is_empty(Fs[i]) && iv_is_empty(F[BATCH - nshort + i]))) {
                snprintf(st->failure, sizeof st->failure,
                         "box %d of a batch of %d: [%.17g, %.17g], alone in a batch of %d:"
                         " [%.17g, %.17g]",
                         BATCH - nshort + i, BATCH, F[BATCH - nshort + i].lo,
                         F[BATCH - nshort + i].hi, nshort, Fs[i].lo, Fs[i].hi);
                fail = 1;
            }
        for (int i = 0; i < BATCH && !fail; i++) {
            for (int j = 0; j < points_per_box && !fail; j++) {
                double p[3] = {tu_pick(boxes[i].x, rng), tu_pick(boxes[i].y, rng),
                               tu_pick(boxes[i].z, rng)};
                oracle_const_t which = (j & 1) ? ORACLE_CONST_HI : ORACLE_CONST_LO;
                if (oracle_eval(t, p, which, v, NULL) != 0) {
                    st->skipped++;
                    continue;
                }
                st->checked++;
                if (!oracle_contained(v, F[i]) || !oracle_contained(v, G[i].v)) {
                    mpfr_snprintf(st->failure, sizeof st->failure,
                                  "f(%.17g, %.17g, %.17g) = %.20RNg not in [%.17g, %.17g]"
                                  " (grad eval [%.17g, %.17g])",
                                  p[0], p[1], p[2], &v->left, F[i].lo, F[i].hi, G[i].v.lo,
                                  G[i].v.hi);
                    fail = 1;
                    break;
                }
                if (oracle_eval(t, p, which, v, g) != 0)
                    continue;
                st->checked_grad++;
                iv_t d[3] = {G[i].dx, G[i].dy, G[i].dz};
                for (int k = 0; k < 3 && !fail; k++)
                    if (!oracle_contained(g[k], d[k])) {
                        mpfr_snprintf(st->failure, sizeof st->failure,
                                      "df/d%c(%.17g, %.17g, %.17g) = %.20RNg not in "
                                      "[%.17g, %.17g]",
                                      "xyz"[k], p[0], p[1], p[2], &g[k]->left, d[k].lo,
                                      d[k].hi);
                        fail = 1;
                    }
            }
        }
    }
    mpfi_clear(v);
    for (int k = 0; k < 3; k++)
        mpfi_clear(g[k]);
    tape_ws_free(ws);
    return fail;
}

/* Is |p - x| <= 2 (e.hi - e.lo) + 2^-50 max(|e.lo|, |e.hi|), x the oracle's
 * value (a 256-bit interval: its left end) and e the rigorous enclosure at the
 * point?  An e that is not finite bounds nothing: true. */
static int near_enclosed(mpfi_t x, double p, iv_t e)
{
    if (!isfinite(e.lo) || !isfinite(e.hi))
        return 1;
    if (!isfinite(p))
        return 0;
    mpfr_t err, tol, t;
    mpfr_inits2(ORACLE_PREC, err, tol, t, (mpfr_ptr)0);
    mpfi_get_left(err, x);
    mpfr_sub_d(err, err, p, MPFR_RNDN);
    mpfr_abs(err, err, MPFR_RNDN);
    mpfr_set_d(tol, e.hi, MPFR_RNDN);
    mpfr_sub_d(tol, tol, e.lo, MPFR_RNDN);
    mpfr_mul_2ui(tol, tol, 1, MPFR_RNDN);
    double big = fabs(e.lo) > fabs(e.hi) ? fabs(e.lo) : fabs(e.hi);
    mpfr_set_d(t, big, MPFR_RNDN);
    mpfr_mul_2si(t, t, -50, MPFR_RNDN);
    mpfr_add(tol, tol, t, MPFR_RNDN);
    int ok = mpfr_cmp(err, tol) <= 0;
    mpfr_clears(err, tol, t, (mpfr_ptr)0);
    return ok;
}

int oracle_check_point_grad(const tape_t *t, const double box[6], long npoints, uint64_t *rng,
                            oracle_stats_t *st)
{
    memset(st, 0, sizeof *st);
    tape_ws_t *ws = tape_ws_new(t->n);
    mpfi_t v, g[3];
    mpfi_init2(v, ORACLE_PREC);
    for (int k = 0; k < 3; k++)
        mpfi_init2(g[k], ORACLE_PREC);
    enum { BATCH = TAPE_BATCH + 13 }; /* two passes, the second short */
    int fail = ws == NULL;
    for (long done = 0; done < npoints && !fail; done += BATCH) {
        double x[BATCH], y[BATCH], z[BATCH], P[BATCH];
        iv_box_t pts[BATCH];
        tape_point_grad_t Q[BATCH];
        iv_grad_t G[BATCH];
        for (int i = 0; i < BATCH; i++) {
            x[i] = tu_pick(iv_make(box[0], box[1]), rng);
            y[i] = tu_pick(iv_make(box[2], box[3]), rng);
            z[i] = tu_pick(iv_make(box[4], box[5]), rng);
            pts[i] = (iv_box_t){iv_point(x[i]), iv_point(y[i]), iv_point(z[i])};
        }
        tape_eval_point_grad(t, ws, BATCH, x, y, z, Q);
        tape_eval_point(t, ws, BATCH, x, y, z, P);
        tape_eval_grad(t, ws, BATCH, pts, G);
        for (int i = 0; i < BATCH && !fail; i++) {
            double p[3] = {x[i], y[i], z[i]};
            if (memcmp(&P[i], &Q[i].v, sizeof P[i]) != 0) {
                snprintf(st->failure, sizeof st->failure,
                         "f(%.17g, %.17g, %.17g): tape_eval_point_grad %.17g, tape_eval_point "
                         "%.17g",
                         p[0], p[1], p[2], Q[i].v, P[i]);
                fail = 1;
                break;
            }
            oracle_const_t which = (i & 1) ? ORACLE_CONST_HI : ORACLE_CONST_LO;
            if (oracle_eval(t, p, which, v, g) != 0) {
                st->skipped++;
                continue;
            }
            st->checked++;
            double q[4] = {Q[i].v, Q[i].dx, Q[i].dy, Q[i].dz};
            iv_t e[4] = {G[i].v, G[i].dx, G[i].dy, G[i].dz};
            for (int k = 0; k < 4 && !fail; k++) {
                if (!near_enclosed(k ? g[k - 1] : v, q[k], e[k])) {
                    mpfr_snprintf(st->failure, sizeof st->failure,
                                  "%s(%.17g, %.17g, %.17g) = %.20RNg: tape_eval_point_grad "
                                  "%.17g, enclosure [%.17g, %.17g]",
                                  (const char *[]){"f", "df/dx", "df/dy", "df/dz"}[k], p[0],
                                  p[1], p[2], k ? &g[k - 1]->left : &v->left, q[k], e[k].lo,
                                  e[k].hi);
                    fail = 1;
                }
                if (k > 0 && isfinite(e[k].lo) && isfinite(e[k].hi))
                    st->checked_grad++;
            }
        }
    }
    mpfi_clear(v);
    for (int k = 0; k < 3; k++)
        mpfi_clear(g[k]);
    tape_ws_free(ws);
    return fail;
}
