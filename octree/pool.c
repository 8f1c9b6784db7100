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
    oct_leaf_t *l = &p->leaves[p->nl];
    memset(l, 0, sizeof *l);
    l->code = c.code;
    l->f_lo = F.lo, l->f_hi = F.hi;
    l->depth = (uint8_t)c.depth;
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

/* Concatenate the top pool and the subtrees' pools, then renumber the leaves
 * in Morton order (the order of a depth-first walk with children 0..7). */
int pool_assemble(build_t *b, const pool_t *top, const frontier_t *front, size_t nfront,
                  oct_tree_t *tree)
{
    int with_slabs = build_keeps_slabs(b);
    size_t nn = top->n, nl = top->nl;
    for (size_t i = 0; i < nfront; i++)
        nn += front[i].pool.n, nl += front[i].pool.nl;
    if (nn > 0x3fffffffu || nl > 0x3fffffffu) {
        atomic_store(&b->failed, BUILD_OUT_OF_MEMORY);
        return -1;
    }
    size_t ml = nl ? nl : 1;
    oct_node_t *nodes = malloc(nn * sizeof *nodes);
    oct_leaf_t *staged = malloc(ml * sizeof *staged), *leaves = malloc(ml * sizeof *leaves);
    oct_slab_t *staged_slabs = with_slabs ? malloc(ml * sizeof *staged_slabs) : NULL;
    oct_slab_t *slabs = with_slabs ? malloc(ml * sizeof *slabs) : NULL;
    if (!nodes || !staged || !leaves || (with_slabs && (!staged_slabs || !slabs))) {
        free(nodes), free(staged), free(leaves), free(staged_slabs), free(slabs);
        atomic_store(&b->failed, BUILD_OUT_OF_MEMORY);
        return -1;
    }
    size_t leaf_bytes = sizeof *leaves + (with_slabs ? sizeof *slabs : 0);
    build_account(b, (ptrdiff_t)(nn * sizeof *nodes + 2 * nl * leaf_bytes));

    /* concatenate: the top pool, then each subtree's pool, indices shifted */
    memcpy(nodes, top->nodes, top->n * sizeof *nodes);
    if (top->nl) { /* memcpy from NULL is undefined even for 0 bytes */
        memcpy(staged, top->leaves, top->nl * sizeof *staged);
        if (with_slabs)
            memcpy(staged_slabs, top->slabs, top->nl * sizeof *staged_slabs);
    }
    size_t on = top->n, ol = top->nl;
    for (size_t i = 0; i < nfront; i++) {
        const pool_t *p = &front[i].pool;
        for (size_t j = 0; j < p->n; j++) {
            oct_node_t v = p->nodes[j];
            uint32_t kind = OCT_NODE_KIND(v);
            if (kind == OCT_INTERIOR)
                v = OCT_NODE(kind, OCT_NODE_VALUE(v) + on);
            else if (kind == OCT_LEAF)
                v = OCT_NODE(kind, OCT_NODE_VALUE(v) + ol);
            nodes[on + j] = v;
        }
        if (p->nl) {
            memcpy(staged + ol, p->leaves, p->nl * sizeof *staged);
            if (with_slabs)
                memcpy(staged_slabs + ol, p->slabs, p->nl * sizeof *staged_slabs);
        }
        nodes[front[i].slot] = OCT_NODE(OCT_INTERIOR, (size_t)front[i].base + on);
        on += p->n, ol += p->nl;
    }

    /* leaves in Morton order: depth-first, children in order (at most 7
     * pending siblings per level) */
    uint32_t stack[8 * (OCT_MAX_DEPTH + 2)];
    int sp = 0;
    uint32_t next_leaf = 0;
    stack[sp++] = 0;
    while (sp > 0) {
        uint32_t i = stack[--sp];
        oct_node_t v = nodes[i];
        if (OCT_NODE_KIND(v) == OCT_LEAF) {
            leaves[next_leaf] = staged[OCT_NODE_VALUE(v)];
            if (with_slabs)
                slabs[next_leaf] = staged_slabs[OCT_NODE_VALUE(v)];
            nodes[i] = OCT_NODE(OCT_LEAF, next_leaf++);
        } else if (OCT_NODE_KIND(v) == OCT_INTERIOR) {
            for (int k = 7; k >= 0; k--)
                stack[sp++] = OCT_NODE_VALUE(v) + (uint32_t)k;
        }
    }
    free(staged);
    free(staged_slabs);
    build_account(b, -(ptrdiff_t)(nl * leaf_bytes));
    tree->nodes = nodes;
    tree->n_nodes = (uint32_t)nn;
    tree->leaves = leaves;
    tree->slabs = slabs;
    tree->n_leaves = (uint32_t)nl;
    return 0;
}
