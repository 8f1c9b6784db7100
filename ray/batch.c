/* ivoct ray — nodes of the search and their evaluation, several to one pass
 * of the ray evaluator (see roots_internal.h). */
#include "roots_internal.h"

/* eval_nodes puts up to 2 nodes in one call: a box, a midpoint and two ends each. */
_Static_assert(RAY_BATCH >= 8, "a batch holds two nodes with their box and three points");

int lane_point(lanes_t *L, double t)
{
    L->lo[L->n] = L->hi[L->n] = t;
    L->pt[L->n] = 1;
    return L->n++;
}

int lane_box(lanes_t *L, double a, double b)
{
    L->lo[L->n] = a;
    L->hi[L->n] = b;
    L->pt[L->n] = 0;
    return L->n++;
}

/* One pass of the ray evaluator (expr/tape.h): a point lane is f at the
 * rounded point p~(t); a segment lane encloses the exact segment and its
 * rounded points; with derivatives, g' along d and the rounding bound. */
void lanes_run(ctx_t *c, lanes_t *L, int grad)
{
    iv_t T[RAY_BATCH];
    for (int k = 0; k < L->n; k++)
        T[k] = iv_make(L->lo[k], L->hi[k]);
    tape_eval_ray(c->tape, c->ws, c->o, c->d, (size_t)L->n, T, L->v, grad ? L->dv : NULL,
                  grad ? L->rnd : NULL);
    if (!grad)
        for (int k = 0; k < L->n; k++)
            L->dv[k] = iv_entire(), L->rnd[k] = INFINITY;
    c->evals++;
}

void node_init(node_t *n, double a, double b)
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

/* Evaluate k (<= 2) nodes: box and midpoint, and both ends when `ends` (else
 * the caller has set them); derivative methods get G', R and the derivative
 * estimates at the points from the same pass: with the one tangent of
 * tape_eval_ray a pass with derivatives costs about two interval passes, too
 * little for an interval pass first (to spare it on excluded segments) to pay.
 *
 * `skip`: the caller drops a node with 0 ∉ G(T) before looking at anything
 * else (the search of mitchell, newton, newton-ah).  The boxes then go first
 * and the points only for the nodes that remain: the evaluator's cost is per
 * lane, and with the octree most segments are excluded by their box alone.
 * A lane's result does not depend on the others, so the values (and the
 * hits) are the same either way; only the number of passes changes. */
void eval_nodes(ctx_t *c, node_t *n, int k, int ends, int skip)
{
    lanes_t L = {0};
    int ib[2], im[2], ia[2], ie[2];
    for (int j = 0; j < k; j++)
        ib[j] = lane_box(&L, n[j].a, n[j].b);
    if (skip) {
        lanes_run(c, &L, c->deriv);
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
        lanes_run(c, &P, c->deriv);
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
    lanes_run(c, &L, c->deriv);
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

void eval_full(ctx_t *c, node_t *n, int k) { eval_nodes(c, n, k, 1, c->skip); }

void eval_halves(ctx_t *c, const node_t *p, node_t *l, node_t *r)
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
