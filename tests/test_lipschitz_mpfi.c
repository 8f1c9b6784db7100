/* Property tests of lipschitz/ (the Kalra–Barr bounds) against an MPFI oracle.
 *
 * Every function of lipschitz.h makes a claim about f over a box or a ray
 * segment; here the claim is checked at sample points of that box or segment
 * with f and ∇f evaluated in MPFI at 256 bits (tests/support/mpfi_tape.h),
 * alternately with each end of the interval constants, on every scene file
 * and on a few expressions with kinks, domain edges, a pole and planes:
 *   1. lip_gradient_bound: |∇f(p)| <= L at the corners, the centre and random
 *      points of the box where f is differentiable (random sub-boxes from the
 *      whole box down to 2^-20 of it);
 *   2. lip_cell_excludes with sign s: f has the strict sign s at every defined
 *      point of a 5x5x5 grid of the box (9x9x9 in one excluded box in 8;
 *      faces, edges and corners included) and at random points;
 *   3. lip_segment_excludes: no root on [a, b]: the value at the exact points
 *      o + t·d, t = a, b, m and 64 more (and at the rounded points p~(t)),
 *      has the strict sign of g(m);
 *   4. lip_normals_within_60_degrees: g·a > |g| |a| / 2 for the gradient g at
 *      every sampled point;
 *   5. the bounds are the upper ends of their interval formulas, bit for bit
 *      (lipschitz.c computes only the upper ends).
 * The boxes of 2-4 are small and many sit near the surface, so that the tests
 * do decide (the number of decisions is asserted > 0, or the check would be
 * vacuous); a quarter of the boxes and segments are placed at the edge of
 * their test (the surface or root at distance r (1 ± δ) from the centre, δ
 * down to 2^-30), where a bound a hair too small would show.  A failure can
 * only be a wrong decision: the oracle is fail-only-if-certain (an MPFI
 * interval that merely touches the bad side is not a failure).  Hand cases
 * check the documented values (exact magnitudes, NaN, no decision on empty
 * or unbounded inputs). */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "../lipschitz/lipschitz.h"
#include "../scene/scene.h"
#include "support/mpfi_tape.h"
#include "support/testutil.h"

enum { BATCH = 13 }; /* not a multiple of 8: the evaluators pad the batch */

/* The MPFI oracle costs ~1-2 us per clause and point (it allocates its
 * slots), so each property has a budget of clause evaluations per scene (times
 * tu_scale()), from which the number of boxes (or rays) follows: the short
 * tapes get many boxes, the long ones (the 64-sphere union, 237 clauses) the
 * floor.  Points per decided box are fixed by what each property needs. */
#define GRAD_BUDGET 60000L  /* with gradient */
#define GRAD_POINTS 9       /* the corners and the centre */
#define GRAD_MAX_BOXES 390
#define CELL_BUDGET 120000L /* values only */
#define CELL_MAX_BOXES 260
#define SEG_BUDGET 110000L  /* with gradient (oracle_eval_ray) */
#define SEG_POINTS 67       /* t = a, b, m and 64 spread over [a, b] */
#define SEG_MAX_RAYS 40
#define CONE_BUDGET 50000L  /* with gradient */
#define CONE_POINTS 12      /* the corners, the centre, 3 on faces or inside */
#define CONE_MAX_BOXES 390

/* ---- sampling ------------------------------------------------------------------ */

/* Boxes for a budget of clause evaluations at cost clause evaluations per box,
 * between floor and cap.  The floor keeps the sanitizer build (a tenth of the
 * budget) deciding some boxes of every scene. */
static long boxes_for(long budget, double cost, long floor, long cap, long unit)
{
    double n = (double)budget * tu_scale() / (cost > 1 ? cost : 1);
    long m = n > (double)cap ? cap : (long)n;
    m = (m + unit - 1) / unit * unit;
    return m < floor ? floor : m;
}

/* A box of the given fraction of the scene box on every axis, placed uniformly inside it. */
static iv_box_t sub_box(const double box[6], double frac, uint64_t *rng)
{
    iv_t r[3];
    for (int k = 0; k < 3; k++) {
        double lo = box[2 * k], hi = box[2 * k + 1], w = (hi - lo) * frac;
        double a = tu_lerp(lo, hi - w, tu_uniform(rng));
        double e = fmin(a + w, hi);
        r[k] = iv_make(a, e < a ? a : e);
    }
    return (iv_box_t){r[0], r[1], r[2]};
}

/* A box of the given fraction of the scene box centred at c. */
static iv_box_t centred_box(const double box[6], const double c[3], double frac)
{
    iv_t r[3];
    for (int k = 0; k < 3; k++) {
        double h = 0.5 * (box[2 * k + 1] - box[2 * k]) * frac;
        r[k] = iv_make(c[k] - h, c[k] + h);
    }
    return (iv_box_t){r[0], r[1], r[2]};
}

static void random_point(const double box[6], uint64_t *rng, double p[3])
{
    for (int k = 0; k < 3; k++)
        p[k] = tu_lerp(box[2 * k], box[2 * k + 1], tu_uniform(rng));
}

static double eval_point(const tape_t *t, tape_ws_t *ws, const double p[3])
{
    double v;
    tape_eval_point(t, ws, 1, &p[0], &p[1], &p[2], &v);
    return v;
}

/* A point near the surface: bisection (in doubles: this only chooses test
 * inputs) between two points of the box, or a point and the centre, where f
 * has opposite signs.  A random point when no sign change is found. */
static void near_surface_point(const tape_t *t, tape_ws_t *ws, const double box[6],
                               uint64_t *rng, double p[3])
{
    for (int tries = 0; tries < 24; tries++) {
        double a[3], b[3];
        random_point(box, rng, a);
        if (tries & 1)
            random_point(box, rng, b);
        else
            for (int k = 0; k < 3; k++)
                b[k] = iv_mid(iv_make(box[2 * k], box[2 * k + 1]));
        double fa = eval_point(t, ws, a), fb = eval_point(t, ws, b);
        if (!((fa < 0 && fb > 0) || (fa > 0 && fb < 0)))
            continue;
        for (int it = 0; it < 64; it++) {
            double m[3];
            for (int k = 0; k < 3; k++)
                m[k] = a[k] + 0.5 * (b[k] - a[k]);
            double fm = eval_point(t, ws, m);
            if (fm != fm)
                break;
            if ((fm < 0) == (fa < 0))
                memcpy(a, m, sizeof a);
            else
                memcpy(b, m, sizeof b);
        }
        memcpy(p, a, sizeof a);
        return;
    }
    random_point(box, rng, p);
}

