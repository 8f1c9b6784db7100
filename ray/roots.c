/* ivoct ray — the root finders on one ray segment.
 *
 * g(t) = f(o + t·d).  Every certified method is a left-first search over
 * sub-segments T = [a, b] of [t0, t1] held on an explicit stack (the right
 * sibling waits while the left one is searched), so the first hit found is
 * the smallest t.  A node carries, from the ray evaluator tape_eval_ray
 * (expr/tape.h: the box of T encloses the exact segment and its rounded
 * points):
 *   G   = F(box of T): the natural interval enclosure of g over T;
 *   G'  = ∇F(box of T)·d, one forward tangent along d (derivative methods);
 *   R   = ± the evaluator's rounding bound (the points are p~(t), not o + t·d);
 *   [g] at a, b and m = mid(T): enclosures of f at the rounded points.
 * The methods differ only in the tests they apply to a node and in how they
 * shrink it; ray/README.md has each one and where it departs from the papers.
 *
 * Batching: several lanes go in one evaluator call (its fixed cost is paid
 * once; its cost per lane stays), so a bisection evaluates both halves and
 * both of their midpoints in one call; a Newton step its new segment,
 * midpoint and ends; a refinement step up to 8 candidate points.
 */
#include <math.h>
#include <string.h>

#include "../lipschitz/lipschitz.h"
#include "ray.h"

#define NL TAPE_LANES
#define STACK_MAX 160

/* ---- methods by name --------------------------------------------------------------- */

static const char *const NAMES[RAY_METHOD_COUNT] = {
    "mitchell", "newton", "newton-ah", "mrfro", "mrfro-newton", "lipschitz", "sampling",
};

const char *ray_method_name(ray_method_t m)
{
    return (unsigned)m < RAY_METHOD_COUNT ? NAMES[m] : NULL;
}

int ray_method_parse(const char *name, ray_method_t *m)
{
    for (int i = 0; i < RAY_METHOD_COUNT; i++)
        if (name && !strcmp(name, NAMES[i])) {
            *m = (ray_method_t)i;
            return 0;
        }
    return 1;
}

int ray_method_certified(ray_method_t m)
{
    return (unsigned)m < RAY_METHOD_COUNT && m != RAY_SAMPLING;
}

void ray_opts_default(ray_opts_t *o)
{
    o->tol_rel = 0x1p-44;
    o->sample_step = 0;
    o->max_nodes = 100000;
}

/* ---- evaluation ---------------------------------------------------------------------- */

typedef struct ctx {
    const tape_t *tape;
    tape_ws_t *ws;
    const double *o, *d;
    int deriv;       /* derivatives wanted (all certified methods but mrfro) */
    int skip;        /* nodes with 0 ∉ G(T) are dropped unseen (see eval_nodes) */
    uint64_t evals;  /* evaluator calls */
    uint64_t nodes;  /* segments examined */
} ctx_t;

/* Up to NL requests of one evaluator call: a segment [lo, hi] or a point (pt). */
typedef struct lanes {
    int n;
    double lo[NL], hi[NL];
    unsigned char pt[NL];
    iv_t v[NL];     /* f over the lane's box (tape_eval_ray) */
    iv_t dv[NL];    /* ∇f·d there; entire without derivatives */
    double rnd[NL]; /* the rounding bound of tape_eval_ray; +inf without derivatives */
} lanes_t;

static int lane_point(lanes_t *L, double t)
{
    for (int k = 0; k < L->n; k++)
        if (L->pt[k] && L->lo[k] == t)
            return k;
    L->lo[L->n] = L->hi[L->n] = t;
    L->pt[L->n] = 1;
    return L->n++;
}

static int lane_box(lanes_t *L, double a, double b)
{
    L->lo[L->n] = a;
    L->hi[L->n] = b;
    L->pt[L->n] = 0;
    return L->n++;
}

