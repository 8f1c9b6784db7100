/* ivoct — modal intervals and the semantic extensions of a tape (modal.h). */
#include "modal.h"

#include <math.h>
#include <stdlib.h>

/* ---- lattice ---------------------------------------------------------------- */
mod_t mod_prop(mod_t a)
{
    if (mod_is_nan(a))
        return mod_make(NAN, NAN);
    return a.lo <= a.hi ? a : mod_dual(a);
}

mod_t mod_impr(mod_t a)
{
    if (mod_is_nan(a))
        return mod_make(NAN, NAN);
    return a.lo >= a.hi ? a : mod_dual(a);
}

iv_t mod_set(mod_t a)
{
    mod_t p = mod_prop(a);
    return iv_make(p.lo, p.hi);
}

bool mod_subset(mod_t a, mod_t b) { return b.lo <= a.lo && a.hi <= b.hi; }

mod_t mod_meet(mod_t a, mod_t b)
{
    if (mod_is_nan(a) || mod_is_nan(b))
        return mod_make(NAN, NAN);
    return mod_make(fmax(a.lo, b.lo), fmin(a.hi, b.hi));
}

mod_t mod_join(mod_t a, mod_t b)
{
    if (mod_is_nan(a) || mod_is_nan(b))
        return mod_make(NAN, NAN);
    return mod_make(fmin(a.lo, b.lo), fmax(a.hi, b.hi));
}

/* ---- rounding of one bound ----------------------------------------------------
 * A lower bound is rounded down for MOD_OUTER and up for MOD_INNER; an upper
 * bound the other way.  "down" = iv_down (below the exact value), "up" = iv_up. */
static inline double rnd_lo(double x, mod_round_t r) { return r == MOD_OUTER ? iv_down(x) : iv_up(x); }
static inline double rnd_hi(double x, mod_round_t r) { return r == MOD_OUTER ? iv_up(x) : iv_down(x); }

/* x + y as a lower / upper bound, exact when a term is 0 */
static inline double sum_lo(double x, double y, mod_round_t r)
{
    return (x == 0 || y == 0) ? x + y : rnd_lo(x + y, r);
}

static inline double sum_hi(double x, double y, mod_round_t r)
{
    return (x == 0 || y == 0) ? x + y : rnd_hi(x + y, r);
}

static inline double prod_lo(double x, double y, mod_round_t r)
{
    return (x == 0 || y == 0) ? 0.0 : rnd_lo(x * y, r);
}

static inline double prod_hi(double x, double y, mod_round_t r)
{
    return (x == 0 || y == 0) ? 0.0 : rnd_hi(x * y, r);
}

static inline double quot_lo(double x, double y, mod_round_t r)
{
    return x == 0 ? 0.0 : rnd_lo(x / y, r);
}

static inline double quot_hi(double x, double y, mod_round_t r)
{
    return x == 0 ? 0.0 : rnd_hi(x / y, r);
}

/* ---- Kaucher arithmetic ------------------------------------------------------- */
mod_t mod_neg(mod_t a) { return mod_make(-a.hi, -a.lo); }

mod_t mod_add(mod_t a, mod_t b, mod_round_t r)
{
    if (mod_is_nan(a) || mod_is_nan(b))
        return mod_make(NAN, NAN);
    return mod_make(sum_lo(a.lo, b.lo, r), sum_hi(a.hi, b.hi, r));
}

mod_t mod_sub(mod_t a, mod_t b, mod_round_t r)
{
    if (mod_is_nan(a) || mod_is_nan(b))
        return mod_make(NAN, NAN);
    return mod_make(sum_lo(a.lo, -b.hi, r), sum_hi(a.hi, -b.lo, r));
}

/* Kaucher's classes: P (both bounds >= 0), N = -P (both <= 0), Z (a1 < 0 < a2,
 * proper holding 0 inside), D = Dual Z (a1 > 0 > a2).  [0, 0] is P. */
