/* The build in parts (oct_plan_*, octree.h): what the build over MPI rests on.
 *
 * For several scenes (the CSG union and the thin shell among them: tapes
 * pruned on the way down) and both chains (the scene's tests; the whole chain
 * with slabs and early leaves), the subtrees of the frontier are spread over
 * three plans (every third one, as three ranks might), built there, moved into
 * one plan with oct_plan_get / oct_plan_put and put together: the tree is
 * oct_build's node for node, leaf for leaf, slab for slab, and its counts are
 * the same.  The three plans' parts (OCT_PLAN_PART, the top's leaves in the
 * first only) hold between them every leaf of the tree exactly once, and their
 * counts add up to the tree's.  A subtree with an index out of range is
 * refused by oct_plan_put; a finish with a subtree missing is an error.
 *
 * The finished subtrees are stored in chunks that many subtrees share and
 * that are freed with the last of them (octree/pool.c): a tree deep enough to
 * fill several chunks is the same built on one thread, on two, and one
 * subtree per oct_plan_build call in reverse order (each call closes its
 * chunks, so every subtree has one of its own, freed in another order than
 * made); its peak memory stays within twice its storage. */
#define _POSIX_C_SOURCE 200809L
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

static const char *const SCENES[] = {"sphere", "gumdrop", "csg-64-spheres", "thin-shell",
                                     "crosscap", "horned-cube"};

static int by_key(const void *a, const void *b)
{
    const oct_leaf_t *x = a, *y = b;
    return x->key < y->key ? -1 : x->key > y->key;
}