/* The unit normal ∇f/|∇f| at p, in doubles (it only places test boxes);
 * 0 when it is not a finite non-zero vector. */
static int unit_normal(const tape_t *t, tape_ws_t *ws, const double p[3], double n[3])
{
    iv_box_t b = {iv_point(p[0]), iv_point(p[1]), iv_point(p[2])};
    iv_grad_t G;
    tape_eval_grad(t, ws, 1, &b, &G);
    double g[3] = {iv_mid(G.dx), iv_mid(G.dy), iv_mid(G.dz)};
    double n2 = g[0] * g[0] + g[1] * g[1] + g[2] * g[2];
    if (!(n2 > 0) || !isfinite(n2))
        return 0;
    for (int k = 0; k < 3; k++)
        n[k] = g[k] / sqrt(n2);
    return 1;
}

/* A failure message with MPFR values (%Rg): cmocka's fail_msg knows only printf's formats. */
#define FAIL_MP(...)                                                                       \
    do {                                                                                   \
        char msg_[2048];                                                                   \
        mpfr_snprintf(msg_, sizeof msg_, __VA_ARGS__);                                     \
        fail_msg("%s", msg_);                                                              \
    } while (0)

static oracle_const_t end_of(long j) { return (j & 1) ? ORACLE_CONST_HI : ORACLE_CONST_LO; }

/* ---- MPFI helpers --------------------------------------------------------------- */

typedef struct {
    mpfi_t v, dv, g[3], s, u;
    mpfr_t l;
} mp_t;

static void mp_init(mp_t *m)
{
    mpfi_init2(m->v, ORACLE_PREC);
    mpfi_init2(m->dv, ORACLE_PREC);
    mpfi_init2(m->s, ORACLE_PREC);
    mpfi_init2(m->u, ORACLE_PREC);
    for (int k = 0; k < 3; k++)
        mpfi_init2(m->g[k], ORACLE_PREC);
    mpfr_init2(m->l, ORACLE_PREC);
}

static void mp_clear(mp_t *m)
{
    mpfi_clear(m->v);
    mpfi_clear(m->dv);
    mpfi_clear(m->s);
    mpfi_clear(m->u);
    for (int k = 0; k < 3; k++)
        mpfi_clear(m->g[k]);
    mpfr_clear(m->l);
}

/* out = |g| = sqrt(g_x^2 + g_y^2 + g_z^2), enclosed */
static void mp_norm(mpfi_t out, mpfi_t g[3], mpfi_t tmp)
{
    mpfi_set_ui(out, 0);
    for (int k = 0; k < 3; k++) {
        mpfi_sqr(tmp, g[k]);
        mpfi_add(out, out, tmp);
    }
    mpfi_sqrt(out, out);
}

/* Does v have the strict sign s (certainly)? */
static int strict_sign(mpfi_t v, int s)
{
    return s > 0 ? mpfi_is_strictly_pos(v) : s < 0 ? mpfi_is_strictly_neg(v) : 0;
}

static const char *box_str(char *buf, size_t n, const iv_box_t *b)
{
    snprintf(buf, n, "[%.17g, %.17g] x [%.17g, %.17g] x [%.17g, %.17g]", b->x.lo, b->x.hi,
             b->y.lo, b->y.hi, b->z.lo, b->z.hi);
    return buf;
}

static const char *grad_str(char *buf, size_t n, iv_grad_t G)
{
    snprintf(buf, n, "G = [%.17g, %.17g] x [%.17g, %.17g] x [%.17g, %.17g]", G.dx.lo, G.dx.hi,
             G.dy.lo, G.dy.hi, G.dz.lo, G.dz.hi);
    return buf;
}

/* ---- every scene -------------------------------------------------------------------- */

typedef struct {
    long boxes, points, skipped, decided, bounded;
    /* how close to the edge the decisions came (for the report): the largest
     * |grad f(p)| / L; the smallest margin mig(f(c)) / (L r) of an excluded
     * box, mig(g(m)) / (G h + rnd) of an excluded segment; the largest angle
     * in degrees between a and a gradient in a proven cone */
    double edge;
} counts_t;

typedef void (*scene_check_t)(const scene_t *s, const char *path, uint64_t *rng, counts_t *c);

/* Runs check on every scene file; asserts each one was checked. */
static void every_scene(const char *what, scene_check_t check, uint64_t seed, counts_t *total)
{
    char **paths;
    int n = tu_scene_files(&paths);
    assert_true(n >= 19);
    uint64_t rng = tu_seed(seed);
    int checked = 0;
    memset(total, 0, sizeof *total);
    double t0 = tu_now(), lo_edge = NAN, hi_edge = NAN;
    for (int i = 0; i < n; i++) {
        scene_t s;
        ivoct_error_t err;
        ivoct_error_clear(&err);
        if (scene_load(paths[i], &s, &err) != 0) {
            char buf[1024];
            fail_msg("cannot load %s: %s", paths[i], ivoct_error_format(&err, buf, sizeof buf));
        }
        counts_t c = {0, 0, 0, 0, 0, NAN};
        check(&s, paths[i], &rng, &c);
        const char *base = strrchr(paths[i], '/');
        printf("%-14s %-24s %4u clauses %6ld boxes %7ld points %6ld skipped %6ld decided"
               " (edge %.6g)\n",
               what, base ? base + 1 : paths[i], s.tape->n, c.boxes, c.points, c.skipped,
               c.decided, c.edge);
        total->boxes += c.boxes;
        total->points += c.points;
        total->skipped += c.skipped;
        total->decided += c.decided;
        total->bounded += c.bounded;
        if (!(c.edge >= lo_edge))
            lo_edge = c.edge == c.edge ? c.edge : lo_edge;
        if (!(c.edge <= hi_edge))
            hi_edge = c.edge == c.edge ? c.edge : hi_edge;
        checked++;
        scene_free(&s);
    }
    printf("%-14s all %d scenes: %ld boxes, %ld points checked, %ld decided, edges %.6g .. "
           "%.6g (%.1f s)\n",
           what, checked, total->boxes, total->points, total->decided, lo_edge, hi_edge,
           tu_now() - t0);
    assert_int_equal(checked, n);
    tu_free_list(paths, n);
}

