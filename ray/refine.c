/* ivoct ray — refinement of a monotone bracket.
 *
 * g is monotone on [a, b], f at a has certified sign sa, and b is "not sa"
 * (certified opposite, or holding 0).  The bracket is shrunk to the boundary
 * between the points where sign sa is certified and the rest: the reported hit
 * is the first point, to a few ulps, where the evaluation cannot certify that
 * the surface is still ahead.
 *
 * Only the certified signs of interval evaluations at points move a and b, so
 * where to look can be guessed by any means.  Three phases, cheapest first:
 *  1. locate: plain double evaluations (tape_eval_point, a small fraction of
 *     an interval pass) find where the double value of f changes sign —
 *     Newton from the derivative estimates the caller has, then secant steps
 *     with guards around each estimate, 8 points a pass;
 *  2. certify: one interval pass at that point and a ladder of points a few
 *     ulps before and after it; on a well-conditioned root this ends it;
 *  3. otherwise (the sign of f is uncertain over more than a few ulps: a
 *     grazing ray, or the guess was off), interval passes of secant estimates
 *     with guards, or 7 equally spaced points, until the bracket is 4 ulps. */
#include "roots_internal.h"

/* The candidate lists below are written for 8 points per evaluator call. */
_Static_assert(RAY_BATCH == 8, "refine.c's candidate lists hold RAY_BATCH = 8 points");


/* Phase 1: a guess in (a, b), or NaN.  fa, fb the values at a, b (of
 * opposite signs, or fb ~ 0); dfa, dfb derivative estimates or NaN. */
static double locate(ctx_t *c, double a, double b, double fa, double fb, double dfa,
                     double dfb)
{
    if (!(fa > 0 || fa < 0) || !isfinite(fb))
        return NAN;
    const int pos = fa > 0;
    double xprev = NAN;
    for (int it = 0; it < 16 && !tiny(a, b); it++) {
        double m = 0.5 * a + 0.5 * b, x = NAN;
        if (isfinite(dfb) && dfb != 0 && fabs(fb) < fabs(fa))
            x = b - fb / dfb;
        else if (isfinite(dfa) && dfa != 0)
            x = a - fa / dfa;
        if (!(x > a && x < b) && fb != fa)
            x = a - fa * ((b - a) / (fb - fa)); /* secant */
        if (!(x > a && x < b))
            x = m;
        double e = isfinite(xprev) ? fabs(x - xprev) : (b - a) / 64;
        double cand[RAY_BATCH] = {m, x, x - e / 16, x + e / 16, x - e / 1024, x + e / 1024,
                           x - e / 65536, x + e / 65536};
        double t[RAY_BATCH], px[RAY_BATCH], py[RAY_BATCH], pz[RAY_BATCH], g[RAY_BATCH];
        int n = 0;
        for (int k = 0; k < RAY_BATCH; k++)
            if (cand[k] > a && cand[k] < b) {
                double p[3];
                ray_point(c->o, c->d, cand[k], p);
                t[n] = cand[k], px[n] = p[0], py[n] = p[1], pz[n] = p[2];
                n++;
            }
        if (n == 0)
            break;
        tape_eval_point(c->tape, c->ws, (size_t)n, px, py, pz, g);
        c->evals++;
        /* b: the smallest point not of a's sign; a: the largest of a's sign before it */
        double nb = b, gb = fb, na = a, ga = fa;
        for (int k = 0; k < n; k++)
            if (!(g[k] == g[k]) || (g[k] > 0) != pos || g[k] == 0)
                if (t[k] < nb)
                    nb = t[k], gb = g[k];
        for (int k = 0; k < n; k++)
            if (g[k] == g[k] && g[k] != 0 && (g[k] > 0) == pos && t[k] > na && t[k] < nb)
                na = t[k], ga = g[k];
        if (!(gb == gb)) /* f undefined there: the guess is lost */
            return NAN;
        a = na, fa = ga, b = nb, fb = gb;
        dfa = dfb = NAN;
        xprev = x;
        if (fb == 0)
            return b;
    }
    return 0.5 * a + 0.5 * b;
}

