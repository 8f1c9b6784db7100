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

/* A depth-first walk's stack: at most 7 pending siblings per level, plus the
 * block being opened. */
#define WALK_STACK (8 * (OCT_MAX_DEPTH + 2))

/* A subtree's pool is built level by level, so its leaves come in
 * breadth-first order; the thread that built it puts them in Morton order,
 * so that the assembly, which runs on one thread, only copies (a walk over
 * every node of the tree there was ~15 % of a 2-thread build). */
int pool_morton(build_t *b, pool_t *p, long base, int untrusted)
{
    if (p->nl == 0 || base < 0)
        return 0;
    int with_slabs = p->slabs != NULL;
    oct_leaf_t *leaves = malloc(p->nl * sizeof *leaves);
    oct_slab_t *slabs = with_slabs ? malloc(p->nl * sizeof *slabs) : NULL;
    unsigned char *seen = untrusted ? calloc((p->nl + 7) / 8, 1) : NULL;
    if (!leaves || (with_slabs && !slabs) || (untrusted && !seen)) {
        free(leaves), free(slabs), free(seen);
        int expected = 0;
        atomic_compare_exchange_strong(&b->failed, &expected, BUILD_OUT_OF_MEMORY);
        return -1;
    }
    build_account(b, (ptrdiff_t)(p->nl * (sizeof *leaves + (with_slabs ? sizeof *slabs : 0))));
    uint32_t stack[WALK_STACK];
    int sp = 0;
    for (int k = 7; k >= 0; k--)
        stack[sp++] = (uint32_t)base + (uint32_t)k;
    /* a pool from elsewhere (oct_plan_put) has valid indices but may reach a
       leaf twice or never, or go deeper than a tree can */
    size_t next = 0;
    int corrupt = 0;
    while (sp > 0 && !corrupt) {
        uint32_t i = stack[--sp];
        oct_node_t v = p->nodes[i];
        if (OCT_NODE_KIND(v) == OCT_LEAF) {
            uint32_t k = OCT_NODE_VALUE(v);
            corrupt = next == p->nl || (seen && seen[k / 8] >> (k % 8) & 1);
            if (seen)
                seen[k / 8] |= (unsigned char)(1u << (k % 8));
            if (!corrupt) {
                leaves[next] = p->leaves[k];
                if (with_slabs)
                    slabs[next] = p->slabs[k];
                p->nodes[i] = OCT_NODE(OCT_LEAF, (uint32_t)next++);
            }
        } else if (OCT_NODE_KIND(v) == OCT_INTERIOR) {
            corrupt = sp + 8 > WALK_STACK;
            for (int k = 7; k >= 0 && !corrupt; k--)
                stack[sp++] = OCT_NODE_VALUE(v) + (uint32_t)k;
        }
    }
    free(seen);
    if (corrupt || next != p->nl) {
        build_account(b, -(ptrdiff_t)(p->nl * (sizeof *leaves + (with_slabs ? sizeof *slabs : 0))));
        free(leaves), free(slabs);
        return -2;
    }
    build_account(b, -(ptrdiff_t)(p->capl * sizeof *p->leaves + p->caps * sizeof *p->slabs));
    free(p->leaves);
    free(p->slabs);
    p->leaves = leaves, p->slabs = slabs;
    p->capl = p->nl, p->caps = with_slabs ? p->nl : 0;
    return 0;
}

/* Concatenate the top pool and the subtrees' pools, leaves in Morton order
 * (the order of a depth-first walk with children 0..7).  A walk over the top
 * pool alone places everything: a leaf above the frontier takes the next
 * number, a subtree's slot the next p->nl numbers (its pool is in Morton
 * order already, pool_morton).  Then each pool is copied with its indices
 * shifted and freed.
 *
 * Memory: the frontier is in Morton order, so the pools' blocks of leaves
 * come in increasing order; the tree's leaf array grows as the pools go and
 * each pool is freed once copied, so the assembly holds little more than one
 * copy of the tree. */
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
    if (nodes)
        build_account(b, (ptrdiff_t)(nn * sizeof *nodes));
    size_t *leaf_at = malloc((nfront ? nfront : 1) * sizeof *leaf_at); /* per pool */
    uint32_t *top_leaf = malloc((top->nl ? top->nl : 1) * sizeof *top_leaf); /* its number */
    uint32_t *slot_of = malloc((top->n ? top->n : 1) * sizeof *slot_of);  /* pool + 1, or 0 */
    oct_leaf_t *leaves = NULL;
    oct_slab_t *slabs = NULL;
    size_t capl = 0, ml = nl ? nl : 1;
    int failed = !nodes || !leaf_at || !top_leaf || !slot_of ||
                 grow_leaves(b, &leaves, with_slabs ? &slabs : NULL, &capl, top->nl ? top->nl : 1, ml);
    if (failed)
        goto out;

    /* the numbering: a depth-first walk of the top pool */
    memset(slot_of, 0, top->n * sizeof *slot_of);
    for (size_t i = 0; i < nfront; i++)
        slot_of[front[i].slot] = (uint32_t)i + 1;
    {
        uint32_t stack[WALK_STACK];
        int sp = 0;
        size_t next = 0;
        if (top->n)
            stack[sp++] = 0;
        while (sp > 0) {
            uint32_t i = stack[--sp];
            oct_node_t v = top->nodes[i];
            if (slot_of[i]) {
                leaf_at[slot_of[i] - 1] = next;
                next += front[slot_of[i] - 1].pool.nl;
            } else if (OCT_NODE_KIND(v) == OCT_LEAF) {
                top_leaf[OCT_NODE_VALUE(v)] = (uint32_t)next++;
            } else if (OCT_NODE_KIND(v) == OCT_INTERIOR) {
                for (int k = 7; k >= 0; k--)
                    stack[sp++] = OCT_NODE_VALUE(v) + (uint32_t)k;
            }
        }
    }

    /* the top pool first (its indices stay), then each subtree's pool */
    for (size_t j = 0; j < top->n; j++) {
        oct_node_t v = top->nodes[j];
        nodes[j] = OCT_NODE_KIND(v) == OCT_LEAF ? OCT_NODE(OCT_LEAF, top_leaf[OCT_NODE_VALUE(v)])
                                                : v;
    }
    size_t on = top->n;
    for (size_t i = 0; i < nfront; i++) {
        pool_t *p = &front[i].pool;
        size_t ol = leaf_at[i];
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
        on += p->n;
        if (p->nl) {
            if (grow_leaves(b, &leaves, with_slabs ? &slabs : NULL, &capl, ol + p->nl, ml)) {
                failed = 1;
                goto out;
            }
            memcpy(leaves + ol, p->leaves, p->nl * sizeof *leaves);
            if (with_slabs)
                memcpy(slabs + ol, p->slabs, p->nl * sizeof *slabs);
        }
        pool_free(b, p);
    }
    if (grow_leaves(b, &leaves, with_slabs ? &slabs : NULL, &capl, ml, ml)) {
        failed = 1;
        goto out;
    }
    for (size_t j = 0; j < top->nl; j++) {
        leaves[top_leaf[j]] = top->leaves[j];
        if (with_slabs)
            slabs[top_leaf[j]] = top->slabs[j];
    }
out:
    free(leaf_at), free(top_leaf), free(slot_of);
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
