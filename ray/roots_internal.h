/* ivoct ray — the root finders' pieces, internal to ray/.
 *
 *   methods.c   the methods as a table of the rules each one applies
 *   batch.c     nodes (sub-segments) and their evaluation, several to a pass
 *   refine.c    refinement of a monotone bracket to a few ulps
 *   newton.c    interval Newton and Alefeld–Hansen extended division
 *   search.c    the left-first search driven by the table; ray_find_root(_n)
 *   sampling.c  fixed-step point sampling (not certified)
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
 */
#ifndef IVOCT_RAY_ROOTS_INTERNAL_H
#define IVOCT_RAY_ROOTS_INTERNAL_H

#include <math.h>
#include <stdint.h>
#include <string.h>

#include "ray.h"

/* Requests (segments or points) per evaluator call.  Its fixed cost is paid
 * once per call and its cost per lane stays, so a bisection evaluates both
 * halves and both of their midpoints in one call, a Newton step its new
 * segment, midpoint and ends, a refinement step up to 8 candidate points.
 * The evaluator processes any count in one call. */
#define RAY_BATCH 8

/* ---- methods.c: what distinguishes the methods ----------------------------------
 * The search (search.c) is one algorithm; each method is a row of this table,
 * and the search asks the row, never the method's name. */
/* Every method but sampling is certified. */
typedef enum { RULES_INCLUSION, RULES_SIGNS, RULES_SAMPLING } ray_rules_t;
typedef enum { MONOTONE_END_SIGNS, MONOTONE_NEWTON } ray_monotone_t;

typedef struct node node_t;

typedef struct ray_method_info {
    const char *name;
    /* RULES_INCLUSION: a node is dropped when `excludes` proves it holds no root,
     *   else shrunk; RULES_SIGNS (MRF): a certified sign change at the ends
     *   proves a root and spares the inclusion test; RULES_SAMPLING: point
     *   sampling, no search (sampling.c). */
    ray_rules_t rules;
    int deriv;         /* the node evaluations carry G'(T) and the rounding bound */
    int skip;          /* boxes first, points only for the nodes not excluded */
    int (*excludes)(const node_t *n); /* RULES_INCLUSION's test */
    /* With 0 ∉ G'(T) (g monotone): one root iff the end signs differ, refined
     * from them (MONOTONE_END_SIGNS), or interval Newton (MONOTONE_NEWTON). */
    ray_monotone_t monotone;
    int extended;      /* Alefeld–Hansen extended division where 0 ∈ G'(T) */
} ray_method_info_t;

const ray_method_info_t *ray_method_info(ray_method_t m); /* NULL for an invalid value */

/* ---- batch.c: evaluation ---------------------------------------------------------- */

typedef struct ctx {
    const tape_t *tape;
    tape_ws_t *ws;
    const double *o, *d;
    const ray_method_info_t *method;
    int deriv;       /* method->deriv: derivatives wanted */
    int skip;        /* method->skip: nodes with 0 ∉ G(T) are dropped unseen (eval_nodes) */
    int any;         /* ray_opts_t.any_root: a root proven in a segment ends the search */
    uint64_t evals;  /* evaluator calls */
    uint64_t nodes;  /* segments examined */
    /* Where refine() may set its refinement aside instead of running it
     * (ray_find_root_defer), when defer_ok; deferred: it did. */
    struct refine_job *defer;
    int defer_ok, deferred;
} ctx_t;

/* Up to RAY_BATCH requests of one evaluator call: a segment [lo, hi] or a point (pt). */
typedef struct lanes {
    int n;
    double lo[RAY_BATCH], hi[RAY_BATCH];
    unsigned char pt[RAY_BATCH];
    iv_t v[RAY_BATCH];     /* f over the lane's box (tape_eval_ray) */
    iv_t dv[RAY_BATCH];    /* ∇f·d there; entire without derivatives */
    double rnd[RAY_BATCH]; /* the rounding bound of tape_eval_ray; +inf without derivatives */
} lanes_t;

/* Append a point or a segment; returns its lane.  A point asked twice gets
 * two lanes: a lane's value does not depend on the others, and looking for
 * the earlier one cost more than the rare extra lane. */
int lane_point(lanes_t *L, double t);
int lane_box(lanes_t *L, double a, double b);
/* One pass of the ray evaluator over the lanes of L (derivatives when grad). */
void lanes_run(ctx_t *c, lanes_t *L, int grad);

struct node {
    double a, b, m;
    iv_t G;           /* F over the box of T (natural inclusion) */
    iv_t Gp;          /* G'(T) ⊇ ∇f(box)·d; entire without derivatives */
    iv_t R;           /* the rounding of the points: f at any rounded point of T, or
                       * the exact g(t), lies in [g(m)] + G'(T)·(T - m) + R */
    iv_t ga, gb, gm;  /* f at the rounded points of a, b, m */
    double dga, dgb, dgm; /* midpoints of g' there (Newton estimates); NaN if unknown */
};

void node_init(node_t *n, double a, double b);
/* Evaluate k (<= 2) nodes: box and midpoint, and both ends when `ends`; skip:
 * boxes first (see batch.c). */
void eval_nodes(ctx_t *c, node_t *n, int k, int ends, int skip);
/* Evaluate k (<= 2) nodes with their ends. */
void eval_full(ctx_t *c, node_t *n, int k);
/* The halves of p: ends known from p, one pass for both boxes and midpoints. */
void eval_halves(ctx_t *c, const node_t *p, node_t *l, node_t *r);

/* ---- predicates on nodes and enclosures ---------------------------------------------- */

