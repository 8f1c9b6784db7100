/* ivoct octree — memory accounting, the node and leaf pools, and the
 * assembly of the pools into one tree.
 *
 * Pools grow by doubling (no allocation per cell), and every allocation is
 * counted against the budget.  Each subtree of the depth-first phase has a
 * pool of its own; assembly concatenates them in frontier order and puts the
 * leaves in Morton order, so the tree does not depend on which thread built
 * which subtree. */
#include <stdlib.h>
#include <string.h>

#include "build_internal.h"

void build_account(build_t *b, ptrdiff_t delta)
{
    size_t now = atomic_fetch_add(&b->bytes, (size_t)delta) + (size_t)delta;
    size_t peak = atomic_load(&b->peak);
    while (now > peak && !atomic_compare_exchange_weak(&b->peak, &peak, now))
        ;
    if (b->max_memory && now > b->max_memory) {
        int expected = 0;
        atomic_compare_exchange_strong(&b->failed, &expected, BUILD_OVER_BUDGET);
    }
}

void *build_grow(build_t *b, void *p, size_t *cap, size_t need, size_t size)
{
    if (need <= *cap)
        return p;
    size_t cap2 = *cap ? *cap : 64;
    while (cap2 < need)
        cap2 *= 2;
    void *q = realloc(p, cap2 * size);
    if (!q) {
        int expected = 0;
        atomic_compare_exchange_strong(&b->failed, &expected, BUILD_OUT_OF_MEMORY);
        return NULL;
    }
    build_account(b, (ptrdiff_t)((cap2 - *cap) * size));
    *cap = cap2;
    return q;
}

long pool_block(build_t *b, pool_t *p)
{
    oct_node_t *q = build_grow(b, p->nodes, &p->cap, p->n + 8, sizeof *q);
    if (!q)
        return -1;
    p->nodes = q;
    p->n += 8;
    return (long)(p->n - 8);
}

int build_keeps_slabs(const build_t *b)
{
    return (b->tests & OCT_TEST_ILIE) && !b->slabs_unused;
}

long pool_leaf(build_t *b, pool_t *p, cell_t c, const decision_t *d)
{
    iv_t F = d->F;
    oct_leaf_t *q = build_grow(b, p->leaves, &p->capl, p->nl + 1, sizeof *q);
    if (!q)
        return -1;
    p->leaves = q;
    if (build_keeps_slabs(b)) {
        oct_slab_t *sl = build_grow(b, p->slabs, &p->caps, p->nl + 1, sizeof *sl);
        if (!sl)
            return -1;
        p->slabs = sl;
        sl[p->nl] = d->slab;
    }
    p->leaves[p->nl] = oct_leaf_make(c.code, c.depth, F.lo, F.hi);
    return (long)p->nl++;
}

void pool_free(build_t *b, pool_t *p)
{
    build_account(b, -(ptrdiff_t)(p->cap * sizeof *p->nodes + p->capl * sizeof *p->leaves +
                            p->caps * sizeof *p->slabs));
    free(p->nodes);
    free(p->leaves);
    free(p->slabs);
    memset(p, 0, sizeof *p);
}

void pool_shrink(build_t *b, pool_t *p)
{
    /* realloc to a smaller size keeps the data; a failure leaves the block */
    oct_node_t *n = p->n && p->n < p->cap ? realloc(p->nodes, p->n * sizeof *n) : NULL;
    if (n) {
        build_account(b, -(ptrdiff_t)((p->cap - p->n) * sizeof *n));
        p->nodes = n, p->cap = p->n;
    }
    oct_leaf_t *l = p->nl && p->nl < p->capl ? realloc(p->leaves, p->nl * sizeof *l) : NULL;
    if (l) {
        build_account(b, -(ptrdiff_t)((p->capl - p->nl) * sizeof *l));
        p->leaves = l, p->capl = p->nl;
    }
    oct_slab_t *sl = p->nl && p->nl < p->caps ? realloc(p->slabs, p->nl * sizeof *sl) : NULL;
    if (sl) {
        build_account(b, -(ptrdiff_t)((p->caps - p->nl) * sizeof *sl));
        p->slabs = sl, p->caps = p->nl;
    }
}

/* The leaves of the tree grow pool by pool, by a quarter at least (so that
 * the assembly's peak stays near one copy of the tree, and the copies of a
 * realloc that cannot remap add up to a few times the array); room for need
 * leaves, at most max.  0 or -1. */
static int grow_leaves(build_t *b, oct_leaf_t **leaves, oct_slab_t **slabs, size_t *cap,
                       size_t need, size_t max)
{
    if (need <= *cap)
        return 0;
    size_t more = *cap + *cap / 4;
    need = need > more ? need : more < max ? more : max;
    oct_leaf_t *l = realloc(*leaves, need * sizeof *l);
    if (!l)
        return -1;
    *leaves = l;
    if (slabs) {
        oct_slab_t *sl = realloc(*slabs, need * sizeof *sl);
        if (!sl)
            return -1;
        *slabs = sl;
    }
    build_account(b, (ptrdiff_t)((need - *cap) * (sizeof *l + (slabs ? sizeof **slabs : 0))));
    *cap = need;
    return 0;
}