/* The scenes are smooth and defined on their whole boxes; these add kinks
 * (abs, min, max), domain edges (sqrt, log, x^1.5), a cone point and a pole,
 * where the interval gradient is unbounded or empty on some boxes and the
 * tests must then decide nothing. */
static const char *const extra_exprs[] = {
    "sqrt(x^2 + y^2 + z^2) - 0.5",
    "max(abs(x) - 0.5, max(abs(y) - 0.4, abs(z) - 0.3))",
    "min(x^2 + y^2 + z^2 - 0.25, (x - 0.6)^2 + y^2 + z^2 - 0.1)",
    "sqrt(x) - y + 0.1*z",
    "log(x + 0.5) - y^2 - z",
    "1/(x - 0.3) - y + z",
    "x^1.5 + y - z",
    /* planes: the bounds are attained (exactly so for the first one on
     * cubes), the sharpest test of their rounding */
    "x + y + z - 0.3",
    "x - 2*y + 0.5*z + 0.1",
};

static void every_expression(const char *what, scene_check_t check, uint64_t seed,
                             counts_t *total)
{
    uint64_t rng = tu_seed(seed);
    memset(total, 0, sizeof *total);
    for (size_t e = 0; e < sizeof extra_exprs / sizeof *extra_exprs; e++) {
        scene_t s;
        memset(&s, 0, sizeof s);
        s.tape = tu_compile(extra_exprs[e]);
        const double box[6] = {-1, 1, -1, 1, -1, 1};
        memcpy(s.box, box, sizeof box);
        counts_t c = {0, 0, 0, 0, 0, NAN};
        check(&s, extra_exprs[e], &rng, &c);
        printf("%-14s %-24.24s %4u clauses %6ld boxes %7ld points %6ld skipped %6ld decided"
               " (edge %.6g)\n",
               what, extra_exprs[e], s.tape->n, c.boxes, c.points, c.skipped, c.decided,
               c.edge);
        total->boxes += c.boxes;
        total->points += c.points;
        total->skipped += c.skipped;
        total->decided += c.decided;
        total->bounded += c.bounded;
        tape_free(s.tape);
    }
}

/* ---- 1. lip_gradient_bound ---------------------------------------------------------- */

static void check_gradient_bound(const scene_t *s, const char *path, uint64_t *rng,
                                 counts_t *c)
{
    const tape_t *t = s->tape;
    tape_ws_t *ws = tape_ws_new(t->n);
    assert_non_null(ws);
    mp_t m;
    mp_init(&m);
    long nbox = boxes_for(GRAD_BUDGET, (double)t->n * GRAD_POINTS, 2 * BATCH, GRAD_MAX_BOXES,
                          BATCH);
    /* corners and centre always, random points on top when the budget allows */
    long npts = (long)(GRAD_BUDGET * tu_scale()) / ((long)t->n * nbox);
    npts = npts < GRAD_POINTS ? GRAD_POINTS : npts > 24 ? 24 : npts;
    char b1[256], b2[256];
    for (long done = 0; done < nbox; done += BATCH) {
        iv_box_t boxes[BATCH];
        iv_grad_t G[BATCH];
        for (int i = 0; i < BATCH; i++)
            boxes[i] = sub_box(s->box, exp2(-20.0 * tu_uniform(rng)), rng);
        tape_eval_grad(t, ws, BATCH, boxes, G);
        for (int i = 0; i < BATCH; i++) {
            double L = lip_gradient_bound(G[i]);
            c->boxes++;
            c->bounded += isfinite(L);
            for (long j = 0; j < npts; j++) {
                double p[3];
                tu_box_point(&boxes[i], (int)j, rng, p);
                if (oracle_eval(t, p, end_of(j), m.v, m.g) != 0) {
                    c->skipped++;
                    continue;
                }
                c->points++;
                /* f is differentiable at p, in the box: G is not empty, and
                 * |∇f(p)| <= L must hold unless |∇f(p)| is certainly above L */
                mp_norm(m.s, m.g, m.u);
                mpfi_get_left(m.l, m.s);
                if (L > 0 && isfinite(L) && !(mpfr_get_d(m.l, MPFR_RNDN) / L <= c->edge))
                    c->edge = mpfr_get_d(m.l, MPFR_RNDN) / L;
                if (L != L || mpfr_cmp_d(m.l, L) > 0)
                    FAIL_MP("%s: box %s, %s: L = %.17g but |grad f(%.17g, %.17g, %.17g)| "
                             ">= %.17Rg",
                             path, box_str(b1, sizeof b1, &boxes[i]),
                             grad_str(b2, sizeof b2, G[i]), L, p[0], p[1], p[2], m.l);
            }
        }
    }
    /* the decided count here: boxes with a finite bound (the others claim nothing) */
    c->decided = c->bounded;
    mp_clear(&m);
    tape_ws_free(ws);
}

static void test_gradient_bound(void **state)
{
    (void)state;
    counts_t total;
    every_scene("gradient bound", check_gradient_bound, 20261301, &total);
    /* not vacuous: most boxes of most scenes have a finite bound and defined points */
    assert_true(total.points >= total.boxes);
    assert_true(total.bounded >= total.boxes / 2);
    every_expression("gradient bound", check_gradient_bound, 20261311, &total);
    assert_true(total.points > 0);
    assert_true(total.skipped > 0); /* the domain edges are reached */
    assert_true(total.bounded < total.boxes); /* and unbounded gradients met */
}

/* ---- 2. lip_cell_excludes --------------------------------------------------------------- */

