/* ivoct — Lipschitz bounds and the Kalra–Barr tests built on them (prefix lip_).
 *
 * Kalra & Barr 1989: if |∇f| <= L on a region, then |f(p) - f(q)| <= L |p - q|
 * there, so a value |f(c)| larger than L times the distance from c to any
 * point of the region proves that f has no zero in it.  Every bound here comes
 * from an interval gradient (expr/tape.h: tape_eval_grad, tape_eval_ray) and
 * is rounded in the safe direction: a bound on a sup is rounded up, a
 * comparison that excludes decides only when it holds with the rounded
 * bounds.  NaN anywhere (an empty enclosure: f defined nowhere) makes a test
 * decide nothing, and so does an unbounded gradient (a domain edge such as
 * sqrt at 0, or a pole): the tests are rigorous only where f is Lipschitz,
 * and there the interval gradient is bounded.
 */
#ifndef IVOCT_LIPSCHITZ_H
#define IVOCT_LIPSCHITZ_H

#include "../expr/interval.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The magnitude of an interval, max(|lo|, |hi|): the bound on |v| for every
 * v in it.  Exact.  NaN for the empty set. */
double lip_magnitude(iv_t a);

/* A Lipschitz constant of f over a box in the Euclidean norm, from an interval
 * gradient G ⊇ {∇f(p) : p in the box}:
 *     L = sqrt(mag(G.dx)^2 + mag(G.dy)^2 + mag(G.dz)^2), rounded up,
 * so |∇f(p)| <= L for every p of the box where f is differentiable, and
 * |f(p) - f(q)| <= L |p - q| on a convex box where f is continuously
 * differentiable.  +inf when a partial is unbounded, NaN when G is empty. */
double lip_gradient_bound(iv_grad_t G);

/* The cell test.  c is a point of the box, fc an enclosure of f at c, G an
 * interval gradient over the box.  With L = lip_gradient_bound(G) and r >=
 * the largest distance from c to a point of the box (both rounded up), f has
 * no zero in the box when mig(fc) > L·r (rounded up).  Returns +1 when the
 * test proves f > 0 on the whole box, -1 when it proves f < 0, 0 when it
 * decides nothing (fc holds 0, L unbounded or NaN). */
int lip_cell_excludes(const iv_box_t *box, const double c[3], iv_t fc, iv_grad_t G);

/* The bound on |g'| along a ray segment from an enclosure dg ⊇ g'(T): its
 * magnitude.  +inf when unbounded, NaN when empty. */
double lip_derivative_bound(iv_t dg);

/* The ray-segment test (Kalra–Barr's G test).  On T = [a, b] with m in T,
 * gm an enclosure of g(m), dg ⊇ g'(T) and rnd >= 0 a bound on how far the
 * values at the evaluated (rounded) points of T may stray from g(m) + g'·(t
 * - m) (expr/tape.h, tape_eval_ray), g has no root on T when
 *     mig(gm) > G·h + rnd,  G = lip_derivative_bound(dg), h = max(m - a, b - m),
 * every product and sum rounded up.  Returns 1 when it proves there is no
 * root, 0 when it decides nothing (gm holds 0 or is empty, G unbounded). */
int lip_segment_excludes(double a, double b, double m, iv_t gm, iv_t dg, double rnd);

/* The normal cone of gradient-adaptive refinement: does every gradient in G
 * make an angle below 60 degrees with the direction a (a != 0), that is
 * g·a > |g| |a| / 2 for every g in G?  Checked with |g| bounded by
 * lip_gradient_bound(G) and every rounding on the safe side, so 1 is a proof;
 * 0 when it cannot be proven (or G is empty or unbounded).  With the cone
 * proven the surface in the box has no fold: every normal is within 60
 * degrees of a. */
int lip_normals_within_60_degrees(iv_grad_t G, const double a[3]);

#ifdef __cplusplus
}
#endif
#endif
