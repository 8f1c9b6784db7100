/* ivoct — the expression DAG: hash-consing, constant folding, exact rewrites,
 * and the flattening into a tape.
 *
 * Semantics that every rewrite here must keep: an expression denotes, at each
 * real point (x, y, z), either a real value or "undefined" (outside the domain
 * of sqrt, log, /, tan, real powers); the engine works with the set of values
 * over the points where f is defined (IEEE 1788 set-based semantics).  So a
 * rewrite is allowed only when both sides are defined at the same points and
 * agree there: x*x -> sqr(x) is, sqrt(x)^2 -> x is not (it would define f at
 * x < 0), x - x -> 0 is not in general (it would define 1/y - 1/y at y = 0).
 *
 * Rewrites done (a, b nodes; n an integer; all exact over the reals):
 *   constant op constant   -> folded with the rigorous iv_* operation, so the
 *                              constant encloses the exact real result
 *   a*a -> sqr(a)   (-a)*(-a) too, via sqr(-a) -> sqr(a);  abs(-a) -> abs(a)
 *   -(-a) -> a      a+0, 0+a, a-0, a*1, 1*a, a/1 -> a;  0-a, a*-1, a/-1 -> -a
 *   min(a,a), max(a,a) -> a
 *   a^n, n an exact integer, |n| <= DAG_MAX_POWI:
 *        n = 1 -> a;  n = 2 -> sqr(a);  otherwise powi(a, n)
 *        n = 0 -> 1 when a is defined everywhere ("total", below), which
 *               also gives 0^0 = 1 (the convention of pow and of IEEE 1788
 *               pown); when a may be undefined somewhere, 0*a + 1, which is
 *               1 exactly where a is defined and undefined elsewhere
 *   a^r, r a double that is not an integer -> powr(a, r): defined for a > 0
 *        (and a = 0 when r > 0), as the real power is
 *   a^b otherwise (b not a constant, or a constant that is not a double, such
 *        as 1/3 or 0.1) -> exp(b*log(a)): defined for a > 0 only, so (-8)^(1/3)
 *        is undefined, like the real power function; e^b -> exp(b)
 * Commutative operations (add, mul, min, max) order their operands by index so
 * that a+b and b+a are one node. */
#include "dag.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* pi and e rounded down and up: the doubles nearest below and above (M_PI and
 * M_E are below the real constants; tests/test_parser.c checks with MPFR). */
const iv_t dag_pi = {0x1.921fb54442d18p+1, 0x1.921fb54442d19p+1};
const iv_t dag_e = {0x1.5bf0a8b145769p+1, 0x1.5bf0a8b14576ap+1};

void dag_init(dag_t *d)
{
    memset(d, 0, sizeof *d);
}

void dag_free(dag_t *d)
{
    free(d->nodes);
    free(d->table);
    memset(d, 0, sizeof *d);
}

static int is_unary(unsigned op) { return op >= TAPE_NEG && op <= TAPE_ABS; }
static int is_binary(unsigned op) { return op >= TAPE_ADD && op <= TAPE_MAX; }

/* ---- hash-consing ---------------------------------------------------------- */

static uint64_t bits_of(double v)
{
    uint64_t u;
    memcpy(&u, &v, sizeof u);
    return u;
}

static uint64_t mix(uint64_t h)
{
    h ^= h >> 33;
    h *= 0xff51afd7ed558ccdull;
    h ^= h >> 33;
    h *= 0xc4ceb9fe1a85ec53ull;
    h ^= h >> 33;
    return h;
}

static uint64_t node_hash(const dag_node_t *n)
{
    uint64_t h = mix(n->op ^ ((uint64_t)n->a << 8) ^ ((uint64_t)n->b << 40));
    h = mix(h ^ bits_of(n->c.lo));
    return mix(h ^ bits_of(n->c.hi) ^ 0x9e3779b97f4a7c15ull);
}

/* Constants compare by bits: two enclosures are one node only when identical
 * (this also makes the empty constant {NaN, NaN} equal to itself). */
static int node_equal(const dag_node_t *p, const dag_node_t *q)
{
    return p->op == q->op && p->a == q->a && p->b == q->b && bits_of(p->c.lo) == bits_of(q->c.lo) &&
           bits_of(p->c.hi) == bits_of(q->c.hi);
}

