/* Every certified ray method against an independent high-precision oracle, on
 * the polynomial comparison surfaces (the eight of surfaces.md are all
 * polynomials: degree 2 to 8), pixel by pixel at 64x64 with each scene's camera.
 *
 * The oracle: along the ray of a pixel (eye o and unit direction d exactly as
 * the renderer has them, doubles), g(t) = f(o + t d) is a polynomial in t.  Its
 * coefficients are computed in MPFR at 192 bits by running the tape with
 * polynomial arithmetic in t (only + - * ^n and constants that are doubles,
 * else the scene is skipped).  Real roots in the box segment [t0, t1] (from
 * ray_clip_box) are isolated through the critical points: the roots of p'
 * (found the same way, recursively) cut [t0, t1] into pieces where p is
 * monotone, and a piece holds a root exactly when p changes sign over it;
 * that root is refined by safeguarded Newton to ~2^-90.
 *
 * What must hold, for each certified method:
 *  - hit/miss agrees with "p has a real root in [t0, t1]";
 *  - on a hit, t agrees with the smallest root r to 1e-12 relative, beyond the
 *    precision limit of double evaluation there: the renderer cannot locate r
 *    closer than the zero band where the double enclosure of f at the point
 *    holds 0, whose half-width is about w(F(p(r))) / |p'(r)|; that term is
 *    added (it is far below 1e-12 r except on grazing rays).
 * except on rays the test calls ambiguous, decided from the polynomial:
 *  - near a double root: a critical point c before the second root (or t1)
 *    with |p(c)| <= 1e-9 L, L = max |p'| on [t0, t1] (the ray comes within
 *    about 1e-9 of touching the surface: a silhouette, a whisker, a singular
 *    point), or
 *  - near the box: |p(t0)| or |p(t1)| <= 1e-9 L (the surface within about 1e-9
 *    of where the ray enters or leaves the box).
 * The ambiguous pixels are counted and printed; they must be few (< 1%). */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>
#include <mpfr.h>

#include "../ray/ray.h"
#include "../scene/scene.h"
#include "support/testutil.h"

#define PREC 192
#define DMAX 16

static const char *const SURFACES[] = {
    "sphere", "drop", "chubs", "crosscap", "gumdrop", "horned-cube", "mcmullen-k3",
    "kusner-schmitt",
};
#define NSURF (sizeof SURFACES / sizeof SURFACES[0])

/* ---- polynomials in t ------------------------------------------------------------ */

typedef struct poly {
    int deg; /* -1 for the zero polynomial */
    mpfr_t c[DMAX + 1];
} poly_t;

static void poly_init(poly_t *p)
{
    for (int k = 0; k <= DMAX; k++)
        mpfr_init2(p->c[k], PREC);
    p->deg = -1;
}

static void poly_clear(poly_t *p)
{
    for (int k = 0; k <= DMAX; k++)
        mpfr_clear(p->c[k]);
}

static void poly_trim(poly_t *p)
{
    while (p->deg >= 0 && mpfr_zero_p(p->c[p->deg]))
        p->deg--;
}

static void poly_copy(poly_t *r, const poly_t *a)
{
    r->deg = a->deg;
    for (int k = 0; k <= a->deg; k++)
        mpfr_set(r->c[k], a->c[k], MPFR_RNDN);
}

static void poly_add(poly_t *r, const poly_t *a, const poly_t *b, int sub)
{
    int d = a->deg > b->deg ? a->deg : b->deg;
    for (int k = 0; k <= d; k++) {
        if (k <= a->deg)
            mpfr_set(r->c[k], a->c[k], MPFR_RNDN);
        else
            mpfr_set_zero(r->c[k], 1);
        if (k <= b->deg) {
            if (sub)
                mpfr_sub(r->c[k], r->c[k], b->c[k], MPFR_RNDN);
            else
                mpfr_add(r->c[k], r->c[k], b->c[k], MPFR_RNDN);
        }
    }
    r->deg = d;
    poly_trim(r);
}

