/* Refinements side by side (ray/refine.c; ray/README.md, "Refinements side by
 * side").  A search may set the refinement of its hit aside
 * (ray_find_root_defer), and refine_batch runs many of them at once, the
 * points of each step sharing passes.  The promise: each ray gets the hit
 * ray_find_root_n gives it alone, bit for bit (kind, t, t_lo, t_hi), and
 * ray_segment_of the segment (*which) it names.
 *
 *  - the camera rays of the eight comparison surfaces and the 64-sphere CSG
 *    union, each clipped to the scene's box and cut in two at a random point
 *    (so the hit's segment, and which one holds its bracket, vary), with
 *    every certified method;
 *  - the jobs of all the scenes in one call of refine_batch, in a random
 *    order: their tapes and rays differ from job to job, and there are more
 *    of them than one batch runs side by side;
 *  - what a refinement promises (ray/README.md, "Refinement of a monotone
 *    bracket"), whatever its guesses were: the hit's bracket [t_lo, t_hi]
 *    lies in the job's, is at most 4 ulps wide, f at the point p~(t_lo)
 *    has the certified sign of the job's start (or t_lo is that start), and
 *    at p~(t_hi) not that sign (or t_hi is the job's end);
 *  - ray_segment_of against the rule it names, on random segment lists with
 *    empty, reversed and non-finite segments;
 *  - ulp, by the bits, against nextafter.
 * Sizes shrink in the sanitizer build (tu_image_size). */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "../ray/roots_internal.h" /* refine_batch and the deferred search themselves */
#include "support/testutil.h"

#define NSCENES (TU_N_COMPARISON + 1)

/* One ray of one scene: its two segments, what the search alone gives, and
 * the refinement set aside. */
typedef struct ray_case {
    const tape_t *tape;
    double o[3], d[3];
    double t0[2], t1[2];
    ray_result_t alone, later;
    int which_alone;
    refine_job_t job;
} ray_case_t;

static int same_bits(double a, double b) { return memcmp(&a, &b, sizeof a) == 0; }

/* The certified sign of f at the rounded point p~(t) of the ray */
static int sign_at(const ray_case_t *c, tape_ws_t *ws, double t)
{
    double p[3];
    tape_ray_point(c->o, c->d, t, p);
    iv_box_t box = {iv_point(p[0]), iv_point(p[1]), iv_point(p[2])};
    iv_t v;
    tape_eval_interval(c->tape, ws, 1, &box, &v);
    return sgn(v);
}

/* The refinement's promise for the job of c, its hit in c->later */
static void check_bracket(const ray_case_t *c, tape_ws_t *ws, const char *method, size_t i)
{
    const ray_result_t *r = &c->later;
    const refine_job_t *j = &c->job;
    if (r->kind != RAY_HIT_ROOT && r->kind != RAY_HIT_ZERO)
        fail_msg("%s: ray %zu: a refinement gave kind %d", method, i, r->kind);
    if (!(j->a <= r->t_lo && r->t_lo <= r->t && r->t <= r->t_hi && r->t_hi <= j->b))
        fail_msg("%s: ray %zu: t %.17g [%.17g, %.17g] outside the job's [%.17g, %.17g]", method,
                 i, r->t, r->t_lo, r->t_hi, j->a, j->b);
    if (!tiny(r->t_lo, r->t_hi))
        fail_msg("%s: ray %zu: bracket [%.17g, %.17g] wider than 4 ulps", method, i, r->t_lo,
                 r->t_hi);
    if (r->t_lo != j->a && sign_at(c, ws, r->t_lo) != j->sa)
        fail_msg("%s: ray %zu: f at t_lo = %.17g is not of the start's certified sign", method,
                 i, r->t_lo);
    if (r->t_hi != j->b && sign_at(c, ws, r->t_hi) == j->sa)
        fail_msg("%s: ray %zu: f at t_hi = %.17g is of the start's certified sign", method, i,
                 r->t_hi);
}

