/* The mesh checker of mesh_check.h.
 *
 * Topology is counted from the half-edges sorted by their lower vertex
 * (counting sort, then a sort of each vertex's few entries), vertex stars from
 * a vertex-to-triangle table, components with a union-find over triangles.
 *
 * Geometry rests on two exact predicates, orient3d (the side of a point with
 * respect to the plane of three others) and orient2d in an axis-plane
 * projection.  Each is first evaluated in double with an error bound derived
 * below; when the bound does not separate the result from 0, it is evaluated
 * again exactly with GMP, on the coordinates as integers over a common power
 * of two (exact_scaled: every step exact, so the sign is the true one).  The
 * intersection predicate is a composition of these, explained above
 * pair_intersects(). */
#include "mesh_check.h"

#include <gmp.h>
#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------------
 * Filtered exact orientation predicates
 *
 * Error bounds.  Let u = 2^-53 (unit roundoff), gamma_n = n u / (1 - n u).
 * Every operation on doubles is correctly rounded, fl(x op y) = (x op y)(1 + d),
 * |d| <= u, as long as nothing overflows or underflows (see the range guard
 * below), and the build compiles with -ffp-contract=off so no fused
 * multiply-add changes the operations written here.
 *
 * orient3d, with ad = a - d etc. rounded:
 *   det = adx (bdy cdz - bdz cdy) + bdx (cdy adz - cdz ady) + cdx (ady bdz - adz bdy)
 * A product of two rounded differences, rounded: 3 roundings, so e (1 + th3)
 * with e the exact product, |th3| <= gamma_3.  Their difference, rounded:
 * within gamma_4 (|e1| + |e2|) of e1 - e2.  Times the rounded difference adx,
 * rounded: within gamma_6 |adx| (|e1| + |e2|).  Two more roundings add the
 * three terms: the computed det is within gamma_8 P of the exact one, where
 * P = sum |adx| (|e1| + |e2|) over the three terms, with exact values.  The
 * computed permanent P' (the same expression with absolute values, every
 * operation rounded) has at most 8 roundings on each of its terms, so
 * P' >= (1 - u)^8 P, and err = fl(c P') >= c (1 - u)^9 P.  With c = 9u,
 * c (1 - u)^9 >= 9u (1 - 9u) > 8u / (1 - 8u) = gamma_8: |det' - det| < err, so
 * |det'| > err gives the exact sign.
 * orient2d: det = (ax - cx)(by - cy) - (ay - cy)(bx - cx): gamma_4 P, P' with
 * at most 4 roundings per term: c = 5u works the same way.
 *
 * Range guard.  The analysis assumes no underflow and no overflow.  Every
 * difference is either 0 or of magnitude in [2^-300, 2^300] (else: exact
 * path; a difference of doubles rounds to 0 only when it is 0).  Then every
 * product of two or three nonzero differences lies within [2^-900, 2^900]:
 * no overflow, no underflow in the products.  A sum or difference whose
 * result is subnormal is exact, so adds are covered.  The one remaining
 * underflow is a tiny cancelled minor times a difference: its absolute error
 * is below 2^-1074, while a nonzero P is at least 2^-900, so the slack
 * between 9u and gamma_8 (about u P >= 2^-953) absorbs it.  If P' = 0, every
 * term is exactly 0 (no product underflowed), so det = 0 exactly. */

#define U_ROUND 0x1p-53
#define ERR3 (9.0 * U_ROUND)
#define ERR2 (5.0 * U_ROUND)
#define RANGE_LO 0x1p-300
#define RANGE_HI 0x1p300

/* The exact stage.  A double is m 2^(x - 53) with an integer |m| < 2^53 (also
 * for subnormals); the coordinates of one predicate call, all multiplied by
 * the same power of two 2^-emin (emin the lowest such x - 53 among them),
 * become integers, and the determinant's sign does not change under a common
 * positive scale (it is homogeneous in the coordinates).  So the exact stage
 * works on GMP integers: the rationals of the coordinates over their common
 * denominator, without the gcds an mpq_t reduces by after every operation
 * (this stage is about 5 times faster than the same in mpq_t, which matters on
 * meshes with flat regions, where every neighbouring pair needs it). */
typedef struct exact {
    mpz_t c[12]; /* coordinates, scaled */
    mpz_t d[9];  /* differences */
    mpz_t m, t, det;
    size_t fallbacks;
} exact_t;

static void exact_init(exact_t *e)
{
    for (int i = 0; i < 12; i++)
        mpz_init(e->c[i]);
    for (int i = 0; i < 9; i++)
        mpz_init(e->d[i]);
    mpz_init(e->m);
    mpz_init(e->t);
    mpz_init(e->det);
    e->fallbacks = 0;
}

static void exact_clear(exact_t *e)
{
    for (int i = 0; i < 12; i++)
        mpz_clear(e->c[i]);
    for (int i = 0; i < 9; i++)
        mpz_clear(e->d[i]);
    mpz_clear(e->m);
    mpz_clear(e->t);
    mpz_clear(e->det);
}

static int in_range(double d)
{
    double a = fabs(d);
    return d == 0 || (a >= RANGE_LO && a <= RANGE_HI);
}

/* c[i] = v[i] 2^-emin for the n finite values v, exactly. */
static void exact_scaled(exact_t *e, const double *v, int n)
{
    int x[12], emin = INT_MAX;
    double f[12];
    for (int i = 0; i < n; i++) {
        f[i] = frexp(v[i], &x[i]); /* v = f 2^x, 0.5 <= |f| < 1, or f = 0 */
        if (f[i] != 0 && x[i] - 53 < emin)
            emin = x[i] - 53;
    }
    for (int i = 0; i < n; i++) {
        /* f 2^53 is an integer below 2^53 in magnitude: exact in mpz_set_d */
        mpz_set_d(e->c[i], ldexp(f[i], 53));
        if (f[i] != 0)
            mpz_mul_2exp(e->c[i], e->c[i], (mp_bitcnt_t)(x[i] - 53 - emin));
    }
}

