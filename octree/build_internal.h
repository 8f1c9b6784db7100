/* ivoct octree — the builder's pieces, internal to octree/.
 *
 *   pool.c   memory accounting, the node and leaf pools, assembly of the tree
 *   chain.c  the test chain: classify the children of a cell
 *   build.c  the two phases (breadth-first top, depth-first subtrees), oct_build
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
    const tape_t *tape; /* SPLIT: the tape for its children */
    int single_use;     /* SPLIT: tape_is_single_use(tape) */
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

/* Nodes and leaves of one part of the tree, grown by doubling. */
typedef struct pool {
    oct_node_t *nodes;
    size_t n, cap;
    oct_leaf_t *leaves;
    oct_slab_t *slabs; /* parallel to leaves, when keeps_slabs */
    size_t nl, capl, caps;
} pool_t;

/* One thread's evaluators and scratch. */
typedef struct worker {
    build_t *b;
    tape_ws_t *ws;
    ilie_ws_t *ilie_ws;        /* only with the ilie test */
    uint8_t *choices;          /* 8 * tape->n: the choices of one interval pass */
    tape_clause_t *tape_store; /* (OCT_MAX_DEPTH + 1) * 8 pruned tapes */
    tape_t tapes[OCT_MAX_DEPTH + 1][8];
    uint32_t *scratch;
    /* Scratch of one classify call (8 cells at most), here rather than on the
     * stack: the passes fill only the entries of the cells still open, which
     * gcc's -Wmaybe-uninitialized cannot follow through the `open` indices. */
    iv_box_t open_boxes[8]; /* the open cells' boxes, packed, for one pass */
    iv_grad_t grad[8];      /* by cell: the gradient, where the gradient pass ran */
    oct_stats_t st;
} worker_t;

/* A cell the top phase hands to the depth-first phase, and its subtree. */
typedef struct frontier {
    cell_t cell;
    tape_t tape;    /* owned copy when pruned, else points at the root tape */
    int owned;
    int single_use;
    size_t slot;    /* index in the top pool of the node word to fill */
    pool_t pool;    /* the subtree, built in phase 2 */
    long base;      /* the index in pool of the cell's children block */
} frontier_t;

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
/* The tree from the top pool and the subtrees' pools (each subtree's block
 * goes into node `slot` of the top pool), leaves in Morton order.  0, or -1
 * with the build failed. */
int pool_assemble(build_t *b, const pool_t *top, const frontier_t *front, size_t nfront,
                  oct_tree_t *tree);

/* ---- chain.c ---- */

/* The boxes of the 8 children of a cell. */
void chain_children_boxes(const build_t *b, cell_t p, iv_box_t *boxes);
/* Run the test chain on m cells (the 8 children of a cell, or the root alone)
 * with tape t; single_use: tape_is_single_use(t).  A cell to split gets in
 * out[k].tape the tape pruned to its box (held in the worker until the next
 * call at the same depth) or t itself. */
void chain_classify(worker_t *w, const tape_t *t, int single_use, const cell_t *cells,
                    const iv_box_t *boxes, int m, decision_t *out);

#endif