static void test_side_by_side_equals_alone(void **state)
{
    (void)state;
    uint64_t rng = tu_seed(0x5eed4ef1);
    scene_t scenes[NSCENES];
    int side = tu_image_size(24);
    size_t cap = (size_t)NSCENES * (size_t)side * (size_t)side;
    ray_case_t *cases = malloc(cap * sizeof *cases);
    refine_job_t **jobs = malloc(cap * sizeof *jobs);
    assert_non_null(cases);
    assert_non_null(jobs);
    uint32_t max_clauses = 0;
    for (int k = 0; k < NSCENES; k++) {
        tu_load_scene(k < TU_N_COMPARISON ? tu_comparison_surfaces[k] : "csg-64-spheres",
                      &scenes[k]);
        if (scenes[k].tape->n > max_clauses)
            max_clauses = scenes[k].tape->n;
    }
    tape_ws_t *ws = tape_ws_new(max_clauses);
    assert_non_null(ws);
    size_t total_set_aside = 0;
    for (int m = 0; m < RAY_METHOD_COUNT; m++) {
        if (!ray_method_certified((ray_method_t)m))
            continue;
        ray_opts_t opts;
        ray_opts_default(&opts);
        size_t n = 0;
        int set_aside = 0, ended_early = 0;
        for (int k = 0; k < NSCENES; k++) {
            const scene_t *s = &scenes[k];
            ray_camera_t cam;
            assert_int_equal(ray_camera_init(&cam, s->camera.eye, s->camera.target,
                                             s->camera.up, s->camera.fov, side, side, NULL),
                             0);
            for (int row = 0; row < side; row++)
                for (int col = 0; col < side; col++) {
                    ray_case_t *c = &cases[n];
                    memcpy(c->o, cam.eye, sizeof c->o);
                    ray_camera_dir(&cam, col, row, c->d);
                    double a, b;
                    if (!ray_clip_box(s->box, c->o, c->d, &a, &b))
                        continue;
                    double cut = tu_lerp(a, b, tu_uniform(&rng));
                    c->tape = s->tape;
                    c->t0[0] = a, c->t1[0] = cut, c->t0[1] = cut, c->t1[1] = b;
                    ray_find_root_n(c->tape, ws, (ray_method_t)m, &opts, c->o, c->d, 2, c->t0,
                                    c->t1, &c->alone, &c->which_alone);
                    int which, deferred;
                    ray_hit_kind_t kind =
                        ray_find_root_defer(c->tape, ws, (ray_method_t)m, &opts, c->o, c->d, 2,
                                            c->t0, c->t1, &c->later, &which, &c->job, &deferred);
                    if (!deferred) {
                        /* the same search, run to its end */
                        assert_int_equal(kind, c->alone.kind);
                        assert_int_equal(which, c->which_alone);
                        ended_early += kind != RAY_MISS;
                        continue;
                    }
                    /* set aside: a hit whose bracket is the job's */
                    assert_int_equal(which, -1);
                    assert_int_equal(kind, RAY_HIT_ROOT);
                    assert_true(c->alone.kind != RAY_MISS);
                    assert_true(c->job.a <= c->alone.t_lo && c->alone.t_hi <= c->job.b);
                    c->job.out = &c->later;
                    n++;
                    set_aside++;
                }
        }
        /* all the scenes' refinements in one call, in a random order */
        for (size_t i = 0; i < n; i++)
            jobs[i] = &cases[i].job;
        for (size_t i = n; i > 1; i--) {
            size_t j = (size_t)(tu_uniform(&rng) * (double)i);
            refine_job_t *x = jobs[i - 1];
            jobs[i - 1] = jobs[j];
            jobs[j] = x;
        }
        uint64_t passes = refine_batch(jobs, (int)n, ws);
        for (size_t i = 0; i < n; i++) {
            const ray_case_t *c = &cases[i];
            if (c->later.kind != c->alone.kind || !same_bits(c->later.t, c->alone.t) ||
                !same_bits(c->later.t_lo, c->alone.t_lo) ||
                !same_bits(c->later.t_hi, c->alone.t_hi))
                fail_msg("%s: ray %zu: side by side kind %d t %.17g [%.17g, %.17g], alone kind "
                         "%d t %.17g [%.17g, %.17g]",
                         ray_method_name((ray_method_t)m), i, c->later.kind, c->later.t,
                         c->later.t_lo, c->later.t_hi, c->alone.kind, c->alone.t,
                         c->alone.t_lo, c->alone.t_hi);
            assert_int_equal(ray_segment_of(c->later.t_lo, 2, c->t0, c->t1), c->which_alone);
            check_bracket(c, ws, ray_method_name((ray_method_t)m), i);
        }
        printf("%-13s %5d refinements set aside (%llu passes side by side), %d hits without "
               "one\n",
               ray_method_name((ray_method_t)m), set_aside, (unsigned long long)passes,
               ended_early);
        total_set_aside += (size_t)set_aside;
    }
    /* the refinement methods had something to refine */
    assert_true(total_set_aside > 64);
    tape_ws_free(ws);
    for (int k = 0; k < NSCENES; k++)
        scene_free(&scenes[k]);
    free(jobs);
    free(cases);
}