enum { CL_P, CL_N, CL_Z, CL_D };

static int kclass(mod_t a)
{
    if (a.lo >= 0 && a.hi >= 0)
        return CL_P;
    if (a.lo <= 0 && a.hi <= 0)
        return CL_N;
    return a.lo < 0 ? CL_Z : CL_D;
}

/* One bound of the Kaucher product: the product of a_i and b_j (i, j in
 * {1, 2}), or for the two mixed cases the min / max of two such products. */
typedef struct {
    signed char i, j;   /* first product a_i b_j */
    signed char i2, j2; /* second product, 0 when none */
    signed char use_max;
} kterm_t;

typedef struct {
    kterm_t lo, hi;
} kentry_t;

#define KT(i, j) {i, j, 0, 0, 0}
/* Kaucher's multiplication table, [class of A][class of B] (modal/README.md) */
static const kentry_t ktable[4][4] = {
    /* A in P */
    {/* B P */ {KT(1, 1), KT(2, 2)}, /* B N */ {KT(2, 1), KT(1, 2)},
     /* B Z */ {KT(2, 1), KT(2, 2)}, /* B D */ {KT(1, 1), KT(1, 2)}},
    /* A in N */
    {/* B P */ {KT(1, 2), KT(2, 1)}, /* B N */ {KT(2, 2), KT(1, 1)},
     /* B Z */ {KT(1, 2), KT(1, 1)}, /* B D */ {KT(2, 2), KT(2, 1)}},
    /* A in Z */
    {/* B P */ {KT(1, 2), KT(2, 2)}, /* B N */ {KT(2, 1), KT(1, 1)},
     /* B Z */ {{1, 2, 2, 1, 0}, {1, 1, 2, 2, 1}}, /* B D */ {KT(0, 0), KT(0, 0)}},
    /* A in D */
    {/* B P */ {KT(1, 1), KT(2, 1)}, /* B N */ {KT(2, 2), KT(1, 2)},
     /* B Z */ {KT(0, 0), KT(0, 0)}, /* B D */ {{1, 1, 2, 2, 1}, {1, 2, 2, 1, 0}}},
};
#undef KT

/* The bound of a term: the pair (a_i, b_j) combined by op (product or
 * quotient), rounded as a lower (is_lo) or upper bound. */
typedef double (*bound_fn)(double, double, mod_round_t);

static double kterm_eval(const kterm_t *k, const double a[3], const double b[3], bound_fn f,
                         mod_round_t r)
{
    if (k->i == 0)
        return 0.0; /* Z x Dual Z: [0, 0] */
    double p = f(a[k->i], b[k->j], r);
    if (k->i2 == 0)
        return p;
    double q = f(a[k->i2], b[k->j2], r);
    return k->use_max ? fmax(p, q) : fmin(p, q);
}

mod_t mod_mul(mod_t a, mod_t b, mod_round_t r)
{
    if (mod_is_nan(a) || mod_is_nan(b))
        return mod_make(NAN, NAN);
    const kentry_t *e = &ktable[kclass(a)][kclass(b)];
    const double A[3] = {0, a.lo, a.hi}, B[3] = {0, b.lo, b.hi};
    return mod_make(kterm_eval(&e->lo, A, B, prod_lo, r), kterm_eval(&e->hi, A, B, prod_hi, r));
}

/* A / B = A * C with C = [1/b2, 1/b1]: c_1 = 1/b_2, c_2 = 1/b_1, so the term
 * a_i c_j is the quotient a_i / b_(3-j), rounded once. */
mod_t mod_div(mod_t a, mod_t b, mod_round_t r)
{
    if (mod_is_nan(a) || mod_is_nan(b))
        return mod_make(NAN, NAN);
    iv_t sb = mod_set(b);
    if (!(sb.lo > 0 || sb.hi < 0))
        return mod_make(NAN, NAN);
    /* the class of C is that of B (same signs) */
    const kentry_t *e = &ktable[kclass(a)][kclass(b)];
    const double A[3] = {0, a.lo, a.hi}, Bq[3] = {0, b.hi, b.lo};
    return mod_make(kterm_eval(&e->lo, A, Bq, quot_lo, r), kterm_eval(&e->hi, A, Bq, quot_hi, r));
}

