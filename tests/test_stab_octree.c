/* Numerical stability stress suite, octree half: every case
 * asserts, against the MPFI oracle, that the octree misses no cell of the
 * surface and that the interval evaluator's enclosures contain the true value.
 * The ray half is tests/test_stab_rays.c; the outcome table is
 * docs/STABILITY.md (bench/stability.sh writes its rows).
 *
 * Machinery (tests/support/coverage.c, shared with test_octree_coverage.c): f
 * sampled on the grid of depth D+2 at exactly the cell-bound coordinates, signs
 * certified in MPFI where |f| is small; every sign change between neighbouring
 * samples, every possible zero sample and every given zero point must lie in a
 * surface leaf; every empty cell's class must match the MPFI sign (or
 * undefinedness) of f at its centre.  Enclosures: tests/support/mpfi_tape.c's
 * oracle_check_tape (random sub-boxes from the whole box down to 2^-30 of it,
 * interval and gradient evaluators, both ends of the interval constants).
 *
 * Cases:
 *  - translated: sphere and gumdrop torus moved by 1e3 ... 1e8 along x and along
 *    the diagonal (cancellation in x - c: cells are ~1e-9 relative to |x|);
 *  - scaled: coordinates multiplied by 1/s, box by s, s = 1e-8 ... 1e8;
 *  - thin shells |sqrt(x^2+y^2+z^2) - 1| - h, h = 1e-3 ... 1e-12, far thinner
 *    than any cell: sampling sees no sign change, so the check is radial
 *    segments with MPFI-certified opposite signs (f < 0 at radius 1, f > 0 at
 *    1 +- 2h), bisected in MPFI to a sub-ulp bracket that must lie in a leaf;
 *  - high degree (Barth sextic, tangle cube, Clebsch cubic) one level deeper than
 *    the coverage test, the whole chain with early leaves;
 *  - singular surfaces: zero lines without sign change and isolated singular
 *    points (exact double points, or MPFR-enclosed irrational ones);
 *  - undefined domains (sqrt and log of negative values, division by intervals
 *    holding 0): no NaN in any enclosure (an enclosure is either the empty set,
 *    where MPFI finds f undefined, or an ordered pair of non-NaN bounds), every
 *    empty cell's class certified, no missed cell where f is defined;
 *  - deep octrees: depth 16 around a sphere of radius 2.5e-4 (checked on a
 *    window of the depth-18 sample grid), with time and memory bounds; a
 *    memory budget hit at depth 16 is a clean error.
 *
 * IVOCT_ASAN=1 runs the grids one level coarser and a tenth of the random
 * points. */
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

#include "../octree/octree.h"
#include "../scene/scene.h"
#include "support/coverage.h"
#include "support/mpfi_tape.h"
#include "support/stab_cases.h"
#include "support/testutil.h"

/* The grid depth of most cases: 5 (4 instrumented). */
static int base_depth(void) { return tu_sanitizer_build() ? 4 : 5; }

/* Enclosures against MPFI on random sub-boxes, and no NaN anywhere: an
 * enclosure is either empty (both bounds NaN: f undefined on the whole box,
 * which MPFI must confirm at points of it) or an ordered pair of non-NaN
 * bounds.  Returns the number of points checked. */