/* ray_segment_of: the first valid segment that ends at or after t_lo, else
 * the last valid one, -1 without one. */
static void test_segment_of(void **state)
{
    (void)state;
    uint64_t rng = tu_seed(0x5e65e6);
    for (int it = 0; it < 20000; it++) {
        int n = 1 + (int)(tu_uniform(&rng) * RAY_MAX_SEGMENTS);
        double t0[RAY_MAX_SEGMENTS], t1[RAY_MAX_SEGMENTS], t = 0;
        for (int j = 0; j < n; j++) {
            double u = tu_uniform(&rng);
            t0[j] = t, t1[j] = t + tu_uniform(&rng);
            if (u < 0.1)
                t1[j] = t0[j] - 1; /* reversed */
            else if (u < 0.15)
                t0[j] = NAN;
            else if (u < 0.2)
                t1[j] = INFINITY;
            else if (u < 0.3)
                t1[j] = t0[j]; /* a point */
            t = t + 1;
        }
        double t_lo = tu_uniform(&rng) * (t + 1) - 0.5;
        int expect = -1, last = -1;
        for (int j = 0; j < n; j++) {
            int valid = t0[j] <= t1[j] && isfinite(t0[j]) && isfinite(t1[j]);
            if (valid && expect < 0 && t_lo <= t1[j])
                expect = j;
            if (valid)
                last = j;
        }
        if (expect < 0)
            expect = last;
        assert_int_equal(ray_segment_of(t_lo, n, t0, t1), expect);
    }
}

/* ulp (the refinement's step size and stopping rule) by the bits against
 * nextafter: random doubles of every exponent, subnormals, 0, the largest
 * double, and both signs; +inf and NaN give NaN. */
static void test_ulp(void **state)
{
    (void)state;
    uint64_t rng = tu_seed(0x0195);
    const double special[] = {0.0, -0.0, 0x1p-1074, 0x1p-1022, 0x1.fffffffffffffp-1023,
                              1.0, 0x1.fffffffffffffp+1023, 12.012789967367183};
    for (size_t k = 0; k < sizeof special / sizeof *special; k++) {
        double x = special[k], a = fabs(x);
        assert_true(same_bits(ulp(x), nextafter(a, INFINITY) - a));
    }
    for (int it = 0; it < 200000; it++) {
        uint64_t bits = tu_next(&rng);
        double x;
        memcpy(&x, &bits, sizeof x);
        double a = fabs(x);
        if (isfinite(x))
            assert_true(same_bits(ulp(x), nextafter(a, INFINITY) - a));
        else
            assert_true(isnan(ulp(x)));
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_side_by_side_equals_alone),
        cmocka_unit_test(test_segment_of),
        cmocka_unit_test(test_ulp),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
