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
 *     first the root of the cubic through the ends of the half the
 *     midpoint's value points to, with the derivative estimates the caller
 *     has there, then secant steps, with guards around each estimate, 8
 *     points a pass;
 *  2. certify: one interval pass at that point and a ladder of points a few
 *     ulps before and after it; on a well-conditioned root this ends it;
 *  3. otherwise (the sign of f is uncertain over more than a few ulps: a
 *     grazing ray, or the guess was off), interval passes of secant estimates
 *     with guards, or 7 points closing in on the end in the band, until the
 *     bracket is 4 ulps.
 *
 * Every step of a refinement asks for at most RAY_BATCH points, and a ray's
 * points are too few to fill the evaluator's lanes.  So refine_batch takes
 * the refinements of many rays at once (those render.c set aside while their
 * rays were walked: ray_find_root_defer) and runs them side by side, each one
 * step a round: the points of all the rays with the same tape go through one
 * pass.  A lane's result does not depend on the others (expr/tape.h), so each
 * ray's hit is the one it gets alone. */
#include "roots_internal.h"

/* The candidate lists below are written for 8 points per step. */
_Static_assert(RAY_BATCH == 8, "refine.c's candidate lists hold RAY_BATCH = 8 points");

enum { LOCATE, CERTIFY, NARROW, DONE };

/* A refinement in progress. */
typedef struct refinement {
    const refine_job_t *job;
    int phase;
    int sa, proven;
    double a, b; /* the certified bracket */
    iv_t ga, gb;
    /* phase 1: its own bracket of double values, and its guess x */
    double la, lb, fa, fb, dfa, dfb, xprev, x;
    int pos, it;
    /* phase 3 */
    double nxprev;
    int nit;
    /* this step's points, for phase `step`: phase 1's n points t[] (values
     * g[]), or the lanes L of an interval pass; at: where they start in the
     * pass */
    int step, n, at;
    double t[RAY_BATCH], g[RAY_BATCH];
    lanes_t L;
} refinement_t;

static void start(refinement_t *s, const refine_job_t *j)
{
    s->job = j;
    s->sa = j->sa;
    s->a = j->a, s->b = j->b;
    s->ga = j->ga, s->gb = j->gb;
    s->proven = j->root || sgn(j->gb) == -j->sa;
    s->nxprev = NAN;
    s->nit = 0;
    s->phase = tiny(s->a, s->b) ? NARROW : LOCATE;
    if (s->phase == LOCATE) {
        s->la = s->a, s->lb = s->b;
        s->fa = iv_mid(s->ga), s->fb = iv_mid(s->gb);
        s->dfa = j->dga, s->dfb = j->dgb;
        s->xprev = NAN;
        s->pos = s->fa > 0;
        s->it = 0;
        /* the midpoint's value says which half holds the double sign change:
         * the guesses start from that half (a sixteenth of the error for the
         * cubic through its ends) */
        double fm = iv_mid(j->gm);
        if (j->m > s->la && j->m < s->lb && isfinite(fm)) {
            if (s->pos ? fm > 0 : fm < 0)
                s->la = j->m, s->fa = fm, s->dfa = j->dgm;
            else
                s->lb = j->m, s->fb = fm, s->dfb = j->dgm;
        }
        if (!(s->fa > 0 || s->fa < 0) || !isfinite(s->fb))
            s->x = NAN, s->phase = CERTIFY;
    }
}

/* The root in (0, 1) of the cubic that takes the values fa, fb and the
 * slopes ha, hb at 0 and 1 (Hermite; for [a, b], ha = (b - a) g'(a)), by
 * Newton's method from u; NaN when it does not settle inside. */
static double hermite_root(double fa, double fb, double ha, double hb, double u)
{
    for (int i = 0; i < 8; i++) {
        double u2 = u * u, u3 = u2 * u;
        double p = fa * (2 * u3 - 3 * u2 + 1) + ha * (u3 - 2 * u2 + u) + fb * (3 * u2 - 2 * u3) +
                   hb * (u3 - u2);
        double dp = 6 * (fa - fb) * (u2 - u) + ha * (3 * u2 - 4 * u + 1) + hb * (3 * u2 - 2 * u);
        double next = u - p / dp;
        if (!(next > 0 && next < 1))
            return NAN;
        if (fabs(next - u) <= 0x1p-50)
            return next;
        u = next;
    }
    return NAN;
}