static int orient3d_exact(exact_t *e, const double *a, const double *b, const double *c,
                          const double *d)
{
    const double v[12] = {a[0], a[1], a[2], b[0], b[1], b[2], c[0], c[1], c[2], d[0], d[1], d[2]};
    e->fallbacks++;
    exact_scaled(e, v, 12);
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++)
            mpz_sub(e->d[3 * i + k], e->c[3 * i + k], e->c[9 + k]);
#define DZ(i, k) e->d[3 * (i) + (k)]
    mpz_mul(e->m, DZ(1, 1), DZ(2, 2));
    mpz_submul(e->m, DZ(1, 2), DZ(2, 1));
    mpz_mul(e->det, DZ(0, 0), e->m);
    mpz_mul(e->m, DZ(2, 1), DZ(0, 2));
    mpz_submul(e->m, DZ(2, 2), DZ(0, 1));
    mpz_addmul(e->det, DZ(1, 0), e->m);
    mpz_mul(e->m, DZ(0, 1), DZ(1, 2));
    mpz_submul(e->m, DZ(0, 2), DZ(1, 1));
    mpz_addmul(e->det, DZ(2, 0), e->m);
#undef DZ
    return mpz_sgn(e->det);
}

/* The sign of det[a - d; b - d; c - d]: which side of the plane abc d lies on
 * (0 on it).  Only compared with other orient3d results, never given a
 * geometric name, so its convention does not matter. */
static int orient3d(exact_t *e, const double *a, const double *b, const double *c,
                    const double *d)
{
    double adx = a[0] - d[0], ady = a[1] - d[1], adz = a[2] - d[2];
    double bdx = b[0] - d[0], bdy = b[1] - d[1], bdz = b[2] - d[2];
    double cdx = c[0] - d[0], cdy = c[1] - d[1], cdz = c[2] - d[2];
    if (in_range(adx) && in_range(ady) && in_range(adz) && in_range(bdx) && in_range(bdy) &&
        in_range(bdz) && in_range(cdx) && in_range(cdy) && in_range(cdz)) {
        double bc = bdy * cdz, cb = bdz * cdy;
        double ca = cdy * adz, ac = cdz * ady;
        double ab = ady * bdz, ba = adz * bdy;
        double det = adx * (bc - cb) + bdx * (ca - ac) + cdx * (ab - ba);
        double perm = (fabs(bc) + fabs(cb)) * fabs(adx) + (fabs(ca) + fabs(ac)) * fabs(bdx) +
                      (fabs(ab) + fabs(ba)) * fabs(cdx);
        if (perm == 0)
            return 0;
        double err = ERR3 * perm;
        if (det > err)
            return 1;
        if (det < -err)
            return -1;
    }
    return orient3d_exact(e, a, b, c, d);
}

static int orient2d_exact(exact_t *e, double ax, double ay, double bx, double by, double cx,
                          double cy)
{
    const double v[6] = {ax, ay, bx, by, cx, cy};
    e->fallbacks++;
    exact_scaled(e, v, 6);
    mpz_sub(e->d[0], e->c[0], e->c[4]);
    mpz_sub(e->d[1], e->c[1], e->c[5]);
    mpz_sub(e->d[2], e->c[2], e->c[4]);
    mpz_sub(e->d[3], e->c[3], e->c[5]);
    mpz_mul(e->det, e->d[0], e->d[3]);
    mpz_submul(e->det, e->d[1], e->d[2]);
    return mpz_sgn(e->det);
}

/* The sign of (a - c) x (b - c) in the plane. */
static int orient2d(exact_t *e, double ax, double ay, double bx, double by, double cx, double cy)
{
    double acx = ax - cx, acy = ay - cy, bcx = bx - cx, bcy = by - cy;
    if (in_range(acx) && in_range(acy) && in_range(bcx) && in_range(bcy)) {
        double l = acx * bcy, r = acy * bcx;
        double det = l - r, perm = fabs(l) + fabs(r);
        if (perm == 0)
            return 0;
        double err = ERR2 * perm;
        if (det > err)
            return 1;
        if (det < -err)
            return -1;
    }
    return orient2d_exact(e, ax, ay, bx, by, cx, cy);
}

/* orient2d of the projection that drops axis k, keeping the other two in
 * cyclic order (k = 0: y z; 1: z x; 2: x y).  Its sign is the sign of
 * component k of (a - c) x (b - c); all three are 0 iff a, b, c are collinear.
 * Restricted to a plane whose normal has a nonzero component k, the
 * projection is an affine bijection onto the axis plane, so it preserves
 * which points lie on which segments, triangles and sides of lines. */
static int orient2d_k(exact_t *e, int k, const double *a, const double *b, const double *c)
{
    int i = (k + 1) % 3, j = (k + 2) % 3;
    return orient2d(e, a[i], a[j], b[i], b[j], c[i], c[j]);
}

/* An axis whose projection keeps triangle abc non-degenerate (the largest
 * normal component first, as a guess, then checked exactly), with the
 * triangle's orientation there in *sign; -1 when a, b, c are collinear. */
static int tri_axis(exact_t *e, const double *a, const double *b, const double *c, int *sign)
{
    double ux = b[0] - a[0], uy = b[1] - a[1], uz = b[2] - a[2];
    double vx = c[0] - a[0], vy = c[1] - a[1], vz = c[2] - a[2];
    double n[3] = {fabs(uy * vz - uz * vy), fabs(uz * vx - ux * vz), fabs(ux * vy - uy * vx)};
    int order[3] = {0, 1, 2};
    for (int i = 0; i < 3; i++) /* by |n| descending; NaN (overflow) anywhere is fine */
        for (int j = i + 1; j < 3; j++)
            if (n[order[j]] > n[order[i]]) {
                int t = order[i];
                order[i] = order[j];
                order[j] = t;
            }
    for (int i = 0; i < 3; i++) {
        int s = orient2d_k(e, order[i], a, b, c);
        if (s) {
            *sign = s;
            return order[i];
        }
    }
    *sign = 0;
    return -1;
}

