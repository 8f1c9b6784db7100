/* Inner estimates of the range (mod_inner_range) against MPFI and MPFR.
 *
 * Over random sub-boxes of every scene (tu_random_subbox) and random boxes of
 * random polynomials and of expressions with sqrt, exp, log, atan: whenever
 * mod_inner_range certifies R = [lo, hi],
 *  1. an MPFI enclosure of f over the box (an independent interval evaluation
 *     of the tape at 128 bits, with the interval constants as intervals) holds
 *     R: a value of R outside it would be a value f does not take;
 *  2. the values of f at sample points (MPFI at 256 bits at each point, both
 *     ends of the interval constants) reach both ends: some sample is <= lo +
 *     tol and some >= hi - tol, tol = sum_k G_k h_k / 2 with G_k a bound on
 *     |df/dx_k| over the box (tape_eval_grad) and h_k the sample spacing: a
 *     sampled minimum is within tol of the true minimum, which lies at or
 *     below lo.  How often a sample lies strictly beyond an end is reported;
 *  3. where every variable occurs once (the sphere, and the separable cases)
 *     the extension is optimal: the exact minimum and maximum are at the
 *     corners that minimise/maximise each term, MPFI at those corners must
 *     lie at or beyond lo and hi (no tolerance: that is the inner claim), and
 *     within rounding of them (1e-12 relative: the optimality);
 * and a scene whose tape has an unsupported operation (min, max, abs) is
 * reported MOD_UNSUPPORTED on every box.  On every box the outer claim of
 * mod_star on the proper box (f* is then the range) is checked as well: the
 * MPFI values of f at ten points of the box lie in it, and so does the inner
 * estimate. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>
#include <mpfi.h>

#include "../modal/modal.h"
#include "../scene/scene.h"
#include "support/mpfi_tape.h"
#include "support/testutil.h"

#define BOX_PREC 128
#define GRID 5 /* samples per axis (plus corners: the grid includes them) */

/* MPFI enclosure of f over a box, clause by clause (supported ops only).
 * Returns 0 when defined on the whole box. */
static int mpfi_box(const tape_t *t, const iv_box_t *box, mpfi_t out)
{
    mpfi_t *S = malloc(t->n * sizeof *S);
    mpfi_t u;
    mpfi_init2(u, BOX_PREC);
    int bad = 0;
    uint32_t done = 0;
    for (uint32_t i = 0; i < t->n && !bad; i++, done++) {
        const tape_clause_t *c = &t->clauses[i];
        mpfi_init2(S[i], BOX_PREC);
        mpfi_ptr o = S[i];
        switch ((tape_op_t)c->op) {
        case TAPE_CONST: mpfi_interv_d(o, c->c.lo, c->c.hi); break;
        case TAPE_X: mpfi_interv_d(o, box->x.lo, box->x.hi); break;
        case TAPE_Y: mpfi_interv_d(o, box->y.lo, box->y.hi); break;
        case TAPE_Z: mpfi_interv_d(o, box->z.lo, box->z.hi); break;
        case TAPE_NEG: mpfi_neg(o, S[c->a]); break;
        case TAPE_SQR: mpfi_sqr(o, S[c->a]); break;
        case TAPE_POWI: {
            long n = (long)c->c.lo, m = n < 0 ? -n : n;
            /* |x|^m for even m (never negative), else x^m by repeated products */
            mpfi_set_ui(o, 1);
            if (m % 2 == 0) {
                mpfi_sqr(u, S[c->a]);
                for (long j = 0; j < m / 2; j++)
                    mpfi_mul(o, o, u);
            } else {
                for (long j = 0; j < m; j++)
                    mpfi_mul(o, o, S[c->a]);
            }
            if (n < 0) {
                if (mpfi_has_zero(o))
                    bad = 1;
                else
                    mpfi_inv(o, o);
            }
            break;
        }
        case TAPE_POWR:
            if (!mpfi_is_strictly_pos(S[c->a])) {
                bad = 1;
                break;
            }
            mpfi_log(u, S[c->a]);
            mpfi_mul_d(u, u, c->c.lo);
            mpfi_exp(o, u);
            break;
        case TAPE_SQRT:
            if (mpfi_is_strictly_neg(S[c->a]) || mpfr_sgn(&S[c->a]->left) < 0)
                bad = 1;
            else
                mpfi_sqrt(o, S[c->a]);
            break;
        case TAPE_EXP: mpfi_exp(o, S[c->a]); break;
        case TAPE_LOG:
            if (!mpfi_is_strictly_pos(S[c->a]))
                bad = 1;
            else
                mpfi_log(o, S[c->a]);
            break;
        case TAPE_SIN: mpfi_sin(o, S[c->a]); break;
        case TAPE_COS: mpfi_cos(o, S[c->a]); break;
        case TAPE_TAN: mpfi_tan(o, S[c->a]); break;
        case TAPE_ATAN: mpfi_atan(o, S[c->a]); break;
        case TAPE_ADD: mpfi_add(o, S[c->a], S[c->b]); break;
        case TAPE_SUB: mpfi_sub(o, S[c->a], S[c->b]); break;
        case TAPE_MUL: mpfi_mul(o, S[c->a], S[c->b]); break;
        case TAPE_DIV:
            if (mpfi_has_zero(S[c->b]))
                bad = 1;
            else
                mpfi_div(o, S[c->a], S[c->b]);
            break;
        default: bad = 1; break;
        }
    }
    if (!bad)
        mpfi_set(out, S[t->n - 1]);
    for (uint32_t i = 0; i < done; i++)
        mpfi_clear(S[i]);
    mpfi_clear(u);
    free(S);
    return bad;
}

