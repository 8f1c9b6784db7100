/* Property test of the tape evaluators against an MPFI oracle, on every scene.
 *
 * For each scene file: random sub-boxes of the scene box (sizes from the whole
 * box down to 2^-30 of it), evaluated in batches with tape_eval_interval and
 * tape_eval_grad; random points inside each box evaluated in MPFI at 256 bits.
 * Property: the MPFI value lies in the double enclosure of the box, and the
 * MPFI gradient lies in the gradient enclosure.  And the plain double point +
 * gradient evaluator (tape_eval_point_grad) at random points: its value and
 * partials within twice the width of the rigorous enclosure at the point of
 * MPFI's (oracle_check_point_grad). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include <cmocka.h>

#include "../scene/scene.h"
#include "support/mpfi_tape.h"
#include "support/testutil.h"

#define BOXES_PER_SCENE 10000
#define POINTS_PER_BOX 2
#define GRAD_POINTS_PER_SCENE 4000

static void check_scene(const char *path, uint64_t *rng)
{
    scene_t s;
    tu_load_scene(path, &s);
    long nbox = (long)(BOXES_PER_SCENE * tu_scale());
    oracle_stats_t st;
    if (oracle_check_tape(s.tape, s.box, nbox, POINTS_PER_BOX, rng, &st) != 0)
        fail_msg("%s: %s", path, st.failure);
    printf("%-40s %6ld points checked, %6ld gradients, %5ld skipped (undefined)\n", path,
           st.checked, st.checked_grad, st.skipped);
    /* the test must not be vacuous: most points of every scene are defined */
    assert_true(st.checked >= (long)(0.9 * nbox * POINTS_PER_BOX));
    assert_true(st.checked_grad >= (long)(0.5 * nbox * POINTS_PER_BOX));
    long npts = (long)(GRAD_POINTS_PER_SCENE * tu_scale());
    if (oracle_check_point_grad(s.tape, s.box, npts, rng, &st) != 0)
        fail_msg("%s: point gradient: %s", path, st.failure);
    printf("%-40s %6ld point gradients checked, %6ld partials, %5ld skipped\n", path, st.checked,
           st.checked_grad, st.skipped);
    assert_true(st.checked >= (long)(0.5 * npts));
    scene_free(&s);
}

static void test_every_scene(void **state)
{
    (void)state;
    char **paths;
    int n = tu_scene_files(&paths);
    uint64_t rng = tu_seed(20261122);
    for (int i = 0; i < n; i++)
        check_scene(paths[i], &rng);
    tu_free_list(paths, n);
}

/* Every op (tu_op_exprs) on the three op boxes, from 1e-3 to 1e3: the point +
 * gradient evaluator's value and partials against the oracle (the interval
 * evaluators' enclosure of every op is test_interval_mpfi's and
 * test_eval_ray_mpfi's). */
static void test_point_grad_every_op(void **state)
{
    (void)state;
    uint64_t rng = tu_seed(20261204);
    long npts = (long)(600 * tu_scale()), checked = 0, partials = 0, tried = 0;
    for (size_t e = 0; e < tu_n_op_exprs; e++) {
        tape_t *t = tu_compile(tu_op_exprs[e]);
        for (size_t b = 0; b < TU_N_OP_BOXES; b++) {
            oracle_stats_t st;
            if (oracle_check_point_grad(t, tu_op_boxes[b], npts, &rng, &st) != 0)
                fail_msg("\"%s\" on box %zu: %s", tu_op_exprs[e], b, st.failure);
            checked += st.checked, partials += st.checked_grad, tried += npts;
        }
        tape_free(t);
    }
    printf("point gradients of every op: %ld points checked, %ld partials, of %ld\n", checked,
           partials, tried);
    /* not vacuous: the ops' domains (log, sqrt, real powers) leave most points */
    assert_true(checked >= tried / 2 && partials >= checked);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_scene),
        cmocka_unit_test(test_point_grad_every_op),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