static int poly_mul(poly_t *r, const poly_t *a, const poly_t *b, mpfr_t tmp)
{
    if (a->deg < 0 || b->deg < 0) {
        r->deg = -1;
        return 0;
    }
    int d = a->deg + b->deg;
    if (d > DMAX)
        return -1;
    poly_t out;
    poly_init(&out);
    for (int k = 0; k <= d; k++)
        mpfr_set_zero(out.c[k], 1);
    for (int i = 0; i <= a->deg; i++)
        for (int j = 0; j <= b->deg; j++) {
            mpfr_mul(tmp, a->c[i], b->c[j], MPFR_RNDN);
            mpfr_add(out.c[i + j], out.c[i + j], tmp, MPFR_RNDN);
        }
    out.deg = d;
    poly_copy(r, &out);
    poly_clear(&out);
    poly_trim(r);
    return 0;
}

/* p(x) by Horner */
static void poly_eval(mpfr_t out, const poly_t *p, const mpfr_t x)
{
    mpfr_set_zero(out, 1);
    for (int k = p->deg; k >= 0; k--) {
        mpfr_mul(out, out, x, MPFR_RNDN);
        mpfr_add(out, out, p->c[k], MPFR_RNDN);
    }
}

static void poly_deriv(poly_t *r, const poly_t *p)
{
    for (int k = 1; k <= p->deg; k++)
        mpfr_mul_si(r->c[k - 1], p->c[k], k, MPFR_RNDN);
    r->deg = p->deg - 1;
    poly_trim(r);
}

/* Is the tape a polynomial we can expand (ops, constants, degree)? */
static int tape_is_polynomial(const tape_t *t)
{
    int *deg = calloc(t->n, sizeof *deg);
    int ok = 1;
    for (uint32_t i = 0; i < t->n && ok; i++) {
        const tape_clause_t *c = &t->clauses[i];
        switch ((tape_op_t)c->op) {
        case TAPE_CONST: ok = c->c.lo == c->c.hi; deg[i] = 0; break;
        case TAPE_X: case TAPE_Y: case TAPE_Z: deg[i] = 1; break;
        case TAPE_NEG: deg[i] = deg[c->a]; break;
        case TAPE_SQR: deg[i] = 2 * deg[c->a]; break;
        case TAPE_POWI: ok = c->c.lo >= 0; deg[i] = (int)c->c.lo * deg[c->a]; break;
        case TAPE_ADD: case TAPE_SUB:
            deg[i] = deg[c->a] > deg[c->b] ? deg[c->a] : deg[c->b];
            break;
        case TAPE_MUL: deg[i] = deg[c->a] + deg[c->b]; break;
        default: ok = 0; break;
        }
        if (deg[i] > DMAX)
            ok = 0;
    }
    free(deg);
    return ok;
}

/* g(t) = f(o + t d) into out, with slots (t->n of them) as scratch. */
static void tape_poly(const tape_t *t, poly_t *slot, const double o[3], const double d[3],
                      poly_t *out, mpfr_t tmp)
{
    for (uint32_t i = 0; i < t->n; i++) {
        const tape_clause_t *c = &t->clauses[i];
        poly_t *r = &slot[i];
        switch ((tape_op_t)c->op) {
        case TAPE_CONST:
            mpfr_set_d(r->c[0], c->c.lo, MPFR_RNDN);
            r->deg = 0;
            poly_trim(r);
            break;
        case TAPE_X: case TAPE_Y: case TAPE_Z: {
            int k = (int)c->op - TAPE_X;
            mpfr_set_d(r->c[0], o[k], MPFR_RNDN);
            mpfr_set_d(r->c[1], d[k], MPFR_RNDN);
            r->deg = 1;
            poly_trim(r);
            break;
        }
        case TAPE_NEG:
            poly_copy(r, &slot[c->a]);
            for (int k = 0; k <= r->deg; k++)
                mpfr_neg(r->c[k], r->c[k], MPFR_RNDN);
            break;
        case TAPE_SQR: poly_mul(r, &slot[c->a], &slot[c->a], tmp); break;
        case TAPE_POWI: {
            int n = (int)c->c.lo;
            r->deg = 0;
            mpfr_set_ui(r->c[0], 1, MPFR_RNDN);
            for (int k = 0; k < n; k++)
                poly_mul(r, r, &slot[c->a], tmp);
            break;
        }
        case TAPE_ADD: poly_add(r, &slot[c->a], &slot[c->b], 0); break;
        case TAPE_SUB: poly_add(r, &slot[c->a], &slot[c->b], 1); break;
        case TAPE_MUL: poly_mul(r, &slot[c->a], &slot[c->b], tmp); break;
        default: break;
        }
    }
    poly_copy(out, &slot[t->n - 1]);
}

/* ---- real roots ---------------------------------------------------------------------- */