static long check_enclosures(const tape_t *t, const double box[6], const char *what)
{
    uint64_t rng = tu_seed(0x57ab1e);
    long nbox = (long)(2000 * tu_scale());
    oracle_stats_t st;
    if (oracle_check_tape(t, box, nbox, 4, &rng, &st))
        fail_msg("%s: enclosure: %s", what, st.failure);

    tape_ws_t *ws = tape_ws_new(t->n);
    assert_non_null(ws);
    enum { B = 8 };
    long empty = 0;
    for (long done = 0; done < nbox; done += B) {
        iv_box_t b[B];
        iv_t F[B];
        iv_grad_t G[B];
        for (int i = 0; i < B; i++) {
            double frac = exp2(-40.0 * tu_uniform(&rng));
            iv_t r[3];
            for (int a = 0; a < 3; a++) {
                double lo = box[2 * a], hi = box[2 * a + 1], wd = (hi - lo) * frac;
                double s = lo + (hi - lo - wd) * tu_uniform(&rng);
                r[a] = iv_make(s, fmin(s + wd, hi));
            }
            b[i] = (iv_box_t){r[0], r[1], r[2]};
        }
        tape_eval_interval(t, ws, B, b, F);
        tape_eval_grad(t, ws, B, b, G);
        for (int i = 0; i < B; i++) {
            iv_t all[5] = {F[i], G[i].v, G[i].dx, G[i].dy, G[i].dz};
            for (int k = 0; k < 5; k++) {
                int nan_lo = isnan(all[k].lo), nan_hi = isnan(all[k].hi);
                if (nan_lo != nan_hi || (!nan_lo && !(all[k].lo <= all[k].hi)))
                    fail_msg("%s: %s enclosure [%g, %g] over [%g,%g]x[%g,%g]x[%g,%g] holds a NaN "
                             "or is reversed",
                             what, k == 0 ? "interval" : "gradient-pass", all[k].lo, all[k].hi,
                             b[i].x.lo, b[i].x.hi, b[i].y.lo, b[i].y.hi, b[i].z.lo, b[i].z.hi);
            }
            if (isnan(F[i].lo)) {
                /* the empty set: f must be undefined at every point of the box */
                empty++;
                for (int c = 0; c < 8; c++) {
                    double p[3] = {c & 1 ? b[i].x.hi : b[i].x.lo, c & 2 ? b[i].y.hi : b[i].y.lo,
                                   c & 4 ? b[i].z.hi : b[i].z.lo};
                    if (cov_mpfi_sign(t, p) != S_UNDEF)
                        fail_msg("%s: enclosure empty but f defined at (%.17g, %.17g, %.17g)",
                                 what, p[0], p[1], p[2]);
                }
            }
        }
    }
    tape_ws_free(ws);
    return st.checked + empty;
}

static void row(const char *name, const cov_summary_t *s, long missed, double t0)
{
    char outcome[128];
    snprintf(outcome, sizeof outcome, "missed cells %ld (%ld sign changes; %ld zero points)",
             missed, s->segments, s->line_points);
    tu_result_row("octree", name, outcome, tu_now() - t0, s->max_error_bound);
}

/* The common case: coverage with the given configurations, enclosures. */
static void check_case(const tape_t *t, const double box[6], const char *name, int depth,
                       unsigned cfgs, const cov_line_t *lines, int n_lines, int need_segments)
{
    double t0 = tu_now();
    cov_summary_t s;
    cov_check_all(t, box, name, depth, cfgs, lines, n_lines, &s);
    if (need_segments)
        assert_true(s.min_segments > 0); /* not vacuous */
    check_enclosures(t, box, name);
    row(name, &s, s.failures, t0);
}

/* ---- translated and scaled ------------------------------------------------------- */

static void test_translated(void **state)
{
    (void)state;
    for (int surf = 0; surf < 2; surf++)
        for (int diag = 0; diag < 2; diag++)
            for (size_t k = 0; k < STAB_N_OFFSETS; k++) {
                stab_case_t sc;
                stab_translated(surf, k, diag, &sc);
                tape_t *t = tu_compile_uvw(sc.f, sc.u, sc.v, sc.w);
                /* the empty-cell check (an MPFI evaluation per empty cell) on the
                 * sphere only: the gumdrop's many cells would dominate the suite */
                check_case(t, sc.box, sc.name, base_depth(),
                           COV_CFG_LIPSCHITZ | COV_CFG_REFINE | (surf ? COV_NO_EMPTY : 0), NULL, 0,
                           1);
                tape_free(t);
            }
}