ray_hit_kind_t refine(ctx_t *c, double a, double b, int sa, iv_t ga, double dga,
                             iv_t gb, double dgb, ray_result_t *res)
{
    int proven = sgn(gb) == -sa;
    /* Update [a, b] from the interval values at the points of L: b the
     * smallest point not certified sa, a the largest sa point before it. */
#define REFINE_UPDATE(L)                                                                   \
    do {                                                                                   \
        for (int k_ = 0; k_ < (L).n; k_++) {                                               \
            int s_ = sgn((L).v[k_]);                                                   \
            if (s_ != sa && (L).lo[k_] < b)                                                \
                b = (L).lo[k_], gb = (L).v[k_];                                        \
            if (s_ == -sa)                                                                 \
                proven = 1;                                                                \
        }                                                                                  \
        for (int k_ = 0; k_ < (L).n; k_++)                                                 \
            if (sgn((L).v[k_]) == sa && (L).lo[k_] > a && (L).lo[k_] < b)              \
                a = (L).lo[k_], ga = (L).v[k_];                                        \
    } while (0)

    if (!tiny(a, b)) {
        double x = locate(c, a, b, iv_mid(ga), iv_mid(gb), dga, dgb);
        if (x > a && x < b) {
            /* phase 2: x and a ladder of ulps around it (sa lies before x) */
            static const double K[RAY_BATCH] = {-32, -8, -3, -2, -1, 0, 1, 4};
            double u = ulp(fmax(fabs(a), fabs(b)));
            lanes_t L = {0};
            for (int k = 0; k < RAY_BATCH; k++) {
                double t = x + K[k] * u;
                if (t > a && t < b)
                    lane_point(&L, t);
            }
            if (L.n) {
                lanes_run(c, &L, 0);
                REFINE_UPDATE(L);
            }
        }
    }
    double xprev = NAN;
    for (int it = 0; it < 200 && !tiny(a, b); it++) {
        /* phase 3 */
        double cand[RAY_BATCH];
        int n = 0;
        double fa = iv_mid(ga), fb = iv_mid(gb);
        if (sgn(gb) == -sa && isfinite(fa) && isfinite(fb) && fb != fa) {
            double x = a - fa * ((b - a) / (fb - fa));
            if (!(x > a && x < b))
                x = 0.5 * a + 0.5 * b;
            double e = isfinite(xprev) ? fabs(x - xprev) : (b - a) / 64;
            double g[6] = {0.5 * a + 0.5 * b, x, x - e / 16, x + e / 16, x - e / 1024,
                           x + e / 1024};
            for (int k = 0; k < 6; k++)
                cand[n++] = g[k];
            xprev = x;
        } else {
            /* the values tell nothing (b in the band where the sign is
             * uncertain): 7 equally spaced points, the bracket shrinks 8 times */
            for (int k = 1; k < RAY_BATCH; k++)
                cand[n++] = a + (b - a) * ((double)k / RAY_BATCH);
            xprev = NAN;
        }
        lanes_t L = {0};
        for (int k = 0; k < n; k++)
            if (cand[k] > a && cand[k] < b)
                lane_point(&L, cand[k]);
        if (L.n == 0)
            break;
        lanes_run(c, &L, 0);
        REFINE_UPDATE(L);
    }
#undef REFINE_UPDATE
    double t = sgn(gb) == S_ZERO ? b : 0.5 * a + 0.5 * b;
    return hit(res, proven ? RAY_HIT_ROOT : RAY_HIT_ZERO, t, a, b);
}

ray_hit_kind_t monotone_case(ctx_t *c, const node_t *n, ray_result_t *res)
{
    int sa = sgn(n->ga), sb = sgn(n->gb);
    if (sa == S_ZERO)
        return hit(res, RAY_HIT_ZERO, n->a, n->a, n->a);
    if (is_sign(sa) && sa == sb)
        return RAY_MISS;
    if (c->any && is_sign(sa) && sb == -sa) /* a root in [a, b]: enough */
        return hit(res, RAY_HIT_ROOT, 0.5 * n->a + 0.5 * n->b, n->a, n->b);
    return refine(c, n->a, n->b, sa, n->ga, n->dga, n->gb, n->dgb, res);
}