static void check_scene(const char *name, int chain)
{
    scene_t s;
    tu_load_scene(name, &s);
    ivoct_error_t err;
    ivoct_error_clear(&err);
    double edge = fmax(s.box[1] - s.box[0], fmax(s.box[3] - s.box[2], s.box[5] - s.box[4]));
    oct_params_t p = {.depth = tu_sanitizer_build() ? 5 : 6, .tests = s.octree.tests, .threads = 2};
    if (chain)
        p.tests = OCT_TEST_INTERVAL | OCT_TEST_LIPSCHITZ | OCT_TEST_ILIE, p.refine = 0.02 * edge;
    oct_tree_t *whole;
    if (oct_build(s.tape, s.box, &p, &whole, &err))
        fail_msg("%s: oct_build: %s", name, err.msg);

    enum { PARTS = 3 };
    oct_plan_t *plan[PARTS];
    for (int k = 0; k < PARTS; k++)
        if (oct_plan_new(s.tape, s.box, &p, &plan[k], &err))
            fail_msg("%s: oct_plan_new: %s", name, err.msg);
    size_t n = oct_plan_subtrees(plan[0]);
    assert_true(n >= 256 || n == 0);
    size_t *which = malloc((n + 1) * sizeof *which);
    for (int k = 0; k < PARTS; k++) {
        assert_int_equal(oct_plan_subtrees(plan[k]), n);
        size_t m = 0;
        for (size_t i = (size_t)k; i < n; i += PARTS)
            which[m++] = i;
        if (oct_plan_build(plan[k], which, m, &err))
            fail_msg("%s: oct_plan_build: %s", name, err.msg);
    }
    for (size_t i = 1; i < n; i++)
        assert_true(oct_plan_subtree_code(plan[0], i) > oct_plan_subtree_code(plan[0], i - 1));

    /* everything into one more plan: the tree of oct_build */
    oct_plan_t *all;
    if (oct_plan_new(s.tape, s.box, &p, &all, &err))
        fail_msg("%s: oct_plan_new: %s", name, err.msg);
    for (size_t i = 0; i < n; i++) {
        oct_subtree_t st;
        assert_int_equal(oct_plan_get(plan[i % PARTS], i, &st), 0);
        assert_int_equal(oct_plan_get(plan[(i + 1) % PARTS], i, &st), -1);
        assert_int_equal(oct_plan_get(plan[i % PARTS], i, &st), 0);
        /* every other subtree with its leaves in reverse order: a subtree from
           elsewhere may come in any order, and the tree is the same */
        oct_node_t *rn = NULL;
        oct_leaf_t *rl = NULL;
        oct_slab_t *rs = NULL;
        if (i % 2 && st.n_leaves > 1) {
            uint32_t nl = st.n_leaves;
            rn = malloc(st.n_nodes * sizeof *rn);
            rl = malloc(nl * sizeof *rl);
            rs = st.slabs ? malloc(nl * sizeof *rs) : NULL;
            for (uint32_t j = 0; j < st.n_nodes; j++)
                rn[j] = OCT_NODE_KIND(st.nodes[j]) == OCT_LEAF
                            ? OCT_NODE(OCT_LEAF, nl - 1 - OCT_NODE_VALUE(st.nodes[j]))
                            : st.nodes[j];
            for (uint32_t j = 0; j < nl; j++) {
                rl[j] = st.leaves[nl - 1 - j];
                if (rs)
                    rs[j] = st.slabs[nl - 1 - j];
            }
            st.nodes = rn, st.leaves = rl, st.slabs = rs;
        }
        if (oct_plan_put(all, i, &st, &err))
            fail_msg("%s: oct_plan_put: %s", name, err.msg);
        free(rn), free(rl), free(rs);
    }
    if (n > 0) {
        /* a missing subtree is an error, a corrupt one is refused */
        oct_tree_t *none;
        oct_plan_t *empty;
        assert_int_equal(oct_plan_new(s.tape, s.box, &p, &empty, &err), 0);
        assert_int_not_equal(oct_plan_finish(empty, 0, &none, &err), 0);
        assert_null(none);
        oct_subtree_t st;
        assert_int_equal(oct_plan_get(plan[0], 0, &st), 0);
        oct_node_t *bad = malloc(st.n_nodes * sizeof *bad);
        memcpy(bad, st.nodes, st.n_nodes * sizeof *bad);
        bad[st.base] = OCT_NODE(OCT_LEAF, st.n_leaves + 5);
        oct_subtree_t corrupt = st;
        corrupt.nodes = bad;
        assert_int_not_equal(oct_plan_put(empty, 0, &corrupt, &err), 0);
        /* valid indices, but a leaf reached twice and another never */
        memcpy(bad, st.nodes, st.n_nodes * sizeof *bad);
        uint32_t first = UINT32_MAX, second = UINT32_MAX;
        for (uint32_t j = 0; j < st.n_nodes && second == UINT32_MAX; j++)
            if (OCT_NODE_KIND(bad[j]) == OCT_LEAF)
                *(first == UINT32_MAX ? &first : &second) = j;
        if (second != UINT32_MAX) {
            bad[second] = bad[first];
            ivoct_error_clear(&err);
            assert_int_not_equal(oct_plan_put(empty, 0, &corrupt, &err), 0);
            assert_non_null(strstr(err.msg, "corrupt"));
            assert_int_equal(oct_plan_has(empty, 0), 0);
        }
        free(bad);
        oct_plan_free(empty);
    }
    oct_tree_t *joined;
    if (oct_plan_finish(all, 0, &joined, &err))
        fail_msg("%s: oct_plan_finish: %s", name, err.msg);
    assert_int_equal(joined->n_nodes, whole->n_nodes);
    assert_int_equal(joined->n_leaves, whole->n_leaves);
    assert_memory_equal(joined->nodes, whole->nodes, whole->n_nodes * sizeof *whole->nodes);
    if (whole->n_leaves)
        assert_memory_equal(joined->leaves, whole->leaves, whole->n_leaves * sizeof *whole->leaves);
    assert_int_equal(joined->slabs != NULL, whole->slabs != NULL);
    if (whole->slabs && whole->n_leaves)
        assert_memory_equal(joined->slabs, whole->slabs, whole->n_leaves * sizeof *whole->slabs);
    assert_int_equal(joined->stats.cells_visited, whole->stats.cells_visited);
    assert_int_equal(joined->stats.split, whole->stats.split);
    assert_int_equal(joined->stats.tape_clauses_evaluated, whole->stats.tape_clauses_evaluated);
    assert_memory_equal(joined->stats.leaves_by_depth, whole->stats.leaves_by_depth,
                        sizeof whole->stats.leaves_by_depth);
    assert_true(joined->stats.max_error_bound == whole->stats.max_error_bound);

    /* the parts: every leaf once, the counts adding up */
    oct_leaf_t *seen = malloc((whole->n_leaves + 1) * sizeof *seen);
    size_t nseen = 0;
    uint64_t cells = 0, leaves_d[OCT_MAX_DEPTH + 1] = {0};
    for (int k = 0; k < PARTS; k++) {
        oct_tree_t *part;
        unsigned flags = OCT_PLAN_PART | (k ? OCT_PLAN_NO_TOP : 0u);
        if (oct_plan_finish(plan[k], flags, &part, &err))
            fail_msg("%s: part %d: %s", name, k, err.msg);
        assert_true(nseen + part->n_leaves <= whole->n_leaves);
        memcpy(seen + nseen, part->leaves, part->n_leaves * sizeof *seen);
        nseen += part->n_leaves;
        cells += part->stats.cells_visited;
        for (int d = 0; d <= OCT_MAX_DEPTH; d++)
            leaves_d[d] += part->stats.leaves_by_depth[d];
        oct_free(part);
        oct_plan_free(plan[k]);
    }
    assert_int_equal(nseen, whole->n_leaves);
    /* the same set: both sorted by key (Morton order within a depth) */
    oct_leaf_t *ref = malloc((nseen + 1) * sizeof *ref);
    if (nseen)
        memcpy(ref, whole->leaves, nseen * sizeof *ref);
    qsort(seen, nseen, sizeof *seen, by_key);
    qsort(ref, nseen, sizeof *ref, by_key);
    if (nseen)
        assert_memory_equal(seen, ref, nseen * sizeof *seen);
    free(ref);
    assert_int_equal(cells, whole->stats.cells_visited);
    assert_memory_equal(leaves_d, whole->stats.leaves_by_depth, sizeof leaves_d);
    free(seen);
    free(which);
    oct_free(joined);
    oct_plan_free(all);
    oct_free(whole);
    scene_free(&s);
}

