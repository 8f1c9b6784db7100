/* The octree does not depend on the number of threads (docs/DESIGN.md §3).
 *
 * Several scenes (among them the CSG union, whose tapes are pruned per cell,
 * and the thin shell, pruned through abs), with the scene's tests and with the
 * whole chain (ILIE slabs, early leaves), are built through the C API with 1,
 * 2 and 3 threads (3 > the cores of a small machine: other interleavings) and
 * twice with 2; each tree is saved with oct_save and the files must be
 * byte-identical.  The statistics that do not measure time or memory must
 * agree too.  The CLI side (ivoct build --threads 1 / 2, compared with cmp)
 * is in tests/test_build_cli.sh. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <cmocka.h>

#include "../octree/octree.h"
#include "../scene/scene.h"
#include "support/testutil.h"

static const char *const SCENES[] = {
    "sphere", "gumdrop", "horned-cube", "csg-64-spheres", "thin-shell", "crosscap", "blobs",
    "steiner-roman",
};

/* The statistics that must not depend on the thread count. */
static void same_counts(const oct_stats_t *a, const oct_stats_t *b)
{
    assert_int_equal(a->cells_visited, b->cells_visited);
    assert_int_equal(a->split, b->split);
    assert_int_equal(a->decided_interval, b->decided_interval);
    assert_int_equal(a->decided_lipschitz, b->decided_lipschitz);
    assert_int_equal(a->decided_ilie, b->decided_ilie);
    assert_int_equal(a->decided_refine, b->decided_refine);
    assert_int_equal(a->decided_max_depth, b->decided_max_depth);
    assert_int_equal(a->tape_clauses_evaluated, b->tape_clauses_evaluated);
    assert_memory_equal(a->leaves_by_depth, b->leaves_by_depth, sizeof a->leaves_by_depth);
    assert_memory_equal(a->cells_by_depth, b->cells_by_depth, sizeof a->cells_by_depth);
    assert_memory_equal(a->split_by_depth, b->split_by_depth, sizeof a->split_by_depth);
    assert_memory_equal(a->tape_length_sum_by_depth, b->tape_length_sum_by_depth,
                        sizeof a->tape_length_sum_by_depth);
    assert_true(a->max_error_bound == b->max_error_bound);
}

static void test_threads(void **state)
{
    (void)state;
    char dir[] = "/tmp/ivoct-determinism-XXXXXX";
    assert_non_null(mkdtemp(dir));
    int depth = tu_sanitizer_build() ? 5 : 6;
    static const int runs[] = {1, 2, 3, 2};
    for (size_t i = 0; i < sizeof SCENES / sizeof *SCENES; i++) {
        scene_t s;
        tu_load_scene(SCENES[i], &s);
        ivoct_error_t err;
        ivoct_error_clear(&err);
        const oct_source_t *src = &s.source;
        double edge = fmax(s.box[1] - s.box[0], fmax(s.box[3] - s.box[2], s.box[5] - s.box[4]));
        /* the scene's tests (interval, lipschitz), then the whole chain with
         * ILIE slabs and early leaves */
        for (int chain = 0; chain < 2; chain++) {
            unsigned tests = chain ? OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ | OCT_TEST_ILIE : s.octree.tests;
            double refine = chain ? 0.02 * edge : 0;
            unsigned char *first = NULL;
            size_t first_n = 0;
            oct_stats_t first_st;
            for (size_t r = 0; r < sizeof runs / sizeof *runs; r++) {
                oct_params_t p = {.depth = depth, .tests = tests, .refine = refine,
                                  .threads = runs[r]};
                oct_tree_t *t;
                if (oct_build(s.tape, s.box, &p, &t, &err) != 0)
                    fail_msg("%s: oct_build: %s", SCENES[i], err.msg);
                assert_int_equal(t->stats.threads, runs[r]);
                char out[4200];
                snprintf(out, sizeof out, "%s/%s-%zu.ivo", dir, SCENES[i], r);
                if (oct_save(t, src, out, &err) != 0)
                    fail_msg("oct_save %s: %s", out, err.msg);
                size_t n;
                unsigned char *bytes = tu_read_file(out, &n);
                if (!first) {
                    first = bytes, first_n = n, first_st = t->stats;
                    printf("%-16s %-16s depth %d: %8u leaves, %9llu cells, %8zu bytes", SCENES[i],
                           chain ? "all, refine" : "scene's tests", depth, t->n_leaves,
                           (unsigned long long)t->stats.cells_visited, n);
                } else {
                    if (n != first_n || memcmp(bytes, first, n) != 0)
                        fail_msg("%s: the tree built with %d threads differs from the one with %d",
                                 SCENES[i], runs[r], runs[0]);
                    same_counts(&first_st, &t->stats);
                    free(bytes);
                }
                remove(out);
                oct_free(t);
            }
            printf(" - identical for 1, 2, 3, 2 threads\n");
            free(first);
        }
        scene_free(&s);
    }
    rmdir(dir);
}