typedef struct {
    long boxes, certified, unsupported, strict_lo, strict_hi, dualised, outer;
    long status[MOD_ENOMEM + 1];
} tally_t;

static double side(const iv_box_t *b, int k) { return k == 0 ? b->x.hi - b->x.lo : k == 1 ? b->y.hi - b->y.lo : b->z.hi - b->z.lo; }

/* checks 1 and 2 on one certified box */
static void check_certified(const char *name, const tape_t *t, tape_ws_t *ws,
                            const iv_box_t *box, iv_t r, tally_t *ty)
{
    /* 1. inside an MPFI enclosure */
    mpfi_t F;
    mpfi_init2(F, BOX_PREC);
    if (mpfi_box(t, box, F) != 0)
        fail_msg("%s: certified on a box where MPFI finds f undefined", name);
    if (!(mpfr_cmp_d(&F->left, r.lo) <= 0 && mpfr_cmp_d(&F->right, r.hi) >= 0))
        fail_msg("%s: box [%a,%a]x[%a,%a]x[%a,%a]: inner [%.17g, %.17g] not inside the MPFI "
                 "enclosure [%.17g, %.17g]",
                 name, box->x.lo, box->x.hi, box->y.lo, box->y.hi, box->z.lo, box->z.hi, r.lo,
                 r.hi, mpfr_get_d(&F->left, MPFR_RNDD), mpfr_get_d(&F->right, MPFR_RNDU));
    mpfi_clear(F);

    /* 2. samples reach both ends within the sampling tolerance */
    iv_grad_t g;
    tape_eval_grad(t, ws, 1, box, &g);
    const iv_t d[3] = {g.dx, g.dy, g.dz};
    double tol = 0;
    for (int k = 0; k < 3; k++) {
        double G = fmax(fabs(d[k].lo), fabs(d[k].hi));
        tol += G * side(box, k) / (GRID - 1) / 2;
    }
    tol = tol * (1 + 1e-9) + 1e-300;
    mpfi_t v;
    mpfi_init2(v, ORACLE_PREC);
    double smin = INFINITY, smax = -INFINITY;
    const iv_t s[3] = {box->x, box->y, box->z};
    for (int i = 0; i < GRID; i++)
        for (int j = 0; j < GRID; j++)
            for (int k = 0; k < GRID; k++) {
                const int ijk[3] = {i, j, k};
                double p[3];
                for (int a = 0; a < 3; a++)
                    p[a] = ijk[a] == GRID - 1 ? s[a].hi
                                              : tu_lerp(s[a].lo, s[a].hi, (double)ijk[a] / (GRID - 1));
                for (int w = 0; w < 2; w++) {
                    if (oracle_eval(t, p, w ? ORACLE_CONST_HI : ORACLE_CONST_LO, v, NULL) != 0)
                        fail_msg("%s: certified but f undefined at a point of the box", name);
                    smin = fmin(smin, mpfr_get_d(&v->left, MPFR_RNDD));
                    smax = fmax(smax, mpfr_get_d(&v->right, MPFR_RNDU));
                }
            }
    mpfi_clear(v);
    if (!(smin <= r.lo + tol) || !(smax >= r.hi - tol))
        fail_msg("%s: box [%a,%a]x[%a,%a]x[%a,%a]: inner [%.17g, %.17g] but samples only reach "
                 "[%.17g, %.17g] (tolerance %.3g)",
                 name, box->x.lo, box->x.hi, box->y.lo, box->y.hi, box->z.lo, box->z.hi, r.lo,
                 r.hi, smin, smax, tol);
    ty->strict_lo += smin <= r.lo;
    ty->strict_hi += smax >= r.hi;
}

