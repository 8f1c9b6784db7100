/* Build statistics: consistent with each other and with the tree they describe;
 * tape pruning measured on the CSG union of 64 spheres.
 *
 * For every scene at depth 5 (4 under IVOCT_ASAN), with "interval",
 * "interval,lipschitz", "interval,lipschitz,ilie" without and with refine
 * (2% of the box's edge), 1 and 2 threads:
 *   leaves = n_leaves = sum of leaves_by_depth = decided max_depth + refine;
 *   decided interval + lipschitz + ilie + refine + max_depth = cells_visited - split;
 *   cells_visited = 1 + 8 split = n_nodes = sum of cells_by_depth;
 *   per depth, from a walk of the nodes: cells, split and leaves counted in
 *   the tree equal cells_by_depth, split_by_depth, leaves_by_depth, and the
 *   empty nodes equal the cells decided by a test;
 *   cells_by_depth[d + 1] = 8 split_by_depth[d];
 *   no test that is off decides anything; without refine every leaf is at
 *   the max depth; trees have slabs exactly when ilie ran;
 *   tape pruning never lengthens a tape: tape_length_sum_by_depth[d] <=
 *   split_by_depth[d] * n, with equality when the tape has no min/max/abs;
 *   with "interval" alone and no choices, every visited cell costs one pass
 *   over the whole tape: tape_clauses_evaluated = cells_visited * n;
 *   every leaf's F interval holds 0 (an interval-test survivor);
 *   max_error_bound is the largest oct_leaf_error_bound, and without ilie the
 *   diagonal of a max-depth cell (up to rounding);
 *   threads is what was asked for; peak_bytes covers the tree's storage.
 *
 * Tape pruning (libfive, docs/DESIGN.md §5: "~300 clauses at the root to about 10 by depth 4"):
 * on scenes/csg-64-spheres.ini the mean tape length of the cells split at
 * depth 4 must be below 1/5 of the root's.  The per-depth means are printed. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "../octree/octree.h"
#include "../scene/scene.h"
#include "support/testutil.h"

static oct_tree_t *build(const scene_t *s, int depth, unsigned tests, double refine, int threads)
{
    oct_params_t p = {.depth = depth, .tests = tests, .refine = refine, .threads = threads};
    oct_tree_t *t;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    if (oct_build(s->tape, s->box, &p, &t, &err) != 0)
        fail_msg("oct_build: %s", err.msg);
    return t;
}

/* Count cells, splits, leaves and empty cells per depth by walking the nodes. */
typedef struct counts {
    uint64_t cells[OCT_MAX_DEPTH + 1], split[OCT_MAX_DEPTH + 1], leaves[OCT_MAX_DEPTH + 1];
    uint64_t empty;
} counts_t;

static void walk(const oct_tree_t *t, counts_t *c)
{
    memset(c, 0, sizeof *c);
    struct {
        uint32_t node;
        int depth;
    } stack[8 * (OCT_MAX_DEPTH + 2)];
    int sp = 0;
    stack[sp].node = 0, stack[sp].depth = 0, sp++;
    while (sp > 0) {
        sp--;
        uint32_t i = stack[sp].node;
        int d = stack[sp].depth;
        assert_true(i < t->n_nodes);
        assert_true(d <= t->depth);
        oct_node_t v = t->nodes[i];
        c->cells[d]++;
        switch (OCT_NODE_KIND(v)) {
        case OCT_INTERIOR:
            c->split[d]++;
            assert_true(OCT_NODE_VALUE(v) + 8 <= t->n_nodes);
            for (int k = 0; k < 8; k++) {
                stack[sp].node = OCT_NODE_VALUE(v) + (uint32_t)k;
                stack[sp].depth = d + 1;
                sp++;
            }
            break;
        case OCT_LEAF:
            assert_true(OCT_NODE_VALUE(v) < t->n_leaves);
            c->leaves[d]++;
            break;
        case OCT_EMPTY:
            c->empty++;
            break;
        default:
            fail_msg("bad node kind");
        }
    }
}