/* ---- functions of one variable ------------------------------------------------
 * phi's extension from candidate points: the minimum and maximum of phi over
 * Set(A) are attained at one of the candidates (the ends of Set(A) and the
 * interior critical points, all exact doubles).  Each phi(c) is enclosed by
 * the rigorous point enclosure E(c) = [down, up]; then
 *   proper A:   lo = min phi, hi = max phi;   improper A: lo = max phi, hi = min phi,
 * a lower bound taken from E.lo (outer) or E.hi (inner), an upper bound the
 * other way: the min / max of values each on the right side of its phi(c) is
 * on the right side of the min / max. */
typedef iv_t (*encl_fn)(double x, const void *arg);

static mod_t unary_ext(mod_t a, encl_fn phi, const void *arg, const double *cand, int nc,
                       mod_round_t r)
{
    bool proper = a.lo <= a.hi;
    double lo = 0, hi = 0;
    for (int k = 0; k < nc; k++) {
        iv_t e = phi(cand[k], arg);
        if (iv_is_empty(e))
            return mod_make(NAN, NAN);
        double vlo = r == MOD_OUTER ? e.lo : e.hi; /* for a lower bound */
        double vhi = r == MOD_OUTER ? e.hi : e.lo; /* for an upper bound */
        if (k == 0) {
            lo = vlo;
            hi = vhi;
        } else if (proper) {
            lo = fmin(lo, vlo);
            hi = fmax(hi, vhi);
        } else {
            lo = fmax(lo, vlo);
            hi = fmin(hi, vhi);
        }
    }
    return mod_make(lo, hi);
}

static mod_t unary_monotone(mod_t a, encl_fn phi, const void *arg, mod_round_t r)
{
    if (mod_is_nan(a))
        return mod_make(NAN, NAN);
    const double c[2] = {a.lo, a.hi};
    return unary_ext(a, phi, arg, c, 2, r);
}

static iv_t e_sqr(double x, const void *arg) { (void)arg; return iv_sqr(iv_point(x)); }
static iv_t e_powi(double x, const void *arg) { return iv_powi(iv_point(x), *(const int *)arg); }
static iv_t e_powr(double x, const void *arg) { return iv_powr(iv_point(x), *(const double *)arg); }
static iv_t e_sqrt(double x, const void *arg) { (void)arg; return iv_sqrt(iv_point(x)); }
static iv_t e_exp(double x, const void *arg) { (void)arg; return iv_exp(iv_point(x)); }
static iv_t e_log(double x, const void *arg) { (void)arg; return iv_log(iv_point(x)); }
static iv_t e_atan(double x, const void *arg) { (void)arg; return iv_atan(iv_point(x)); }
static iv_t e_sin(double x, const void *arg) { (void)arg; return iv_sin(iv_point(x)); }
static iv_t e_cos(double x, const void *arg) { (void)arg; return iv_cos(iv_point(x)); }
static iv_t e_tan(double x, const void *arg) { (void)arg; return iv_tan(iv_point(x)); }

/* |x|^n-like shape: min at 0 when 0 is inside Set(A) */
static mod_t unary_even(mod_t a, encl_fn phi, const void *arg, mod_round_t r)
{
    if (mod_is_nan(a))
        return mod_make(NAN, NAN);
    iv_t s = mod_set(a);
    double c[3] = {a.lo, a.hi, 0.0};
    return unary_ext(a, phi, arg, c, (s.lo < 0 && s.hi > 0) ? 3 : 2, r);
}

mod_t mod_sqr(mod_t a, mod_round_t r) { return unary_even(a, e_sqr, NULL, r); }