/* slabs_unused only skips work whose result nobody reads: the same nodes and
 * leaves, the same decisions, and no slab array (max_error_bound may grow where
 * only a slab would have made it smaller). */
static void test_slabs_unused(void **state)
{
    (void)state;
    int depth = tu_sanitizer_build() ? 5 : 6;
    for (size_t i = 0; i < sizeof SCENES / sizeof *SCENES; i++) {
        scene_t s;
        tu_load_scene(SCENES[i], &s);
        ivoct_error_t err;
        ivoct_error_clear(&err);
        double edge = fmax(s.box[1] - s.box[0], fmax(s.box[3] - s.box[2], s.box[5] - s.box[4]));
        static const unsigned chains[] = {
            OCT_TEST_INTERVAL | OCT_TEST_ILIE,
            OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ | OCT_TEST_ILIE,
        };
        for (int c = 0; c < 2; c++) {
            for (int with_refine = 0; with_refine < 2; with_refine++) {
                oct_tree_t *t[2];
                for (int unused = 0; unused < 2; unused++) {
                    oct_params_t p = {.depth = depth, .tests = chains[c],
                                      .refine = with_refine ? 0.02 * edge : 0,
                                      .slabs_unused = unused, .threads = 2};
                    if (oct_build(s.tape, s.box, &p, &t[unused], &err) != 0)
                        fail_msg("%s: oct_build: %s", SCENES[i], err.msg);
                }
                assert_non_null(t[0]->slabs);
                assert_null(t[1]->slabs);
                assert_int_equal(t[0]->n_nodes, t[1]->n_nodes);
                assert_int_equal(t[0]->n_leaves, t[1]->n_leaves);
                assert_memory_equal(t[0]->nodes, t[1]->nodes, t[0]->n_nodes * sizeof *t[0]->nodes);
                assert_memory_equal(t[0]->leaves, t[1]->leaves,
                                    t[0]->n_leaves * sizeof *t[0]->leaves);
                const oct_stats_t *a = &t[0]->stats, *b = &t[1]->stats;
                assert_int_equal(a->decided_interval, b->decided_interval);
                assert_int_equal(a->decided_lipschitz, b->decided_lipschitz);
                assert_int_equal(a->decided_ilie, b->decided_ilie);
                assert_int_equal(a->decided_refine, b->decided_refine);
                /* without slabs a leaf at the max depth on a single-use tape
                 * has its diagonal as bound, never less than its slab's */
                if (with_refine)
                    assert_true(a->max_error_bound == b->max_error_bound);
                else
                    assert_true(a->max_error_bound <= b->max_error_bound);
                assert_true(b->tape_clauses_evaluated <= a->tape_clauses_evaluated);
                oct_free(t[0]);
                oct_free(t[1]);
            }
        }
        scene_free(&s);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_threads),
        cmocka_unit_test(test_slabs_unused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