static void check_stats(const char *name, const scene_t *s, const oct_tree_t *t, unsigned tests,
                        int threads)
{
    const oct_stats_t *st = &t->stats;
    uint32_t n = s->tape->n;
    uint64_t sum_leaves = 0, sum_cells = 0, sum_split = 0;
    for (int d = 0; d <= OCT_MAX_DEPTH; d++) {
        sum_leaves += st->leaves_by_depth[d];
        sum_cells += st->cells_by_depth[d];
        sum_split += st->split_by_depth[d];
    }
    assert_int_equal(sum_leaves, t->n_leaves);
    assert_int_equal(st->decided_max_depth + st->decided_refine, t->n_leaves);
    assert_int_equal(st->decided_interval + st->decided_lipschitz + st->decided_ilie +
                         st->decided_refine + st->decided_max_depth,
                     st->cells_visited - st->split);
    assert_int_equal(st->cells_visited, 1 + 8 * st->split);
    assert_int_equal(st->cells_visited, t->n_nodes);
    assert_int_equal(sum_cells, st->cells_visited);
    assert_int_equal(sum_split, st->split);

    counts_t c;
    walk(t, &c);
    for (int d = 0; d <= OCT_MAX_DEPTH; d++) {
        assert_int_equal(c.cells[d], st->cells_by_depth[d]);
        assert_int_equal(c.split[d], st->split_by_depth[d]);
        assert_int_equal(c.leaves[d], st->leaves_by_depth[d]);
        if (d < OCT_MAX_DEPTH)
            assert_int_equal(st->cells_by_depth[d + 1], 8 * st->split_by_depth[d]);
        if (d > t->depth)
            assert_int_equal(st->cells_by_depth[d], 0);
    }
    assert_int_equal(c.empty, st->decided_interval + st->decided_lipschitz + st->decided_ilie);

    if (!(tests & OCT_TEST_LIPSCHITZ))
        assert_int_equal(st->decided_lipschitz, 0);
    if (!(tests & OCT_TEST_ILIE)) {
        assert_int_equal(st->decided_ilie, 0);
        assert_null(t->slabs);
    } else {
        assert_non_null(t->slabs);
    }
    if (!(t->refine > 0)) {
        /* no early leaves: every leaf at the max depth */
        assert_int_equal(st->decided_refine, 0);
        assert_int_equal(st->leaves_by_depth[t->depth], t->n_leaves);
    }

    int choices = tape_has_choices(s->tape);
    for (int d = 0; d <= OCT_MAX_DEPTH; d++) {
        assert_true(st->tape_length_sum_by_depth[d] <= st->split_by_depth[d] * n);
        if (!choices)
            assert_int_equal(st->tape_length_sum_by_depth[d], st->split_by_depth[d] * n);
    }
    if (!choices && tests == OCT_TEST_INTERVAL)
        assert_int_equal(st->tape_clauses_evaluated, st->cells_visited * n);
    else
        assert_true(st->tape_clauses_evaluated >= st->cells_visited);

    for (uint32_t i = 0; i < t->n_leaves; i++) {
        const oct_leaf_t *l = &t->leaves[i];
        if (!(l->f_lo <= 0 && 0 <= l->f_hi))
            fail_msg("%s: leaf %u has F = [%g, %g] without 0", name, i, l->f_lo, l->f_hi);
    }

    /* the largest error bound is that of some leaf; without slabs, a leaf's
     * is its diagonal, the same for every max-depth leaf */
    double worst = 0;
    for (uint32_t i = 0; i < t->n_leaves; i++) {
        double e = oct_leaf_error_bound(t, i);
        assert_true(e >= 0);
        if (e > worst)
            worst = e;
    }
    assert_true(st->max_error_bound == worst);
    if (t->n_leaves > 0 && !(tests & OCT_TEST_ILIE)) {
        double e[3];
        for (int a = 0; a < 3; a++)
            e[a] = (s->box[2 * a + 1] - s->box[2 * a]) / (double)(1u << t->depth);
        double diag = sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
        assert_true(st->max_error_bound >= diag * (1 - 1e-6));
        assert_true(st->max_error_bound <= diag * (1 + 1e-6));
    }
    assert_int_equal(st->threads, threads);
    size_t storage = (size_t)t->n_nodes * sizeof *t->nodes + (size_t)t->n_leaves * sizeof *t->leaves;
    assert_true(st->peak_bytes >= storage);
    assert_true(st->time_s >= 0 && st->time_s < 600);
}