/* ------------------------------------------------------------------------
 * Segment and triangle tests (closed sets; triangles non-degenerate,
 * segments with distinct ends)
 */

typedef struct geo {
    const double *p;
    exact_t ex;
} geo_t;

#define PT(g, i) ((g)->p + 3 * (size_t)(i))

/* x, collinear with a and b, lies on the closed segment ab: within its
 * bounding box (exact comparisons of the coordinates). */
static int on_segment(const double *a, const double *b, const double *x)
{
    for (int k = 0; k < 3; k++)
        if (x[k] < fmin(a[k], b[k]) || x[k] > fmax(a[k], b[k]))
            return 0;
    return 1;
}

/* Closed segments pq and ab, coplanar, meet (in projection k, which is
 * injective on their plane).  With the four orientations of each segment's
 * ends with respect to the other's line: if both pairs are strictly separated
 * they cross.  If they meet otherwise, some orientation is 0, i.e. an end lies
 * on the other's line; if the lines are distinct, they have that end as their
 * only common point, so it is where the segments meet and it lies on the
 * other segment; if the lines are the same (all four 0), two overlapping
 * collinear segments have an end of one on the other.  An end on the other's
 * line is on the segment iff it is in its box. */
static int segments_meet2(geo_t *g, int k, const double *p, const double *q, const double *a,
                          const double *b)
{
    int o1 = orient2d_k(&g->ex, k, p, q, a), o2 = orient2d_k(&g->ex, k, p, q, b);
    if (o1 && o1 == o2)
        return 0;
    int o3 = orient2d_k(&g->ex, k, a, b, p), o4 = orient2d_k(&g->ex, k, a, b, q);
    if (o3 && o3 == o4)
        return 0;
    if (o1 && o2 && o3 && o4)
        return 1; /* both pairs strictly separated: a proper crossing */
    return (o1 == 0 && on_segment(p, q, a)) || (o2 == 0 && on_segment(p, q, b)) ||
           (o3 == 0 && on_segment(a, b, p)) || (o4 == 0 && on_segment(a, b, q));
}

/* Point x, in the plane of t0 t1 t2, lies in the closed triangle: in
 * projection k (where the triangle has orientation st != 0) no edge has x
 * strictly on its outer side. */
static int point_in_tri2(geo_t *g, int k, int st, const double *x, const double *t0,
                         const double *t1, const double *t2)
{
    return orient2d_k(&g->ex, k, t0, t1, x) != -st && orient2d_k(&g->ex, k, t1, t2, x) != -st &&
           orient2d_k(&g->ex, k, t2, t0, x) != -st;
}

/* Triangle t0 t1 t2 with its projection axis, found when first needed. */
typedef struct tri {
    const double *v[3];
    int axis, sign; /* axis -2: not yet known */
} tri_t;

static tri_t tri_make(geo_t *g, const uint32_t *idx)
{
    tri_t t = {{PT(g, idx[0]), PT(g, idx[1]), PT(g, idx[2])}, -2, 0};
    return t;
}

static int tri_plane_axis(geo_t *g, tri_t *t)
{
    if (t->axis == -2)
        t->axis = tri_axis(&g->ex, t->v[0], t->v[1], t->v[2], &t->sign);
    return t->axis;
}

/* The closed segment pq meets the closed triangle T; op, oq are the
 * orientations of p and q with respect to T's plane (orient3d(T, .)).
 *   both strictly on one side: no.
 *   both on the plane: a planar question; in the plane, a segment meets a
 *     triangle iff an end lies in the triangle, or else (both ends outside,
 *     the segment entering it) the segment crosses its boundary, one of its
 *     three edges.
 *   otherwise the line pq is transversal to the plane and the segment meets it
 *     in exactly one point X (X = p when op = 0).  For each edge ti tj of T,
 *     orient3d(p, q, ti, tj) = s * orient2d_plane(X, ti, tj) with one fixed
 *     sign s != 0 for all three edges (the volume of p q ti tj is the height
 *     of the segment's direction over the plane times the signed area of
 *     X ti tj), so X is in the closed T iff the three are not of both strict
 *     signs (T non-degenerate: they are never all 0). */
static int segment_meets_tri(geo_t *g, const double *p, const double *q, tri_t *t, int op,
                             int oq)
{
    if (op == 0 && oq == 0) {
        int k = tri_plane_axis(g, t);
        const double *const *v = t->v;
        return point_in_tri2(g, k, t->sign, p, v[0], v[1], v[2]) ||
               point_in_tri2(g, k, t->sign, q, v[0], v[1], v[2]) ||
               segments_meet2(g, k, p, q, v[0], v[1]) || segments_meet2(g, k, p, q, v[1], v[2]) ||
               segments_meet2(g, k, p, q, v[2], v[0]);
    }
    if (op == oq)
        return 0;
    int s0 = orient3d(&g->ex, p, q, t->v[0], t->v[1]);
    int s1 = orient3d(&g->ex, p, q, t->v[1], t->v[2]);
    if (s0 && s1 && s0 != s1)
        return 0;
    int s2 = orient3d(&g->ex, p, q, t->v[2], t->v[0]);
    int pos = s0 > 0 || s1 > 0 || s2 > 0, neg = s0 < 0 || s1 < 0 || s2 < 0;
    return !(pos && neg);
}

static int side(geo_t *g, const tri_t *t, const double *x)
{
    return orient3d(&g->ex, t->v[0], t->v[1], t->v[2], x);
}