static void check_cell(const scene_t *s, const char *path, uint64_t *rng, counts_t *c)
{
    const tape_t *t = s->tape;
    tape_ws_t *ws = tape_ws_new(t->n);
    assert_non_null(ws);
    mp_t m;
    mp_init(&m);
    /* In every excluded box a grid of g^3 points (faces, edges and corners
     * included) and g^2 random points (inside or on a face): g = 5, and g =
     * 9 in one excluded box in 8 (when the tape is short enough to afford
     * it).  About half the boxes are excluded: the cost of a box follows. */
    int big = t->n <= 64 ? 9 : 5;
    double per_excluded = (7.0 * (125 + 25) + (big * big * big + big * big)) / 8.0;
    long nbox = boxes_for(CELL_BUDGET, 0.5 * per_excluded * t->n, 2 * BATCH, CELL_MAX_BOXES,
                          BATCH);
    char b1[256], b2[256];
    for (long done = 0; done < nbox; done += BATCH) {
        iv_box_t boxes[BATCH], cb[BATCH];
        iv_grad_t G[BATCH];
        iv_t fc[BATCH];
        double cen[BATCH][3];
        for (int i = 0; i < BATCH; i++) {
            double q[3];
            double frac = exp2(-3.0 - 9.0 * tu_uniform(rng));
            if (i % 4 == 2) {
                /* at the edge of the test: the centre at distance r (1 ± δ)
                 * from the surface along the normal, r the half diagonal,
                 * δ = 2^-1..2^-30; on a plane with the box's diagonal as
                 * normal the Kalra–Barr bound is attained, so a bound a
                 * hair too small would exclude a box the plane crosses */
                near_surface_point(t, ws, s->box, rng, q);
                double r2 = 0, h[3], n[3];
                for (int k = 0; k < 3; k++) {
                    h[k] = 0.5 * (s->box[2 * k + 1] - s->box[2 * k]) * frac;
                    r2 += h[k] * h[k];
                }
                if (unit_normal(t, ws, q, n)) {
                    double dist = sqrt(r2) * (1.0 + (tu_next(rng) & 1 ? 1 : -1) *
                                                        exp2(-1.0 - 29.0 * tu_uniform(rng)));
                    for (int k = 0; k < 3; k++)
                        q[k] += dist * n[k];
                }
            } else if (i & 1) {
                /* near the surface, shifted by up to one box size: the box
                 * may or may not hold the surface */
                near_surface_point(t, ws, s->box, rng, q);
                for (int k = 0; k < 3; k++)
                    q[k] += (s->box[2 * k + 1] - s->box[2 * k]) * frac *
                            (2.0 * tu_uniform(rng) - 1.0);
            } else {
                random_point(s->box, rng, q);
            }
            boxes[i] = centred_box(s->box, q, frac);
            for (int k = 0; k < 3; k++)
                cen[i][k] = iv_mid(tu_box_side(&boxes[i], k));
            cb[i] = (iv_box_t){iv_point(cen[i][0]), iv_point(cen[i][1]), iv_point(cen[i][2])};
        }
        tape_eval_interval(t, ws, BATCH, cb, fc);
        tape_eval_grad(t, ws, BATCH, boxes, G);
        for (int i = 0; i < BATCH; i++) {
            c->boxes++;
            int sg = lip_cell_excludes(&boxes[i], cen[i], fc[i], G[i]);
            assert_true(sg == 0 || sg == 1 || sg == -1);
            if (sg == 0)
                continue;
            int g = c->decided % 8 == 0 ? big : 5;
            c->decided++;
            {
                double r2 = 0, mig = sg > 0 ? fc[i].lo : -fc[i].hi;
                for (int k = 0; k < 3; k++) {
                    iv_t sd = tu_box_side(&boxes[i], k);
                    double leg = fmax(cen[i][k] - sd.lo, sd.hi - cen[i][k]);
                    r2 += leg * leg;
                }
                double margin = mig / (lip_gradient_bound(G[i]) * sqrt(r2));
                if (!(margin >= c->edge))
                    c->edge = margin;
            }
            /* the proof says mig(fc) > 0 with the sign s */
            assert_true(sg > 0 ? fc[i].lo > 0 : fc[i].hi < 0);
            long npts = (long)g * g * g + (long)g * g;
            for (long j = 0; j < npts; j++) {
                double p[3];
                if (j < (long)g * g * g) {
                    long idx[3] = {j % g, (j / g) % g, j / ((long)g * g)};
                    for (int k = 0; k < 3; k++) {
                        iv_t sd = tu_box_side(&boxes[i], k);
                        p[k] = idx[k] == 0       ? sd.lo
                               : idx[k] == g - 1 ? sd.hi
                                                 : tu_lerp(sd.lo, sd.hi, (double)idx[k] / (g - 1));
                    }
                } else {
                    tu_box_point(&boxes[i], 9 + (int)(j & 1), rng, p);
                }
                if (oracle_eval(t, p, end_of(j), m.v, NULL) != 0) {
                    c->skipped++;
                    continue;
                }
                c->points++;
                if (!strict_sign(m.v, sg))
                    FAIL_MP("%s: box %s excluded with sign %d (c = (%.17g, %.17g, %.17g), "
                             "fc = [%.17g, %.17g], %s, L = %.17g) but f(%.17g, %.17g, %.17g) "
                             "= [%.17Rg, %.17Rg]",
                             path, box_str(b1, sizeof b1, &boxes[i]), sg, cen[i][0], cen[i][1],
                             cen[i][2], fc[i].lo, fc[i].hi, grad_str(b2, sizeof b2, G[i]),
                             lip_gradient_bound(G[i]), p[0], p[1], p[2], &m.v->left,
                             &m.v->right);
            }
        }
    }
    mp_clear(&m);
    tape_ws_free(ws);
}

static void test_cell_excludes(void **state)
{
    (void)state;
    counts_t total;
    every_scene("cell", check_cell, 20261302, &total);
    assert_true(total.decided > 0); /* the test is not vacuous */
    assert_true(total.points > 0);
    every_expression("cell", check_cell, 20261312, &total);
    assert_true(total.decided > 0);
}

/* ---- 3. lip_segment_excludes -------------------------------------------------------------- */

/* [t0, t1]: the parameters of the ray o + t·d inside the box (t0 > t1: misses) */
static void chord(const double box[6], const double o[3], const double d[3], double *t0,
                  double *t1)
{
    double lo = -INFINITY, hi = INFINITY;
    for (int k = 0; k < 3; k++) {
        if (d[k] == 0) {
            if (o[k] < box[2 * k] || o[k] > box[2 * k + 1])
                lo = INFINITY;
            continue;
        }
        double a = (box[2 * k] - o[k]) / d[k], b = (box[2 * k + 1] - o[k]) / d[k];
        lo = fmax(lo, fmin(a, b));
        hi = fmin(hi, fmax(a, b));
    }
    *t0 = lo;
    *t1 = hi;
}

static void unit_vector(uint64_t *rng, double d[3])
{
    double n2;
    do {
        n2 = 0;
        for (int k = 0; k < 3; k++) {
            d[k] = 2.0 * tu_uniform(rng) - 1.0;
            n2 += d[k] * d[k];
        }
    } while (n2 > 1.0 || n2 < 1e-6);
    double n = sqrt(n2);
    for (int k = 0; k < 3; k++)
        d[k] /= n;
}