static void run_boxes(const char *name, const tape_t *t, const double box6[6], long n,
                      uint64_t *rng, tally_t *ty)
{
    tape_ws_t *ws = tape_ws_new(t->n);
    assert_non_null(ws);
    int supported = mod_tape_supported(t);
    for (long b = 0; b < n; b++) {
        iv_box_t box = tu_random_subbox(box6, rng);
        iv_t r;
        mod_info_t info;
        mod_status_t st = mod_inner_range(t, &box, &r, &info);
        ty->boxes++;
        ty->status[st]++;
        /* the outer claim f*(X) ⊆ S on the proper box (f* is then the range):
         * every point value of f lies in S, and so does the inner estimate */
        mod_t X[3] = {mod_from_iv(box.x), mod_from_iv(box.y), mod_from_iv(box.z)}, S;
        mod_status_t sst = mod_star(t, X, &S, NULL);
        if (!supported)
            assert_int_equal(sst, MOD_UNSUPPORTED);
        if (sst == MOD_OK) {
            ty->outer++;
            if (st == MOD_OK && !(S.lo <= r.lo && r.hi <= S.hi))
                fail_msg("%s: inner [%.17g, %.17g] not inside f* [%.17g, %.17g]", name, r.lo, r.hi,
                         S.lo, S.hi);
            mpfi_t v;
            mpfi_init2(v, ORACLE_PREC);
            for (int j = 0; j < 10; j++) {
                double p[3];
                tu_box_point(&box, j, rng, p);
                for (int w = 0; w < 2; w++) {
                    if (oracle_eval(t, p, w ? ORACLE_CONST_HI : ORACLE_CONST_LO, v, NULL) != 0)
                        fail_msg("%s: f* certified but f undefined at a point of the box", name);
                    if (!(mpfr_cmp_d(&v->left, S.lo) >= 0 && mpfr_cmp_d(&v->right, S.hi) <= 0))
                        fail_msg("%s: f(%a, %a, %a) outside f* [%.17g, %.17g]", name, p[0], p[1],
                                 p[2], S.lo, S.hi);
                }
            }
            mpfi_clear(v);
        }
        if (!supported) {
            if (st != MOD_UNSUPPORTED)
                fail_msg("%s: unsupported tape, status '%s'", name, mod_status_name(st));
            ty->unsupported++;
            continue;
        }
        assert_true(st != MOD_UNSUPPORTED && st != MOD_EINVAL && st != MOD_ENOMEM);
        if (st != MOD_OK) {
            assert_true(iv_is_empty(r));
            continue;
        }
        assert_true(r.lo <= r.hi);
        ty->certified++;
        ty->dualised += info.use[0] == MOD_VAR_DUALISED || info.use[1] == MOD_VAR_DUALISED ||
                        info.use[2] == MOD_VAR_DUALISED;
        check_certified(name, t, ws, &box, r, ty);
    }
    tape_ws_free(ws);
}

