/* ivoct ray — the left-first search of the certified methods, driven by the
 * method table (methods.c), and the entry points ray_find_root(_n). */
#include "roots_internal.h"

#define STACK_MAX 160

typedef struct search {
    const ray_method_info_t *method;
    double tol;
    node_t stack[STACK_MAX];
    int sp;
} search_t;

static void push(search_t *S, const node_t *n) { S->stack[S->sp++] = *n; }

/* One node of the search: RAY_MISS when it holds no hit (its children, if
 * any, pushed), else the hit in res. */
static ray_hit_kind_t step(ctx_t *c, search_t *S, const node_t *np, ray_result_t *res)
{
    node_t n = *np;
    const ray_method_info_t *M = S->method;
    int sa = sgn(n.ga), sb = sgn(n.gb);
    int at_tol = n.b - n.a <= S->tol;
    int left_only = 0;

    if (M->rules == RULES_SIGNS) {
        /* MRF's rules: a certified sign change (or 0 held at b) proves a root in
         * T, and then no inclusion test is needed */
        if (sa == S_ZERO)
            return hit(res, RAY_HIT_ZERO, n.a, n.a, n.a);
        if (!proven(&n)) {
            if (M->excludes(&n))
                return RAY_MISS;
            if (M->deriv && monotone(&n) && is_sign(sa) && is_sign(sb))
                return RAY_MISS; /* monotone, same signs at both ends */
            if (at_tol)
                return hit(res, RAY_HIT_TANGENT, n.m, n.a, n.b);
        } else {
            if (c->any && sb == -sa)
                return hit(res, RAY_HIT_ROOT, n.m, n.a, n.b);
            if (M->monotone == MONOTONE_NEWTON && monotone(&n)) {
                int k = newton_case(c, &n, res);
                if (k != UNDECIDED)
                    return (ray_hit_kind_t)k;
                sa = sgn(n.ga), sb = sgn(n.gb); /* n shrunk; its sign change stays */
            }
            if (tiny(n.a, n.b))
                return hit(res, sb == -sa ? RAY_HIT_ROOT : RAY_HIT_ZERO,
                           sb == S_ZERO ? n.b : n.m, n.a, n.b);
            /* the first root lies in the left half when the sign flips there */
            int sm = sgn(n.gm);
            left_only = sm == -sa || sm == S_ZERO;
        }
    } else {
        if (M->excludes(&n))
            return RAY_MISS;
        if (monotone(&n)) {
            if (M->monotone == MONOTONE_NEWTON) {
                int k = newton_case(c, &n, res);
                if (k != UNDECIDED)
                    return (ray_hit_kind_t)k;
                sa = sgn(n.ga), sb = sgn(n.gb), at_tol = n.b - n.a <= S->tol;
            } else if (sa != S_UNDEF && sb != S_UNDEF) {
                return monotone_case(c, &n, res);
            }
            /* f undefined where a sign was needed: bisect */
        }
        if (sa == S_ZERO && at_tol)
            return hit(res, RAY_HIT_ZERO, n.a, n.a, n.a);
        if (at_tol)
            return hit(res, proven(&n) && sb != S_ZERO ? RAY_HIT_ROOT : RAY_HIT_TANGENT, n.m,
                       n.a, n.b);
        if (M->extended) {
            iv_t gmx = iv_add(n.gm, n.R);
            if (is_sign(sgn(gmx)) && !iv_is_empty(n.Gp)) {
                double lo[2], hi[2];
                int np = ah_pieces(&n, gmx, lo, hi);
                if (np == 0)
                    return RAY_MISS;
                if (np == 2 || hi[0] - lo[0] <= 0.75 * (n.b - n.a)) {
                    node_t p[2];
                    for (int j = 0; j < np; j++)
                        node_init(&p[j], lo[j], hi[j]);
                    eval_full(c, p, np);
                    for (int j = np - 1; j >= 0; j--)
                        push(S, &p[j]);
                    return RAY_MISS;
                }
            }
            /* 0 ∈ g(m), or no gain: bisect */
        }
    }
    node_t l, r;
    eval_halves(c, &n, &l, &r);
    if (!left_only)
        push(S, &r);
    push(S, &l);
    return RAY_MISS;
}

/* The left-first search.  One refinement of the tangent rule: a segment that
 * reaches the tolerance undecided is set aside, and the search goes on over
 * the next tol of the ray.  A root found there is the hit (certified: the
 * first root is certified to lie in [t_lo, t], at most about 2 tol wide);
 * else the set-aside segment is (RAY_HIT_TANGENT).  Without this, mrfro,
 * whose natural inclusion cannot exclude a neighbour closer to a root than
 * its overestimation, would end most of its searches on such a neighbour. */