static void test_scaled(void **state)
{
    (void)state;
    for (int surf = 0; surf < 2; surf++)
        for (size_t k = 0; k < STAB_N_SCALES; k++) {
            stab_case_t sc;
            stab_scaled(surf, k, &sc);
            tape_t *t = tu_compile_uvw(sc.f, sc.u, sc.v, sc.w);
            check_case(t, sc.box, sc.name, base_depth(),
                       COV_CFG_LIPSCHITZ | COV_CFG_REFINE | (surf ? COV_NO_EMPTY : 0), NULL, 0, 1);
            tape_free(t);
        }
}

/* ---- thin shells ------------------------------------------------------------------ */

/* p, q with MPFI-certified opposite signs: bisect (in MPFI) to a bracket of a few
 * ulps, which must lie in a covered cell.  Returns 0 when the signs at p and q
 * are not certified opposite (counted, never expected here). */
static int check_bracket(const cov_grid_t *g, const cov_cover_t *cv, const double p0[3],
                         const double q0[3], const char *what, cov_result_t *r)
{
    double p[3], q[3];
    memcpy(p, p0, sizeof p);
    memcpy(q, q0, sizeof q);
    int sp = cov_mpfi_sign(g->tape, p), sq = cov_mpfi_sign(g->tape, q);
    if (!((sp == S_POS && sq == S_NEG) || (sp == S_NEG && sq == S_POS)))
        return 0;
    for (int it = 0; it < 60; it++) {
        double m[3];
        int same = 1;
        for (int a = 0; a < 3; a++) {
            m[a] = p[a] + 0.5 * (q[a] - p[a]);
            same &= m[a] == p[a] || m[a] == q[a];
        }
        if (same)
            break;
        int sm = cov_mpfi_sign(g->tape, m);
        if (sm == sp)
            memcpy(p, m, sizeof p);
        else if (sm == sq)
            memcpy(q, m, sizeof q);
        else
            break; /* m is a possible zero itself: the bracket [p, q] holds it */
    }
    double lo[3], hi[3];
    for (int a = 0; a < 3; a++)
        lo[a] = fmin(p[a], q[a]), hi[a] = fmax(p[a], q[a]);
    cov_check_box(g, cv, lo, hi, what, r);
    return 1;
}