/* A random ray that crosses the box: origin inside, or outside up to three
 * box sizes away aimed at a random point of the box. */
static void random_ray(const double box[6], uint64_t *rng, double o[3], double d[3],
                       double *t0, double *t1)
{
    for (;;) {
        double q[3], diag = 0;
        for (int k = 0; k < 3; k++)
            diag = fmax(diag, box[2 * k + 1] - box[2 * k]);
        random_point(box, rng, q);
        if (tu_next(rng) & 1) {
            memcpy(o, q, sizeof q);
            unit_vector(rng, d);
        } else {
            double u[3];
            unit_vector(rng, u);
            double r = diag * tu_lerp(0.6, 3.0, tu_uniform(rng));
            double n2 = 0;
            for (int k = 0; k < 3; k++) {
                o[k] = iv_mid(iv_make(box[2 * k], box[2 * k + 1])) + r * u[k];
                d[k] = q[k] - o[k];
                n2 += d[k] * d[k];
            }
            if (!(n2 > 0))
                continue;
            for (int k = 0; k < 3; k++)
                d[k] /= sqrt(n2);
        }
        chord(box, o, d, t0, t1);
        if (*t0 < *t1)
            return;
    }
}

/* A root of g(t) = f(p~(t)) on [t0, t1] (in doubles: it only places test
 * segments): the first sign change of 65 samples, bisected.  0 if none. */
static int ray_root(const tape_t *t, tape_ws_t *ws, const double o[3], const double d[3],
                    double t0, double t1, double *root)
{
    double p[3], prev_t = t0, prev_g;
    tape_ray_point(o, d, t0, p);
    prev_g = eval_point(t, ws, p);
    for (int j = 1; j <= 64; j++) {
        double tt = tu_lerp(t0, t1, j / 64.0);
        tape_ray_point(o, d, tt, p);
        double gt = eval_point(t, ws, p);
        if ((prev_g < 0 && gt > 0) || (prev_g > 0 && gt < 0)) {
            double a = prev_t, b = tt;
            for (int it = 0; it < 60; it++) {
                double m = a + 0.5 * (b - a);
                tape_ray_point(o, d, m, p);
                double gm = eval_point(t, ws, p);
                if (gm != gm)
                    break;
                if ((gm < 0) == (prev_g < 0))
                    a = m;
                else
                    b = m;
            }
            *root = a;
            return 1;
        }
        prev_t = tt;
        prev_g = gt;
    }
    return 0;
}

static void check_segments(const scene_t *s, const char *path, uint64_t *rng, counts_t *c)
{
    const tape_t *t = s->tape;
    tape_ws_t *ws = tape_ws_new(t->n);
    assert_non_null(ws);
    mp_t m;
    mp_init(&m);
    /* the ends, m and 64 points spread over [a, b], at the exact points o + t·d
     * and (the ends, m and every other t) at the rounded points; most
     * segments are excluded (they are short) */
    double per_seg = 0.85 * BATCH * 1.5 * SEG_POINTS;
    long nray = boxes_for(SEG_BUDGET, per_seg * t->n, 4, SEG_MAX_RAYS, 1);
    long per = (long)((double)SEG_BUDGET * tu_scale() / ((double)nray * per_seg * t->n) *
                      SEG_POINTS);
    per = per < 8 ? 8 : per > SEG_POINTS ? SEG_POINTS : per;
    for (long r = 0; r < nray; r++) {
        double o[3], d[3], t0, t1;
        random_ray(s->box, rng, o, d, &t0, &t1);
        iv_t T[BATCH], Tm[BATCH], g[BATCH], gm[BATCH], dg[BATCH];
        double rnd[BATCH], mid[BATCH];
        double troot = 0;
        int has_root = ray_root(t, ws, o, d, t0, t1, &troot);
        for (int i = 0; i < BATCH; i++) {
            if (i % 4 == 2 && has_root) {
                /* at the edge of the test: a root t* at distance h (1 ± δ)
                 * from m on the long side of T (h = max(m - a, b - m), δ =
                 * 2^-1..2^-30); where g is nearly linear the bound is nearly
                 * attained, so a slightly short h or G would exclude a
                 * segment that holds t* */
                double h = (t1 - t0) * exp2(-2.0 - 18.0 * tu_uniform(rng));
                double dist = h * (1.0 + (tu_next(rng) & 1 ? 1 : -1) *
                                             exp2(-1.0 - 29.0 * tu_uniform(rng)));
                double v = tu_next(rng) & 1 ? 1.0 : tu_uniform(rng);
                int toward = tu_next(rng) & 1 ? 1 : -1;
                mid[i] = troot - toward * dist;
                T[i] = toward > 0 ? iv_make(mid[i] - v * h, mid[i] + h)
                                  : iv_make(mid[i] - h, mid[i] + v * h);
            } else {
                double len = (t1 - t0) * exp2(-20.0 * tu_uniform(rng));
                double a = tu_lerp(t0, t1 - len, tu_uniform(rng));
                double b = fmin(a + len, t1);
                b = b < a ? a : b;
                T[i] = iv_make(a, b);
                /* m: the midpoint mostly, now and then anywhere in T */
                mid[i] = tu_next(rng) % 4 ? iv_mid(T[i]) : tu_lerp(a, b, tu_uniform(rng));
            }
            Tm[i] = iv_point(mid[i]);
        }
        tape_eval_ray(t, ws, o, d, BATCH, Tm, gm, NULL, NULL);
        tape_eval_ray(t, ws, o, d, BATCH, T, g, dg, rnd);
        for (int i = 0; i < BATCH; i++) {
            c->boxes++;
            int ex = lip_segment_excludes(T[i].lo, T[i].hi, mid[i], gm[i], dg[i], rnd[i]);
            assert_true(ex == 0 || ex == 1);
            if (!ex)
                continue;
            c->decided++;
            assert_true(gm[i].lo > 0 || gm[i].hi < 0);
            int sg = gm[i].lo > 0 ? 1 : -1;
            double margin = (sg > 0 ? gm[i].lo : -gm[i].hi) /
                            (lip_derivative_bound(dg[i]) *
                                 fmax(mid[i] - T[i].lo, T[i].hi - mid[i]) +
                             rnd[i]);
            if (!(margin >= c->edge))
                c->edge = margin;
            for (long j = 0; j < per; j++) {
                double tt = j == 0   ? T[i].lo
                            : j == 1 ? T[i].hi
                            : j == 2 ? mid[i]
                                     : tu_lerp(T[i].lo, T[i].hi,
                                            ((double)(j - 3) + tu_uniform(rng)) /
                                                (double)(per - 3));
                /* the exact point o + t·d (gradient required by the oracle
                 * here: points where f is not differentiable are skipped, a
                 * set of measure zero on the segment) */
                if (oracle_eval_ray(t, o, d, tt, end_of(j), m.v, m.dv, m.g) != 0) {
                    c->skipped++;
                } else {
                    c->points++;
                    if (!strict_sign(m.v, sg))
                        FAIL_MP("%s: o (%.17g %.17g %.17g) d (%.17g %.17g %.17g) T = "
                                 "[%.17g, %.17g] m = %.17g excluded (gm = [%.17g, %.17g], dg = "
                                 "[%.17g, %.17g], rnd = %.17g) but g(%.17g) = [%.17Rg, %.17Rg]",
                                 path, o[0], o[1], o[2], d[0], d[1], d[2], T[i].lo, T[i].hi,
                                 mid[i], gm[i].lo, gm[i].hi, dg[i].lo, dg[i].hi, rnd[i], tt,
                                 &m.v->left, &m.v->right);
                }
                /* the rounded point p~(t): tape.h promises f(p~(t)) in the same
                 * bound, which is what a root finder evaluating "at t" sees */
                if (j >= 3 && (j & 1))
                    continue;
                double p[3];
                tape_ray_point(o, d, tt, p);
                if (oracle_eval(t, p, end_of(j + 1), m.v, NULL) != 0) {
                    c->skipped++;
                    continue;
                }
                c->points++;
                if (!strict_sign(m.v, sg))
                    FAIL_MP("%s: o (%.17g %.17g %.17g) d (%.17g %.17g %.17g) T = [%.17g, "
                             "%.17g] m = %.17g excluded (gm = [%.17g, %.17g], dg = [%.17g, "
                             "%.17g], rnd = %.17g) but f(p~(%.17g)) = [%.17Rg, %.17Rg]",
                             path, o[0], o[1], o[2], d[0], d[1], d[2], T[i].lo, T[i].hi, mid[i],
                             gm[i].lo, gm[i].hi, dg[i].lo, dg[i].hi, rnd[i], tt, &m.v->left,
                             &m.v->right);
            }
        }
    }
    mp_clear(&m);
    tape_ws_free(ws);
}