mod_t mod_powi(mod_t a, int n, mod_round_t r)
{
    if (mod_is_nan(a))
        return mod_make(NAN, NAN);
    if (n == 0)
        return mod_point(1.0);
    iv_t s = mod_set(a);
    if (n < 0 && !(s.lo > 0 || s.hi < 0))
        return mod_make(NAN, NAN);
    if (n > 0 && n % 2 == 0)
        return unary_even(a, e_powi, &n, r);
    return unary_monotone(a, e_powi, &n, r); /* odd n, or n < 0 on one side of 0 */
}

mod_t mod_powr(mod_t a, double e, mod_round_t r)
{
    if (mod_is_nan(a) || !(e == e) || e == floor(e))
        return mod_make(NAN, NAN);
    iv_t s = mod_set(a);
    if (e > 0 ? !(s.lo >= 0) : !(s.lo > 0))
        return mod_make(NAN, NAN);
    return unary_monotone(a, e_powr, &e, r);
}

mod_t mod_sqrt(mod_t a, mod_round_t r)
{
    if (mod_is_nan(a) || !(mod_set(a).lo >= 0))
        return mod_make(NAN, NAN);
    return unary_monotone(a, e_sqrt, NULL, r);
}

mod_t mod_exp(mod_t a, mod_round_t r) { return unary_monotone(a, e_exp, NULL, r); }

mod_t mod_log(mod_t a, mod_round_t r)
{
    if (mod_is_nan(a) || !(mod_set(a).lo > 0))
        return mod_make(NAN, NAN);
    return unary_monotone(a, e_log, NULL, r);
}

mod_t mod_atan(mod_t a, mod_round_t r) { return unary_monotone(a, e_atan, NULL, r); }

/* sin is monotone on Set(A) when its derivative cos has one sign there */
static bool one_sign(iv_t d) { return !iv_is_empty(d) && (d.lo >= 0 || d.hi <= 0); }

mod_t mod_sin(mod_t a, mod_round_t r)
{
    if (mod_is_nan(a) || !one_sign(iv_cos(mod_set(a))))
        return mod_make(NAN, NAN);
    return unary_monotone(a, e_sin, NULL, r);
}

mod_t mod_cos(mod_t a, mod_round_t r)
{
    if (mod_is_nan(a) || !one_sign(iv_sin(mod_set(a))))
        return mod_make(NAN, NAN);
    return unary_monotone(a, e_cos, NULL, r);
}

mod_t mod_tan(mod_t a, mod_round_t r)
{
    if (mod_is_nan(a))
        return mod_make(NAN, NAN);
    iv_t t = iv_tan(mod_set(a)); /* whole line when a pole may be inside */
    if (iv_is_empty(t) || !isfinite(t.lo) || !isfinite(t.hi))
        return mod_make(NAN, NAN);
    return unary_monotone(a, e_tan, NULL, r);
}

/* ---- tapes ------------------------------------------------------------------------ */
const char *mod_status_name(mod_status_t s)
{
    switch (s) {
    case MOD_OK: return "ok";
    case MOD_NOT_INTERPRETABLE: return "not interpretable";
    case MOD_UNSUPPORTED: return "unsupported operation";
    case MOD_DOMAIN: return "not proved defined and continuous (or monotone) on the box";
    case MOD_OVERFLOW: return "overflow";
    case MOD_NO_INNER: return "no inner estimate (improper result)";
    case MOD_EINVAL: return "invalid argument";
    case MOD_ENOMEM: return "out of memory";
    }
    return "unknown status";
}

static bool op_supported(uint32_t op)
{
    switch ((tape_op_t)op) {
    case TAPE_CONST: case TAPE_X: case TAPE_Y: case TAPE_Z:
    case TAPE_NEG: case TAPE_SQR: case TAPE_POWI: case TAPE_POWR:
    case TAPE_SQRT: case TAPE_EXP: case TAPE_LOG:
    case TAPE_SIN: case TAPE_COS: case TAPE_TAN: case TAPE_ATAN:
    case TAPE_ADD: case TAPE_SUB: case TAPE_MUL: case TAPE_DIV:
        return true;
    default:
        return false;
    }
}