static void test_every_scene(void **state)
{
    (void)state;
    char **paths;
    int n = tu_scene_files(&paths);
    int depth = tu_sanitizer_build() ? 4 : 5;
    for (int i = 0; i < n; i++) {
        scene_t s;
        tu_load_scene(paths[i], &s);
        static const unsigned configs[3] = {
            OCT_TEST_INTERVAL, OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ,
            OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ | OCT_TEST_ILIE};
        double edge = fmax(s.box[1] - s.box[0], fmax(s.box[3] - s.box[2], s.box[5] - s.box[4]));
        uint64_t visited[4][2];
        for (int c = 0; c < 4; c++)
            for (int th = 1; th <= 2; th++) {
                /* c = 3: the whole chain with early leaves */
                unsigned tests = configs[c < 3 ? c : 2];
                oct_tree_t *t = build(&s, depth, tests, c == 3 ? 0.02 * edge : 0, th);
                check_stats(paths[i], &s, t, tests, th);
                visited[c][th - 1] = t->stats.cells_visited;
                oct_free(t);
            }
        /* the counts do not depend on the thread count; each test added only
         * ever removes cells, and so do early leaves */
        for (int c = 0; c < 4; c++)
            assert_int_equal(visited[c][0], visited[c][1]);
        for (int c = 1; c < 4; c++)
            assert_true(visited[c][0] <= visited[c - 1][0]);
        scene_free(&s);
    }
    tu_free_list(paths, n);
}

/* Edge cases: depth 0 (the root is the only cell) and a surface that does not
 * meet the box (the root is decided empty). */
static void test_edge_trees(void **state)
{
    (void)state;
    tape_t *tape;
    ivoct_error_t err;
    ivoct_error_clear(&err);
    assert_int_equal(tape_compile("x^2 + y^2 + z^2 - 1", &tape, &err), 0);
    scene_t s = {0};
    s.tape = tape;
    double box[6] = {-2, 2, -2, 2, -2, 2};
    memcpy(s.box, box, sizeof box);

    oct_tree_t *t = build(&s, 0, OCT_TEST_INTERVAL, 0, 1);
    assert_int_equal(t->n_leaves, 1);
    assert_int_equal(t->n_nodes, 1);
    assert_int_equal(t->stats.split, 0);
    check_stats("depth 0", &s, t, OCT_TEST_INTERVAL, 1);
    oct_free(t);

    double far[6] = {3, 4, 3, 4, 3, 4};
    memcpy(s.box, far, sizeof far);
    t = build(&s, 6, OCT_TEST_INTERVAL, 0, 2);
    assert_int_equal(t->n_leaves, 0);
    assert_int_equal(t->n_nodes, 1);
    assert_int_equal(OCT_NODE_KIND(t->nodes[0]), OCT_EMPTY);
    assert_int_equal(OCT_NODE_VALUE(t->nodes[0]), OCT_OUTSIDE);
    check_stats("empty root", &s, t, OCT_TEST_INTERVAL, 2);
    oct_free(t);
    tape_free(tape);
}

static void test_tape_pruning(void **state)
{
    (void)state;
    char path[4096];
    snprintf(path, sizeof path, "%s/scenes/csg-64-spheres.ini", tu_source_dir());
    scene_t s;
    tu_load_scene(path, &s);
    assert_true(tape_has_choices(s.tape));
    int depth = 6;
    oct_tree_t *t = build(&s, depth, OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ, 0, 2);
    check_stats(path, &s, t, OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ, 2);
    const oct_stats_t *st = &t->stats;
    printf("CSG 64 spheres: the tape has %u clauses; mean tape length of the cells split, by depth:\n",
           s.tape->n);
    double mean[OCT_MAX_DEPTH + 1] = {0};
    for (int d = 0; d < depth; d++) {
        assert_true(st->split_by_depth[d] > 0);
        mean[d] = (double)st->tape_length_sum_by_depth[d] / (double)st->split_by_depth[d];
        printf("  depth %d: %8llu cells split, mean tape %7.2f clauses\n", d,
               (unsigned long long)st->split_by_depth[d], mean[d]);
    }
    printf("  depth 4 / root = %.3f (must be < 0.2)\n", mean[4] / mean[0]);
    assert_true(mean[0] <= s.tape->n);
    assert_true(mean[4] < mean[0] / 5);
    oct_free(t);
    scene_free(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_scene),
        cmocka_unit_test(test_edge_trees),
        cmocka_unit_test(test_tape_pruning),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