static int table_grow(dag_t *d)
{
    uint32_t cap = d->table_cap ? d->table_cap * 2 : 1024;
    if (cap < d->table_cap || cap > (1u << 31))
        return DAG_ENOMEM;
    uint32_t *t = calloc(cap, sizeof *t);
    if (!t)
        return DAG_ENOMEM;
    for (uint32_t i = 0; i < d->n; i++) {
        uint32_t s = (uint32_t)node_hash(&d->nodes[i]) & (cap - 1);
        while (t[s])
            s = (s + 1) & (cap - 1);
        t[s] = i + 1;
    }
    free(d->table);
    d->table = t;
    d->table_cap = cap;
    return DAG_OK;
}

/* The node equal to *proto, created if absent. */
static int intern(dag_t *d, const dag_node_t *proto, uint32_t *out)
{
    /* keep the load factor at most 1/2 so probe sequences stay short */
    if ((uint64_t)(d->n + 1) * 2 > d->table_cap) {
        int rc = table_grow(d);
        if (rc)
            return rc;
    }
    uint32_t mask = d->table_cap - 1;
    uint32_t s = (uint32_t)node_hash(proto) & mask;
    for (; d->table[s]; s = (s + 1) & mask) {
        if (node_equal(&d->nodes[d->table[s] - 1], proto)) {
            *out = d->table[s] - 1;
            return DAG_OK;
        }
    }
    if (d->n == d->cap) {
        uint32_t cap = d->cap ? d->cap * 2 : 256;
        if (cap < d->cap || cap > (1u << 31))
            return DAG_ENOMEM;
        dag_node_t *nodes = realloc(d->nodes, (size_t)cap * sizeof *nodes);
        if (!nodes)
            return DAG_ENOMEM;
        d->nodes = nodes;
        d->cap = cap;
    }
    d->nodes[d->n] = *proto;
    d->table[s] = d->n + 1;
    *out = d->n++;
    return DAG_OK;
}

/* "total": defined at every real point.  Only x^0 needs it (see the top). */
static int op_total(const dag_t *d, unsigned op, uint32_t a, uint32_t b, iv_t c)
{
    switch (op) {
    case TAPE_CONST: return !iv_is_empty(c);
    case TAPE_X:
    case TAPE_Y:
    case TAPE_Z: return 1;
    case TAPE_NEG:
    case TAPE_SQR:
    case TAPE_EXP:
    case TAPE_SIN:
    case TAPE_COS:
    case TAPE_ATAN:
    case TAPE_ABS: return d->nodes[a].total;
    case TAPE_POWI: return c.lo > 0 && d->nodes[a].total;
    case TAPE_ADD:
    case TAPE_SUB:
    case TAPE_MUL:
    case TAPE_MIN:
    case TAPE_MAX: return d->nodes[a].total && d->nodes[b].total;
    default: return 0; /* DIV SQRT LOG TAN POWR */
    }
}

static int make(dag_t *d, unsigned op, uint32_t a, uint32_t b, iv_t c, uint32_t *out)
{
    dag_node_t proto;
    memset(&proto, 0, sizeof proto); /* no padding garbage in what we hash */
    proto.op = (uint8_t)op;
    proto.a = a;
    proto.b = b;
    proto.c = c;
    proto.total = (uint8_t)op_total(d, op, a, b, c);
    return intern(d, &proto, out);
}

/* ---- builders ---------------------------------------------------------------- */

static const iv_t iv_zero = {0, 0};

int dag_leaf(dag_t *d, tape_op_t op, uint32_t *out)
{
    return make(d, op, 0, 0, iv_zero, out);
}

int dag_const(dag_t *d, iv_t c, uint32_t *out)
{
    return make(d, TAPE_CONST, 0, 0, c, out);
}

static int is_const(const dag_t *d, uint32_t i) { return d->nodes[i].op == TAPE_CONST; }

/* A constant that is exactly the real number v. */
static int is_point(const dag_t *d, uint32_t i, double v)
{
    return is_const(d, i) && d->nodes[i].c.lo == v && d->nodes[i].c.hi == v;
}

/* ---- exact folding of point constants ----------------------------------------
 * The iv_* operations push every bound out by an ulp even when the operation
 * is exact, so 2*3+1 would fold to [7-, 7+] and x^(1+1) would not see an
 * integer exponent.  When the operands are points and the double result is
 * exact, the fold keeps the point; the checks below are error-free
 * transformations (TwoSum, and the fma residual, which is representable and
 * so is 0 only when the result is exact, as long as the operands are not
 * too close to the subnormal range). */
