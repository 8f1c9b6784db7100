/* ivoct octree — memory accounting, the node and leaf pools, and the
 * assembly of the pools into one tree.
 *
 * Pools grow by doubling (no allocation per cell), and every allocation is
 * counted against the budget.  Each subtree of the second phase is built in
 * its worker's pool and then copied to arrays of its own, leaves in Morton
 * order (pool_morton); assembly concatenates those in frontier order, so the
 * tree does not depend on which thread built which subtree. */
#include <stdlib.h>
#include <string.h>

#include "build_internal.h"
#include "../mem/mem.h"

/* The subtrees' arrays, written once each when a subtree is done
 * (pool_morton), are carved from chunks rather than malloc'd one by one: a
 * subtree's arrays are a few hundred kilobytes, too small for a huge page of
 * their own, and together they are as large as the tree.  A chunk is
 * 2 MiB-aligned with huge pages asked for (mem/mem.h), and twice as large as
 * the one before it, from 2 MiB up to ARENA_CHUNK (a small build stays small); one
 * worker fills it; it is freed when the last pool in it is freed and no
 * worker fills it any more.  The budget counts the bytes of the pools, not
 * of the chunks' unused ends.
 *
 * The assembly frees the pools one by one as it copies them into the tree,
 * in frontier order, which is the order a chunk was filled in (or its
 * reverse, when subtrees were built in reverse): the freed room grows from
 * one end of the chunk, and each 2 MiB page it covers wholly goes back to the
 * system at once (mem_release), not when the whole chunk is freed.  The
 * tree's own fresh pages, touched by the same copies, are then those pages
 * again: on a virtual machine, pages the host supplies anew cost ~20 times
 * more than pages the guest gives back and takes again (mem/mem.h). */
#define ARENA_ALIGN ((size_t)2 << 20)
#define ARENA_CHUNK ((size_t)32 << 20)

struct arena_chunk {
    size_t size, used; /* bytes, this header included */
    size_t live;       /* pools in it not yet freed */
    int open;          /* a worker still fills it */
    size_t low;        /* the pools below this offset are freed */
    size_t kept_lo, kept_hi; /* the pages outside [kept_lo, kept_hi) are released
                                (never the first, which holds this header) */
};

static size_t round_up(size_t n, size_t to) { return (n + to - 1) / to * to; }

static void chunk_release(arena_chunk_t *c)
{
    if (c && !c->open && !c->live)
        free(c);
}

void arena_close(arena_chunk_t **cur)
{
    if (*cur) {
        (*cur)->open = 0;
        chunk_release(*cur);
        *cur = NULL;
    }
}

/* bytes (a multiple of 64) from the worker's chunk *cur, or a new one; NULL
 * when out of memory. */
static char *arena_take(arena_chunk_t **cur, size_t bytes)
{
    const size_t head = round_up(sizeof(arena_chunk_t), 64);
    arena_chunk_t *c = *cur;
    if (!c || c->size - c->used < bytes) {
        size_t size = c ? 2 * c->size : ARENA_ALIGN;
        if (size > ARENA_CHUNK)
            size = ARENA_CHUNK;
        size = round_up(head + bytes > size ? head + bytes : size, ARENA_ALIGN);
        c = aligned_alloc(ARENA_ALIGN, size);
        if (!c)
            return NULL;
        mem_huge_advise(c, size);
        *c = (arena_chunk_t){size, head, 0, 1, head, ARENA_ALIGN, size};
        arena_close(cur);
        *cur = c;
    }
    char *p = (char *)c + c->used;
    c->used += bytes;
    return p;
}

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
    void *q = mem_huge_realloc(p, cap2 * size);
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

/* The bytes of a pool carved from a chunk (pool_morton's layout). */
static size_t pool_bytes(const pool_t *p)
{
    return round_up(p->cap * sizeof *p->nodes, 64) + round_up(p->capl * sizeof *p->leaves, 64) +
           round_up(p->caps * sizeof *p->slabs, 64);
}