/* Concatenate the top pool and the subtrees' pools, then put the leaves in
 * Morton order (the order of a depth-first walk with children 0..7).
 *
 * Memory: each subtree's nodes are freed once copied, and its leaves once
 * the walk has passed them.  The frontier is in Morton order (one level of
 * the breadth-first top phase, children in order), so the walk meets the
 * subtrees' leaves one pool after the other: at the first leaf of pool i,
 * every pool before it is done.  The tree's leaf array grows as the pools
 * go, so the assembly holds little more than one copy of the tree. */
int pool_assemble(build_t *b, pool_t *top, frontier_t *front, size_t nfront, oct_tree_t *tree)
{
    int with_slabs = build_keeps_slabs(b);
    size_t nn = top->n, nl = top->nl;
    for (size_t i = 0; i < nfront; i++)
        nn += front[i].pool.n, nl += front[i].pool.nl;
    if (nn > 0x3fffffffu || nl > 0x3fffffffu) {
        atomic_store(&b->failed, BUILD_OUT_OF_MEMORY);
        return -1;
    }
    oct_node_t *nodes = malloc(nn * sizeof *nodes);
    /* where each pool's leaves start in the staged numbering: top, then pools */
    size_t *first_leaf = malloc((nfront + 2) * sizeof *first_leaf);
    if (!nodes || !first_leaf) {
        free(nodes), free(first_leaf);
        atomic_store(&b->failed, BUILD_OUT_OF_MEMORY);
        return -1;
    }
    build_account(b, (ptrdiff_t)(nn * sizeof *nodes));

    /* concatenate the nodes: the top pool, then each subtree's pool, indices
     * shifted (leaf words in the staged numbering) */
    memcpy(nodes, top->nodes, top->n * sizeof *nodes);
    size_t on = top->n, ol = top->nl;
    first_leaf[0] = 0;
    for (size_t i = 0; i < nfront; i++) {
        pool_t *p = &front[i].pool;
        first_leaf[i + 1] = ol;
        for (size_t j = 0; j < p->n; j++) {
            oct_node_t v = p->nodes[j];
            uint32_t kind = OCT_NODE_KIND(v);
            if (kind == OCT_INTERIOR)
                v = OCT_NODE(kind, OCT_NODE_VALUE(v) + on);
            else if (kind == OCT_LEAF)
                v = OCT_NODE(kind, OCT_NODE_VALUE(v) + ol);
            nodes[on + j] = v;
        }
        nodes[front[i].slot] = OCT_NODE(OCT_INTERIOR, (size_t)front[i].base + on);
        on += p->n, ol += p->nl;
        build_account(b, -(ptrdiff_t)(p->cap * sizeof *p->nodes));
        free(p->nodes);
        p->nodes = NULL, p->n = p->cap = 0;
    }
    first_leaf[nfront + 1] = ol;

    /* leaves in Morton order: depth-first, children in order (at most 7
     * pending siblings per level) */
    oct_leaf_t *leaves = NULL;
    oct_slab_t *slabs = NULL;
    size_t capl = 0, done = 0; /* pools before `done` are freed */
    size_t ml = nl ? nl : 1;
    int failed =
        grow_leaves(b, &leaves, with_slabs ? &slabs : NULL, &capl, top->nl ? top->nl : 1, ml);
    uint32_t stack[8 * (OCT_MAX_DEPTH + 2)];
    int sp = 0;
    uint32_t next_leaf = 0;
    stack[sp++] = 0;
    while (sp > 0 && !failed) {
        uint32_t i = stack[--sp];
        oct_node_t v = nodes[i];
        if (OCT_NODE_KIND(v) == OCT_LEAF) {
            size_t staged = OCT_NODE_VALUE(v);
            const oct_leaf_t *from;
            const oct_slab_t *from_slab;
            if (staged < top->nl) {
                from = &top->leaves[staged];
                from_slab = with_slabs ? &top->slabs[staged] : NULL;
            } else {
                /* the pool that holds it: at or after `done` (Morton order) */
                size_t k = done;
                while (first_leaf[k + 2] <= staged)
                    k++;
                for (; done < k; done++)
                    pool_free(b, &front[done].pool);
                const pool_t *p = &front[k].pool;
                if (grow_leaves(b, &leaves, with_slabs ? &slabs : NULL, &capl,
                                next_leaf + p->nl + top->nl, ml)) {
                    failed = 1;
                    break;
                }
                from = &p->leaves[staged - first_leaf[k + 1]];
                from_slab = with_slabs ? &p->slabs[staged - first_leaf[k + 1]] : NULL;
            }
            leaves[next_leaf] = *from;
            if (with_slabs)
                slabs[next_leaf] = *from_slab;
            nodes[i] = OCT_NODE(OCT_LEAF, next_leaf++);
        } else if (OCT_NODE_KIND(v) == OCT_INTERIOR) {
            for (int k = 7; k >= 0; k--)
                stack[sp++] = OCT_NODE_VALUE(v) + (uint32_t)k;
        }
    }
    free(first_leaf);
    if (failed) {
        free(nodes), free(leaves), free(slabs);
        atomic_store(&b->failed, BUILD_OUT_OF_MEMORY);
        return -1;
    }
    tree->nodes = nodes;
    tree->n_nodes = (uint32_t)nn;
    tree->leaves = leaves;
    tree->slabs = slabs;
    tree->n_leaves = (uint32_t)nl;
    return 0;
}