static void print_tally(const char *name, const tally_t *ty)
{
    printf("%-34s %5ld boxes: %5ld certified (%ld with a dualised variable; a sample "
           "strictly beyond lo %ld, hi %ld), no inner %ld, not interpretable %ld, domain %ld, "
           "unsupported %ld; f* outer estimates %ld\n",
           name, ty->boxes, ty->certified, ty->dualised, ty->strict_lo, ty->strict_hi,
           ty->status[MOD_NO_INNER], ty->status[MOD_NOT_INTERPRETABLE], ty->status[MOD_DOMAIN],
           ty->status[MOD_UNSUPPORTED], ty->outer);
}

static void test_scenes(void **state)
{
    (void)state;
    char **paths;
    int n = tu_scene_files(&paths);
    uint64_t rng = tu_seed(20261202);
    long nbox = (long)(400 * tu_scale());
    long total_cert = 0, total_unsup = 0;
    for (int i = 0; i < n; i++) {
        scene_t s;
        tu_load_scene(paths[i], &s);
        tally_t ty;
        memset(&ty, 0, sizeof ty);
        const char *base = strrchr(paths[i], '/');
        base = base ? base + 1 : paths[i];
        run_boxes(base, s.tape, s.box, nbox, &rng, &ty);
        print_tally(base, &ty);
        total_cert += ty.certified;
        total_unsup += ty.unsupported;
        if (strcmp(base, "sphere.ini") == 0 || strcmp(base, "gumdrop.ini") == 0 ||
            strcmp(base, "mcmullen-k3.ini") == 0 || strcmp(base, "chubs.ini") == 0)
            assert_true(ty.certified > 0); /* the test is not vacuous on these */
        if (strcmp(base, "sphere.ini") == 0) /* uni-incident: all but point-like boxes */
            assert_true(ty.certified >= nbox / 2);
        scene_free(&s);
    }
    tu_free_list(paths, n);
    assert_true(total_cert > 0 && total_unsup > 0); /* csg-64-spheres uses min */
}

/* random polynomials: sums of products of powers and of linear factors */
static void random_poly(uint64_t *rng, char *buf, size_t cap)
{
    size_t len = 0;
    int terms = 1 + (int)(tu_next(rng) % 5);
    for (int t = 0; t < terms; t++) {
        int c = (int)(tu_next(rng) % 9) - 4;
        len += (size_t)snprintf(buf + len, cap - len, "%s%d", t ? " + " : "", c == 0 ? 1 : c);
        int factors = (int)(tu_next(rng) % 4);
        for (int f = 0; f < factors; f++) {
            char v = "xyz"[tu_next(rng) % 3];
            int kind = (int)(tu_next(rng) % 3);
            if (kind == 0)
                len += (size_t)snprintf(buf + len, cap - len, "*%c^%d", v,
                                        1 + (int)(tu_next(rng) % 5));
            else if (kind == 1)
                len += (size_t)snprintf(buf + len, cap - len, "*(%c - %d)", v,
                                        (int)(tu_next(rng) % 5) - 2);
            else
                len += (size_t)snprintf(buf + len, cap - len, "*(%c + %c)", v,
                                        "xyz"[tu_next(rng) % 3]);
        }
    }
}

static void test_random_polynomials(void **state)
{
    (void)state;
    uint64_t rng = tu_seed(4242);
    const double box[6] = {-2, 2, -2, 2, -2, 2};
    long npoly = (long)(100 * tu_scale()) + 5, cert = 0, dual = 0;
    for (long i = 0; i < npoly; i++) {
        char f[512];
        random_poly(&rng, f, sizeof f);
        tape_t *t = tu_compile(f);
        tally_t ty;
        memset(&ty, 0, sizeof ty);
        run_boxes(f, t, box, 50, &rng, &ty);
        cert += ty.certified;
        dual += ty.dualised;
        tape_free(t);
    }
    printf("random polynomials: %ld certified inner estimates checked (%ld with a dualised "
           "variable)\n", cert, dual);
    assert_true(cert > npoly * 5);
}