/* ------------------------------------------------------------------------
 * The pair predicate.  Triangles A and B, non-degenerate, are fine iff
 * A ∩ B = conv(S), S the vertices whose indices they share (|S| = s).
 *
 * s = 3: the same triangle twice: A ∩ B = A = conv(S), fine by definition.
 *
 * s = 2, shared edge uw, A = uwa, B = uwb: A ∩ B always holds [u, w].
 *   If b is off the plane of A, the two planes are distinct and both hold the
 *   line uw, so A ∩ B lies on that line, where A holds exactly [u, w] (a is off
 *   it): fine.  If b is in A's plane, then in that plane A and B lie each on
 *   one side of the line uw: on opposite sides they meet only on the line, in
 *   [u, w] (fine); on the same side both hold a half-disc around the middle of
 *   uw: intersecting (this is the fold-flat case).  So: intersecting iff
 *   orient3d(u, w, a, b) = 0 and orient2d(u, w, a), orient2d(u, w, b) agree in a
 *   projection where uwa is non-degenerate (b is not on the line: B is
 *   non-degenerate).
 *
 * s = 1, shared vertex v, A = v a1 a2, B = v b1 b2: fine iff A ∩ B = {v}.
 *   Claim: A ∩ B != {v} iff the edge [a1, a2] meets B or [b1, b2] meets A.
 *   If: v is on neither edge (the triangles are non-degenerate), so a common
 *   point of [a1, a2] and B is a point of A ∩ B other than v.  Only if: take
 *   x != v in A ∩ B.  The ray from v through x stays in A over [v, r1] and
 *   leaves it at r1 on the opposite edge [a1, a2] (a ray from a vertex into a
 *   triangle leaves it through the opposite side); likewise it leaves B at r2
 *   on [b1, b2].  Both r1 and r2 lie beyond x; if r1 is the nearer, r1 lies on
 *   [v, r2], in B, so [a1, a2] meets B; else r2 lies in A.  This covers every
 *   degenerate way two fans can touch: edges from v overlapping, coplanar
 *   fans folded over each other, a far vertex or edge touching the other
 *   triangle, vertices with equal coordinates (those touch).
 *
 * s = 0: fine iff A ∩ B = ∅.  Claim: A ∩ B != ∅ iff an edge of A meets B or an
 *   edge of B meets A.  Not coplanar: A ∩ B lies on the line L where the
 *   planes meet, A ∩ L and B ∩ L are segments (or points) whose ends lie on
 *   the boundaries of A and B; two overlapping intervals have an end of one
 *   in the other, i.e. a point of an edge of one triangle in the other.
 *   Coplanar: if no edge of B meets A, A ∩ B lies in B's relative interior;
 *   A ∩ B = A ∩ int B is then closed and open in A, nonempty, so it is all of
 *   the connected A: the edges of A lie in B.  Before the six segment tests,
 *   the usual rejection: all vertices of one strictly on one side of the
 *   other's plane.
 *
 * Every step is a segment-triangle test, itself made of orient3d and of
 * planar orient2d tests, all exact: the answer is exact for the doubles. */
static int pair_intersects(geo_t *g, const uint32_t *ia, const uint32_t *ib)
{
    int inb[3], s = 0;
    for (int i = 0; i < 3; i++) {
        inb[i] = ia[i] == ib[0] || ia[i] == ib[1] || ia[i] == ib[2];
        s += inb[i];
    }
    if (s == 3)
        return 0;
    if (s == 2) {
        int k = !inb[0] ? 0 : !inb[1] ? 1 : 2;
        uint32_t a = ia[k], u = ia[(k + 1) % 3], w = ia[(k + 2) % 3];
        uint32_t b = ib[0] != u && ib[0] != w ? ib[0] : ib[1] != u && ib[1] != w ? ib[1] : ib[2];
        const double *pu = PT(g, u), *pw = PT(g, w), *pa = PT(g, a), *pb = PT(g, b);
        if (orient3d(&g->ex, pu, pw, pa, pb) != 0)
            return 0;
        int sa, axis = tri_axis(&g->ex, pu, pw, pa, &sa);
        return orient2d_k(&g->ex, axis, pu, pw, pb) == sa;
    }
    tri_t ta = tri_make(g, ia), tb = tri_make(g, ib);
    if (s == 1) {
        int ka = inb[0] ? 0 : inb[1] ? 1 : 2;
        uint32_t v = ia[ka];
        int kb = ib[0] == v ? 0 : ib[1] == v ? 1 : 2;
        const double *a1 = ta.v[(ka + 1) % 3], *a2 = ta.v[(ka + 2) % 3];
        const double *b1 = tb.v[(kb + 1) % 3], *b2 = tb.v[(kb + 2) % 3];
        if (segment_meets_tri(g, a1, a2, &tb, side(g, &tb, a1), side(g, &tb, a2)))
            return 1;
        return segment_meets_tri(g, b1, b2, &ta, side(g, &ta, b1), side(g, &ta, b2));
    }
    int oa[3], ob[3];
    for (int i = 0; i < 3; i++)
        ob[i] = side(g, &ta, tb.v[i]);
    if (ob[0] && ob[0] == ob[1] && ob[1] == ob[2])
        return 0;
    for (int i = 0; i < 3; i++)
        oa[i] = side(g, &tb, ta.v[i]);
    if (oa[0] && oa[0] == oa[1] && oa[1] == oa[2])
        return 0;
    for (int i = 0; i < 3; i++)
        if (segment_meets_tri(g, ta.v[i], ta.v[(i + 1) % 3], &tb, oa[i], oa[(i + 1) % 3]))
            return 1;
    for (int i = 0; i < 3; i++)
        if (segment_meets_tri(g, tb.v[i], tb.v[(i + 1) % 3], &ta, ob[i], ob[(i + 1) % 3]))
            return 1;
    return 0;
}

static int has_repeat(const uint32_t *t) { return t[0] == t[1] || t[1] == t[2] || t[0] == t[2]; }

static int is_degenerate(geo_t *g, const uint32_t *t)
{
    int sign;
    return has_repeat(t) || tri_axis(&g->ex, PT(g, t[0]), PT(g, t[1]), PT(g, t[2]), &sign) < 0;
}