static void test_thin_shells(void **state)
{
    (void)state;
    const char *const *hs = stab_shell_widths;
    const double box[6] = {-1.1, 1.1, -1.1, 1.1, -1.1, 1.1};
    int depth = base_depth();
    for (size_t k = 0; k < STAB_N_SHELLS; k++) {
        double t0 = tu_now();
        double h = strtod(hs[k], NULL);
        char f[96], name[64];
        snprintf(f, sizeof f, "abs(sqrt(x^2 + y^2 + z^2) - 1) - %s", hs[k]);
        snprintf(name, sizeof name, "thin shell h=%s", hs[k]);
        tape_t *t = tu_compile(f);
        cov_summary_t s;
        /* the grid checks (sign changes only where the grid straddles the shell,
         * i.e. h = 1e-3; empty cells everywhere) */
        cov_check_all(t, box, name, depth, COV_CFG_ILIE, NULL, 0, &s);
        check_enclosures(t, box, name);

        /* radial brackets on both faces of the shell */
        cov_grid_t g;
        cov_grid_init(&g, t, box, depth);
        uint64_t rng = tu_seed(0x5e11 + k);
        int ndir = (int)(400 * tu_scale());
        long brackets = 0, uncertified = 0;
        static const unsigned cfg[2] = {OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ,
                                        OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ | OCT_TEST_ILIE};
        long failures = 0;
        for (int c = 0; c < 2; c++) {
            oct_params_t p = {.depth = depth, .tests = cfg[c], .threads = 2};
            oct_tree_t *tree;
            ivoct_error_t err;
            ivoct_error_clear(&err);
            assert_int_equal(oct_build(t, box, &p, &tree, &err), 0);
            cov_cover_t cv;
            cov_cover_init(&cv, tree);
            cov_result_t r = {0};
            for (int i = 0; i < ndir; i++) {
                double u[3], n2 = 0;
                do {
                    n2 = 0;
                    for (int a = 0; a < 3; a++) {
                        u[a] = 2 * tu_uniform(&rng) - 1;
                        n2 += u[a] * u[a];
                    }
                } while (n2 > 1 || n2 < 0.01);
                double n = sqrt(n2), mid[3], out[3], in[3];
                for (int a = 0; a < 3; a++) {
                    mid[a] = u[a] / n;
                    out[a] = mid[a] * (1 + 2 * h);
                    in[a] = mid[a] * (1 - 2 * h);
                }
                int ok_out = check_bracket(&g, &cv, mid, out, name, &r);
                int ok_in = check_bracket(&g, &cv, mid, in, name, &r);
                brackets += ok_out + ok_in;
                uncertified += !ok_out + !ok_in;
            }
            failures += r.failures;
            printf("%-30s [%s] %ld radial brackets, all in surface leaves: %s\n", name,
                   c ? "ilie" : "lipschitz", r.point_boxes, r.failures ? "NO" : "yes");
            cov_cover_free(&cv);
            oct_free(tree);
        }
        cov_grid_free(&g);
        /* every bracket certified (radius 1 is inside the shell, 1 +- 2h outside) */
        assert_int_equal(uncertified, 0);
        assert_true(brackets > 0);
        char outcome[128];
        snprintf(outcome, sizeof outcome, "missed cells %ld (%ld radial brackets)", failures,
                 brackets);
        tu_result_row("octree", name, outcome, tu_now() - t0, s.max_error_bound);
        if (failures)
            fail_msg("%s: %ld radial brackets in no surface leaf", name, failures);
        tape_free(t);
    }
}

/* ---- high degree and singular surfaces --------------------------------------------- */

static void test_high_degree(void **state)
{
    (void)state;
    const char *const *names = stab_high_degree_scenes;
    for (size_t k = 0; k < STAB_N_HIGH_DEGREE; k++) {
        scene_t s;
        tu_load_scene(names[k], &s);
        /* one level deeper than test_octree_coverage, the whole chain (with and
         * without early leaves) */
        check_case(s.tape, s.box, names[k], base_depth() + 1, COV_CFG_REFINE | COV_NO_EMPTY, NULL,
                   0, 1);
        scene_free(&s);
    }
}

/* Singular points that must lie in surface leaves: exact zeros (checked with
 * cov_check_zero_point, which asserts f = 0 in MPFI), or a box the point is
 * certainly in. */
typedef struct sing_point {
    double lo[3], hi[3];
} sing_point_t;

static void check_singular(const char *scene, const cov_line_t *lines, int n_lines,
                           const sing_point_t *pts, int n_pts)
{
    double t0 = tu_now();
    scene_t s;
    tu_load_scene(scene, &s);
    int depth = base_depth();
    cov_summary_t sum;
    cov_check_all(s.tape, s.box, scene, depth, COV_CFG_LIPSCHITZ | COV_CFG_REFINE | COV_NO_EMPTY,
                  lines, n_lines, &sum);
    assert_true(sum.min_segments > 0);
    cov_grid_t g;
    cov_grid_init(&g, s.tape, s.box, depth);
    long failures = sum.failures, checked = 0;
    static const unsigned cfg[2] = {OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ,
                                    OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ | OCT_TEST_ILIE};
    for (int c = 0; c < 2; c++) {
        double edge = s.box[1] - s.box[0];
        oct_params_t p = {.depth = depth, .tests = cfg[c], .refine = c ? 0.02 * edge : 0,
                          .threads = 2};
        oct_tree_t *tree;
        ivoct_error_t err;
        ivoct_error_clear(&err);
        assert_int_equal(oct_build(s.tape, s.box, &p, &tree, &err), 0);
        cov_cover_t cv;
        cov_cover_init(&cv, tree);
        cov_result_t r = {0};
        for (int i = 0; i < n_pts; i++) {
            if (memcmp(pts[i].lo, pts[i].hi, sizeof pts[i].lo) == 0)
                cov_check_zero_point(&g, &cv, pts[i].lo, scene, &r);
            else
                cov_check_box(&g, &cv, pts[i].lo, pts[i].hi, scene, &r);
            checked++;
        }
        failures += r.failures;
        cov_cover_free(&cv);
        oct_free(tree);
    }
    cov_grid_free(&g);
    char outcome[160];
    snprintf(outcome, sizeof outcome,
             "missed cells %ld (%ld sign changes; %ld zero-line points; %ld singular points)",
             failures, sum.segments, sum.line_points, checked);
    tu_result_row("octree", scene, outcome, tu_now() - t0, sum.max_error_bound);
    if (failures)
        fail_msg("%s: %ld singular points in no surface leaf", scene, failures);
    scene_free(&s);
}