static ray_hit_kind_t search(ctx_t *c, const ray_opts_t *opts, int nseg,
                             const double *t0, const double *t1, ray_result_t *res)
{
    double scale = 0;
    for (int j = 0; j < nseg; j++)
        scale = fmax(scale, fmax(fabs(t0[j]), fabs(t1[j])));
    double tol_rel = opts->tol_rel > 0 ? opts->tol_rel : 0x1p-44;
    long budget = opts->max_nodes > 0 ? opts->max_nodes : 100000;
    search_t S;
    S.method = c->method;
    S.tol = fmax(tol_rel * scale, 8.0 * ulp(scale));
    S.sp = 0;
    /* the segments, two to an evaluator call, first on top of the stack */
    node_t roots[RAY_MAX_SEGMENTS];
    for (int j = 0; j < nseg; j++)
        node_init(&roots[j], t0[j], t1[j]);
    for (int j = 0; j < nseg; j += 2)
        eval_full(c, roots + j, nseg - j < 2 ? nseg - j : 2);
    for (int j = nseg - 1; j >= 0; j--)
        push(&S, &roots[j]);

    node_t pending = roots[0];
    int have_pending = 0;
    ray_hit_kind_t k = RAY_MISS;
    while (S.sp > 0) {
        node_t n = S.stack[--S.sp];
        if (have_pending && n.a > pending.b + 1024 * S.tol)
            break;
        c->nodes++;
        if ((long)c->nodes > budget || S.sp + 2 > STACK_MAX) {
            k = hit(res, RAY_HIT_BUDGET, n.a, n.a, n.b);
            break;
        }
        c->defer_ok = !have_pending; /* the pending segment needs the hit's t */
        k = step(c, &S, &n, res);
        if (k == RAY_HIT_TANGENT) {
            if (!have_pending)
                pending = n, have_pending = 1;
            k = res->kind = RAY_MISS;
            res->t = res->t_lo = res->t_hi = NAN;
            continue;
        }
        if (k != RAY_MISS)
            break;
    }
    if (have_pending) {
        if (k != RAY_MISS && k != RAY_HIT_BUDGET && res->t <= pending.b + 1024 * S.tol)
            res->t_lo = pending.a;
        else
            k = hit(res, RAY_HIT_TANGENT, pending.m, pending.a, pending.b);
    }
    return k;
}

/* ---- entry ------------------------------------------------------------------------------------------------ */

static int valid_segment(double t0, double t1)
{
    return t0 <= t1 && isfinite(t0) && isfinite(t1);
}

int ray_segment_of(double t_lo, int n, const double *t0, const double *t1)
{
    /* the search is left first, so the segments before it hold no root */
    int w = -1;
    for (int j = 0; j < n; j++)
        if (valid_segment(t0[j], t1[j])) {
            w = j;
            if (t_lo <= t1[j])
                break;
        }
    return w;
}

ray_hit_kind_t ray_find_root(const tape_t *tape, tape_ws_t *ws, ray_method_t m,
                             const ray_opts_t *opts, const double o[3], const double d[3],
                             double t0, double t1, ray_result_t *res)
{
    return ray_find_root_n(tape, ws, m, opts, o, d, 1, &t0, &t1, res, NULL);
}

ray_hit_kind_t ray_find_root_n(const tape_t *tape, tape_ws_t *ws, ray_method_t m,
                               const ray_opts_t *opts, const double o[3], const double d[3],
                               int n, const double *t0, const double *t1, ray_result_t *res,
                               int *which)
{
    return ray_find_root_defer(tape, ws, m, opts, o, d, n, t0, t1, res, which, NULL, NULL);
}

ray_hit_kind_t ray_find_root_defer(const tape_t *tape, tape_ws_t *ws, ray_method_t m,
                                   const ray_opts_t *opts, const double o[3],
                                   const double d[3], int n, const double *t0,
                                   const double *t1, ray_result_t *res, int *which,
                                   refine_job_t *job, int *deferred)
{
    if (deferred)
        *deferred = 0;
    res->kind = RAY_MISS;
    res->t = res->t_lo = res->t_hi = NAN;
    res->evals = res->nodes = 0;
    if (which)
        *which = -1;
    ray_opts_t def;
    if (!opts) {
        ray_opts_default(&def);
        opts = &def;
    }
    if ((unsigned)m >= RAY_METHOD_COUNT || n < 1 || n > RAY_MAX_SEGMENTS)
        return RAY_MISS;
    for (int i = 0; i < 3; i++)
        if (!isfinite(o[i]) || !isfinite(d[i]))
            return RAY_MISS;
    /* invalid segments (t0 > t1, not finite) hold nothing */
    double a[RAY_MAX_SEGMENTS], b[RAY_MAX_SEGMENTS];
    int idx[RAY_MAX_SEGMENTS], k = 0;
    for (int j = 0; j < n; j++)
        if (valid_segment(t0[j], t1[j]))
            a[k] = t0[j], b[k] = t1[j], idx[k++] = j;
    if (k == 0)
        return RAY_MISS;
    const ray_method_info_t *M = ray_method_info(m);
    /* Boxes first pays where a pass costs by the lane; where short passes are
     * padded to a whole batch, the points ride along with the boxes for free
     * and skipping would only cost a second pass (the values are the same
     * either way: eval_nodes). */
    int skip = M->skip && tape_short_lanes() < RAY_BATCH;
    ctx_t c = {tape, ws, o, d, M, M->deriv, skip, opts->any_root != 0, 0, 0, job, 0, 0};
    ray_hit_kind_t kind = RAY_MISS;
    int w = -1;
    if (M->rules == RULES_SAMPLING) {
        for (int j = 0; j < k && kind == RAY_MISS; j++)
            if ((kind = sampling(&c, opts, a[j], b[j], res)) != RAY_MISS)
                w = idx[j];
    } else if ((kind = search(&c, opts, k, a, b, res)) != RAY_MISS && !c.deferred) {
        w = ray_segment_of(res->t_lo, n, t0, t1);
    }
    if (which)
        *which = w;
    res->evals = c.evals;
    res->nodes = c.nodes;
    if (deferred)
        *deferred = c.deferred;
    return kind;
}