typedef struct roots {
    int n;
    mpfr_t r[DMAX + 2];
} roots_t;

static void roots_init(roots_t *R)
{
    for (int k = 0; k < DMAX + 2; k++)
        mpfr_init2(R->r[k], PREC);
    R->n = 0;
}

static void roots_clear(roots_t *R)
{
    for (int k = 0; k < DMAX + 2; k++)
        mpfr_clear(R->r[k]);
}

static void roots_add(roots_t *R, const mpfr_t x)
{
    if (R->n > 0 && mpfr_equal_p(R->r[R->n - 1], x))
        return;
    mpfr_set(R->r[R->n++], x, MPFR_RNDN);
}

/* The root of p in [u, v] where p(u), p(v) have opposite signs and p is
 * monotone: safeguarded Newton (bisection when a step leaves the bracket). */
static void refine_root(const poly_t *p, const poly_t *dp, const mpfr_t u, const mpfr_t v,
                        int su, mpfr_t x)
{
    mpfr_t lo, hi, fx, dx, w;
    mpfr_inits2(PREC, lo, hi, fx, dx, w, (mpfr_ptr)0);
    mpfr_set(lo, u, MPFR_RNDN);
    mpfr_set(hi, v, MPFR_RNDN);
    mpfr_add(x, lo, hi, MPFR_RNDN);
    mpfr_div_2ui(x, x, 1, MPFR_RNDN);
    for (int it = 0; it < 400; it++) {
        poly_eval(fx, p, x);
        int s = mpfr_sgn(fx);
        if (s == 0)
            break;
        if ((s > 0) == (su > 0))
            mpfr_set(lo, x, MPFR_RNDN);
        else
            mpfr_set(hi, x, MPFR_RNDN);
        mpfr_sub(w, hi, lo, MPFR_RNDN);
        if (mpfr_get_exp(w) < mpfr_get_exp(hi) - 90 || mpfr_zero_p(w))
            break;
        poly_eval(dx, dp, x);
        int newton_ok = 0;
        if (!mpfr_zero_p(dx)) {
            mpfr_div(dx, fx, dx, MPFR_RNDN);
            mpfr_sub(dx, x, dx, MPFR_RNDN);
            newton_ok = mpfr_greater_p(dx, lo) && mpfr_less_p(dx, hi);
        }
        /* bisect every 4th step so the bracket keeps shrinking */
        if (newton_ok && it % 4 != 3) {
            mpfr_set(x, dx, MPFR_RNDN);
        } else {
            mpfr_add(x, lo, hi, MPFR_RNDN);
            mpfr_div_2ui(x, x, 1, MPFR_RNDN);
        }
    }
    mpfr_clears(lo, hi, fx, dx, w, (mpfr_ptr)0);
}

/* All distinct real roots of p in [a, b], sorted; crit (may be NULL) gets the
 * critical points (roots of p') in [a, b]. */
static void real_roots(const poly_t *p, const mpfr_t a, const mpfr_t b, roots_t *R,
                       roots_t *crit)
{
    R->n = 0;
    if (crit)
        crit->n = 0;
    if (p->deg <= 0)
        return;
    poly_t dp;
    poly_init(&dp);
    poly_deriv(&dp, p);
    roots_t C;
    roots_init(&C);
    real_roots(&dp, a, b, &C, NULL);
    mpfr_t u, v, pu, pv, x;
    mpfr_inits2(PREC, u, v, pu, pv, x, (mpfr_ptr)0);
    mpfr_set(u, a, MPFR_RNDN);
    for (int k = 0; k <= C.n; k++) {
        mpfr_set(v, k < C.n ? C.r[k] : b, MPFR_RNDN);
        poly_eval(pu, p, u);
        poly_eval(pv, p, v);
        int su = mpfr_sgn(pu), sv = mpfr_sgn(pv);
        if (su == 0)
            roots_add(R, u);
        else if (sv != 0 && su != sv) {
            refine_root(p, &dp, u, v, su, x);
            roots_add(R, x);
        }
        if (k == C.n && sv == 0)
            roots_add(R, v);
        mpfr_set(u, v, MPFR_RNDN);
    }
    if (crit) {
        crit->n = 0;
        for (int k = 0; k < C.n; k++)
            roots_add(crit, C.r[k]);
    }
    mpfr_clears(u, v, pu, pv, x, (mpfr_ptr)0);
    roots_clear(&C);
    poly_clear(&dp);
}