/* 0 ∉ G(T): no root (an empty G — f defined nowhere on T — also holds none) */
static inline int excluded(const node_t *n) { return !iv_contains(n->G, 0.0); }

enum { S_NEG = -1, S_ZERO = 0, S_POS = 1, S_UNDEF = 2 };

/* Certified sign of an enclosure at a point.  S_ZERO: the enclosure is finite
 * and holds 0 (f vanishes within the rounding); S_UNDEF: empty (f undefined) or
 * unbounded, which tells nothing. */
static inline int sgn(iv_t g)
{
    if (iv_is_empty(g))
        return S_UNDEF;
    if (g.lo > 0)
        return S_POS;
    if (g.hi < 0)
        return S_NEG;
    return isfinite(g.lo) && isfinite(g.hi) ? S_ZERO : S_UNDEF;
}

static inline int is_sign(int s) { return s == S_POS || s == S_NEG; }

/* The gap from |x| to the next double up: nextafter(|x|, +inf) - |x|, by
 * the bits (the refinement asks it every step; the call to libm cost more
 * than the step's bookkeeping).  A finite |x| (subnormals and 0 included)
 * and its successor are consecutive as integers; +inf and NaN give NaN. */
static inline double ulp(double x)
{
    x = fabs(x);
    uint64_t u;
    memcpy(&u, &x, sizeof u);
    u += 1;
    double next;
    memcpy(&next, &u, sizeof next);
    return next - x;
}

/* T is as narrow as the refinement goes: a few ulps */
static inline int tiny(double a, double b)
{
    return b - a <= 4.0 * ulp(fmax(fabs(a), fabs(b)));
}


/* 0 ∉ G'(T): g strictly monotone on T */
static inline int monotone(const node_t *n) { return !iv_is_empty(n->Gp) && !iv_contains(n->Gp, 0.0); }

/* A certified sign change between the ends (or 0 held at b): a root in T. */
static inline int proven(const node_t *n)
{
    int sa = sgn(n->ga), sb = sgn(n->gb);
    return is_sign(sa) && (sb == -sa || sb == S_ZERO);
}

static inline ray_hit_kind_t hit(ray_result_t *res, ray_hit_kind_t kind, double t, double lo,
                          double hi)
{
    res->kind = kind;
    res->t = t;
    res->t_lo = lo;
    res->t_hi = hi;
    return kind;
}

/* ---- refine.c ------------------------------------------------------------------------ */

/* A refinement of a ray's hit: refine()'s arguments, the ray, and where the
 * hit goes. */
typedef struct refine_job {
    const tape_t *tape;
    const double *o, *d;
    double a, b;
    int sa;
    int root; /* a root is known to lie in [a, b]: the hit is RAY_HIT_ROOT */
    iv_t ga, gb, gm;
    double m, dga, dgb, dgm;
    ray_result_t *out; /* its kind, t, t_lo and t_hi are set */
} refine_job_t;

/* g monotone on n's [a, b], f at a of certified sign sa, b "not sa": the hit,
 * refined to a few ulps (see refine.c) from what the node knows (its ends
 * and midpoint, their values and derivative estimates); a RAY_HIT_ROOT
 * whatever the refinement proves when root.  With c->defer and c->defer_ok
 * the refinement is set aside there instead (c->deferred): res is then the
 * bracket, RAY_HIT_ROOT at t = b, until refine_batch runs it. */
ray_hit_kind_t refine(ctx_t *c, const node_t *n, int sa, int root, ray_result_t *res);
/* Run the n refinements side by side, their points of each step in shared
 * passes (per tape); each hit is the one refine() gives it alone.  Returns
 * the evaluator passes. */
uint64_t refine_batch(refine_job_t *const *jobs, int n, tape_ws_t *ws);
/* The monotone case of the end-sign methods: one root iff the end signs differ. */
ray_hit_kind_t monotone_case(ctx_t *c, const node_t *n, ray_result_t *res);

/* ray_find_root_n, but where a refinement is needed (refine()) it may be set
 * aside in *job (may be NULL: never) instead, and *deferred says whether it
 * was: res is then RAY_HIT_ROOT with the bracket [t_lo, t_hi] that holds the
 * hit, t = t_hi, and *which is -1; refine_batch on job, its out set, gives
 * the hit of ray_find_root_n, and ray_segment_of its *which. */
ray_hit_kind_t ray_find_root_defer(const tape_t *tape, tape_ws_t *ws, ray_method_t m,
                                   const ray_opts_t *opts, const double o[3],
                                   const double d[3], int n, const double *t0,
                                   const double *t1, ray_result_t *res, int *which,
                                   refine_job_t *job, int *deferred);

/* *which of ray_find_root_n for a hit whose bracket starts at t_lo: the
 * first valid segment (t0 <= t1, both finite) that ends at or after t_lo,
 * else the last valid one; -1 if none is valid. */
int ray_segment_of(double t_lo, int n, const double *t0, const double *t1);

/* ---- newton.c ------------------------------------------------------------------------ */

#define UNDECIDED (-1)
/* Interval Newton on a monotone node: a hit kind, or UNDECIDED with *np shrunk. */
int newton_case(ctx_t *c, node_t *np, ray_result_t *res);
/* Alefeld–Hansen: N(T) ∩ T with 0 ∈ G'(T) as 0..2 pieces, left first. */
int ah_pieces(const node_t *n, iv_t gmx, double lo[2], double hi[2]);

/* ---- sampling.c ---------------------------------------------------------------------- */

ray_hit_kind_t sampling(ctx_t *c, const ray_opts_t *opts, double t0, double t1,
                        ray_result_t *res);

#endif