#define PT(x, y, z) {{x, y, z}, {x, y, z}}

static void test_singular(void **state)
{
    (void)state;
    /* chubs: the 12 nodes (+-1/sqrt2, +-1/sqrt2, 0) and permutations, 1/sqrt2
     * enclosed by the doubles around it (MPFR, directed rounding) */
    mpfr_t v;
    mpfr_init2(v, 128);
    mpfr_set_ui(v, 2, MPFR_RNDN);
    mpfr_rec_sqrt(v, v, MPFR_RNDN);
    double a = mpfr_get_d(v, MPFR_RNDD), b = mpfr_get_d(v, MPFR_RNDU);
    mpfr_clear(v);
    assert_true(a < b);
    sing_point_t chubs[12];
    int n = 0;
    for (int zero = 0; zero < 3; zero++)
        for (int sgn = 0; sgn < 4; sgn++) {
            sing_point_t p;
            int k = 0;
            for (int ax = 0; ax < 3; ax++) {
                if (ax == zero) {
                    p.lo[ax] = p.hi[ax] = 0;
                    continue;
                }
                int neg = sgn >> k++ & 1;
                p.lo[ax] = neg ? -b : a;
                p.hi[ax] = neg ? -a : b;
            }
            chubs[n++] = p;
        }
    check_singular("chubs", NULL, 0, chubs, n);

    /* Kusner-Schmitt: (1,1,1) and the sign permutations with an even number of
     * minus signs, exact zeros */
    const sing_point_t ks[] = {PT(1, 1, 1), PT(1, -1, -1), PT(-1, 1, -1), PT(-1, -1, 1)};
    check_singular("kusner-schmitt", NULL, 0, ks, 4);

    /* the drop's tip */
    const sing_point_t drop[] = {PT(0, 0, 0)};
    check_singular("drop", NULL, 0, drop, 1);

    /* zero lines without sign change (and their singular points) */
    const cov_line_t cross[] = {{2, -INFINITY, INFINITY}};
    const sing_point_t cross_pts[] = {PT(0, 0, 0), PT(0, 0, -1)};
    check_singular("crosscap", cross, 1, cross_pts, 2);
    const cov_line_t steiner[] = {{0, -INFINITY, INFINITY}, {1, -INFINITY, INFINITY},
                                  {2, -INFINITY, INFINITY}};
    const sing_point_t steiner_pts[] = {PT(0, 0, 0)};
    check_singular("steiner-roman", steiner, 3, steiner_pts, 1);
    const cov_line_t whitney[] = {{2, -INFINITY, 0.0}, {2, 0.0, INFINITY}};
    const sing_point_t whitney_pts[] = {PT(0, 0, 0)};
    check_singular("whitney-umbrella", whitney, 2, whitney_pts, 1);
}