/* The pool at [at, at + bytes) of closed chunk c was freed: when it was the
 * lowest or the highest live one, the live room shrinks, and the pages no
 * longer in it go back to the system (the page holding the header stays).
 * A pool freed from the middle only waits for the chunk's free. */
static void chunk_shrink(arena_chunk_t *c, size_t at, size_t bytes)
{
    if (at == c->low)
        c->low = at + bytes;
    else if (at + bytes == c->used)
        c->used = at;
    else
        return;
    size_t lo = c->low / ARENA_ALIGN * ARENA_ALIGN, hi = round_up(c->used, ARENA_ALIGN);
    if (lo > c->kept_lo) {
        mem_release((char *)c + c->kept_lo, lo - c->kept_lo);
        c->kept_lo = lo;
    }
    if (hi < c->kept_hi && hi >= c->kept_lo) {
        mem_release((char *)c + hi, c->kept_hi - hi);
        c->kept_hi = hi;
    }
}

void pool_free(build_t *b, pool_t *p)
{
    build_account(b, -(ptrdiff_t)(p->cap * sizeof *p->nodes + p->capl * sizeof *p->leaves +
                            p->caps * sizeof *p->slabs));
    if (p->chunk) {
        arena_chunk_t *c = p->chunk;
        c->live--;
        if (!c->open && c->live)
            chunk_shrink(c, (size_t)((char *)p->nodes - (char *)c), pool_bytes(p));
        chunk_release(c);
    } else {
        free(p->nodes);
        free(p->leaves);
        free(p->slabs);
    }
    memset(p, 0, sizeof *p);
}

void pool_clear(pool_t *p)
{
    p->n = p->nl = 0;
}

/* The tree's leaves (and slabs) are allocated whole at the start of the
 * assembly, but the kernel maps their pages only as the pools are copied in,
 * while each pool copied is freed: the budget counts them as they fill
 * (*counted of them so far, raised to `upto`), so that it sees what the
 * assembly holds, little more than one copy of the tree. */
static void count_filled(build_t *b, size_t *counted, size_t upto, size_t per_leaf)
{
    if (upto > *counted) {
        build_account(b, (ptrdiff_t)((upto - *counted) * per_leaf));
        *counted = upto;
    }
}

/* A depth-first walk's stack: at most 7 pending siblings per level, plus the
 * block being opened. */
#define WALK_STACK (8 * (OCT_MAX_DEPTH + 2))

/* A subtree is built level by level, so its leaves come in breadth-first
 * order; the thread that built it puts them in Morton order, so that the
 * assembly, which runs on one thread, only copies (a walk over every node of
 * the tree there was ~15 % of a 2-thread build).  The copy is also what
 * frees the worker's pool for the next subtree: the pool grows to the
 * largest subtree once, and each subtree's arrays are written once, at
 * their size. */