/* Phase 1's next points (the phase over: its guess in x). */
static void locate_points(refinement_t *s)
{
    double a = s->la, b = s->lb, fa = s->fa, fb = s->fb, dfa = s->dfa, dfb = s->dfb;
    s->n = 0;
    if (s->it >= 16 || tiny(a, b)) {
        s->x = 0.5 * a + 0.5 * b, s->phase = CERTIFY;
        return;
    }
    double m = 0.5 * a + 0.5 * b, x = NAN;
    if (isfinite(dfb) && dfb != 0 && fabs(fb) < fabs(fa))
        x = b - fb / dfb;
    else if (isfinite(dfa) && dfa != 0)
        x = a - fa / dfa;
    if (!(x > a && x < b) && fb != fa)
        x = a - fa * ((b - a) / (fb - fa)); /* secant */
    if (!(x > a && x < b))
        x = m;
    double e = isfinite(s->xprev) ? fabs(x - s->xprev) : (b - a) / 64;
    if (s->it == 0 && isfinite(dfa) && isfinite(dfb)) {
        /* with both slopes, the cubic through both ends (Hermite) is far
         * nearer than Newton from one end: its error goes as (b - a)^4,
         * Newton's as (b - a)^2.  x moves there, and its guards span 2^-26
         * to 2^-14 of the distance between the two guesses */
        double u = hermite_root(fa, fb, (b - a) * dfa, (b - a) * dfb, (x - a) / (b - a));
        double xh = a + u * (b - a);
        if (xh > a && xh < b) {
            e = fabs(xh - x) / 1024;
            x = xh;
        }
    }
    /* the nearest guards no nearer than 4 ulps: where x is that close, one
     * of them is likely across the root, which ends the phase */
    e = fmax(e, 0x1p18 * ulp(x));
    /* x, then its guards outwards on either side, then m: a guard that rounds
     * to the one before it on its side (a few ulps from the root) is left out */
    if (x > a && x < b)
        s->t[s->n++] = x;
    for (int side = -1; side <= 1; side += 2) {
        double prev = x;
        for (double r = 65536; r >= 16; r /= 64) {
            double t = x + side * (e / r);
            if (t > a && t < b && t != prev)
                s->t[s->n++] = t;
            prev = t;
        }
    }
    if (m > a && m < b && m != x)
        s->t[s->n++] = m;
    /* the lanes left free go to equally spaced points: near the root, where
     * the values are mostly rounding, they shrink the bracket by their
     * number + 1 whatever the values say */
    const int spaced = RAY_BATCH - s->n;
    double prev = a;
    for (int k = 1; k <= spaced; k++) {
        double t = a + (b - a) * ((double)k / (spaced + 1));
        if (t > prev && t < b)
            s->t[s->n++] = t;
        prev = t;
    }
    if (s->n == 0)
        s->x = m, s->phase = CERTIFY;
    else
        s->x = x;
}

/* Phase 1 from the values g[] at its points t[]. */
static void locate_update(refinement_t *s)
{
    /* b: the smallest point not of a's sign (NaN and 0 are not); a: the
     * largest of a's sign before it */
    double nb = s->lb, gb = s->fb, na = s->la, ga = s->fa;
    int of_a[RAY_BATCH];
    for (int k = 0; k < s->n; k++)
        of_a[k] = s->pos ? s->g[k] > 0 : s->g[k] < 0;
    for (int k = 0; k < s->n; k++)
        if (!of_a[k] && s->t[k] < nb)
            nb = s->t[k], gb = s->g[k];
    for (int k = 0; k < s->n; k++)
        if (of_a[k] && s->t[k] > na && s->t[k] < nb)
            na = s->t[k], ga = s->g[k];
    if (!(gb == gb)) { /* f undefined there: the guess is lost */
        s->x = NAN, s->phase = CERTIFY;
        return;
    }
    s->la = na, s->fa = ga, s->lb = nb, s->fb = gb;
    s->dfa = s->dfb = NAN;
    s->xprev = s->x;
    s->it++;
    if (gb == 0)
        s->x = nb, s->phase = CERTIFY;
}