/* ---- undefined domains ------------------------------------------------------------ */

static void test_undefined(void **state)
{
    (void)state;
    /* Every f is continuous where defined, except at poles where it does not change
     * sign (1/x^2, an even power of the denominator) or where the pole lies on a
     * grid plane (x/y on y = 0: a sample there is undefined, so no segment of the
     * grid straddles it) -- so a sign change between two defined neighbouring
     * samples is a zero. */
    static const struct {
        const char *f;
        double box[6];
        int has_surface, has_undefined;
    } cases[] = {
        /* (the domain edge x = 0.1 on no cell plane: cells wholly outside it exist) */
        {"sqrt(x - 0.1) - y^2 - z^2 - 0.1", {-1, 1, -1, 1, -1, 1}, 1, 1},
        /* (log -> -inf at the domain's edge: the cells there are decided inside
         * before any is wholly undefined) */
        {"log(x^2 + y^2 + z^2 - 0.25)", {-1, 1, -1, 1, -1, 1}, 1, 0},
        {"sqrt(x^2 + y^2 - 0.25) - 0.3", {-1, 1, -1, 1, -1, 1}, 1, 1},
        {"log(-x) + sqrt(y + 0.5) - 1", {-1, 1, -1, 1, -1, 1}, 1, 1},
        {"1/x^2 - 5", {-1, 1, -1, 1, -1, 1}, 1, 0},
        {"1/(x^2 + y^2 + z^2 - 0.25)^2 - 16", {-1, 1, -1, 1, -1, 1}, 1, 0},
        {"x/y - 1", {-1, 1, -1, 1, -1, 1}, 1, 0},
        {"sqrt(-1 - x^2) + y", {-1, 1, -1, 1, -1, 1}, 0, 1},
        {"log(-x^2 - y^2) + z", {-1, 1, -1, 1, -1, 1}, 0, 1},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        double t0 = tu_now();
        tape_t *t = tu_compile(cases[i].f);
        cov_summary_t s;
        cov_check_all(t, cases[i].box, cases[i].f, base_depth(), COV_CFG_ALL, NULL, 0, &s);
        if (cases[i].has_surface)
            assert_true(s.min_segments > 0);
        else
            assert_int_equal(s.leaves, 0); /* defined nowhere (log(-x^2-y^2): only on the z
                                              axis, where log(0) is undefined too) */
        if (cases[i].has_undefined)
            assert_true(s.undefined > 0);
        long n = check_enclosures(t, cases[i].box, cases[i].f);
        char name[128];
        snprintf(name, sizeof name, "undefined: %s", cases[i].f);
        char outcome[160];
        snprintf(outcome, sizeof outcome,
                 "missed cells %ld (%ld sign changes; %ld undefined cells; %ld enclosures)",
                 s.failures, s.segments, s.undefined, n);
        tu_result_row("octree", name, outcome, tu_now() - t0, s.max_error_bound);
        tape_free(t);
    }
}

/* ---- deep octrees ----------------------------------------------------------------- */