int pool_morton(build_t *b, const oct_subtree_t *src, int untrusted, arena_chunk_t **arena,
                pool_t *dst)
{
    memset(dst, 0, sizeof *dst);
    size_t n = src->n_nodes, nl = src->n_leaves, base = src->base, ml = nl ? nl : 1;
    int with_slabs = src->slabs != NULL;
    size_t nb = round_up(n * sizeof(oct_node_t), 64), lb = round_up(ml * sizeof(oct_leaf_t), 64),
           sb = with_slabs ? round_up(ml * sizeof(oct_slab_t), 64) : 0;
    char *m = arena_take(arena, nb + lb + sb);
    unsigned char *seen = untrusted ? calloc((nl + 7) / 8 + 1, 1) : NULL;
    if (!m || (untrusted && !seen)) {
        if (m) /* the last bytes taken from *arena: given back */
            (*arena)->used -= nb + lb + sb;
        free(seen);
        int expected = 0;
        atomic_compare_exchange_strong(&b->failed, &expected, BUILD_OUT_OF_MEMORY);
        return -1;
    }
    oct_node_t *nodes = (oct_node_t *)m;
    oct_leaf_t *leaves = (oct_leaf_t *)(m + nb);
    oct_slab_t *slabs = with_slabs ? (oct_slab_t *)(m + nb + lb) : NULL;
    memcpy(nodes, src->nodes, n * sizeof *nodes);
    uint32_t stack[WALK_STACK];
    int sp = 0;
    for (int k = 7; k >= 0; k--)
        stack[sp++] = (uint32_t)base + (uint32_t)k;
    /* a subtree from elsewhere (oct_plan_put) has valid indices but may reach a
       leaf twice or never, or go deeper than a tree can */
    size_t next = 0;
    int corrupt = 0;
    while (sp > 0 && !corrupt) {
        uint32_t i = stack[--sp];
        oct_node_t v = nodes[i];
        if (OCT_NODE_KIND(v) == OCT_LEAF) {
            uint32_t k = OCT_NODE_VALUE(v);
            corrupt = next == nl || (seen && seen[k / 8] >> (k % 8) & 1);
            if (seen)
                seen[k / 8] |= (unsigned char)(1u << (k % 8));
            if (!corrupt) {
                leaves[next] = src->leaves[k];
                if (with_slabs)
                    slabs[next] = src->slabs[k];
                nodes[i] = OCT_NODE(OCT_LEAF, (uint32_t)next++);
            }
        } else if (OCT_NODE_KIND(v) == OCT_INTERIOR) {
            corrupt = sp + 8 > WALK_STACK;
            for (int k = 7; k >= 0 && !corrupt; k--)
                stack[sp++] = OCT_NODE_VALUE(v) + (uint32_t)k;
        }
    }
    free(seen);
    if (corrupt || next != nl) {
        (*arena)->used -= nb + lb + sb;
        return -2;
    }
    dst->nodes = nodes, dst->n = dst->cap = n;
    dst->leaves = leaves, dst->slabs = slabs;
    dst->nl = nl, dst->capl = ml;
    dst->caps = with_slabs ? ml : 0;
    dst->chunk = *arena;
    dst->chunk->live++;
    build_account(b, (ptrdiff_t)(dst->cap * sizeof *nodes + dst->capl * sizeof *leaves +
                                 dst->caps * sizeof *slabs));
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
 * come in increasing order; the tree's leaf array fills as the pools go and
 * each pool is freed once copied (its chunk with the last of its pools), so
 * the assembly holds little more than one copy of the tree. */
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
    oct_node_t *nodes = mem_huge_alloc(nn * sizeof *nodes);
    if (nodes)
        build_account(b, (ptrdiff_t)(nn * sizeof *nodes));
    size_t *leaf_at = malloc((nfront ? nfront : 1) * sizeof *leaf_at); /* per pool */
    uint32_t *top_leaf = malloc((top->nl ? top->nl : 1) * sizeof *top_leaf); /* its number */
    uint32_t *slot_of = malloc((top->n ? top->n : 1) * sizeof *slot_of);  /* pool + 1, or 0 */
    size_t ml = nl ? nl : 1, counted = 0;
    size_t per_leaf = sizeof(oct_leaf_t) + (with_slabs ? sizeof(oct_slab_t) : 0);
    oct_leaf_t *leaves = mem_huge_alloc(ml * sizeof *leaves);
    oct_slab_t *slabs = with_slabs ? mem_huge_alloc(ml * sizeof *slabs) : NULL;
    int failed = !nodes || !leaf_at || !top_leaf || !slot_of || !leaves || (with_slabs && !slabs);
    if (failed)
        goto out;
    count_filled(b, &counted, top->nl, per_leaf);

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
            count_filled(b, &counted, ol + p->nl, per_leaf);
            memcpy(leaves + ol, p->leaves, p->nl * sizeof *leaves);
            if (with_slabs)
                memcpy(slabs + ol, p->slabs, p->nl * sizeof *slabs);
        }
        pool_free(b, p);
    }
    count_filled(b, &counted, ml, per_leaf);
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