/* One pass of the ray evaluator (expr/tape.h): a point lane is f at the
 * rounded point p~(t); a segment lane encloses the exact segment and its
 * rounded points; with derivatives, g' along d and the rounding bound. */
static void run(ctx_t *c, lanes_t *L, int grad)
{
    iv_t T[NL];
    for (int k = 0; k < L->n; k++)
        T[k] = iv_make(L->lo[k], L->hi[k]);
    tape_eval_ray(c->tape, c->ws, c->o, c->d, (size_t)L->n, T, L->v, grad ? L->dv : NULL,
                  grad ? L->rnd : NULL);
    if (!grad)
        for (int k = 0; k < L->n; k++)
            L->dv[k] = iv_entire(), L->rnd[k] = INFINITY;
    c->evals++;
}

/* ---- nodes ----------------------------------------------------------------------------- */

typedef struct node {
    double a, b, m;
    iv_t G;           /* F over the box of T (natural inclusion) */
    iv_t Gp;          /* G'(T) ⊇ ∇f(box)·d; entire without derivatives */
    iv_t R;           /* the rounding of the points: f at any rounded point of T, or
                       * the exact g(t), lies in [g(m)] + G'(T)·(T - m) + R */
    iv_t ga, gb, gm;  /* f at the rounded points of a, b, m */
    double dga, dgb, dgm; /* midpoints of g' there (Newton estimates); NaN if unknown */
} node_t;

static void node_init(node_t *n, double a, double b)
{
    n->a = a;
    n->b = b;
    n->m = 0.5 * a + 0.5 * b;
}

static double mid_deriv(const ctx_t *c, const lanes_t *L, int k)
{
    return c->deriv ? iv_mid(L->dv[k]) : NAN;
}

/* G' and R from a box lane.  R: the points evaluated are p~(t), and
 * p~(t) - p~(m) = (t - m)d + e, o + t·d - p~(m) = (t - m)d + e', with
 * |e_i|, |e'_i| <= rho_i (tape.h); so f(p~(t)) - f(p~(m)) and g(t) - f(p~(m))
 * differ from ∇f(ξ)·(t - m)d (ξ in the box) by at most the lane's rounding
 * bound. */
static void set_deriv(node_t *n, const lanes_t *L, int ib)
{
    n->Gp = L->dv[ib];
    n->R = iv_make(-L->rnd[ib], L->rnd[ib]);
}

/* the derivative estimates at the points (lanes of L; -1: not evaluated) */
static void set_deriv_points(const ctx_t *c, node_t *n, const lanes_t *L, int im, int ia, int ie)
{
    n->dgm = mid_deriv(c, L, im);
    if (ia >= 0)
        n->dga = mid_deriv(c, L, ia);
    if (ie >= 0)
        n->dgb = mid_deriv(c, L, ie);
}

/* 0 ∉ G(T): no root (an empty G — f defined nowhere on T — also holds none) */
static int excluded(const node_t *n) { return !iv_contains(n->G, 0.0); }

/* Evaluate k (<= 2) nodes: box and midpoint, and both ends when `ends` (else
 * the caller has set them); derivative methods get G', R and the derivative
 * estimates at the points from the same pass.  (With three partials per slot
 * a derivative pass cost ~6 interval passes, and an interval pass came first
 * to spare it on excluded segments; with the one tangent of tape_eval_ray it
 * costs ~2, and the second pass no longer pays.)
 *
 * `skip`: the caller drops a node with 0 ∉ G(T) before looking at anything
 * else (the search of mitchell, newton, newton-ah).  The boxes then go first
 * and the points only for the nodes that remain: the evaluator's cost is per
 * lane, and with the octree most segments are excluded by their box alone.
 * A lane's result does not depend on the others, so the values (and the
 * hits) are the same either way; only the number of passes changes. */