static void test_transcendental(void **state)
{
    (void)state;
    static const char *const f[] = {
        "exp(x) * y + log(z + 3) - 1",
        "sqrt(x^2 + y^2 + 1) - z^3",
        "atan(x*y) + exp(-z^2)",
        "x / (y^2 + 1) + z",
        "(x + 3)^-2 + sqrt(y + 3) * z",
        "(x + 3)^0.5 * exp(y) - log(z + 3)^3",
        "sin(x/4) + cos(y/4 + 1) + z",
    };
    uint64_t rng = tu_seed(31337);
    const double box[6] = {-2, 2, -2, 2, -2, 2};
    for (size_t i = 0; i < sizeof f / sizeof f[0]; i++) {
        tape_t *t = tu_compile(f[i]);
        tally_t ty;
        memset(&ty, 0, sizeof ty);
        run_boxes(f[i], t, box, (long)(400 * tu_scale()), &rng, &ty);
        print_tally(f[i], &ty);
        assert_true(ty.certified > 0);
        tape_free(t);
    }
}

/* 3. optimality where each variable occurs once: sum of g_k(x_k) with g_k
 * even-like (x^2, x^4) or monotone; the extremes are at known corners */
static void test_optimal_uni_incident(void **state)
{
    (void)state;
    static const struct {
        const char *f;
        int kind[3]; /* 0: u^2-like (min at the point nearest 0), 1: increasing */
    } cases[] = {
        {"x^2 + y^2 + z^2 - 1", {0, 0, 0}},
        {"x^4 + exp(y) + z^3", {0, 1, 1}},
        {"sqrt(x + 3) + atan(y) + 2*z", {1, 1, 1}},
    };
    uint64_t rng = tu_seed(5);
    const double box6[6] = {-2.5, 2.5, -2.5, 2.5, -2.5, 2.5};
    long checked = 0;
    mpfi_t v;
    mpfi_init2(v, ORACLE_PREC);
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        tape_t *t = tu_compile(cases[c].f);
        for (long b = 0; b < (long)(3000 * tu_scale()); b++) {
            iv_box_t box = tu_random_subbox(box6, &rng);
            iv_t r;
            mod_info_t info;
            mod_status_t st = mod_inner_range(t, &box, &r, &info);
            if (st == MOD_NO_INNER)
                continue; /* a point-like box: rounding leaves nothing certain */
            assert_int_equal(st, MOD_OK);
            for (int k = 0; k < 3; k++)
                assert_int_equal(info.use[k], MOD_VAR_ONCE);
            const iv_t s[3] = {box.x, box.y, box.z};
            double pmin[3], pmax[3];
            for (int k = 0; k < 3; k++) {
                if (cases[c].kind[k] == 0) {
                    pmin[k] = s[k].lo > 0 ? s[k].lo : s[k].hi < 0 ? s[k].hi : 0.0;
                    pmax[k] = fabs(s[k].lo) > fabs(s[k].hi) ? s[k].lo : s[k].hi;
                } else {
                    pmin[k] = s[k].lo;
                    pmax[k] = s[k].hi;
                }
            }
            double w = fmax(fabs(r.lo), fabs(r.hi)) + 1;
            assert_int_equal(oracle_eval(t, pmin, ORACLE_CONST_LO, v, NULL), 0);
            if (!(mpfr_cmp_d(&v->right, r.lo) <= 0 && r.lo - mpfr_get_d(&v->left, MPFR_RNDD) <= 1e-12 * w))
                fail_msg("%s: min %.17g, inner lo %.17g", cases[c].f,
                         mpfr_get_d(&v->left, MPFR_RNDN), r.lo);
            assert_int_equal(oracle_eval(t, pmax, ORACLE_CONST_LO, v, NULL), 0);
            if (!(mpfr_cmp_d(&v->left, r.hi) >= 0 && mpfr_get_d(&v->right, MPFR_RNDU) - r.hi <= 1e-12 * w))
                fail_msg("%s: max %.17g, inner hi %.17g", cases[c].f,
                         mpfr_get_d(&v->left, MPFR_RNDN), r.hi);
            checked++;
        }
        tape_free(t);
    }
    mpfi_clear(v);
    printf("%ld optimal inner estimates checked at their extreme corners\n", checked);
    assert_true(checked > (long)(3000 * tu_scale()));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_optimal_uni_incident),
        cmocka_unit_test(test_transcendental),
        cmocka_unit_test(test_random_polynomials),
        cmocka_unit_test(test_scenes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