static void assert_same_tree(const oct_tree_t *a, const oct_tree_t *b)
{
    assert_int_equal(a->n_nodes, b->n_nodes);
    assert_int_equal(a->n_leaves, b->n_leaves);
    assert_memory_equal(a->nodes, b->nodes, b->n_nodes * sizeof *b->nodes);
    assert_memory_equal(a->leaves, b->leaves, b->n_leaves * sizeof *b->leaves);
}

static void test_chunks(void **state)
{
    (void)state;
    scene_t s;
    tu_load_scene("gumdrop", &s);
    ivoct_error_t err;
    ivoct_error_clear(&err);
    /* depth 8: ~5 MB of leaves and nodes, past the first chunks (2, 4 MiB) */
    oct_params_t p = {.depth = 8, .tests = OCT_TEST_INTERVAL, .threads = 1};
    oct_tree_t *one, *two, *pieces;
    if (oct_build(s.tape, s.box, &p, &one, &err))
        fail_msg("oct_build: %s", err.msg);
    size_t storage = one->n_nodes * sizeof *one->nodes + one->n_leaves * sizeof *one->leaves;
    assert_true(storage > ((size_t)6 << 20));
    assert_true(one->stats.peak_bytes >= storage && one->stats.peak_bytes <= 2 * storage);
    p.threads = 2;
    if (oct_build(s.tape, s.box, &p, &two, &err))
        fail_msg("oct_build: %s", err.msg);
    assert_same_tree(two, one);
    assert_true(two->stats.peak_bytes <= 2 * storage);

    oct_plan_t *plan;
    if (oct_plan_new(s.tape, s.box, &p, &plan, &err))
        fail_msg("oct_plan_new: %s", err.msg);
    size_t n = oct_plan_subtrees(plan);
    assert_true(n >= 256);
    for (size_t k = n; k-- > 0;)
        if (oct_plan_build(plan, &k, 1, &err))
            fail_msg("oct_plan_build %zu: %s", k, err.msg);
    if (oct_plan_finish(plan, 0, &pieces, &err))
        fail_msg("oct_plan_finish: %s", err.msg);
    assert_same_tree(pieces, one);
    oct_plan_free(plan);
    oct_free(pieces);
    oct_free(two);
    oct_free(one);
    scene_free(&s);
}

static void test_parts(void **state)
{
    (void)state;
    for (size_t i = 0; i < sizeof SCENES / sizeof *SCENES; i++)
        for (int chain = 0; chain < 2; chain++)
            check_scene(SCENES[i], chain);
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_parts), cmocka_unit_test(test_chunks)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