static void eval_nodes(ctx_t *c, node_t *n, int k, int ends, int skip)
{
    lanes_t L = {0};
    int ib[2], im[2], ia[2], ie[2];
    for (int j = 0; j < k; j++)
        ib[j] = lane_box(&L, n[j].a, n[j].b);
    if (skip) {
        run(c, &L, c->deriv);
        lanes_t P = {0};
        for (int j = 0; j < k; j++) {
            n[j].G = L.v[ib[j]];
            if (excluded(&n[j])) {
                /* never looked at again; set so nothing indeterminate is copied */
                n[j].gm = n[j].Gp = n[j].R = iv_entire();
                n[j].dgm = NAN;
                if (ends)
                    n[j].ga = n[j].gb = iv_entire(), n[j].dga = n[j].dgb = NAN;
                im[j] = -1;
                continue;
            }
            /* the points go to P, the box stays in L */
            im[j] = lane_point(&P, n[j].m);
            if (ends) {
                ia[j] = lane_point(&P, n[j].a);
                ie[j] = lane_point(&P, n[j].b);
            }
        }
        if (P.n == 0)
            return;
        run(c, &P, c->deriv);
        for (int j = 0; j < k; j++) {
            if (im[j] < 0)
                continue;
            n[j].gm = P.v[im[j]];
            n[j].Gp = n[j].R = iv_entire();
            n[j].dgm = NAN;
            if (ends) {
                n[j].ga = P.v[ia[j]];
                n[j].gb = P.v[ie[j]];
                n[j].dga = n[j].dgb = NAN;
            }
            if (c->deriv) {
                set_deriv(&n[j], &L, ib[j]);
                set_deriv_points(c, &n[j], &P, im[j], ends ? ia[j] : -1, ends ? ie[j] : -1);
            }
        }
        return;
    }
    for (int j = 0; j < k; j++) {
        im[j] = lane_point(&L, n[j].m);
        if (ends) {
            ia[j] = lane_point(&L, n[j].a);
            ie[j] = lane_point(&L, n[j].b);
        }
    }
    run(c, &L, c->deriv);
    for (int j = 0; j < k; j++) {
        n[j].G = L.v[ib[j]];
        n[j].gm = L.v[im[j]];
        n[j].Gp = n[j].R = iv_entire();
        n[j].dgm = NAN;
        if (ends) {
            n[j].ga = L.v[ia[j]];
            n[j].gb = L.v[ie[j]];
            n[j].dga = n[j].dgb = NAN;
        }
        if (c->deriv) {
            set_deriv(&n[j], &L, ib[j]);
            set_deriv_points(c, &n[j], &L, im[j], ends ? ia[j] : -1, ends ? ie[j] : -1);
        }
    }
}

static void eval_full(ctx_t *c, node_t *n, int k) { eval_nodes(c, n, k, 1, c->skip); }

/* The halves of p: ends known from p, one pass for both boxes and midpoints. */
static void eval_halves(ctx_t *c, const node_t *p, node_t *l, node_t *r)
{
    node_t h[2];
    node_init(&h[0], p->a, p->m);
    node_init(&h[1], p->m, p->b);
    h[0].ga = p->ga, h[0].dga = p->dga, h[0].gb = p->gm, h[0].dgb = p->dgm;
    h[1].ga = p->gm, h[1].dga = p->dgm, h[1].gb = p->gb, h[1].dgb = p->dgb;
    eval_nodes(c, h, 2, 0, c->skip);
    *l = h[0];
    *r = h[1];
}

/* ---- small predicates --------------------------------------------------------------------- */

enum { S_NEG = -1, S_ZERO = 0, S_POS = 1, S_UNDEF = 2 };

/* Certified sign of an enclosure at a point.  S_ZERO: the enclosure is finite
 * and holds 0 (f vanishes within the rounding); S_UNDEF: empty (f undefined) or
 * unbounded, which tells nothing. */