static int arity(uint32_t op)
{
    return op < TAPE_OP_COUNT ? tape_op_arity((tape_op_t)op) : 0;
}

bool mod_tape_supported(const tape_t *t)
{
    if (!t || t->n == 0)
        return false;
    for (uint32_t i = 0; i < t->n; i++) {
        const tape_clause_t *c = &t->clauses[i];
        if (!op_supported(c->op))
            return false;
        int ar = arity(c->op);
        if ((ar >= 1 && c->a >= i) || (ar == 2 && c->b >= i))
            return false; /* not a well-formed tape */
    }
    return true;
}

static uint64_t sat_add(uint64_t a, uint64_t b) { return a > UINT64_MAX - b ? UINT64_MAX : a + b; }

#define MOD_STACK_CLAUSES 1024

int mod_incidences(const tape_t *t, uint64_t inc[3])
{
    inc[0] = inc[1] = inc[2] = 0;
    if (!t || t->n == 0)
        return 0;
    uint64_t stack[MOD_STACK_CLAUSES], *paths = stack;
    if (t->n > MOD_STACK_CLAUSES) {
        paths = malloc(t->n * sizeof *paths);
        if (!paths)
            return -1;
    }
    for (uint32_t i = 0; i < t->n; i++)
        paths[i] = 0;
    paths[t->n - 1] = 1;
    for (uint32_t i = t->n; i-- > 0;) {
        const tape_clause_t *c = &t->clauses[i];
        int ar = arity(c->op);
        if (ar >= 1 && c->a < i)
            paths[c->a] = sat_add(paths[c->a], paths[i]);
        if (ar == 2 && c->b < i)
            paths[c->b] = sat_add(paths[c->b], paths[i]);
        if (c->op == TAPE_X || c->op == TAPE_Y || c->op == TAPE_Z)
            inc[c->op - TAPE_X] = sat_add(inc[c->op - TAPE_X], paths[i]);
    }
    if (paths != stack)
        free(paths);
    return 0;
}

static mod_t clause_modal(const tape_clause_t *c, const mod_t *S, const mod_t X[3],
                          mod_round_t r)
{
    /* operands only for ops that have them (mod_tape_supported checked a, b < i) */
    mod_t a = arity(c->op) >= 1 ? S[c->a] : mod_make(NAN, NAN);
    switch ((tape_op_t)c->op) {
    case TAPE_CONST:
        return r == MOD_OUTER ? mod_make(c->c.lo, c->c.hi) : mod_make(c->c.hi, c->c.lo);
    case TAPE_X: return X[0];
    case TAPE_Y: return X[1];
    case TAPE_Z: return X[2];
    case TAPE_NEG: return mod_neg(a);
    case TAPE_SQR: return mod_sqr(a, r);
    case TAPE_POWI: return mod_powi(a, (int)c->c.lo, r);
    case TAPE_POWR: return mod_powr(a, c->c.lo, r);
    case TAPE_SQRT: return mod_sqrt(a, r);
    case TAPE_EXP: return mod_exp(a, r);
    case TAPE_LOG: return mod_log(a, r);
    case TAPE_SIN: return mod_sin(a, r);
    case TAPE_COS: return mod_cos(a, r);
    case TAPE_TAN: return mod_tan(a, r);
    case TAPE_ATAN: return mod_atan(a, r);
    case TAPE_ADD: return mod_add(a, S[c->b], r);
    case TAPE_SUB: return mod_sub(a, S[c->b], r);
    case TAPE_MUL: return mod_mul(a, S[c->b], r);
    case TAPE_DIV: return mod_div(a, S[c->b], r);
    default: return mod_make(NAN, NAN);
    }
}