/* The lanes of phases 2 and 3 (L.n = 0: the phase has none). */
static void certify_lanes(refinement_t *s)
{
    /* phase 2: x and a ladder of ulps around it (sa lies before x).  Where
     * the certified sign ends lies mostly within 12 ulps before x and 4
     * after (the comparison surfaces); no two steps there are wider than 4
     * ulps, so wherever it ends in that range the bracket is done.  -32
     * catches wider bands.  Interval lanes cost by the lane: 6, not 8 */
    static const double K[] = {-32, -12, -8, -4, 0, 4};
    s->L.n = 0;
    s->phase = NARROW;
    if (!(s->x > s->a && s->x < s->b))
        return;
    double u = ulp(fmax(fabs(s->a), fabs(s->b)));
    for (int k = 0; k < (int)(sizeof K / sizeof K[0]); k++) {
        double t = s->x + K[k] * u;
        if (t > s->a && t < s->b)
            lane_point(&s->L, t);
    }
}

static void narrow_lanes(refinement_t *s)
{
    s->L.n = 0;
    if (s->nit >= 200 || tiny(s->a, s->b)) {
        s->phase = DONE;
        return;
    }
    double a = s->a, b = s->b, cand[RAY_BATCH];
    int n = 0;
    double fa = iv_mid(s->ga), fb = iv_mid(s->gb);
    if (sgn(s->gb) == -s->sa && isfinite(fa) && isfinite(fb) && fb != fa) {
        double x = a - fa * ((b - a) / (fb - fa));
        if (!(x > a && x < b))
            x = 0.5 * a + 0.5 * b;
        double e = isfinite(s->nxprev) ? fabs(x - s->nxprev) : (b - a) / 64;
        const double g[6] = {0.5 * a + 0.5 * b, x, x - e / 16, x + e / 16, x - e / 1024,
                             x + e / 1024};
        for (int k = 0; k < 6; k++)
            cand[n++] = g[k];
        s->nxprev = x;
    } else if (b - a > 0x1p10 * ulp(fmax(fabs(a), fabs(b)))) {
        /* the values tell nothing (b in the band where the sign is
         * uncertain), and a is far: the boundary is most likely near b, at
         * the edge of the band around the root.  7 points closing in on b
         * geometrically, 1/2 to 2^-19 of the bracket before it: the bracket
         * shrinks 2 to 2^19 times */
        for (int k = 1; k < RAY_BATCH; k++)
            cand[n++] = b - (b - a) * ldexp(1.0, 2 - 3 * k);
        s->nxprev = NAN;
    } else {
        /* the values tell nothing: 7 equally spaced points, the bracket
         * shrinks 8 times */
        for (int k = 1; k < RAY_BATCH; k++)
            cand[n++] = a + (b - a) * ((double)k / RAY_BATCH);
        s->nxprev = NAN;
    }
    for (int k = 0; k < n; k++)
        if (cand[k] > a && cand[k] < b)
            lane_point(&s->L, cand[k]);
    if (s->L.n == 0)
        s->phase = DONE;
}

/* Phases 2 and 3: [a, b] from the interval values at the points of L: b the
 * smallest point not certified sa, a the largest sa point before it. */
static void bracket_update(refinement_t *s)
{
    const lanes_t *L = &s->L;
    for (int k = 0; k < L->n; k++) {
        int sk = sgn(L->v[k]);
        if (sk != s->sa && L->lo[k] < s->b)
            s->b = L->lo[k], s->gb = L->v[k];
        if (sk == -s->sa)
            s->proven = 1;
    }
    for (int k = 0; k < L->n; k++)
        if (sgn(L->v[k]) == s->sa && L->lo[k] > s->a && L->lo[k] < s->b)
            s->a = L->lo[k], s->ga = L->v[k];
}

/* This step's points of s: 0 when it needs none (finished). */
static int step_points(refinement_t *s)
{
    for (;;) {
        switch (s->phase) {
        case LOCATE:
            locate_points(s);
            if (s->n)
                return s->step = LOCATE, s->n;
            break;
        case CERTIFY:
            certify_lanes(s);
            if (s->L.n)
                return s->step = CERTIFY, s->L.n;
            break;
        case NARROW:
            narrow_lanes(s);
            if (s->L.n)
                return s->step = NARROW, s->L.n;
            break;
        default: return 0;
        }
    }
}

/* Jobs refined side by side: RAY_BATCH points each at most, up to a few
 * evaluator batches a pass. */
#define SIDE_BY_SIDE 32
#define PASS_LANES (SIDE_BY_SIDE * RAY_BATCH)

/* One pass over the points of this step of the refinements s[k], k in
 * idx[0..m) (one tape), of one kind: plain values for phase 1, enclosures
 * at the rounded points p~(t) for phases 2 and 3. */
