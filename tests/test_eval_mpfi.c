/* Property test of the tape evaluators against an MPFI oracle, on every scene.
 *
 * For each scene file: random sub-boxes of the scene box (sizes from the whole
 * box down to 2^-30 of it), evaluated in batches with tape_eval_interval and
 * tape_eval_grad; random points inside each box evaluated in MPFI at 256 bits.
 * Property: the MPFI value lies in the double enclosure of the box, and the
 * MPFI gradient lies in the gradient enclosure. */
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

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_scene),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