static bool finite_mod(mod_t a) { return isfinite(a.lo) && isfinite(a.hi); }

static mod_status_t tape_eval_slots(const tape_t *t, const mod_t X[3], mod_round_t r,
                                    mod_t *S, mod_t *out)
{
    for (uint32_t i = 0; i < t->n; i++) {
        mod_t v = clause_modal(&t->clauses[i], S, X, r);
        if (mod_is_nan(v))
            return MOD_DOMAIN;
        if (!finite_mod(v))
            return MOD_OVERFLOW;
        S[i] = v;
    }
    *out = S[t->n - 1];
    return MOD_OK;
}

static mod_status_t check_box(const mod_t X[3])
{
    for (int k = 0; k < 3; k++)
        if (!finite_mod(X[k]))
            return MOD_EINVAL;
    return MOD_OK;
}

mod_status_t mod_tape_eval(const tape_t *t, const mod_t X[3], mod_round_t r, mod_t *out)
{
    if (!t || !X || !out)
        return MOD_EINVAL;
    *out = mod_make(NAN, NAN);
    if (check_box(X) != MOD_OK)
        return MOD_EINVAL;
    if (!mod_tape_supported(t))
        return MOD_UNSUPPORTED;
    mod_t stack[256], *S = stack;
    if (t->n > 256) {
        S = malloc(t->n * sizeof *S);
        if (!S)
            return MOD_ENOMEM;
    }
    mod_status_t st = tape_eval_slots(t, X, r, S, out);
    if (st != MOD_OK)
        *out = mod_make(NAN, NAN);
    if (S != stack)
        free(S);
    return st;
}

/* f defined and continuous on the box Set(X), and whether C^1 there (so the
 * interval gradient proves monotonicity), is tape_check_continuous (expr/). */

/* The common driver of mod_star (want_improper = false, outer rounding) and
 * mod_dstar (want_improper = true, inner rounding); dualise: make blocking
 * variables improper instead of failing (mod_inner_range). */