static void run_pass(refinement_t *s, const int *idx, int m, int plain, tape_ws_t *ws)
{
    double px[PASS_LANES], py[PASS_LANES], pz[PASS_LANES], g[PASS_LANES];
    iv_box_t box[PASS_LANES];
    iv_t v[PASS_LANES];
    int n = 0;
    for (int i = 0; i < m; i++) {
        refinement_t *r = &s[idx[i]];
        const double *o = r->job->o, *d = r->job->d;
        r->at = n;
        int nk = plain ? r->n : r->L.n;
        for (int k = 0; k < nk; k++, n++) {
            double p[3];
            tape_ray_point(o, d, plain ? r->t[k] : r->L.lo[k], p);
            if (plain) {
                px[n] = p[0], py[n] = p[1], pz[n] = p[2];
            } else {
                box[n].x = iv_point(p[0]);
                box[n].y = iv_point(p[1]);
                box[n].z = iv_point(p[2]);
            }
        }
    }
    const tape_t *tape = s[idx[0]].job->tape;
    if (plain)
        tape_eval_point(tape, ws, (size_t)n, px, py, pz, g);
    else
        tape_eval_interval(tape, ws, (size_t)n, box, v);
    for (int i = 0; i < m; i++) {
        refinement_t *r = &s[idx[i]];
        if (plain) {
            for (int k = 0; k < r->n; k++)
                r->g[k] = g[r->at + k];
            locate_update(r);
        } else {
            for (int k = 0; k < r->L.n; k++)
                r->L.v[k] = v[r->at + k];
            bracket_update(r);
            r->nit += r->step == NARROW;
        }
    }
}

uint64_t refine_batch(refine_job_t *const *jobs, int n, tape_ws_t *ws)
{
    uint64_t passes = 0;
    for (int base = 0; base < n; base += SIDE_BY_SIDE) {
        const int m = n - base < SIDE_BY_SIDE ? n - base : SIDE_BY_SIDE;
        refinement_t s[SIDE_BY_SIDE];
        for (int k = 0; k < m; k++)
            start(&s[k], jobs[base + k]);
        int active[SIDE_BY_SIDE], na = m;
        for (int k = 0; k < m; k++)
            active[k] = k;
        while (na > 0) {
            /* the refinements that still need points; those done give their hit */
            int left = 0;
            for (int i = 0; i < na; i++) {
                refinement_t *r = &s[active[i]];
                if (step_points(r)) {
                    active[left++] = active[i];
                    continue;
                }
                double t = sgn(r->gb) == S_ZERO ? r->b : 0.5 * r->a + 0.5 * r->b;
                hit(r->job->out, r->proven ? RAY_HIT_ROOT : RAY_HIT_ZERO, t, r->a, r->b);
            }
            na = left;
            /* a pass per tape and kind of step, the refinements in their order */
            unsigned char taken[SIDE_BY_SIDE] = {0};
            for (int i = 0; i < na; i++) {
                if (taken[i])
                    continue;
                const tape_t *tape = s[active[i]].job->tape;
                const int plain = s[active[i]].step == LOCATE;
                int idx[SIDE_BY_SIDE], ni = 0;
                for (int j = i; j < na; j++) {
                    const refinement_t *r = &s[active[j]];
                    if (!taken[j] && r->job->tape == tape && (r->step == LOCATE) == plain)
                        taken[j] = 1, idx[ni++] = active[j];
                }
                run_pass(s, idx, ni, plain, ws);
                passes++;
            }
        }
    }
    return passes;
}

ray_hit_kind_t refine(ctx_t *c, const node_t *n, int sa, int root, ray_result_t *res)
{
    refine_job_t j = {.tape = c->tape, .o = c->o, .d = c->d, .a = n->a, .b = n->b, .sa = sa,
                      .root = root, .ga = n->ga, .gb = n->gb, .gm = n->gm, .m = n->m,
                      .dga = n->dga, .dgb = n->dgb, .dgm = n->dgm, .out = res},
                 *one = &j;
    if (c->defer && c->defer_ok) {
        /* set aside (ray_find_root_defer): the hit lies in [a, b] */
        *c->defer = j;
        c->deferred = 1;
        return hit(res, RAY_HIT_ROOT, n->b, n->a, n->b);
    }
    c->evals += refine_batch(&one, 1, c->ws);
    return res->kind;
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
    return refine(c, n, sa, 0, res);
}
