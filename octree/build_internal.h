/* ivoct octree — the builder's pieces, internal to octree/.
 *
 *   pool.c   memory accounting, the node and leaf pools, assembly of the tree
 *   chain.c  the test chain: classify the children of a cell
 *   build.c  the two phases (the top on one thread, then subtrees level by
 *            level on every thread), oct_build
 *   tape_set.c  pruned tapes stored once (tape_set.h)
 */
#ifndef IVOCT_OCTREE_BUILD_INTERNAL_H
#define IVOCT_OCTREE_BUILD_INTERNAL_H

#include <stdatomic.h>
#include <stddef.h>

#include "../ilie/ilie.h"
#include "octree.h"

/* A cell of the build: its address and Morton code at its depth. */
typedef struct cell {
    uint32_t ix, iy, iz;
    int depth;
    uint64_t code;
} cell_t;

enum { SPLIT, LEAF, EMPTY };

/* What the chain decided for one cell. */
typedef struct decision {
    int kind;
    oct_class_t cls;    /* EMPTY */
    iv_t F;             /* enclosure of f over the cell */
    oct_slab_t slab;    /* LEAF: its slab (n = 0 when none) */
} decision_t;

/* The build's settings and shared state. */
typedef struct build {
    const tape_t *tape;
    double box[6];
    int max_depth;
    unsigned tests;
    double refine;
    int slabs_unused;   /* oct_params_t.slabs_unused */
    int choices;        /* the tape has min/max/abs to prune */
    int single_use;     /* the root tape is a single-use expression */
    size_t max_memory;
    atomic_size_t bytes, peak;
    atomic_int failed;  /* BUILD_OVER_BUDGET or BUILD_OUT_OF_MEMORY once failed */
} build_t;

enum { BUILD_OVER_BUDGET = 1, BUILD_OUT_OF_MEMORY = 2 };

/* A block that the arrays of finished subtrees are carved from (pool.c). */
typedef struct arena_chunk arena_chunk_t;

/* Nodes and leaves of one part of the tree, grown by doubling while it is
 * built. */
typedef struct pool {
    oct_node_t *nodes;
    size_t n, cap;
    oct_leaf_t *leaves;
    oct_slab_t *slabs; /* parallel to leaves, when keeps_slabs */
    size_t nl, capl, caps;
    arena_chunk_t *chunk; /* the arrays are in this chunk (pool_morton); NULL: malloc'd */
} pool_t;

/* Cells per chain_classify call: the children of CHAIN_BATCH / 8 cells that
 * share a tape, evaluated together (the evaluators want many boxes per call;
 * more than a few hundred buys nothing and costs cache). */
#define CHAIN_BATCH 512

/* Scratch of one chain_classify call, CHAIN_BATCH entries each, in one
 * allocation that starts at `ilie` (build.c).  The passes fill only the
 * entries of the cells still open. */
typedef struct chain_scratch {
    iv_t *F;              /* by cell: f over its box */
    int *open, *thin;     /* indices of the cells still open, and of the thin ones */
    iv_grad_t *grad;      /* by cell: the gradient, where the gradient pass ran */
    ilie_t *ilie;         /* by cell: the ILIE, where the ILIE pass ran */
    iv_box_t *open_boxes; /* the open cells' boxes, packed, for one pass */
    iv_grad_t *open_grad; /* packed results */
    iv_t *open_F;
    ilie_t *open_ilie;
    double (*centre)[3];
} chain_scratch_t;

/* The largest squared diagonal of the leaves without a slab so far
 * (cell_diagonal_squared), and the rounded-up widths of the leaf that gave it
 * (chain.c, note_leaf_diagonal). */
typedef struct leaf_diagonal {
    double d2;
    double u[3];
} leaf_diagonal_t;

/* One thread's evaluators and scratch. */
typedef struct worker {
    build_t *b;
    tape_ws_t *ws;
    ilie_ws_t *ilie_ws;        /* only with the ilie test */
    uint8_t *choices;          /* CHAIN_BATCH * tape->n: the choices of one interval pass */
    uint32_t *scratch;         /* 3 * tape->n */
    chain_scratch_t chain;
    struct wave *wave;         /* the levels of the subtree being built (build.c) */
    pool_t work;               /* the subtree being built, copied out when done */
    arena_chunk_t *arena;      /* the chunk the finished subtrees are copied to */
    leaf_diagonal_t diagonal;  /* the largest squared diagonal of a leaf without a slab */
    oct_stats_t st;
} worker_t;

/* A cell the top phase hands to the subtree phase, and its subtree. */
typedef struct frontier {
    cell_t cell;
    tape_t tape;    /* owned copy when pruned, else points at the root tape */
    int owned;
    int single_use;
    size_t slot;    /* index in the top pool of the node word to fill */
    pool_t pool;    /* the subtree, built in phase 2 */
    long base;      /* the index in pool of the cell's children block */
    int present;    /* the subtree is built here or was put (oct_plan_put) */
    oct_stats_t st; /* its counts alone (the workers' hold the top phase's) */
    double max_diagonal2; /* worker_t.diagonal.d2 over this subtree */
} frontier_t;