static mod_status_t extension(const tape_t *t, const mod_t Xin[3], bool want_improper,
                              bool dualise, mod_t *out, mod_info_t *info)
{
    mod_info_t local;
    if (!info)
        info = &local;
    *info = (mod_info_t){{0, 0, 0}, {0, 0, 0}, {MOD_VAR_ABSENT, MOD_VAR_ABSENT, MOD_VAR_ABSENT}, 0};
    if (!t || !Xin || !out)
        return MOD_EINVAL;
    *out = mod_make(NAN, NAN);
    if (check_box(Xin) != MOD_OK)
        return MOD_EINVAL;
    if (!mod_tape_supported(t))
        return MOD_UNSUPPORTED;
    mod_round_t r = want_improper ? MOD_INNER : MOD_OUTER;
    mod_t X[3] = {Xin[0], Xin[1], Xin[2]};
    iv_t s0 = mod_set(X[0]), s1 = mod_set(X[1]), s2 = mod_set(X[2]);
    iv_box_t box = {s0, s1, s2};

    mod_status_t st = MOD_ENOMEM;
    iv_t *S = malloc(t->n * sizeof *S);
    mod_t *M = malloc(t->n * sizeof *M);
    tape_ws_t *ws = NULL;
    if (!S || !M)
        goto done;
    if (mod_incidences(t, info->incidence) != 0)
        goto done;
    int smooth_i;
    switch (tape_check_continuous(t, &box, S, &smooth_i)) {
    case TAPE_DOMAIN_CONTINUOUS: st = MOD_OK; break;
    case TAPE_DOMAIN_OVERFLOW: st = MOD_OVERFLOW; break;
    default: st = MOD_DOMAIN; break;
    }
    if (st != MOD_OK)
        goto done;
    bool smooth = smooth_i != 0;

    bool need_grad = false;
    for (int k = 0; k < 3; k++)
        need_grad = need_grad || (info->incidence[k] > 1 && !mod_is_point(X[k]));
    iv_grad_t g = {{0, 0}, {0, 0}, {0, 0}, {0, 0}};
    if (need_grad && smooth) {
        ws = tape_ws_new(t->n);
        if (!ws) {
            st = MOD_ENOMEM;
            goto done;
        }
        tape_eval_grad(t, ws, 1, &box, &g);
    }
    const iv_t d[3] = {g.dx, g.dy, g.dz};

    /* the two boxes: Xl for the lower bound, Xh for the upper */
    mod_t Xl[3], Xh[3];
    bool two = false;
    st = MOD_OK;
    for (int k = 0; k < 3; k++) {
        Xl[k] = Xh[k] = X[k];
        if (info->incidence[k] == 0) {
            info->use[k] = MOD_VAR_ABSENT;
            continue;
        }
        if (mod_is_point(X[k])) {
            info->use[k] = MOD_VAR_POINT;
            continue;
        }
        if (info->incidence[k] == 1) {
            info->use[k] = MOD_VAR_ONCE;
            continue;
        }
        int mono = 0;
        if (need_grad && smooth && !iv_is_empty(d[k])) {
            if (d[k].lo >= 0)
                mono = 1;
            else if (d[k].hi <= 0)
                mono = -1;
        }
        info->monotone[k] = mono;
        if (mono != 0) {
            /* the modal endpoint rule, either modality */
            Xl[k] = mod_point(mono > 0 ? X[k].lo : X[k].hi);
            Xh[k] = mod_point(mono > 0 ? X[k].hi : X[k].lo);
            info->use[k] = MOD_VAR_MONOTONE;
            two = true;
            continue;
        }
        bool improper = X[k].lo > X[k].hi;
        if (improper == want_improper) {
            info->use[k] = MOD_VAR_MULTI;
        } else if (dualise) {
            Xl[k] = Xh[k] = mod_dual(X[k]);
            info->use[k] = MOD_VAR_DUALISED;
        } else {
            info->use[k] = MOD_VAR_BLOCKING;
            st = MOD_NOT_INTERPRETABLE;
        }
    }
    if (st != MOD_OK)
        goto done;

    mod_t lo_r, hi_r;
    st = tape_eval_slots(t, Xl, r, M, &lo_r);
    info->passes = 1;
    if (st != MOD_OK)
        goto done;
    hi_r = lo_r;
    if (two) {
        st = tape_eval_slots(t, Xh, r, M, &hi_r);
        info->passes = 2;
        if (st != MOD_OK)
            goto done;
    }
    *out = mod_make(lo_r.lo, hi_r.hi);
done:
    if (st != MOD_OK)
        *out = mod_make(NAN, NAN);
    tape_ws_free(ws);
    free(S);
    free(M);
    return st;
}

mod_status_t mod_star(const tape_t *t, const mod_t X[3], mod_t *out, mod_info_t *info)
{
    return extension(t, X, false, false, out, info);
}

mod_status_t mod_dstar(const tape_t *t, const mod_t X[3], mod_t *out, mod_info_t *info)
{
    return extension(t, X, true, false, out, info);
}

mod_status_t mod_inner_range(const tape_t *t, const iv_box_t *box, iv_t *out, mod_info_t *info)
{
    if (!box || !out)
        return MOD_EINVAL;
    *out = iv_empty();
    const iv_t s[3] = {box->x, box->y, box->z};
    mod_t X[3];
    for (int k = 0; k < 3; k++) {
        if (!isfinite(s[k].lo) || !isfinite(s[k].hi) || !(s[k].lo <= s[k].hi))
            return MOD_EINVAL;
        X[k] = mod_make(s[k].lo, s[k].hi);
    }
    mod_t m;
    mod_status_t st = extension(t, X, true, true, &m, info);
    if (st != MOD_OK)
        return st;
    if (!(m.lo <= m.hi))
        return MOD_NO_INNER;
    *out = iv_make(m.lo, m.hi);
    return MOD_OK;
}
