/* ivoct ray — interval Newton, and Alefeld–Hansen extended division.
 *
 * Interval Newton on a monotone segment.
 * T <- T ∩ N(T), N(T) = m - [g(m)] / G'(T), with [g(m)] widened by R to hold the
 * exact g(m).  Empty: no root.  N(T) inside the interior of T proves a root.
 * Iterates to a few ulps, or until a step no longer removes a quarter of T (the
 * rounding of g(m) then dominates: the monotone refinement finishes the job
 * from the end signs).  Returns a hit kind, or UNDECIDED (with *np shrunk) when
 * f is undefined at the points it needs: the caller bisects. */
#include "roots_internal.h"

int newton_case(ctx_t *c, node_t *np, ray_result_t *res)
{
    node_t n = *np;
    int proven = 0;
    for (int it = 0; it < 200 && !tiny(n.a, n.b); it++) {
        iv_t N = iv_sub(iv_point(n.m), iv_div(iv_add(n.gm, n.R), n.Gp));
        if (iv_is_empty(N))
            break;
        double lo = fmax(N.lo, n.a), hi = fmin(N.hi, n.b);
        if (lo > hi)
            return RAY_MISS;
        if (N.lo > n.a && N.hi < n.b) {
            proven = 1;
            if (c->any) /* a root in N ∩ T: enough */
                return hit(res, RAY_HIT_ROOT, 0.5 * lo + 0.5 * hi, lo, hi);
        }
        if (hi - lo > 0.75 * (n.b - n.a))
            break;
        node_t nn;
        node_init(&nn, lo, hi);
        eval_nodes(c, &nn, 1, 1, 0); /* its points are used even if excluded */
        c->nodes++;
        if (excluded(&nn) && !proven)
            return RAY_MISS;
        n = nn;
        if (!monotone(&n))
            break; /* cannot happen for a sub-segment, but keep the logic honest */
    }
    *np = n;
    int sa = sgn(n.ga), sb = sgn(n.gb);
    if (!proven && is_sign(sa) && sa == sb)
        return RAY_MISS;
    if (sa == S_ZERO)
        return hit(res, RAY_HIT_ZERO, n.a, n.a, n.b);
    if (!is_sign(sa) || sb == S_UNDEF)
        return UNDECIDED;
    if (c->any && sb == -sa)
        return hit(res, RAY_HIT_ROOT, 0.5 * n.a + 0.5 * n.b, n.a, n.b);
    if (!tiny(n.a, n.b)) {
        return (int)refine(c, &n, sa, proven, res);
    }
    int kind = proven || sb == -sa ? RAY_HIT_ROOT : RAY_HIT_ZERO;
    return hit(res, (ray_hit_kind_t)kind, sb == S_ZERO ? n.b : 0.5 * n.a + 0.5 * n.b, n.a, n.b);
}

/* ---- Alefeld–Hansen extended division -----------------------------------------------------------
 * N(T) = m - [g(m)] / G'(T) with 0 ∈ G'(T) = [d1, d2] and 0 ∉ [g(m)] = [c1, c2]:
 * with c the bound of [g(m)] nearest 0, d > 0 gives c/d2 and d < 0 gives c/d1,
 * so N ∩ T is at most two segments: [a, m - c/d2] and [m - c/d1, b] for c > 0
 * (mirrored for c < 0), each inside one half of T.  Returns the count (0..2),
 * left first. */
int ah_pieces(const node_t *n, iv_t gmx, double lo[2], double hi[2])
{
    double cc = gmx.lo > 0 ? gmx.lo : gmx.hi;
    double d1 = n->Gp.lo, d2 = n->Gp.hi;
    iv_t M = iv_point(n->m), C = iv_point(cc);
    int have_left = 0, have_right = 0;
    double u = -INFINITY, v = INFINITY;
    /* positive d: quotient c/d2 */
    if (d2 > 0) {
        iv_t q = iv_sub(M, iv_div(C, iv_point(d2)));
        if (cc > 0)
            have_left = 1, u = fmax(u, q.hi);
        else
            have_right = 1, v = fmin(v, q.lo);
    }
    if (d1 < 0) {
        iv_t q = iv_sub(M, iv_div(C, iv_point(d1)));
        if (cc > 0)
            have_right = 1, v = fmin(v, q.lo);
        else
            have_left = 1, u = fmax(u, q.hi);
    }
    int k = 0;
    if (have_left && have_right && u >= v) { /* rounding closed the gap */
        lo[0] = n->a, hi[0] = n->b;
        return 1;
    }
    if (have_left && u >= n->a)
        lo[k] = n->a, hi[k] = fmin(u, n->b), k++;
    if (have_right && v <= n->b)
        lo[k] = fmax(v, n->a), hi[k] = n->b, k++;
    return k;
}