#define EXACT_MIN 0x1p-969 /* 2^(-1074 + 105): residuals at least 2^-1074 */

static int exact_sum(double a, double b, double *r)
{
    double s = a + b;
    if (!isfinite(s))
        return 0;
    double bb = s - a;
    double e = (a - (s - bb)) + (b - bb);
    *r = s;
    return e == 0;
}

static int exact_mul(double a, double b, double *r)
{
    double s = a * b;
    if (!isfinite(s))
        return 0;
    *r = s;
    if (s == 0)
        return a == 0 || b == 0;
    return fabs(s) >= EXACT_MIN && fma(a, b, -s) == 0;
}

static int exact_div(double a, double b, double *r)
{
    if (b == 0)
        return 0;
    double s = a / b;
    if (!isfinite(s))
        return 0;
    *r = s;
    if (a == 0)
        return 1;
    return s != 0 && fabs(a) >= EXACT_MIN && fma(s, b, -a) == 0;
}

static int exact_powi(double a, int n, double *r)
{
    double p = 1, base = a;
    unsigned m = n < 0 ? 0u - (unsigned)n : (unsigned)n;
    while (m) {
        if ((m & 1) && !exact_mul(p, base, &p))
            return 0;
        m >>= 1;
        if (m && !exact_mul(base, base, &base))
            return 0;
    }
    return n >= 0 ? (*r = p, 1) : exact_div(1, p, r);
}

static int exact_sqrt(double a, double *r)
{
    if (!(a >= 0))
        return 0;
    double s = sqrt(a);
    *r = s;
    return a == 0 || (a >= EXACT_MIN && fma(s, s, -a) == 0);
}

static int is_point_iv(iv_t a) { return a.lo == a.hi && isfinite(a.lo); }

static iv_t fold_unary(unsigned op, iv_t a, double param)
{
    double r;
    if (is_point_iv(a)) {
        int exact = 0;
        switch (op) {
        case TAPE_SQR: exact = exact_mul(a.lo, a.lo, &r); break;
        case TAPE_POWI: exact = exact_powi(a.lo, (int)param, &r); break;
        case TAPE_SQRT: exact = exact_sqrt(a.lo, &r); break;
        default: break;
        }
        if (exact)
            return iv_point(r);
    }
    switch (op) {
    case TAPE_NEG: return iv_neg(a);
    case TAPE_SQR: return iv_sqr(a);
    case TAPE_POWI: return iv_powi(a, (int)param);
    case TAPE_POWR: return iv_powr(a, param);
    case TAPE_SQRT: return iv_sqrt(a);
    case TAPE_EXP: return iv_exp(a);
    case TAPE_LOG: return iv_log(a);
    case TAPE_SIN: return iv_sin(a);
    case TAPE_COS: return iv_cos(a);
    case TAPE_TAN: return iv_tan(a);
    case TAPE_ATAN: return iv_atan(a);
    default: return iv_abs(a); /* TAPE_ABS */
    }
}

static iv_t fold_binary(unsigned op, iv_t a, iv_t b)
{
    double r;
    if (is_point_iv(a) && is_point_iv(b)) {
        int exact = 0;
        switch (op) {
        case TAPE_ADD: exact = exact_sum(a.lo, b.lo, &r); break;
        case TAPE_SUB: exact = exact_sum(a.lo, -b.lo, &r); break;
        case TAPE_MUL: exact = exact_mul(a.lo, b.lo, &r); break;
        case TAPE_DIV: exact = exact_div(a.lo, b.lo, &r); break;
        default: break;
        }
        if (exact)
            return iv_point(r);
    }
    switch (op) {
    case TAPE_ADD: return iv_add(a, b);
    case TAPE_SUB: return iv_sub(a, b);
    case TAPE_MUL: return iv_mul(a, b);
    case TAPE_DIV: return iv_div(a, b);
    case TAPE_MIN: return iv_min(a, b);
    default: return iv_max(a, b); /* TAPE_MAX */
    }
}