/* ---- cell.c ----
 * oct_box_diagonal in two steps: the squared diagonal rounded up, then its
 * root rounded up, which depends on that bound alone and grows with it.  So
 * the largest diagonal of many boxes is the root of their largest square,
 * one square root in all (the builder's max_error_bound). */
double cell_diagonal_of_squared(double d2);

/* The widths of a box rounded up: the upper ends of iv_sub(hi, lo), which
 * are their magnitudes (on a box, lo <= hi, the lower end lies in [-upper,
 * upper]: both are hi - lo widened alike). */
static inline void cell_widths_up(const iv_box_t *b, double u[3])
{
    const iv_t *s = &b->x;
    for (int a = 0; a < 3; a++)
        u[a] = iv_add_up(s[a].hi, -s[a].lo);
}

/* The squared diagonal rounded up from those widths: the upper end of the
 * interval sum of their squares (iv_sqr, iv_add), bit for bit, with only the
 * upper ends computed.  Every step rounds upward or is exact, so it grows
 * with each width. */
static inline double cell_diagonal_squared_of(const double u[3])
{
    return iv_add_up(iv_add_up(iv_sqr_hi(u[0]), iv_sqr_hi(u[1])), iv_sqr_hi(u[2]));
}

/* The squared diagonal of a box rounded up (inline: it runs once per leaf
 * without a slab). */
static inline double cell_diagonal_squared(const iv_box_t *b)
{
    double u[3];
    cell_widths_up(b, u);
    return cell_diagonal_squared_of(u);
}

/* ---- pool.c ---- */

/* Count delta bytes (negative: freed); past the budget the build fails. */
void build_account(build_t *b, ptrdiff_t delta);
/* Grow p (of *cap elements of size bytes) to hold need; NULL and the build
 * failed when out of memory. */
void *build_grow(build_t *b, void *p, size_t *cap, size_t need, size_t size);
/* Are the leaves' slabs stored? */
int build_keeps_slabs(const build_t *b);
/* Reserve 8 contiguous nodes; the index of the first, or -1. */
long pool_block(build_t *b, pool_t *p);
/* Append the leaf of cell c; its index in the pool, or -1. */
long pool_leaf(build_t *b, pool_t *p, cell_t c, const decision_t *d);
void pool_free(build_t *b, pool_t *p);
/* Empty the pool, keeping its arrays for the next subtree. */
void pool_clear(pool_t *p);
/* Copy a subtree (its words index its own arrays; base: its children's
 * block) into the pool dst, in new arrays exactly as long as its contents,
 * the leaves (and slabs, when src has them) in Morton order, the order of a
 * depth-first walk from base (children 0..7), and the leaf words
 * renumbered.  The arrays are carved from the chunk *arena (a new one when
 * it is full or NULL), which one thread fills.  0; -1 with
 * the build failed (out of memory); -2 when the walk reaches more or fewer
 * leaves than src holds, or goes deeper than a tree can, or (untrusted: a
 * subtree from oct_plan_put) reaches a leaf twice: src is corrupt.  dst is
 * empty but on success. */
int pool_morton(build_t *b, const oct_subtree_t *src, int untrusted, arena_chunk_t **arena,
                pool_t *dst);
/* The thread is done filling chunk *cur (freed once its pools are); *cur is
 * then NULL. */
void arena_close(arena_chunk_t **cur);
/* The tree from the top pool and the subtrees' pools (each subtree's block
 * goes into node `slot` of the top pool; each pool in Morton order, by
 * pool_morton), leaves in Morton order; the subtrees' pools are freed on the
 * way.  0, or -1 with the build failed. */
int pool_assemble(build_t *b, pool_t *top, frontier_t *front, size_t nfront, oct_tree_t *tree);

/* ---- chain.c ---- */

/* The boxes of the 8 children of a cell. */
void chain_children_boxes(const build_t *b, cell_t p, iv_box_t *boxes);
/* Run the test chain on m <= CHAIN_BATCH cells (of one depth) with tape t;
 * single_use: tape_is_single_use(t). */
void chain_classify(worker_t *w, const tape_t *t, int single_use, const cell_t *cells,
                    const iv_box_t *boxes, int m, decision_t *out);
/* After chain_classify with t: when the choices of cell k decided anything,
 * write t pruned with them into clauses (room for t->n), out its tape, and
 * return 1; else 0 (the cell keeps t). */
int chain_prune(worker_t *w, const tape_t *t, int k, tape_clause_t *clauses, tape_t *out);

#endif