static int sgn(iv_t g)
{
    if (iv_is_empty(g))
        return S_UNDEF;
    if (g.lo > 0)
        return S_POS;
    if (g.hi < 0)
        return S_NEG;
    return isfinite(g.lo) && isfinite(g.hi) ? S_ZERO : S_UNDEF;
}

static int is_sign(int s) { return s == S_POS || s == S_NEG; }

static double ulp(double x)
{
    x = fabs(x);
    return nextafter(x, INFINITY) - x;
}

/* T is as narrow as the refinement goes: a few ulps */
static int tiny(double a, double b)
{
    return b - a <= 4.0 * ulp(fmax(fabs(a), fabs(b)));
}


/* 0 ∉ G'(T): g strictly monotone on T */
static int monotone(const node_t *n) { return !iv_is_empty(n->Gp) && !iv_contains(n->Gp, 0.0); }

/* Kalra–Barr (lipschitz/lipschitz.h): |g(m)| > G·h + R: no root.  Where the
 * test has nothing to work with — f undefined at m, or no finite bound G (f
 * not Lipschitz on T, e.g. sqrt at 0) — the interval test 0 ∉ F(T) stands in. */
static int lipschitz_excluded(const node_t *n)
{
    if (sgn(n->gm) == S_UNDEF || !isfinite(lip_derivative_bound(n->Gp)))
        return excluded(n);
    return lip_segment_excludes(n->a, n->b, n->m, n->gm, n->Gp, lip_magnitude(n->R));
}

static ray_hit_kind_t hit(ray_result_t *res, ray_hit_kind_t kind, double t, double lo,
                          double hi)
{
    res->kind = kind;
    res->t = t;
    res->t_lo = lo;
    res->t_hi = hi;
    return kind;
}

/* ---- refinement of a monotone bracket ------------------------------------------------------
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
        double cand[NL] = {m, x, x - e / 16, x + e / 16, x - e / 1024, x + e / 1024,
                           x - e / 65536, x + e / 65536};
        double t[NL], px[NL], py[NL], pz[NL], g[NL];
        int n = 0;
        for (int k = 0; k < NL; k++)
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

static ray_hit_kind_t refine(ctx_t *c, double a, double b, int sa, iv_t ga, double dga,
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
            static const double K[NL] = {-32, -8, -3, -2, -1, 0, 1, 4};
            double u = ulp(fmax(fabs(a), fabs(b)));
            lanes_t L = {0};
            for (int k = 0; k < NL; k++) {
                double t = x + K[k] * u;
                if (t > a && t < b)
                    lane_point(&L, t);
            }
            if (L.n) {
                run(c, &L, 0);
                REFINE_UPDATE(L);
            }
        }
    }
    double xprev = NAN;
    for (int it = 0; it < 200 && !tiny(a, b); it++) {
        /* phase 3 */
        double cand[NL];
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
            for (int k = 1; k < NL; k++)
                cand[n++] = a + (b - a) * ((double)k / NL);
            xprev = NAN;
        }
        lanes_t L = {0};
        for (int k = 0; k < n; k++)
            if (cand[k] > a && cand[k] < b)
                lane_point(&L, cand[k]);
        if (L.n == 0)
            break;
        run(c, &L, 0);
        REFINE_UPDATE(L);
    }
#undef REFINE_UPDATE
    double t = sgn(gb) == S_ZERO ? b : 0.5 * a + 0.5 * b;
    return hit(res, proven ? RAY_HIT_ROOT : RAY_HIT_ZERO, t, a, b);
}

/* The monotone case of mitchell and lipschitz: one root iff the end signs differ. */
static ray_hit_kind_t monotone_case(ctx_t *c, const node_t *n, ray_result_t *res)
{
    int sa = sgn(n->ga), sb = sgn(n->gb);
    if (sa == S_ZERO)
        return hit(res, RAY_HIT_ZERO, n->a, n->a, n->a);
    if (is_sign(sa) && sa == sb)
        return RAY_MISS;
    return refine(c, n->a, n->b, sa, n->ga, n->dga, n->gb, n->dgb, res);
}