/* ---- the oracle for one ray ------------------------------------------------------------- */

typedef struct oracle {
    int hit;       /* p has a real root in [t0, t1] */
    double r;      /* the smallest one */
    double dp_r;   /* |p'(r)| */
    int ambiguous;
} oracle_t;

typedef struct ctx {
    poly_t *slot;
    poly_t p, dp, ddp;
    mpfr_t tmp, a, b, x, y;
    roots_t R, C, C2;
} ctx_t;

static void oracle_ray(ctx_t *c, const tape_t *t, const double o[3], const double d[3],
                       double t0, double t1, oracle_t *out)
{
    tape_poly(t, c->slot, o, d, &c->p, c->tmp);
    mpfr_set_d(c->a, t0, MPFR_RNDN);
    mpfr_set_d(c->b, t1, MPFR_RNDN);
    real_roots(&c->p, c->a, c->b, &c->R, &c->C);
    poly_deriv(&c->dp, &c->p);
    poly_deriv(&c->ddp, &c->dp);
    /* L = max |p'| on [t0, t1]: at the ends and the roots of p'' */
    real_roots(&c->ddp, c->a, c->b, &c->C2, NULL);
    double L = 0;
    for (int k = -2; k < c->C2.n; k++) {
        poly_eval(c->y, &c->dp, k == -2 ? c->a : k == -1 ? c->b : c->C2.r[k]);
        L = fmax(L, fabs(mpfr_get_d(c->y, MPFR_RNDN)));
    }
    double thr = 1e-9 * L;
    out->hit = c->R.n > 0;
    out->r = out->hit ? mpfr_get_d(c->R.r[0], MPFR_RNDN) : NAN;
    out->dp_r = NAN;
    if (out->hit) {
        poly_eval(c->y, &c->dp, c->R.r[0]);
        out->dp_r = fabs(mpfr_get_d(c->y, MPFR_RNDN));
    }
    out->ambiguous = 0;
    for (int e = 0; e < 2; e++) {
        poly_eval(c->y, &c->p, e ? c->b : c->a);
        if (fabs(mpfr_get_d(c->y, MPFR_RNDN)) <= thr)
            out->ambiguous = 1;
    }
    for (int k = 0; k < c->C.n; k++) {
        if (c->R.n >= 2 && mpfr_greater_p(c->C.r[k], c->R.r[1]))
            break;
        poly_eval(c->y, &c->p, c->C.r[k]);
        if (fabs(mpfr_get_d(c->y, MPFR_RNDN)) <= thr)
            out->ambiguous = 1;
    }
}

/* ---- the test ------------------------------------------------------------------------------ */

static int image_size(void)
{
    int n = (int)(64 * sqrt(tu_scale()) + 0.5);
    return n < 16 ? 16 : n;
}