static void test_deep(void **state)
{
    (void)state;
    double t0 = tu_now();
    /* a sphere of radius 2.5e-4 at an arbitrary point of [-1,1]^3, depth 16: cells
     * of 3.05e-5, so about 8 cells per radius */
    const double c[3] = {0.3, 0.2, 0.1}, rad = 2.5e-4;
    const double box[6] = {-1, 1, -1, 1, -1, 1};
    const int depth = 16;
    tape_t *t = tu_compile_uvw("u^2 + v^2 + w^2 - 6.25e-8", "x - 0.3", "y - 0.2", "z - 0.1");
    double w = (box[1] - box[0]) / (double)(1u << depth);
    uint32_t i0[3], n = (uint32_t)ceil(2.6 * rad / w) + 2;
    if (tu_sanitizer_build())
        n = n / 2 + 1; /* a window on part of the sphere */
    for (int a = 0; a < 3; a++)
        i0[a] = (uint32_t)floor((c[a] - 1.3 * rad - box[2 * a]) / w);
    cov_grid_t g;
    cov_grid_init_window(&g, t, box, depth, i0, n);
    static const unsigned cfg[3] = {OCT_TEST_INTERVAL, OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ,
                                    OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ | OCT_TEST_ILIE};
    long failures = 0, segments = 0;
    double max_err = 0;
    for (int k = 0; k < 3; k++) {
        oct_params_t p = {.depth = depth, .tests = cfg[k], .threads = 2};
        oct_tree_t *tree;
        ivoct_error_t err;
        ivoct_error_clear(&err);
        double tb = tu_now();
        assert_int_equal(oct_build(t, box, &p, &tree, &err), 0);
        tb = tu_now() - tb;
        cov_cover_t cv;
        cov_cover_init(&cv, tree);
        cov_result_t r = {0};
        cov_check_sign_changes(&g, &cv, "deep sphere", &r);
        printf("deep sphere r=2.5e-4 depth 16 [%d]: %u leaves, %.3f s, peak %zu bytes, "
               "%ld sign-change segments, %ld failures\n",
               k, tree->n_leaves, tb, tree->stats.peak_bytes, r.segments, r.failures);
        /* bounded: the leaves follow the surface (area / cell^2 ~ 4 pi 8.2^2 ~ 850,
         * times the overestimation), not the volume */
        assert_true(tree->n_leaves < 20000);
        assert_true(tree->stats.peak_bytes < ((size_t)64 << 20));
        assert_true(r.segments > 0);
        failures += r.failures;
        segments += r.segments;
        max_err = fmax(max_err, tree->stats.max_error_bound);
        cov_cover_free(&cv);
        oct_free(tree);
    }
    cov_grid_free(&g);
    tape_free(t);
    char outcome[128];
    snprintf(outcome, sizeof outcome, "missed cells %ld (%ld sign changes)", failures, segments);
    tu_result_row("octree", "deep: sphere r=2.5e-4 depth 16", outcome, tu_now() - t0, max_err);
    if (failures)
        fail_msg("deep sphere: %ld failures", failures);

    /* A box of 1e-4 cutting the unit sphere at depth 16 would need ~2^32 leaves:
     * the memory budget must stop it with an error, not a crash. */
    t0 = tu_now();
    t = tu_compile("x^2 + y^2 + z^2 - 1");
    const double small[6] = {1 - 5e-5, 1 + 5e-5, -5e-5, 5e-5, -5e-5, 5e-5};
    oct_params_t p = {.depth = 16, .tests = OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ, .threads = 2,
                      .max_memory = (size_t)32 << 20};
    oct_tree_t *tree = NULL;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    int rc = oct_build(t, small, &p, &tree, &err);
    printf("box 1e-4 cutting the sphere, depth 16, budget 32 MiB: rc %d (%s) in %.2f s\n", rc,
           err.msg, tu_now() - t0);
    assert_int_not_equal(rc, 0);
    assert_null(tree);
    assert_true(err.msg[0] != 0);
    tu_result_row("octree", "deep: box 1e-4 on the sphere depth 16 (32 MiB budget)",
                  "clean out-of-budget error", tu_now() - t0, NAN);

    /* the same small box at the base depth: a full check */
    t0 = tu_now();
    cov_summary_t s;
    cov_check_all(t, small, "box 1e-4 on the unit sphere", base_depth(), COV_CFG_ALL, NULL, 0, &s);
    assert_true(s.min_segments > 0);
    row("deep: box 1e-4 on the unit sphere", &s, s.failures, t0);
    tape_free(t);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_translated), cmocka_unit_test(test_scaled),
        cmocka_unit_test(test_thin_shells), cmocka_unit_test(test_high_degree),
        cmocka_unit_test(test_singular),   cmocka_unit_test(test_undefined),
        cmocka_unit_test(test_deep),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
