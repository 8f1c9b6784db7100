/* Property test of the ray evaluator tape_eval_ray (expr/tape.h) against the
 * MPFI oracle, on every scene and on expressions exercising every op.
 *
 * Random rays o + t·d (origins in and around the box, directions with now
 * and then an exact zero component) and random parameter intervals T (widths
 * from the whole box down to 2^-40 of it, one in 8 a point), evaluated in
 * batches of 13 lanes (not a multiple of 8: padding).  At random t
 * of T (the ends included):
 *  - a segment lane: the oracle at the exact point o + t·d (MPFI) and at the
 *    rounded point p~(t) must lie in g, ∇f·d in dg, and Σ|∂_i f|·rho_i in
 *    [-rnd, rnd] (rho_i the documented rounding radius, exact in MPFI);
 *  - a point lane [t, t]: the same at its rounded point p~(t);
 *  - the values-only call (dg = NULL) must return the same g;
 *  - the last 1 to 8 lanes evaluated again as a short batch give the same
 *    bits (short batches are padded and may run through another pass). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "../scene/scene.h"
#include "support/mpfi_tape.h"
#include "support/testutil.h"

enum { BATCH = 13 };

typedef struct {
    long checked, checked_deriv, skipped;
} counts_t;

/* mpfi: Σ |g_k| rho_k with rho_k = 2^-51 (|o_k| + 2 tmax |d_k|), exactly */
static void rounding_sum(mpfi_t out, mpfi_t g[3], const double o[3], const double d[3],
                         double tmax)
{
    mpfi_t r, a;
    mpfi_init2(r, ORACLE_PREC);
    mpfi_init2(a, ORACLE_PREC);
    mpfi_set_ui(out, 0);
    for (int k = 0; k < 3; k++) {
        mpfi_set_d(r, fabs(d[k]));
        mpfi_mul_d(r, r, 2.0 * tmax);
        mpfi_add_d(r, r, fabs(o[k]));
        mpfi_mul_2si(r, r, -51);
        mpfi_abs(a, g[k]);
        mpfi_mul(a, a, r);
        mpfi_add(out, out, a);
    }
    mpfi_clear(r);
    mpfi_clear(a);
}

/* One lane at parameter tt: at the exact point (segments only) and at the
 * rounded point.  Returns 0 or fails the test with a message. */
static void check_at(const tape_t *t, const char *what, const double o[3], const double d[3],
                     iv_t T, double tt, iv_t g, iv_t dg, double rnd, oracle_const_t which,
                     counts_t *cnt)
{
    mpfi_t v, dv, gr[3], s;
    mpfi_init2(v, ORACLE_PREC);
    mpfi_init2(dv, ORACLE_PREC);
    mpfi_init2(s, ORACLE_PREC);
    for (int k = 0; k < 3; k++)
        mpfi_init2(gr[k], ORACLE_PREC);
    double tmax = fmax(fabs(T.lo), fabs(T.hi));
    double p[3];
    tape_ray_point(o, d, tt, p);
    for (int exact = T.lo < T.hi; exact >= 0; exact--) {
        /* the value alone first (defined points that are not differentiable count) */
        int bad = exact ? oracle_eval_ray(t, o, d, tt, which, v, dv, gr)
                        : oracle_eval(t, p, which, v, gr);
        if (bad && !exact)
            bad = oracle_eval(t, p, which, v, NULL) ? 2 : 1;
        if (bad == 2 || (bad && exact)) {
            cnt->skipped++;
            continue;
        }
        cnt->checked++;
        if (!oracle_contained(v, g))
            fail_msg("%s: o (%.17g %.17g %.17g) d (%.17g %.17g %.17g) T [%.17g, %.17g] "
                     "t %.17g (%s point): f = %.17g not in g [%.17g, %.17g]",
                     what, o[0], o[1], o[2], d[0], d[1], d[2], T.lo, T.hi, tt,
                     exact ? "exact" : "rounded", mpfr_get_d(&v->left, MPFR_RNDN), g.lo, g.hi);
        if (bad)
            continue; /* not differentiable there */
        if (!exact) {
            mpfi_set_ui(dv, 0);
            for (int k = 0; k < 3; k++) {
                mpfi_mul_d(s, gr[k], d[k]);
                mpfi_add(dv, dv, s);
            }
        }
        cnt->checked_deriv++;
        if (!oracle_contained(dv, dg))
            fail_msg("%s: o (%.17g %.17g %.17g) d (%.17g %.17g %.17g) T [%.17g, %.17g] "
                     "t %.17g (%s point): g' = %.17g not in dg [%.17g, %.17g]",
                     what, o[0], o[1], o[2], d[0], d[1], d[2], T.lo, T.hi, tt,
                     exact ? "exact" : "rounded", mpfr_get_d(&dv->left, MPFR_RNDN), dg.lo,
                     dg.hi);
        rounding_sum(s, gr, o, d, tmax);
        if (!oracle_contained(s, iv_make(-rnd, rnd)))
            fail_msg("%s: o (%.17g %.17g %.17g) d (%.17g %.17g %.17g) T [%.17g, %.17g] "
                     "t %.17g: sum |df_i| rho_i = %.17g above rnd %.17g",
                     what, o[0], o[1], o[2], d[0], d[1], d[2], T.lo, T.hi, tt,
                     mpfr_get_d(&s->right, MPFR_RNDU), rnd);
    }
    mpfi_clear(v);
    mpfi_clear(dv);
    mpfi_clear(s);
    for (int k = 0; k < 3; k++)
        mpfi_clear(gr[k]);
}