int mc_triangles_intersect(const double *points, const uint32_t a[3], const uint32_t b[3])
{
    geo_t g;
    g.p = points;
    exact_init(&g.ex);
    int res = is_degenerate(&g, a) || is_degenerate(&g, b) ? -1 : pair_intersects(&g, a, b);
    exact_clear(&g.ex);
    return res;
}

/* ------------------------------------------------------------------------
 * Small helpers
 */

/* malloc of n elements of size sz, at least one byte (so n = 0 is not a failure), NULL on
 * overflow */
static void *alloc_n(size_t n, size_t sz, int zero)
{
    if (sz && n > SIZE_MAX / sz)
        return NULL;
    size_t bytes = n * sz;
    if (bytes == 0)
        bytes = 1;
    return zero ? calloc(1, bytes) : malloc(bytes);
}

static uint64_t mix64(uint64_t z)
{
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

static int cmp_size(const void *a, const void *b)
{
    size_t x = *(const size_t *)a, y = *(const size_t *)b;
    return (x > y) - (x < y);
}

static int cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

static uint32_t uf_find(uint32_t *par, uint32_t x)
{
    while (par[x] != x) {
        par[x] = par[par[x]]; /* path halving */
        x = par[x];
    }
    return x;
}

static void uf_union(uint32_t *par, uint32_t a, uint32_t b)
{
    a = uf_find(par, a);
    b = uf_find(par, b);
    if (a < b)
        par[b] = a;
    else if (b < a)
        par[a] = b;
}

/* Counting sort's offsets: cnt[k + 1] holds the count of key k; afterwards
 * cnt[k] is where key k starts. */
static void prefix_sums(size_t *cnt, size_t n)
{
    for (size_t k = 0; k < n; k++)
        cnt[k + 1] += cnt[k];
}

/* After filling with pos[k]++ from the starts, pos[k] is the start of k + 1:
 * shift back to the starts. */
static void unshift(size_t *pos, size_t n)
{
    for (size_t k = n; k > 0; k--)
        pos[k] = pos[k - 1];
    pos[0] = 0;
}

/* ------------------------------------------------------------------------
 * Topology
 */

/* Coincident vertices: an open-addressing table of the used vertices keyed
 * by their coordinates (-0.0 taken as 0.0, since they are the same point);
 * each later vertex equal to an earlier group adds one pair per member. */
static int count_coincident(const double *pts, size_t nv, const unsigned char *used,
                            size_t n_used, size_t *pairs)
{
    size_t m = 1;
    while (m < 2 * n_used + 1)
        m <<= 1;
    uint32_t *rep = alloc_n(m, sizeof *rep, 0); /* the group's first vertex */
    uint32_t *cnt = alloc_n(m, sizeof *cnt, 1); /* its size; 0: an empty slot */
    if (!rep || !cnt) {
        free(rep);
        free(cnt);
        return -1;
    }
    *pairs = 0;
    for (size_t v = 0; v < nv; v++) {
        if (!used[v])
            continue;
        const double *p = pts + 3 * v;
        uint64_t h = 0;
        for (int k = 0; k < 3; k++) {
            double x = p[k] == 0 ? 0.0 : p[k];
            uint64_t bits;
            memcpy(&bits, &x, sizeof bits);
            h = mix64(h ^ bits);
        }
        for (size_t at = (size_t)h & (m - 1);; at = (at + 1) & (m - 1)) {
            if (!cnt[at]) {
                rep[at] = (uint32_t)v;
                cnt[at] = 1;
                break;
            }
            const double *q = pts + 3 * (size_t)rep[at];
            if (q[0] == p[0] && q[1] == p[1] && q[2] == p[2]) {
                *pairs += cnt[at]++;
                break;
            }
        }
    }
    free(rep);
    free(cnt);
    return 0;
}

/* Edges from the half-edges: key (hi << 32) | (t << 1) | dir per directed edge
 * of two distinct indices, bucketed by its lower index, sorted in the bucket
 * (by hi, then triangle).  Counts the edge classes and joins the triangles of
 * each edge in the union-find par. */
static int count_edges(const uint32_t *tris, size_t nt, size_t nv, uint32_t *par, mc_report_t *r)
{
    size_t *off = alloc_n(nv + 1, sizeof *off, 1);
    uint64_t *he = alloc_n(3 * nt, sizeof *he, 0);
    if (!off || !he) {
        free(off);
        free(he);
        return -1;
    }
    for (size_t t = 0; t < nt; t++)
        for (int k = 0; k < 3; k++) {
            uint32_t i = tris[3 * t + k], j = tris[3 * t + (k + 1) % 3];
            if (i != j)
                off[(size_t)(i < j ? i : j) + 1]++;
        }
    prefix_sums(off, nv);
    for (size_t t = 0; t < nt; t++)
        for (int k = 0; k < 3; k++) {
            uint32_t i = tris[3 * t + k], j = tris[3 * t + (k + 1) % 3];
            if (i == j)
                continue;
            uint32_t lo = i < j ? i : j, hi = i < j ? j : i;
            he[off[lo]++] = (uint64_t)hi << 32 | (uint64_t)t << 1 | (uint64_t)(i < j);
        }
    unshift(off, nv);
    for (size_t v = 0; v < nv; v++) {
        size_t s = off[v], e = off[v + 1];
        qsort(he + s, e - s, sizeof *he, cmp_u64);
        for (size_t a = s; a < e;) {
            size_t b = a + 1;
            while (b < e && he[b] >> 32 == he[a] >> 32)
                b++;
            size_t m = b - a;
            r->edges++;
            if (m == 1)
                r->boundary_edges++;
            else if (m >= 3)
                r->nonmanifold_edges++;
            else if ((he[a] & 1) == (he[a + 1] & 1))
                r->misoriented_edges++;
            for (size_t c = a + 1; c < b; c++)
                uf_union(par, (uint32_t)((he[a] >> 1) & 0x7fffffffu),
                         (uint32_t)((he[c] >> 1) & 0x7fffffffu));
            a = b;
        }
    }
    free(off);
    free(he);
    return 0;
}

static size_t find_u32(const uint32_t *v, size_t n, uint32_t x)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (v[mid] < x)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

/* Vertex stars.  The triangles around v, each t = v a b, give the link of v:
 * the graph on the other vertices with an edge a-b per triangle.  Two
 * triangles around v share an edge v-w iff their link edges share w.  The
 * star is one disc (a closed fan or one open fan) iff the link is one cycle
 * or one path: connected, every vertex of degree at most 2 (a vertex of
 * degree 3 or more is an edge v-w in three or more triangles).  A triangle
 * with a repeated index is no 2-cell: its vertices are non-manifold. */
static int count_vertex_stars(const uint32_t *tris, size_t nt, size_t nv, mc_report_t *r)
{
    size_t *off = alloc_n(nv + 1, sizeof *off, 1);
    uint32_t *inc = alloc_n(3 * nt, sizeof *inc, 0);
    if (!off || !inc) {
        free(off);
        free(inc);
        return -1;
    }
    for (size_t t = 0; t < nt; t++) {
        const uint32_t *x = tris + 3 * t;
        off[(size_t)x[0] + 1]++;
        if (x[1] != x[0])
            off[(size_t)x[1] + 1]++;
        if (x[2] != x[0] && x[2] != x[1])
            off[(size_t)x[2] + 1]++;
    }
    prefix_sums(off, nv);
    for (size_t t = 0; t < nt; t++) {
        const uint32_t *x = tris + 3 * t;
        inc[off[x[0]]++] = (uint32_t)t;
        if (x[1] != x[0])
            inc[off[x[1]]++] = (uint32_t)t;
        if (x[2] != x[0] && x[2] != x[1])
            inc[off[x[2]]++] = (uint32_t)t;
    }
    unshift(off, nv);
    size_t maxdeg = 0;
    for (size_t v = 0; v < nv; v++)
        if (off[v + 1] - off[v] > maxdeg)
            maxdeg = off[v + 1] - off[v];
    uint32_t *ep = alloc_n(2 * maxdeg, sizeof *ep, 0);
    uint32_t *uq = alloc_n(2 * maxdeg, sizeof *uq, 0);
    uint32_t *par = alloc_n(2 * maxdeg, sizeof *par, 0);
    if (!ep || !uq || !par) {
        free(off);
        free(inc);
        free(ep);
        free(uq);
        free(par);
        return -1;
    }
    for (size_t v = 0; v < nv; v++) {
        size_t s = off[v], deg = off[v + 1] - s;
        if (!deg)
            continue;
        int bad = 0;
        for (size_t i = 0; i < deg && !bad; i++) {
            const uint32_t *x = tris + 3 * (size_t)inc[s + i];
            if (has_repeat(x)) {
                bad = 1;
                break;
            }
            int k = x[0] == v ? 0 : x[1] == v ? 1 : 2;
            ep[2 * i] = x[(k + 1) % 3];
            ep[2 * i + 1] = x[(k + 2) % 3];
        }
        size_t nu = 0;
        if (!bad) {
            memcpy(uq, ep, 2 * deg * sizeof *uq);
            qsort(uq, 2 * deg, sizeof *uq, cmp_u32);
            for (size_t i = 0; i < 2 * deg;) {
                size_t j = i + 1;
                while (j < 2 * deg && uq[j] == uq[i])
                    j++;
                if (j - i > 2)
                    bad = 1; /* degree 3 or more in the link */
                uq[nu++] = uq[i];
                i = j;
            }
        }
        if (!bad) {
            for (size_t i = 0; i < nu; i++)
                par[i] = (uint32_t)i;
            for (size_t i = 0; i < deg; i++)
                uf_union(par, (uint32_t)find_u32(uq, nu, ep[2 * i]),
                         (uint32_t)find_u32(uq, nu, ep[2 * i + 1]));
            size_t roots = 0;
            for (size_t i = 0; i < nu; i++)
                roots += uf_find(par, (uint32_t)i) == i;
            bad = roots != 1;
        }
        r->nonmanifold_vertices += bad;
    }
    free(off);
    free(inc);
    free(ep);
    free(uq);
    free(par);
    return 0;
}

/* ------------------------------------------------------------------------
 * Candidate pairs: a uniform grid of the triangles' bounding boxes
 *
 * The cell size h starts at the mean of the triangles' largest box sides and
 * doubles until the (cell, triangle) entries number at most 16 per triangle
 * (+1024): memory stays O(n) whatever the size spread.  The occupied cells
 * are hashed into M buckets (M a power of two >= entries): a triangle is
 * listed once per bucket it reaches (its cells' buckets, deduplicated), in
 * increasing order.  A pair listed together in a bucket is tested only when
 * their closed boxes overlap (else they cannot meet) and the bucket is the
 * one of the cell holding the lower corner of the boxes' overlap: both boxes
 * reach that cell (the cell index is monotone in the coordinate), so every
 * overlapping pair is tested, and in one bucket only, once (each triangle
 * appears once per bucket). */

#define GRID_MAX_DIM (1u << 20)

typedef struct grid {
    double lo[3], inv;
    uint32_t dim[3];
    size_t mask; /* M - 1 */
} grid_t;

static uint32_t cell_of(const grid_t *gr, int k, double x)
{
    double c = (x - gr->lo[k]) * gr->inv;
    if (!(c > 0)) /* also NaN, from a single-cell grid (inv 0) over huge spans */
        return 0;
    if (c >= (double)gr->dim[k])
        return gr->dim[k] - 1;
    return (uint32_t)c;
}

static size_t bucket_of(const grid_t *gr, uint32_t x, uint32_t y, uint32_t z)
{
    return (size_t)mix64((uint64_t)x | (uint64_t)y << 21 | (uint64_t)z << 42) & gr->mask;
}

static void tri_box(const double *pts, const uint32_t *t, double lo[3], double hi[3])
{
    const double *a = pts + 3 * (size_t)t[0], *b = pts + 3 * (size_t)t[1],
                 *c = pts + 3 * (size_t)t[2];
    for (int k = 0; k < 3; k++) {
        lo[k] = fmin(a[k], fmin(b[k], c[k]));
        hi[k] = fmax(a[k], fmax(b[k], c[k]));
    }
}

/* cells of a box, per axis first and last */
static void box_cells(const grid_t *gr, const double lo[3], const double hi[3], uint32_t c0[3],
                      uint32_t c1[3])
{
    for (int k = 0; k < 3; k++) {
        c0[k] = cell_of(gr, k, lo[k]);
        c1[k] = cell_of(gr, k, hi[k]);
    }
}

/* The buckets of triangle t, deduplicated and sorted, into *buf (grown as
 * needed); the count, or (size_t)-1 when out of memory. */
static size_t tri_buckets(const grid_t *gr, const double *pts, const uint32_t *t, size_t **buf,
                          size_t *cap)
{
    double lo[3], hi[3];
    uint32_t c0[3], c1[3];
    tri_box(pts, t, lo, hi);
    box_cells(gr, lo, hi, c0, c1);
    size_t n = (size_t)(c1[0] - c0[0] + 1) * (c1[1] - c0[1] + 1) * (c1[2] - c0[2] + 1);
    if (n > *cap) {
        size_t *nb = realloc(*buf, n * sizeof **buf);
        if (!nb)
            return (size_t)-1;
        *buf = nb;
        *cap = n;
    }
    size_t *b = *buf, m = 0;
    for (uint32_t z = c0[2]; z <= c1[2]; z++)
        for (uint32_t y = c0[1]; y <= c1[1]; y++)
            for (uint32_t x = c0[0]; x <= c1[0]; x++)
                b[m++] = bucket_of(gr, x, y, z);
    if (m > 1) {
        qsort(b, m, sizeof *b, cmp_size);
        size_t u = 1;
        for (size_t i = 1; i < m; i++)
            if (b[i] != b[u - 1])
                b[u++] = b[i];
        m = u;
    }
    return m;
}

static void prefix_sums32(uint32_t *cnt, size_t n)
{
    for (size_t k = 0; k < n; k++)
        cnt[k + 1] += cnt[k];
}

static void unshift32(uint32_t *pos, size_t n)
{
    for (size_t k = n; k > 0; k--)
        pos[k] = pos[k - 1];
    pos[0] = 0;
}

/* Sets up the grid for the non-degenerate triangles (see above); the number
 * of (cell, triangle) entries, at most cap, in *raw.  The cell size is the
 * only choice: too small and big triangles fill many cells, too large and
 * cells hold many triangles; both cost time, neither correctness. */
static void grid_setup(grid_t *gr, const double *pts, const uint32_t *tris, size_t nt,
                       const unsigned char *degen, size_t na, uint64_t *raw)
{
    double glo[3] = {INFINITY, INFINITY, INFINITY}, ghi[3] = {-INFINITY, -INFINITY, -INFINITY};
    double ext = 0;
    for (size_t t = 0; t < nt; t++) {
        if (degen[t])
            continue;
        double lo[3], hi[3];
        tri_box(pts, tris + 3 * t, lo, hi);
        double side = 0;
        for (int k = 0; k < 3; k++) {
            glo[k] = fmin(glo[k], lo[k]);
            ghi[k] = fmax(ghi[k], hi[k]);
            side = fmax(side, hi[k] - lo[k]);
        }
        ext += side;
    }
    uint64_t cap = 16 * (uint64_t)na + 1024;
    if (cap > UINT32_MAX)
        cap = UINT32_MAX;
    double h = ext / (double)na, span[3], smax = 0;
    for (int k = 0; k < 3; k++) {
        gr->lo[k] = glo[k];
        span[k] = ghi[k] - glo[k];
        smax = fmax(smax, span[k]);
    }
    for (;;) {
        /* one cell for absurd inputs (spans or sizes overflowing): slow, still right */
        int single = !(h > 0 && isfinite(h) && isfinite(smax));
        if (!single) {
            if (h < smax / GRID_MAX_DIM)
                h = smax / GRID_MAX_DIM;
            gr->inv = 1 / h;
            for (int k = 0; k < 3; k++) {
                double d = floor(span[k] * gr->inv) + 1;
                gr->dim[k] = d >= GRID_MAX_DIM ? GRID_MAX_DIM : (uint32_t)d;
            }
        } else {
            gr->inv = 0;
            gr->dim[0] = gr->dim[1] = gr->dim[2] = 1;
        }
        uint64_t n = 0;
        for (size_t t = 0; t < nt && n <= cap; t++) {
            if (degen[t])
                continue;
            double lo[3], hi[3];
            uint32_t c0[3], c1[3];
            tri_box(pts, tris + 3 * t, lo, hi);
            box_cells(gr, lo, hi, c0, c1);
            n += (uint64_t)(c1[0] - c0[0] + 1) * (c1[1] - c0[1] + 1) * (c1[2] - c0[2] + 1);
        }
        if (n <= cap || single) {
            *raw = n;
            return;
        }
        h *= 2;
    }
}

static int find_intersections(geo_t *g, const uint32_t *tris, size_t nt,
                              const unsigned char *degen, mc_report_t *r)
{
    size_t na = 0;
    for (size_t t = 0; t < nt; t++)
        na += !degen[t];
    if (na < 2)
        return 0;
    grid_t gr;
    uint64_t raw;
    grid_setup(&gr, g->p, tris, nt, degen, na, &raw);
    size_t m = 1;
    while (m < raw)
        m <<= 1;
    gr.mask = m - 1;

    int ret = -1;
    size_t *buf = NULL, bcap = 0;
    uint32_t *off = alloc_n(m + 1, sizeof *off, 1);
    uint32_t *ent = alloc_n((size_t)raw, sizeof *ent, 0);
    if (!off || !ent)
        goto done;
    for (size_t t = 0; t < nt; t++) {
        if (degen[t])
            continue;
        size_t n = tri_buckets(&gr, g->p, tris + 3 * t, &buf, &bcap);
        if (n == (size_t)-1)
            goto done;
        for (size_t i = 0; i < n; i++)
            off[buf[i] + 1]++;
    }
    prefix_sums32(off, m);
    for (size_t t = 0; t < nt; t++) {
        if (degen[t])
            continue;
        size_t n = tri_buckets(&gr, g->p, tris + 3 * t, &buf, &bcap);
        if (n == (size_t)-1)
            goto done;
        for (size_t i = 0; i < n; i++)
            ent[off[buf[i]]++] = (uint32_t)t;
    }
    unshift32(off, m);

    int found = 0;
    for (size_t b = 0; b < m; b++) {
        uint32_t s = off[b], e = off[b + 1];
        for (uint32_t x = s; x < e; x++) {
            uint32_t i = ent[x];
            double loi[3], hii[3];
            tri_box(g->p, tris + 3 * (size_t)i, loi, hii);
            for (uint32_t y = x + 1; y < e; y++) {
                uint32_t j = ent[y]; /* > i: filled in increasing order */
                double loj[3], hij[3];
                tri_box(g->p, tris + 3 * (size_t)j, loj, hij);
                if (loi[0] > hij[0] || loj[0] > hii[0] || loi[1] > hij[1] || loj[1] > hii[1] ||
                    loi[2] > hij[2] || loj[2] > hii[2])
                    continue;
                if (bucket_of(&gr, cell_of(&gr, 0, fmax(loi[0], loj[0])),
                              cell_of(&gr, 1, fmax(loi[1], loj[1])),
                              cell_of(&gr, 2, fmax(loi[2], loj[2]))) != b)
                    continue;
                if (!pair_intersects(g, tris + 3 * (size_t)i, tris + 3 * (size_t)j))
                    continue;
                r->intersecting_pairs++;
                if (!found || i < r->first_pair[0] || (i == r->first_pair[0] && j < r->first_pair[1])) {
                    r->first_pair[0] = i;
                    r->first_pair[1] = j;
                    found = 1;
                }
            }
        }
    }
    ret = 0;
done:
    free(buf);
    free(off);
    free(ent);
    return ret;
}

/* ------------------------------------------------------------------------
 * The API
 */

int mc_check(const double *points, size_t nv, const uint32_t *tris, size_t nt,
             int check_intersections, mc_report_t *r)
{
    memset(r, 0, sizeof *r);
    /* triangle numbers go into 31 bits of a half-edge key */
    if (nt >= (size_t)1 << 31 || (nt && !tris) || (nv && !points))
        return -1;
    for (size_t i = 0; i < 3 * nt; i++)
        if (tris[i] >= nv)
            return -1;
    int ret = -1;
    geo_t g;
    g.p = points;
    exact_init(&g.ex);
    unsigned char *used = alloc_n(nv, 1, 1), *degen = alloc_n(nt, 1, 0);
    uint32_t *par = alloc_n(nt, sizeof *par, 0);
    if (!used || !degen || !par)
        goto done;
    for (size_t i = 0; i < 3 * nt; i++)
        used[tris[i]] = 1;
    for (size_t v = 0; v < nv; v++) {
        if (!used[v])
            continue;
        r->vertices++;
        /* the predicates need finite numbers (frexp of an infinity or a NaN is no number) */
        if (!isfinite(points[3 * v]) || !isfinite(points[3 * v + 1]) || !isfinite(points[3 * v + 2]))
            goto done;
    }
    r->triangles = nt;
    for (size_t t = 0; t < nt; t++) {
        degen[t] = (unsigned char)is_degenerate(&g, tris + 3 * t);
        r->degenerate_triangles += degen[t];
    }
    if (count_coincident(points, nv, used, r->vertices, &r->coincident_vertices))
        goto done;
    for (size_t t = 0; t < nt; t++)
        par[t] = (uint32_t)t;
    if (count_edges(tris, nt, nv, par, r))
        goto done;
    for (size_t t = 0; t < nt; t++)
        r->components += uf_find(par, (uint32_t)t) == t;
    if (count_vertex_stars(tris, nt, nv, r))
        goto done;
    r->euler = (long)r->vertices - (long)r->edges + (long)r->triangles;
    if (check_intersections) {
        if (find_intersections(&g, tris, nt, degen, r))
            goto done;
        r->intersections_checked = 1;
    }
    ret = 0;
done:
    r->exact_fallbacks = g.ex.fallbacks;
    if (ret)
        memset(r, 0, sizeof *r);
    exact_clear(&g.ex);
    free(used);
    free(degen);
    free(par);
    return ret;
}

int mc_is_closed_embedded(const mc_report_t *r)
{
    return r->triangles > 0 && r->boundary_edges == 0 && r->nonmanifold_edges == 0 &&
           r->misoriented_edges == 0 && r->nonmanifold_vertices == 0 &&
           r->degenerate_triangles == 0 && r->coincident_vertices == 0 &&
           r->intersections_checked && r->intersecting_pairs == 0;
}

double mc_signed_volume(const double *points, const uint32_t *tris, size_t nt)
{
    double v = 0;
    for (size_t t = 0; t < nt; t++) {
        const double *a = points + 3 * (size_t)tris[3 * t], *b = points + 3 * (size_t)tris[3 * t + 1],
                     *c = points + 3 * (size_t)tris[3 * t + 2];
        /* a . (b x c): six times the signed volume of the tetrahedron 0 a b c */
        v += a[0] * (b[1] * c[2] - b[2] * c[1]) + a[1] * (b[2] * c[0] - b[0] * c[2]) +
             a[2] * (b[0] * c[1] - b[1] * c[0]);
    }
    return v / 6;
}