static void test_segment_excludes(void **state)
{
    (void)state;
    counts_t total;
    every_scene("segment", check_segments, 20261303, &total);
    assert_true(total.decided > 0);
    assert_true(total.points > 0);
    every_expression("segment", check_segments, 20261313, &total);
    assert_true(total.decided > 0);
}

/* ---- 4. lip_normals_within_60_degrees ------------------------------------------------------ */

static void check_cone(const scene_t *s, const char *path, uint64_t *rng, counts_t *c)
{
    const tape_t *t = s->tape;
    tape_ws_t *ws = tape_ws_new(t->n);
    assert_non_null(ws);
    mp_t m;
    mp_init(&m);
    /* about 7 boxes in 10 are proven */
    long nbox = boxes_for(CONE_BUDGET, 0.7 * CONE_POINTS * t->n, 2 * BATCH, CONE_MAX_BOXES,
                          BATCH);
    long npts = CONE_POINTS;
    char b1[256], b2[256];
    for (long done = 0; done < nbox; done += BATCH) {
        iv_box_t boxes[BATCH], cb[BATCH];
        iv_grad_t G[BATCH], Gc[BATCH];
        double a[BATCH][3];
        for (int i = 0; i < BATCH; i++) {
            double q[3];
            if (i % 3)
                near_surface_point(t, ws, s->box, rng, q);
            else
                random_point(s->box, rng, q);
            boxes[i] = centred_box(s->box, q, exp2(-4.0 - 12.0 * tu_uniform(rng)));
            cb[i] = (iv_box_t){iv_point(iv_mid(boxes[i].x)), iv_point(iv_mid(boxes[i].y)),
                               iv_point(iv_mid(boxes[i].z))};
        }
        tape_eval_grad(t, ws, BATCH, boxes, G);
        tape_eval_grad(t, ws, BATCH, cb, Gc);
        for (int i = 0; i < BATCH; i++) {
            /* a: the gradient at the centre, perturbed by a random vector of
             * relative size 2^-20..2^1 and scaled by 2^-10..2^10 (|a| != 1);
             * one in four a random unit vector */
            double gc[3] = {iv_mid(Gc[i].dx), iv_mid(Gc[i].dy), iv_mid(Gc[i].dz)};
            double n2 = gc[0] * gc[0] + gc[1] * gc[1] + gc[2] * gc[2];
            unit_vector(rng, a[i]);
            if (tu_next(rng) % 4 && isfinite(n2) && n2 > 0) {
                double eps = sqrt(n2) * exp2(1.0 - 21.0 * tu_uniform(rng));
                double scale = exp2(floor(-10.0 + 21.0 * tu_uniform(rng))) / sqrt(n2);
                for (int k = 0; k < 3; k++)
                    a[i][k] = (gc[k] + eps * a[i][k]) * scale;
            }
            if (a[i][0] == 0 && a[i][1] == 0 && a[i][2] == 0)
                a[i][0] = 1; /* a != 0 is the precondition */
        }
        for (int i = 0; i < BATCH; i++) {
            c->boxes++;
            int ok = lip_normals_within_60_degrees(G[i], a[i]);
            assert_true(ok == 0 || ok == 1);
            if (!ok)
                continue;
            c->decided++;
            for (long j = 0; j < npts; j++) {
                double p[3];
                tu_box_point(&boxes[i], (int)j, rng, p);
                if (oracle_eval(t, p, end_of(j), m.v, m.g) != 0) {
                    c->skipped++;
                    continue;
                }
                c->points++;
                /* q = g·a - |g| |a| / 2, fail only if q <= 0 certainly */
                mpfi_set_ui(m.dv, 0);
                for (int k = 0; k < 3; k++) {
                    mpfi_mul_d(m.u, m.g[k], a[i][k]);
                    mpfi_add(m.dv, m.dv, m.u);
                }
                mp_norm(m.s, m.g, m.u);
                mpfi_set_ui(m.v, 0);
                for (int k = 0; k < 3; k++) {
                    mpfi_set_d(m.u, a[i][k]);
                    mpfi_sqr(m.u, m.u);
                    mpfi_add(m.v, m.v, m.u);
                }
                mpfi_sqrt(m.v, m.v);
                mpfi_mul(m.s, m.s, m.v);
                mpfi_div_ui(m.s, m.s, 2);
                /* the angle, for the report: the largest met in a proven cone */
                double angle = acos(fmin(1.0, mpfi_get_d(m.dv) /
                                                  (2.0 * mpfi_get_d(m.s)))) * 180.0 / acos(-1.0);
                if (!(angle <= c->edge))
                    c->edge = angle;
                mpfi_sub(m.dv, m.dv, m.s);
                mpfi_get_right(m.l, m.dv);
                if (mpfr_cmp_ui(m.l, 0) <= 0)
                    FAIL_MP("%s: box %s, %s, a = (%.17g, %.17g, %.17g): cone proven but at "
                             "(%.17g, %.17g, %.17g) grad f = (%.17g, %.17g, %.17g) makes 60 "
                             "degrees or more with a (g.a - |g||a|/2 <= %.17Rg)",
                             path, box_str(b1, sizeof b1, &boxes[i]),
                             grad_str(b2, sizeof b2, G[i]), a[i][0], a[i][1], a[i][2], p[0],
                             p[1], p[2], mpfi_get_d(m.g[0]), mpfi_get_d(m.g[1]),
                             mpfi_get_d(m.g[2]), m.l);
            }
        }
    }
    mp_clear(&m);
    tape_ws_free(ws);
}