/* Unary node with its parameter (the exponent of POWI / POWR). */
static int unary_param(dag_t *d, unsigned op, uint32_t a, double param, uint32_t *out)
{
    if (is_const(d, a))
        return dag_const(d, fold_unary(op, d->nodes[a].c, param), out);
    unsigned aop = d->nodes[a].op;
    if (op == TAPE_NEG && aop == TAPE_NEG) {
        *out = d->nodes[a].a;
        return DAG_OK;
    }
    /* even functions: the sign of the operand does not matter */
    if ((op == TAPE_SQR || op == TAPE_ABS) && aop == TAPE_NEG)
        a = d->nodes[a].a;
    iv_t c = (op == TAPE_POWI || op == TAPE_POWR) ? iv_point(param) : iv_zero;
    return make(d, op, a, 0, c, out);
}

int dag_unary(dag_t *d, tape_op_t op, uint32_t a, uint32_t *out)
{
    return unary_param(d, op, a, 0, out);
}

int dag_binary(dag_t *d, tape_op_t op, uint32_t a, uint32_t b, uint32_t *out)
{
    /* before folding, so that a constant times itself is folded by iv_sqr,
     * which is tighter than iv_mul when the constant's enclosure holds 0 */
    if (op == TAPE_MUL && a == b)
        return dag_unary(d, TAPE_SQR, a, out);
    if (is_const(d, a) && is_const(d, b))
        return dag_const(d, fold_binary(op, d->nodes[a].c, d->nodes[b].c), out);
    if ((op == TAPE_ADD || op == TAPE_MUL || op == TAPE_MIN || op == TAPE_MAX) && a > b) {
        uint32_t t = a;
        a = b;
        b = t;
    }
    switch (op) {
    case TAPE_ADD:
        if (is_point(d, a, 0) || is_point(d, b, 0)) {
            *out = is_point(d, a, 0) ? b : a;
            return DAG_OK;
        }
        break;
    case TAPE_SUB:
        if (is_point(d, b, 0)) {
            *out = a;
            return DAG_OK;
        }
        if (is_point(d, a, 0))
            return dag_unary(d, TAPE_NEG, b, out);
        break;
    case TAPE_MUL:
        if (is_point(d, a, 1) || is_point(d, b, 1)) {
            *out = is_point(d, a, 1) ? b : a;
            return DAG_OK;
        }
        if (is_point(d, a, -1) || is_point(d, b, -1))
            return dag_unary(d, TAPE_NEG, is_point(d, a, -1) ? b : a, out);
        break;
    case TAPE_DIV:
        if (is_point(d, b, 1)) {
            *out = a;
            return DAG_OK;
        }
        if (is_point(d, b, -1))
            return dag_unary(d, TAPE_NEG, a, out);
        break;
    case TAPE_MIN:
    case TAPE_MAX:
        if (a == b) {
            *out = a;
            return DAG_OK;
        }
        break;
    default: break;
    }
    return make(d, op, a, b, iv_zero, out);
}

/* a^b as exp(b*log(a)), or exp(b) when a is the constant e. */
static int pow_general(dag_t *d, uint32_t a, uint32_t b, uint32_t *out)
{
    uint32_t e, t;
    int rc = dag_const(d, dag_e, &e);
    if (rc)
        return rc;
    if (a != e) {
        if ((rc = dag_unary(d, TAPE_LOG, a, &t)) || (rc = dag_binary(d, TAPE_MUL, b, t, &t)))
            return rc;
        b = t;
    }
    return dag_unary(d, TAPE_EXP, b, out);
}

int dag_pow(dag_t *d, uint32_t a, uint32_t b, uint32_t *out)
{
    if (!is_const(d, b))
        return pow_general(d, a, b, out);
    iv_t e = d->nodes[b].c;
    if (iv_is_empty(e)) /* the exponent is defined nowhere: so is the power */
        return dag_const(d, iv_empty(), out);
    if (e.lo != e.hi || !isfinite(e.lo)) /* a constant that is not a double */
        return pow_general(d, a, b, out);
    double r = e.lo;
    if (r != floor(r))
        return unary_param(d, TAPE_POWR, a, r, out);
    if (fabs(r) > DAG_MAX_POWI) {
        /* A constant base is folded by iv_powi, which takes any int; a
         * variable base with a huge exponent is most likely a typo, and
         * exp/log would silently drop the negative bases. */
        if (is_const(d, a) && fabs(r) <= 0x1p30)
            return dag_const(d, iv_powi(d->nodes[a].c, (int)r), out);
        return DAG_EEXPONENT;
    }
    int n = (int)r;
    uint32_t t, one;
    int rc;
    switch (n) {
    case 0:
        if ((rc = dag_const(d, iv_point(1), &one)))
            return rc;
        if (d->nodes[a].total) {
            *out = one;
            return DAG_OK;
        }
        /* 1 where a is defined: 0*a is exactly 0 there (iv_mul gives [0,0]
         * for a finite or infinite enclosure), undefined elsewhere */
        if ((rc = dag_const(d, iv_point(0), &t)) || (rc = dag_binary(d, TAPE_MUL, t, a, &t)))
            return rc;
        return dag_binary(d, TAPE_ADD, t, one, out);
    case 1: *out = a; return DAG_OK;
    case 2: return dag_unary(d, TAPE_SQR, a, out);
    default: return unary_param(d, TAPE_POWI, a, n, out);
    }
}