static void test_roots_against_oracle(void **state)
{
    (void)state;
    const int size = image_size();
    const size_t npix = (size_t)size * size;
    ctx_t c;
    poly_init(&c.p);
    poly_init(&c.dp);
    poly_init(&c.ddp);
    mpfr_inits2(PREC, c.tmp, c.a, c.b, c.x, c.y, (mpfr_ptr)0);
    roots_init(&c.R);
    roots_init(&c.C);
    roots_init(&c.C2);
    printf("%-15s %7s %6s %9s %10s %12s\n", "surface", "in box", "hits", "ambiguous",
           "band-used", "max rel err");
    for (size_t si = 0; si < NSURF; si++) {
        char path[4096];
        snprintf(path, sizeof path, "%s/scenes/%s.ini", tu_source_dir(), SURFACES[si]);
        scene_t s;
        ivoct_error_t err;
        ivoct_error_clear(&err);
        if (scene_load(path, &s, &err))
            fail_msg("%s: %s", path, err.msg);
        if (!tape_is_polynomial(s.tape)) {
            printf("%-15s skipped: not a polynomial with double constants\n", SURFACES[si]);
            scene_free(&s);
            continue;
        }
        ray_camera_t cam;
        assert_int_equal(
            ray_camera_init(&cam, s.eye, s.target, s.up, s.fov, size, size, &err), 0);
        c.slot = malloc(s.tape->n * sizeof *c.slot);
        for (uint32_t i = 0; i < s.tape->n; i++)
            poly_init(&c.slot[i]);
        tape_ws_t *ws = tape_ws_new(s.tape->n);

        /* the oracle for every pixel */
        oracle_t *orc = calloc(npix, sizeof *orc);
        unsigned char *inbox = calloc(npix, 1);
        double *band = calloc(npix, sizeof *band);
        size_t n_in = 0, n_hit = 0, n_amb = 0;
        for (size_t i = 0; i < npix; i++) {
            double d[3], t0, t1;
            ray_camera_dir(&cam, (int)(i % size), (int)(i / size), d);
            if (!ray_clip_box(s.box, cam.eye, d, &t0, &t1))
                continue;
            inbox[i] = 1;
            n_in++;
            oracle_ray(&c, s.tape, cam.eye, d, t0, t1, &orc[i]);
            n_hit += orc[i].hit;
            n_amb += orc[i].ambiguous;
            if (orc[i].hit) {
                /* the zero band: the enclosure of f at the point of r */
                double p[3];
                iv_t v;
                ray_point(cam.eye, d, orc[i].r, p);
                iv_box_t pb = {iv_point(p[0]), iv_point(p[1]), iv_point(p[2])};
                tape_eval_interval(s.tape, ws, 1, &pb, &v);
                band[i] = 4 * (v.hi - v.lo) / orc[i].dp_r;
            }
        }
        if (n_amb * 100 >= npix)
            fail_msg("%s: %zu ambiguous pixels of %zu", SURFACES[si], n_amb, npix);

        /* each certified method */
        for (int m = 0; m < RAY_METHOD_COUNT; m++) {
            if (!ray_method_certified((ray_method_t)m))
                continue;
            ray_image_t img;
            ray_stats_t st;
            ray_box_source_t bs;
            ray_source_t src = ray_box_source(&bs, s.box);
            ray_render_opts_t o;
            ray_render_opts_default(&o);
            o.method = (ray_method_t)m;
            assert_int_equal(ray_image_alloc(&img, size, size, &err), 0);
            if (ray_render(s.tape, &cam, &src, &o, &img, &st, &err))
                fail_msg("render: %s", err.msg);
            double max_rel = 0;
            size_t band_used = 0;
            for (size_t i = 0; i < npix; i++) {
                if (!inbox[i]) {
                    if (img.hit[i])
                        fail_msg("%s %s pixel %zu: a hit on a ray that misses the box",
                                 SURFACES[si], ray_method_name((ray_method_t)m), i);
                    continue;
                }
                const oracle_t *q = &orc[i];
                if (q->ambiguous)
                    continue;
                if (img.hit[i] != q->hit)
                    fail_msg("%s %s pixel %zu (col %zu row %zu): renderer %s, oracle %s "
                             "(r = %.17g, t = %.17g)",
                             SURFACES[si], ray_method_name((ray_method_t)m), i, i % size,
                             i / size, img.hit[i] ? "hit" : "miss", q->hit ? "hit" : "miss",
                             q->r, img.t[i]);
                if (!q->hit)
                    continue;
                double e = fabs(img.t[i] - q->r);
                double rel = e / fabs(q->r);
                if (e > 1e-12 * fabs(q->r)) {
                    band_used++;
                    if (!(e <= 1e-12 * fabs(q->r) + band[i]))
                        fail_msg("%s %s pixel %zu: t = %.17g, oracle r = %.17g: error %.3g "
                                 "(relative %.3g, zero band %.3g)",
                                 SURFACES[si], ray_method_name((ray_method_t)m), i, img.t[i],
                                 q->r, e, rel, band[i]);
                } else if (rel > max_rel) {
                    max_rel = rel;
                }
            }
            printf("%-15s %7zu %6zu %9zu %10zu %12.3g  %s\n", SURFACES[si], n_in, n_hit, n_amb,
                   band_used, max_rel, ray_method_name((ray_method_t)m));
            ray_image_free(&img);
        }
        free(orc);
        free(inbox);
        free(band);
        tape_ws_free(ws);
        for (uint32_t i = 0; i < s.tape->n; i++)
            poly_clear(&c.slot[i]);
        free(c.slot);
        scene_free(&s);
    }
    poly_clear(&c.p);
    poly_clear(&c.dp);
    poly_clear(&c.ddp);
    mpfr_clears(c.tmp, c.a, c.b, c.x, c.y, (mpfr_ptr)0);
    roots_clear(&c.R);
    roots_clear(&c.C);
    roots_clear(&c.C2);
    mpfr_free_cache();
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_roots_against_oracle),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