static void test_normals_cone(void **state)
{
    (void)state;
    counts_t total;
    every_scene("normal cone", check_cone, 20261304, &total);
    assert_true(total.decided > 0);
    assert_true(total.points > 0);
    every_expression("normal cone", check_cone, 20261314, &total);
    assert_true(total.decided > 0);
}

/* ---- the documented values on hand-made inputs -------------------------------------------- */

static iv_grad_t grad_of(iv_t dx, iv_t dy, iv_t dz)
{
    iv_grad_t G = {iv_make(0, 0), dx, dy, dz};
    return G;
}

/* 5. The bounds are the upper ends of their interval formulas (lipschitz.c
 * computes only those), bit for bit: L = iv_sqrt(0 + mag(dx)^2 + mag(dy)^2 +
 * mag(dz)^2).hi, and the cell test decides exactly when mig(fc) > iv_mul(L, r).hi
 * with r the same norm of the legs, over random magnitudes of every size
 * (zeros, subnormals, huge, infinite) and empty partials. */
static double norm3_formula(double a, double b, double c)
{
    iv_t s = iv_add(iv_add(iv_add(iv_point(0), iv_sqr(iv_point(a))), iv_sqr(iv_point(b))),
                    iv_sqr(iv_point(c)));
    return iv_sqrt(s).hi;
}

static double random_magnitude(uint64_t *rng)
{
    switch (tu_next(rng) % 8) {
    case 0: return 0.0;
    case 1: return INFINITY;
    case 2: return tu_uniform(rng) * 0x1p-1060; /* subnormal */
    case 3: return tu_uniform(rng) * 0x1p1000;
    default: return ldexp(tu_uniform(rng), (int)(tu_next(rng) % 200) - 100);
    }
}

static int same_bits(double a, double b)
{
    return (a != a && b != b) || memcmp(&a, &b, sizeof a) == 0;
}

static void test_upper_ends(void **state)
{
    (void)state;
    uint64_t rng = tu_seed(0x7570706572ULL);
    for (int i = 0; i < 200000; i++) {
        double m[3];
        iv_grad_t G;
        iv_t *p[3] = {&G.dx, &G.dy, &G.dz};
        G.v = iv_make(-1, 1);
        for (int k = 0; k < 3; k++) {
            m[k] = random_magnitude(&rng);
            *p[k] = tu_next(&rng) % 2 ? iv_make(-m[k], 0.5 * m[k]) : iv_make(-0.5 * m[k], m[k]);
        }
        if (tu_next(&rng) % 50 == 0) {
            int k = (int)(tu_next(&rng) % 3);
            *p[k] = iv_empty();
            m[k] = NAN;
        }
        double L = norm3_formula(m[0], m[1], m[2]);
        assert_true(same_bits(lip_gradient_bound(G), L));

        /* a cell around c with legs h, and fc with a margin either side of L r */
        double c[3] = {0.25, -0.5, 1.0}, h[3];
        iv_box_t box;
        iv_t *ax[3] = {&box.x, &box.y, &box.z};
        for (int k = 0; k < 3; k++) {
            h[k] = ldexp(1.0, -(int)(tu_next(&rng) % 30));
            *ax[k] = iv_make(c[k] - h[k], c[k] + h[k]);
        }
        double leg[3];
        for (int k = 0; k < 3; k++)
            leg[k] = iv_up(fmax(c[k] - ax[k]->lo, ax[k]->hi - c[k]));
        double bound = iv_mul(iv_point(L), iv_point(norm3_formula(leg[0], leg[1], leg[2]))).hi;
        double f = isfinite(bound) ? bound * (1 + ldexp(tu_uniform(&rng) - 0.5, -40)) : 1.0;
        iv_t fc = tu_next(&rng) % 2 ? iv_make(f, 2 * f + 1) : iv_make(-2 * f - 1, -f);
        double mig = fc.lo > 0 ? fc.lo : -fc.hi;
        int want = mig > bound ? (fc.lo > 0 ? 1 : -1) : 0;
        assert_int_equal(lip_cell_excludes(&box, c, fc, G), want);
    }
}