/* ---- interval Newton on a monotone segment ---------------------------------------------------
 * T <- T ∩ N(T), N(T) = m - [g(m)] / G'(T), with [g(m)] widened by R to hold the
 * exact g(m).  Empty: no root.  N(T) inside the interior of T proves a root.
 * Iterates to a few ulps, or until a step no longer removes a quarter of T (the
 * rounding of g(m) then dominates: the monotone refinement finishes the job
 * from the end signs).  Returns a hit kind, or UNDECIDED (with *np shrunk) when
 * f is undefined at the points it needs: the caller bisects. */
#define UNDECIDED (-1)

static int newton_case(ctx_t *c, node_t *np, ray_result_t *res)
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
        if (N.lo > n.a && N.hi < n.b)
            proven = 1;
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
    if (!tiny(n.a, n.b)) {
        ray_hit_kind_t k = refine(c, n.a, n.b, sa, n.ga, n.dga, n.gb, n.dgb, res);
        if (proven)
            res->kind = RAY_HIT_ROOT;
        return proven ? RAY_HIT_ROOT : (int)k;
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
static int ah_pieces(const node_t *n, iv_t gmx, double lo[2], double hi[2])
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

/* ---- the search ------------------------------------------------------------------------------------- */

/* A certified sign change between the ends (or 0 held at b): a root in T. */
static int proven(const node_t *n)
{
    int sa = sgn(n->ga), sb = sgn(n->gb);
    return is_sign(sa) && (sb == -sa || sb == S_ZERO);
}

typedef struct search {
    ray_method_t m;
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
    const ray_method_t m = S->m;
    int sa = sgn(n.ga), sb = sgn(n.gb);
    int at_tol = n.b - n.a <= S->tol;
    int left_only = 0;

    if (m == RAY_MRFRO || m == RAY_MRFRO_NEWTON) {
        /* MRF's rules: a certified sign change (or 0 held at b) proves a root in
         * T, and then no inclusion test is needed */
        if (sa == S_ZERO)
            return hit(res, RAY_HIT_ZERO, n.a, n.a, n.a);
        if (!proven(&n)) {
            if (excluded(&n))
                return RAY_MISS;
            if (m == RAY_MRFRO_NEWTON && monotone(&n) && is_sign(sa) && is_sign(sb))
                return RAY_MISS; /* monotone, same signs at both ends */
            if (at_tol)
                return hit(res, RAY_HIT_TANGENT, n.m, n.a, n.b);
        } else {
            if (m == RAY_MRFRO_NEWTON && monotone(&n)) {
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
        if (m == RAY_LIPSCHITZ ? lipschitz_excluded(&n) : excluded(&n))
            return RAY_MISS;
        if (monotone(&n)) {
            const int newtonish = m == RAY_NEWTON || m == RAY_NEWTON_AH;
            if (newtonish) {
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
        if (m == RAY_NEWTON_AH) {
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
static ray_hit_kind_t search(ctx_t *c, ray_method_t m, const ray_opts_t *opts, int nseg,
                             const double *t0, const double *t1, ray_result_t *res)
{
    double scale = 0;
    for (int j = 0; j < nseg; j++)
        scale = fmax(scale, fmax(fabs(t0[j]), fabs(t1[j])));
    double tol_rel = opts->tol_rel > 0 ? opts->tol_rel : 0x1p-44;
    long budget = opts->max_nodes > 0 ? opts->max_nodes : 100000;
    search_t S;
    S.m = m;
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

/* ---- sampling (not certified) ----------------------------------------------------------------------- */

static void point_value(ctx_t *c, int n, const double *t, double *g)
{
    double x[NL], y[NL], z[NL];
    for (int k = 0; k < n; k++) {
        double p[3];
        ray_point(c->o, c->d, t[k], p);
        x[k] = p[0], y[k] = p[1], z[k] = p[2];
    }
    tape_eval_point(c->tape, c->ws, (size_t)n, x, y, z, g);
    c->evals++;
}

/* Bisection with plain double evaluations, seven interior points per call. */
static ray_hit_kind_t sample_bisect(ctx_t *c, double a, double b, double ga, ray_result_t *res)
{
    while (!tiny(a, b)) {
        double t[NL - 1], g[NL - 1];
        int n = 0;
        for (int j = 1; j < NL; j++) {
            double tj = a + (b - a) * ((double)j / NL);
            if (tj > a && tj < b && (n == 0 || tj > t[n - 1]))
                t[n++] = tj;
        }
        if (n == 0)
            break;
        point_value(c, n, t, g);
        double na = a, nb = b;
        int found = 0;
        for (int j = 0; j < n && !found; j++) {
            if (g[j] == 0)
                return hit(res, RAY_HIT_ROOT, t[j], t[j], t[j]);
            if (g[j] != g[j])
                continue;
            if ((g[j] < 0) != (ga < 0))
                nb = t[j], found = 1;
            else
                na = t[j];
        }
        a = na, b = nb;
    }
    return hit(res, RAY_HIT_ROOT, 0.5 * a + 0.5 * b, a, b);
}

static ray_hit_kind_t sampling(ctx_t *c, const ray_opts_t *opts, double t0, double t1,
                               ray_result_t *res)
{
    double len = t1 - t0;
    double step = opts->sample_step > 0 ? opts->sample_step : len / 1000;
    double nd = step > 0 ? ceil(len / step) : 1;
    long n = nd < 1 ? 1 : nd > 1e8 ? 100000000L : (long)nd;
    double prev_t = NAN, prev_g = NAN;
    for (long base = 0; base <= n; base += NL) {
        double t[NL], g[NL];
        int cnt = 0;
        for (long k = base; k <= n && cnt < NL; k++)
            t[cnt++] = k == n ? t1 : t0 + len * ((double)k / (double)n);
        point_value(c, cnt, t, g);
        for (int j = 0; j < cnt; j++) {
            if (g[j] == 0)
                return hit(res, RAY_HIT_ROOT, t[j], t[j], t[j]);
            if (g[j] != g[j])
                continue;
            if (prev_g == prev_g && (prev_g < 0) != (g[j] < 0))
                return sample_bisect(c, prev_t, t[j], prev_g, res);
            prev_t = t[j], prev_g = g[j];
        }
    }
    return RAY_MISS;
}

/* ---- entry ------------------------------------------------------------------------------------------------ */

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
        if (t0[j] <= t1[j] && isfinite(t0[j]) && isfinite(t1[j]))
            a[k] = t0[j], b[k] = t1[j], idx[k++] = j;
    if (k == 0)
        return RAY_MISS;
    const int deriv = m != RAY_MRFRO && m != RAY_SAMPLING;
    const int skip = m == RAY_MITCHELL || m == RAY_NEWTON || m == RAY_NEWTON_AH;
    ctx_t c = {tape, ws, o, d, deriv, skip, 0, 0};
    ray_hit_kind_t kind = RAY_MISS;
    int w = -1;
    if (m == RAY_SAMPLING) {
        for (int j = 0; j < k && kind == RAY_MISS; j++)
            if ((kind = sampling(&c, opts, a[j], b[j], res)) != RAY_MISS)
                w = j;
    } else if ((kind = search(&c, m, opts, k, a, b, res)) != RAY_MISS) {
        /* the first segment holding the start of the hit's bracket: the
         * search is left first, so the segments before it hold no root */
        w = k - 1;
        for (int j = 0; j < k; j++)
            if (res->t_lo <= b[j]) {
                w = j;
                break;
            }
    }
    if (which && w >= 0)
        *which = idx[w];
    res->evals = c.evals;
    res->nodes = c.nodes;
    return kind;
}