/* ---- flattening ---------------------------------------------------------------- */

int dag_to_tape(const dag_t *d, uint32_t root, tape_t **out)
{
    *out = NULL;
    /* map[i]: 0 = dead, else slot + 1.  Operands have smaller indices than
     * their users, so one backward sweep marks everything root needs. */
    uint32_t *map = calloc((size_t)root + 1, sizeof *map);
    tape_t *t = malloc(sizeof *t);
    if (!map || !t) {
        free(map);
        free(t);
        return DAG_ENOMEM;
    }
    map[root] = 1;
    uint32_t live = 0;
    for (uint32_t i = root + 1; i-- > 0;) {
        if (!map[i])
            continue;
        live++;
        const dag_node_t *nd = &d->nodes[i];
        if (is_unary(nd->op) || is_binary(nd->op))
            map[nd->a] = 1;
        if (is_binary(nd->op))
            map[nd->b] = 1;
    }
    t->n = live;
    t->clauses = malloc((size_t)live * sizeof *t->clauses);
    if (!t->clauses) {
        free(map);
        free(t);
        return DAG_ENOMEM;
    }
    uint32_t k = 0;
    for (uint32_t i = 0; i <= root; i++) {
        if (!map[i])
            continue;
        const dag_node_t *nd = &d->nodes[i];
        tape_clause_t *cl = &t->clauses[k];
        memset(cl, 0, sizeof *cl);
        cl->op = nd->op;
        cl->a = (is_unary(nd->op) || is_binary(nd->op)) ? map[nd->a] - 1 : 0;
        cl->b = is_binary(nd->op) ? map[nd->b] - 1 : 0;
        cl->c = nd->c;
        map[i] = ++k;
    }
    free(map);
    *out = t;
    return DAG_OK;
}

/* ---- tapes ---------------------------------------------------------------------- */

void tape_free(tape_t *t)
{
    if (!t)
        return;
    free(t->clauses);
    free(t);
}

tape_t *tape_clone(const tape_t *t)
{
    if (!t)
        return NULL;
    tape_t *c = malloc(sizeof *c);
    if (!c)
        return NULL;
    c->n = t->n;
    c->clauses = malloc((size_t)(t->n ? t->n : 1) * sizeof *c->clauses);
    if (!c->clauses) {
        free(c);
        return NULL;
    }
    if (t->n)
        memcpy(c->clauses, t->clauses, (size_t)t->n * sizeof *c->clauses);
    return c;
}

const char *tape_op_name(tape_op_t op)
{
    static const char *const names[TAPE_OP_COUNT] = {
        [TAPE_CONST] = "const", [TAPE_X] = "x",       [TAPE_Y] = "y",       [TAPE_Z] = "z",
        [TAPE_NEG] = "neg",     [TAPE_SQR] = "sqr",   [TAPE_POWI] = "powi", [TAPE_POWR] = "powr",
        [TAPE_SQRT] = "sqrt",   [TAPE_EXP] = "exp",   [TAPE_LOG] = "log",   [TAPE_SIN] = "sin",
        [TAPE_COS] = "cos",     [TAPE_TAN] = "tan",   [TAPE_ATAN] = "atan", [TAPE_ABS] = "abs",
        [TAPE_ADD] = "add",     [TAPE_SUB] = "sub",   [TAPE_MUL] = "mul",   [TAPE_DIV] = "div",
        [TAPE_MIN] = "min",     [TAPE_MAX] = "max",
    };
    return (unsigned)op < TAPE_OP_COUNT ? names[op] : "?";
}