static void test_hand_cases(void **state)
{
    (void)state;
    /* lip_magnitude is exact: max(|lo|, |hi|) */
    assert_true(lip_magnitude(iv_make(-3, 2)) == 3);
    assert_true(lip_magnitude(iv_make(1, 5)) == 5);
    assert_true(lip_magnitude(iv_make(-7, -2)) == 7);
    assert_true(lip_magnitude(iv_make(0, 0)) == 0);
    assert_true(lip_magnitude(iv_make(-0.1, 0.1)) == 0.1);
    assert_true(lip_magnitude(iv_make(-INFINITY, 1)) == INFINITY);
    assert_true(lip_magnitude(iv_make(DBL_MAX, INFINITY)) == INFINITY);
    assert_true(isnan(lip_magnitude(iv_empty())));
    assert_true(lip_derivative_bound(iv_make(-2, 1.5)) == 2);
    assert_true(isnan(lip_derivative_bound(iv_empty())));

    /* L bounds sqrt(3^2 + 4^2 + 12^2) = 13, rounded up: at least 13, not far off */
    double L = lip_gradient_bound(grad_of(iv_make(-3, 1), iv_make(2, 4), iv_make(-12, 12)));
    assert_true(L >= 13 && L <= 13 * (1 + 0x1p-48));
    double L0 = lip_gradient_bound(grad_of(iv_make(0, 0), iv_make(0, 0), iv_make(0, 0)));
    assert_true(L0 >= 0 && isfinite(L0));
    assert_true(lip_gradient_bound(grad_of(iv_make(0, 1), iv_entire(), iv_make(0, 0))) ==
                INFINITY);
    assert_true(isnan(lip_gradient_bound(grad_of(iv_empty(), iv_empty(), iv_empty()))));

    /* the cell test: f = x on [1, 2]^3 from c = 1.5: |f(c)| = 1.5 > L r = sqrt(3)/2 */
    iv_box_t box = {{1, 2}, {1, 2}, {1, 2}};
    double c[3] = {1.5, 1.5, 1.5};
    iv_grad_t gx = grad_of(iv_make(1, 1), iv_make(0, 0), iv_make(0, 0));
    assert_int_equal(lip_cell_excludes(&box, c, iv_make(1.5, 1.5), gx), 1);
    assert_int_equal(lip_cell_excludes(&box, c, iv_make(-1.5, -1.5), gx), -1);
    /* |f(c)| = 0.8 < sqrt(3)/2 ~ 0.866: no proof; 0 in fc, empty, unbounded: nothing */
    assert_int_equal(lip_cell_excludes(&box, c, iv_make(0.8, 0.8), gx), 0);
    assert_int_equal(lip_cell_excludes(&box, c, iv_make(-1, 1), gx), 0);
    assert_int_equal(lip_cell_excludes(&box, c, iv_empty(), gx), 0);
    assert_int_equal(
        lip_cell_excludes(&box, c, iv_make(1.5, 1.5),
                          grad_of(iv_make(1, 1), iv_make(-INFINITY, 0), iv_make(0, 0))),
        0);
    assert_int_equal(
        lip_cell_excludes(&box, c, iv_make(1.5, 1.5), grad_of(iv_empty(), iv_empty(), iv_empty())),
        0);

    /* the segment test: g(m) = 1, |g'| <= 2, h = 0.25: 1 > 0.5 + rnd */
    assert_int_equal(lip_segment_excludes(0, 0.5, 0.25, iv_make(1, 1), iv_make(-2, 2), 0), 1);
    assert_int_equal(lip_segment_excludes(0, 0.5, 0.25, iv_make(-1, -1), iv_make(-2, 2), 0), 1);
    /* too long, rnd too large, 0 in gm, gm empty, dg unbounded or empty: nothing */
    assert_int_equal(lip_segment_excludes(0, 1.5, 0.75, iv_make(1, 1), iv_make(-2, 2), 0), 0);
    assert_int_equal(lip_segment_excludes(0, 0.5, 0.25, iv_make(1, 1), iv_make(-2, 2), 0.6), 0);
    assert_int_equal(lip_segment_excludes(0, 0.5, 0.25, iv_make(-1, 1), iv_make(-2, 2), 0), 0);
    assert_int_equal(lip_segment_excludes(0, 0.5, 0.25, iv_empty(), iv_make(-2, 2), 0), 0);
    assert_int_equal(lip_segment_excludes(0, 0.5, 0.25, iv_make(1, 1), iv_make(0, INFINITY), 0),
                     0);
    assert_int_equal(lip_segment_excludes(0, 0.5, 0.25, iv_make(1, 1), iv_empty(), 0), 0);
    assert_int_equal(
        lip_segment_excludes(0, 0.5, 0.25, iv_make(1, 1), iv_make(-2, 2), INFINITY), 0);

    /* the cone: gradients in [1, 1.1] x [-0.1, 0.1] x [0, 0] are within ~8 degrees of x */
    double ax[3] = {1, 0, 0}, ay[3] = {0, 1, 0}, diag[3] = {1, 1, 0};
    iv_grad_t near_x = grad_of(iv_make(1, 1.1), iv_make(-0.1, 0.1), iv_make(0, 0));
    assert_int_equal(lip_normals_within_60_degrees(near_x, ax), 1);
    assert_int_equal(lip_normals_within_60_degrees(near_x, diag), 1); /* < 45 + 8 degrees */
    assert_int_equal(lip_normals_within_60_degrees(near_x, ay), 0);
    /* a at 63.4 degrees from the only gradient (1, 0, 0): false, so no proof;
     * a gradient range holding 0 neither */
    double at63[3] = {1, 2, 0};
    assert_int_equal(
        lip_normals_within_60_degrees(grad_of(iv_make(1, 1), iv_make(0, 0), iv_make(0, 0)),
                                      at63),
        0);
    assert_int_equal(
        lip_normals_within_60_degrees(grad_of(iv_make(-0.1, 1), iv_make(0, 0), iv_make(0, 0)),
                                      ax),
        0);
    assert_int_equal(
        lip_normals_within_60_degrees(grad_of(iv_empty(), iv_empty(), iv_empty()), ax), 0);
    assert_int_equal(
        lip_normals_within_60_degrees(grad_of(iv_make(1, INFINITY), iv_make(0, 0), iv_make(0, 0)),
                                      ax),
        0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_hand_cases),
        cmocka_unit_test(test_gradient_bound),
        cmocka_unit_test(test_cell_excludes),
        cmocka_unit_test(test_segment_excludes),
        cmocka_unit_test(test_normals_cone),
        cmocka_unit_test(test_upper_ends),
    };
    /* IVOCT_TEST_FILTER=test_cell_excludes runs one test (a cmocka pattern) */
    const char *filter = getenv("IVOCT_TEST_FILTER");
    if (filter && *filter)
        cmocka_set_test_filter(filter);
    return cmocka_run_group_tests(tests, NULL, NULL);
}