/* the same interval, bit for bit (any two empty sets are the same) */
static int same_iv(iv_t a, iv_t b)
{
    return memcmp(&a, &b, sizeof a) == 0 || (iv_is_empty(a) && iv_is_empty(b));
}

/* nray random rays through box, BATCH segments each, points_per_lane t's per lane */
static void check_tape(const tape_t *t, const double box[6], const char *what, long nray,
                       int points_per_lane, uint64_t *rng, counts_t *cnt)
{
    tape_ws_t *ws = tape_ws_new(t->n);
    assert_non_null(ws);
    double diag = 0;
    for (int k = 0; k < 3; k++)
        diag = fmax(diag, box[2 * k + 1] - box[2 * k]);
    for (long r = 0; r < nray; r++) {
        double o[3], d[3];
        for (int k = 0; k < 3; k++) {
            double lo = box[2 * k], hi = box[2 * k + 1], w = hi - lo;
            o[k] = tu_lerp(lo - w, hi + w, tu_uniform(rng));
            d[k] = tu_next(rng) % 8 == 0 ? 0.0 : tu_lerp(-1, 1, tu_uniform(rng));
        }
        iv_t T[BATCH], g[BATCH], dg[BATCH], g2[BATCH];
        double rnd[BATCH];
        for (int i = 0; i < BATCH; i++) {
            double len = 3 * diag * exp2(-40.0 * tu_uniform(rng));
            double a = tu_lerp(-2 * diag, 2 * diag, tu_uniform(rng));
            T[i] = tu_next(rng) % 8 == 0 ? iv_point(a) : iv_make(a, a + len);
        }
        tape_eval_ray(t, ws, o, d, BATCH, T, g, dg, rnd);
        tape_eval_ray(t, ws, o, d, BATCH, T, g2, NULL, NULL);
        /* the last 1 to 8 lanes again as a short batch (padded, and on some
         * paths run by a pass compiled for 8 lanes): the same bits */
        int ns = 1 + (int)(r % 8);
        iv_t gs[8], dgs[8], gs2[8];
        double rnds[8];
        tape_eval_ray(t, ws, o, d, (size_t)ns, T + BATCH - ns, gs, dgs, rnds);
        tape_eval_ray(t, ws, o, d, (size_t)ns, T + BATCH - ns, gs2, NULL, NULL);
        for (int i = 0; i < ns; i++) {
            int j = BATCH - ns + i;
            assert_true(same_iv(gs[i], g[j]) && same_iv(dgs[i], dg[j]) && same_iv(gs2[i], g2[j]));
            assert_true(memcmp(&rnds[i], &rnd[j], sizeof rnd[j]) == 0);
        }
        for (int i = 0; i < BATCH; i++) {
            assert_true(memcmp(&g[i], &g2[i], sizeof g[i]) == 0 ||
                        (iv_is_empty(g[i]) && iv_is_empty(g2[i])));
            /* an interval or the empty set, never half NaN */
            assert_true((dg[i].lo != dg[i].lo) == (dg[i].hi != dg[i].hi));
            assert_false(rnd[i] != rnd[i]);
            for (int j = 0; j < points_per_lane; j++) {
                double tt = j == 0 ? T[i].lo : j == 1 ? T[i].hi
                                             : tu_lerp(T[i].lo, T[i].hi, tu_uniform(rng));
                tt = fmin(fmax(tt, T[i].lo), T[i].hi);
                check_at(t, what, o, d, T[i], tt, g[i], dg[i], rnd[i],
                         (j & 1) ? ORACLE_CONST_HI : ORACLE_CONST_LO, cnt);
            }
        }
    }
    tape_ws_free(ws);
}

static void test_every_scene(void **state)
{
    (void)state;
    char **paths;
    int n = tu_scene_files(&paths);
    uint64_t rng = tu_seed(20261203);
    long nray = (long)(400 * tu_scale());
    for (int i = 0; i < n; i++) {
        scene_t s;
        tu_load_scene(paths[i], &s);
        counts_t c = {0, 0, 0};
        check_tape(s.tape, s.box, paths[i], nray, 3, &rng, &c);
        printf("%-40s %6ld values checked, %6ld derivatives, %5ld skipped\n", paths[i],
               c.checked, c.checked_deriv, c.skipped);
        /* not vacuous: most points of every scene are defined */
        assert_true(c.checked >= (long)(0.8 * nray * BATCH * 3));
        scene_free(&s);
    }
    tu_free_list(paths, n);
}

static void test_every_operation(void **state)
{
    (void)state;
    uint64_t rng = tu_seed(20261204);
    long nray = (long)(40 * tu_scale());
    if (nray < 4)
        nray = 4;
    int seen[TAPE_OP_COUNT] = {0};
    /* every op of the tape language (testutil's list) */
    for (size_t e = 0; e < tu_n_op_exprs; e++) {
        tape_t *t;
        ivoct_error_t err;
        ivoct_error_clear(&err);
        assert_int_equal(tape_compile(tu_op_exprs[e], &t, &err), 0);
        for (uint32_t i = 0; i < t->n; i++)
            seen[t->clauses[i].op] = 1;
        counts_t c = {0, 0, 0};
        for (size_t b = 0; b < TU_N_OP_BOXES; b++)
            check_tape(t, tu_op_boxes[b], tu_op_exprs[e], nray, 3, &rng, &c);
        assert_true(c.checked > 0);
        tape_free(t);
    }
    for (int op = 0; op < TAPE_OP_COUNT; op++)
        if (!seen[op])
            fail_msg("op %s not exercised", tape_op_name((tape_op_t)op));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_scene),
        cmocka_unit_test(test_every_operation),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
