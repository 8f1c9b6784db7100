/* ivoct — the octree of surface cells (prefix oct_).
 *
 * oct_build subdivides a box recursively.  Each cell goes through a chain of
 * certified tests, cheapest first, and stops at the first that decides it holds
 * no surface:
 *   interval   0 not in F(cell)                    -> empty (inside / outside)
 *   lipschitz  |f(c)| > L r, L >= sup |grad f|      -> empty (Kalra-Barr)
 *   ilie       the slab {p : 0 in a.(p - c) + J} misses the cell -> empty (Buhler)
 * otherwise the cell is split into 8 down to the max depth, where it is a
 * surface leaf -- or, with refine, earlier where its slab is thin and the
 * surface has no fold (a leaf whose error bound is the slab's thickness).
 * On a single-use tape (every input and clause used once) the interval result
 * is the exact range up to rounding, so lipschitz and ilie cannot decide what
 * interval leaves open: they are skipped there (ILIE still runs where a slab
 * is wanted: with refine, and at the max depth unless slabs_unused).
 * Guarantee: every point of the box where f = 0 lies in a
 * surface leaf (cells are closed boxes).  A surface leaf may hold no surface.
 *
 * Storage: a pool of nodes, each a 32-bit word; nodes[0] is the root, and the
 * 8 children of a cell are contiguous.  Surface leaves are kept apart, in Morton order, with their
 * payload.  Cells are addressed by (depth, ix, iy, iz) with 0 <= i < 2^depth;
 * their bounds come from oct_coord so that neighbours share bounds exactly.
 */
#ifndef IVOCT_OCTREE_H
#define IVOCT_OCTREE_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "../expr/error.h"
#include "../expr/tape.h"

#ifdef __cplusplus
extern "C" {
#endif

#define OCT_MAX_DEPTH 21 /* 3 * 21 = 63 bits of Morton code */

/* The tests of the chain; by name: oct_tests_parse, oct_tests_format (below). */
enum {
    OCT_TEST_INTERVAL = 1u << 0,
    OCT_TEST_LIPSCHITZ = 1u << 1,
    OCT_TEST_ILIE = 1u << 2,
};

/* A node word: the top 2 bits say what it is, the low 30 an index or a class. */
typedef uint32_t oct_node_t;
enum {
    OCT_INTERIOR = 0u, /* low bits: index of the first of its 8 children in nodes[] */
    OCT_LEAF = 1u,     /* low bits: index in leaves[] */
    OCT_EMPTY = 2u,    /* low bits: an oct_class_t */
};
typedef enum { OCT_INSIDE = 0, OCT_OUTSIDE = 1, OCT_UNDEFINED = 2 } oct_class_t;

#define OCT_NODE_KIND(n) ((n) >> 30)
#define OCT_NODE_VALUE(n) ((n) & 0x3fffffffu)
#define OCT_NODE(kind, value) (((uint32_t)(kind) << 30) | (uint32_t)(value))

/* A surface leaf: 16 bytes.  key holds the depth d and the Morton code at
 * that depth (bits (z y x) per level, root first) as 1 << 3d | code: the
 * highest set bit says the depth (3d + 1 <= 64 bits for d <= 21); read them
 * with oct_leaf_depth and oct_leaf_code.  [f_lo, f_hi] encloses f over the
 * leaf: the build's enclosure rounded outward to float (floats keep the leaf
 * small; the leaf's own bound is a few ulps of a float away from the double
 * one, and every consumer only reads it). */
typedef struct oct_leaf {
    uint64_t key;
    float f_lo, f_hi;
} oct_leaf_t;

static inline int oct_leaf_depth(const oct_leaf_t *l)
{
#if defined(__GNUC__)
    return l->key ? (63 - __builtin_clzll(l->key)) / 3 : 0;
#else
    int d = 0;
    while (d < 21 && l->key >> (3 * d + 3))
        d++;
    return d;
#endif
}

static inline uint64_t oct_leaf_code(const oct_leaf_t *l)
{
    return l->key ^ (uint64_t)1 << (3 * oct_leaf_depth(l));
}

/* The leaf of Morton code `code` at `depth` (0..21) with enclosure F (rounded
 * outward to floats; NaN stays NaN). */
oct_leaf_t oct_leaf_make(uint64_t code, int depth, double f_lo, double f_hi);

/* The ILIE slab of a surface leaf (builds with the ilie test): 48 bytes, in an
 * array parallel to the leaves. */
typedef struct oct_slab {
    double n[3];        /* unit normal (|n| = 1 up to rounding); 0 0 0: the leaf has no slab */
    double d_lo, d_hi;  /* every point p of the surface in the leaf has d_lo <= n.p <= d_hi */
    double thickness;   /* certified slab thickness w(J)/|a| (>= d_hi - d_lo up to rounding) */
} oct_slab_t;

typedef struct oct_params {
    int depth;          /* max depth, 0..OCT_MAX_DEPTH */
    unsigned tests;     /* OCT_TEST_* */
    double refine;      /* > 0 (needs OCT_TEST_ILIE): a cell whose slab is thinner than
                           refine and whose normals stay within 60 degrees of the slab's
                           becomes a leaf before the max depth */
    int slabs_unused;   /* non-zero: nothing will read the leaves' slabs, so ILIE runs
                           only where it can decide a cell (on a single-use tape it then
                           never runs: see oct_build) */
    int threads;        /* <= 0: all cores */
    size_t max_memory;  /* bytes; 0 = no limit */
    /* Called now and then with the fraction done, from one thread at a time. */
    void (*progress)(void *user, double fraction);
    void *progress_user;
} oct_params_t;

typedef struct oct_stats {
    uint64_t cells_visited;   /* cells that went through the chain */
    uint64_t split;           /* cells split into 8 */
    /* cells decided (sum = cells_visited - split) */
    uint64_t decided_interval, decided_lipschitz, decided_ilie, decided_refine;
    uint64_t decided_max_depth; /* undecided at the max depth: surface leaves */
    uint64_t leaves_by_depth[OCT_MAX_DEPTH + 1];
    uint64_t cells_by_depth[OCT_MAX_DEPTH + 1];
    /* tape pruning: sum over split cells at each depth of the length of the
     * tape their children are evaluated with */
    uint64_t tape_length_sum_by_depth[OCT_MAX_DEPTH + 1];
    uint64_t split_by_depth[OCT_MAX_DEPTH + 1];
    uint64_t tape_clauses_evaluated; /* clauses x cells, over every evaluation */
    double max_error_bound;          /* largest certified error bound of a leaf */
    uint64_t leaves_certain;         /* leaves that surely hold surface (oct_certify) */
    double certain_time_s;           /* wall time of oct_certify (not in time_s) */
    double time_s;
    size_t peak_bytes;               /* octree storage and build scratch */
    int threads;
} oct_stats_t;

typedef struct oct_tree {
    double box[6];
    int depth;
    unsigned tests;
    oct_node_t *nodes;  /* nodes[0] is the root; children blocks follow */
    uint32_t n_nodes;
    oct_leaf_t *leaves;
    uint32_t n_leaves;
    oct_slab_t *slabs;  /* n_leaves entries when the build ran the ilie test without
                           slabs_unused, else NULL */
    uint8_t *certain;   /* n_leaves witness codes after oct_certify (0: not certain;
                           see oct_witness_decode), else NULL */
    double refine;
    oct_stats_t stats;
} oct_tree_t;

/* Build the octree of f = 0 (tape t) in box.  Returns 0 and a new tree, or
 * non-zero with err set (memory budget exceeded, out of memory, bad params). */
int oct_build(const tape_t *t, const double box[6], const oct_params_t *params,
              oct_tree_t **out, ivoct_error_t *err);

void oct_free(oct_tree_t *tree);

/* ---- a build in parts (for a build spread over processes: cli/mpi.c) ----------
 * oct_build first splits the box breadth-first on one thread until at least
 * 256 cells are to be split (or none are): the frontier, all at one depth,
 * the same cells for any thread count.  Each frontier cell's subtree is then
 * built on its own, with the root box's coordinates and the tape pruned on
 * the way down, so any process that has the plan can build any of them; the
 * parts put together give the tree of oct_build node for node (the same file).
 *   oct_plan_new      the top of the tree and the frontier (cheap)
 *   oct_plan_build    build some subtrees, on the plan's threads
 *   oct_plan_get/put  a built subtree as flat arrays, to send and receive
 *   oct_plan_finish   the tree: every subtree (oct_build's tree), or a part
 * oct_build is these four calls.  The memory budget covers the whole plan. */
typedef struct oct_plan oct_plan_t;

/* One subtree, flat: node words index its own arrays (an interior word the
 * first of 8 children in nodes, a leaf word an index in leaves); `base` is
 * the first of the frontier cell's 8 children.  `stats` and `max_diagonal2`
 * are its share of the build's counts (cells, leaves, tests). */
typedef struct oct_subtree {
    uint32_t base, n_nodes, n_leaves;
    const oct_node_t *nodes;
    const oct_leaf_t *leaves;
    const oct_slab_t *slabs; /* n_leaves, or NULL when the build keeps none */
    oct_stats_t stats;
    double max_diagonal2;    /* the largest squared diagonal of a leaf without a slab */
} oct_subtree_t;

int oct_plan_new(const tape_t *t, const double box[6], const oct_params_t *params,
                 oct_plan_t **out, ivoct_error_t *err);
void oct_plan_free(oct_plan_t *plan);
/* The frontier: how many subtrees, their depth, the Morton code of number i
 * at that depth (increasing with i). */
size_t oct_plan_subtrees(const oct_plan_t *plan);
int oct_plan_subtree_depth(const oct_plan_t *plan);
uint64_t oct_plan_subtree_code(const oct_plan_t *plan, size_t i);
/* Does the plan hold subtree i (built or put)? */
int oct_plan_has(const oct_plan_t *plan, size_t i);
/* Build subtrees which[0..n) (those not held yet) on the plan's threads. */
int oct_plan_build(oct_plan_t *plan, const size_t *which, size_t n, ivoct_error_t *err);
/* Subtree i, borrowed from the plan (valid until oct_plan_finish or _free);
 * -1 when the plan does not hold it. */
int oct_plan_get(const oct_plan_t *plan, size_t i, oct_subtree_t *out);
/* Copy subtree i into the plan (from another process: its indices are
 * checked, so a bad one is an error, not a crash). */
int oct_plan_put(oct_plan_t *plan, size_t i, const oct_subtree_t *in, ivoct_error_t *err);

enum {
    /* the subtrees the plan does not hold become empty cells (class
       OCT_OUTSIDE) instead of an error: a process's part of the tree */
    OCT_PLAN_PART = 1u,
    /* with OCT_PLAN_PART: also drop the leaves above the frontier (one
       process's part has them, the others' do not) */
    OCT_PLAN_NO_TOP = 2u,
};
/* The tree of the subtrees held (with the counts of what it holds: stats
 * summed over its subtrees, plus the top phase's unless OCT_PLAN_NO_TOP).
 * The subtrees' storage moves into the tree: afterwards the plan can only be
 * freed. */
int oct_plan_finish(oct_plan_t *plan, unsigned flags, oct_tree_t **out, ivoct_error_t *err);

/* Add the counts of from to to (sums, and the largest error bound). */
void oct_stats_add(oct_stats_t *to, const oct_stats_t *from);

/* Bound number i of 2^depth equal parts of [lo, hi] (0 <= depth <= 62):
 * oct_coord(lo, hi, 0, d) = lo, oct_coord(lo, hi, 2^d, d) = hi, monotone in
 * i, and the same double for the same fraction i / 2^d at any depth.  Inline:
 * the builder and the ray walk compute bounds on every cell. */
static inline double oct_coord(double lo, double hi, uint64_t i, int depth)
{
    uint64_t n = (uint64_t)1 << depth;
    if (i == 0)
        return lo;
    if (i >= n)
        return hi;
    /* 2^-depth from its exponent bits; i < 2^53 and the scaling are exact,
     * so i / 2^depth is the fraction itself, the same at any depth; each
     * step is monotone in i, so neighbours never overlap */
    uint64_t bits = (uint64_t)(1023 - depth) << 52;
    double pow2neg;
    memcpy(&pow2neg, &bits, sizeof pow2neg);
    double v = lo + (hi - lo) * ((double)i * pow2neg);
    return v < hi ? v : hi;
}

/* The box of the cell (depth, ix, iy, iz) of the tree's box. */
iv_box_t oct_cell_box(const double box[6], int depth, uint32_t ix, uint32_t iy, uint32_t iz);

/* Morton code <-> cell coordinates at a depth (0..OCT_MAX_DEPTH; the child
 * number at each level: bit 0 x, bit 1 y, bit 2 z).  oct_unmorton ignores the
 * bits of code above 3·depth. */
uint64_t oct_morton(uint32_t ix, uint32_t iy, uint32_t iz, int depth);
void oct_unmorton(uint64_t code, int depth, uint32_t *ix, uint32_t *iy, uint32_t *iz);

/* The box of a leaf. */
iv_box_t oct_leaf_box(const oct_tree_t *tree, const oct_leaf_t *leaf);

/* The diagonal of a box, rounded up. */
double oct_box_diagonal(const iv_box_t *box);

/* Does leaf i carry a slab? */
int oct_leaf_has_slab(const oct_tree_t *tree, uint32_t i);

/* The certified error bound of leaf i: how far a point of the surface in the
 * leaf can be from the leaf's approximation of it -- from the mid-plane of its
 * slab when it has one (the slab thickness; a leaf that stopped early has one
 * thinner than `refine`), else from any point of the leaf (its diagonal).
 * Rounded up. */
double oct_leaf_error_bound(const oct_tree_t *tree, uint32_t i);

/* ---- leaves that surely hold surface (certain.c) --------------------------------
 * A surface leaf only may hold surface.  oct_certify proves, for as many
 * leaves as it can, that the leaf surely holds a point where f = 0:
 *  - f is proved defined and continuous on the whole (closed, connected) leaf
 *    (tape_check_continuous, or tape_is_total for the tape), and
 *  - two sample points of the leaf have certified opposite signs (a rigorous
 *    interval evaluation at the point: an enclosure that excludes 0), so f
 *    has a zero between them by the intermediate value theorem; or
 *  - one sample point has a certified zero (its enclosure is [0, 0]).
 * (The modal inner estimate of the range, mod_inner_range, is not used: on
 * leaves this small it certified no leaf the samples missed, at twice the
 * cost; octree/README.md.)
 * The witness is kept as one byte per leaf: the sample points are a fixed set
 * of OCT_SAMPLES points of the leaf (oct_leaf_sample), so a witness is one or
 * two indices into that set, and its coordinates are recomputed from the
 * leaf when written.  The result depends only on each leaf and the tape:
 * the same for any thread count and any SIMD path. */

/* 8 corners (k = 0..7: bit 0 x, bit 1 y, bit 2 z at the upper end), the
 * centre (8), the face centres (9..14: -x, +x, -y, +y, -z, +z). */
#define OCT_SAMPLES 15

/* Sample point k (0 <= k < OCT_SAMPLES) of a box: each coordinate is the
 * box's lower bound, upper bound, or its midpoint lo + (hi - lo) / 2 rounded
 * to nearest and clamped to [lo, hi]; so every sample lies in the box, and
 * the same box gives the same doubles. */
void oct_leaf_sample(const iv_box_t *box, int k, double p[3]);

typedef enum oct_witness_kind {
    OCT_WITNESS_NONE = 0,  /* not certain */
    OCT_WITNESS_ZERO,      /* f(sample k0) is certified 0 */
    OCT_WITNESS_SIGNS      /* f(sample k0) < 0 < f(sample k1), certified */
} oct_witness_kind_t;

typedef struct oct_witness {
    oct_witness_kind_t kind;
    int k0, k1; /* sample indices; -1 where the kind has none */
} oct_witness_t;

/* The witness a code names (0 is OCT_WITNESS_NONE; codes are
 * 1 + k0 for ZERO, 16 + 14 k0 + (k1 < k0 ? k1 : k1 - 1) for SIGNS; the
 * codes 226..255 are unused and read as NONE). */
oct_witness_t oct_witness_decode(uint8_t code);
/* The code of a witness (the inverse of oct_witness_decode on valid ones;
 * 0 for anything else). */
uint8_t oct_witness_encode(oct_witness_t w);

/* Does leaf i surely hold surface (tree->certain set and its code not 0)? */
int oct_leaf_certain(const oct_tree_t *tree, uint32_t i);

/* Fill tree->certain (replacing any earlier array) for the tape t the tree
 * was built from, on `threads` threads (<= 0: all cores), and set
 * stats.leaves_certain and stats.certain_time_s.  A leaf's code is not 0
 * only when the argument above proves it holds a zero of f (of the exact
 * function of t: the enclosures are rigorous).  Errors: out of memory, a NULL
 * argument; then the tree is left as it was. */
int oct_certify(oct_tree_t *tree, const tape_t *t, int threads, ivoct_error_t *err);

/* ---- a pruned tape per leaf ---------------------------------------------------
 * For evaluations confined to one leaf (ray casting: the root finders search a
 * leaf's segment of the ray): the tape pruned to the branches of min, max and
 * abs that can matter in the leaf.  The tape of a leaf is pruned over a box
 * that holds the leaf grown by `margin` on every side (rounded outward), and
 * it equals f at every point of that box where f is defined; the margin must
 * cover how far the evaluations may stray out of the leaf by rounding (ray/:
 * ray_tape_margin).  Pruning follows the tree from the root as the build
 * does; a leaf shares its parent's tape where nothing more was decided, and
 * equal tapes are stored once. */
typedef struct oct_leaf_tapes {
    uint32_t n_leaves;
    const tape_t **of_leaf; /* of_leaf[i]: the tape of leaf i (its tape->n <= the
                               root tape's; the root tape itself where nothing
                               was pruned) */
    size_t n_tapes;         /* pruned tapes stored (the root tape not counted) */
    size_t n_clauses;       /* their clauses in all */
    double mean_clauses;    /* the mean length of the leaves' tapes (the root's when
                               there are no leaves) */
    tape_t *tapes;          /* storage: tapes[0] is the root tape, borrowed */
    tape_clause_t *clauses;
} oct_leaf_tapes_t;

/* Prune `tape` (the tape the tree was built from; borrowed, it must outlive
 * the result) for every leaf of tree.  A tape without choices gives every
 * leaf the root tape.  max_ratio < 1: a probe first prunes the top three
 * levels only, and when the tapes there are not on average at most max_ratio
 * times the root's length, pruning is not worth a walk of the whole tree:
 * every leaf gets the root tape (n_tapes = 0); max_ratio >= 1 always walks.
 * Errors: out of memory, bad arguments. */
int oct_leaf_tapes_build(const oct_tree_t *tree, const tape_t *tape, double margin,
                         double max_ratio, oct_leaf_tapes_t **out, ivoct_error_t *err);
void oct_leaf_tapes_free(oct_leaf_tapes_t *lt);

/* ---- native file (.ivo) -----------------------------------------------------
 * The scene the tree was built from travels with it so it can be rebuilt or
 * rendered: its name, its named subexpressions and f, as texts; for a
 * parametric surface also the parametrization f was implicitized from (f is
 * then the implicit polynomial, the text the tree was built from). */
typedef struct oct_source {
    char *name;
    size_t n_lets;
    char **let_names, **let_texts;
    char *f;
    char *param[3];  /* X(u,v), Y(u,v), Z(u,v) as written; NULL for an implicit scene */
    double patch[4]; /* u0 u1 v0 v1 of the parametrization's patch; NaN when not given */
} oct_source_t;

/* Write atomically (temporary file renamed on success). */
int oct_save(const oct_tree_t *tree, const oct_source_t *src, const char *path,
             ivoct_error_t *err);
/* Read and validate (magic, version, sizes, checksum, structure); a truncated
 * or corrupt file is an error, never a crash.  src may be NULL.  An index of
 * pieces (below) is read as the whole tree. */
int oct_load(const char *path, oct_tree_t **tree, oct_source_t *src, ivoct_error_t *err);
void oct_source_free(oct_source_t *src);

/* ---- a tree in pieces (.pivo: `ivoct build --save F.pivo` under mpirun) ------------
 * Each process saves its part of the tree (oct_plan_finish with OCT_PLAN_PART)
 * with oct_save, and one of them writes the index, a text file:
 *   ivoct-pieces 1 pieces=N leaves=L
 *   # a comment
 *   FILE,LEAVES,CHECKSUM          one line per piece
 * FILE relative to the index's folder (or absolute), LEAVES its leaf count,
 * CHECKSUM the 16 hex digits of the checksum that ends it (oct_file_checksum).
 * oct_load reads the index as the whole tree: every piece is loaded and
 * validated, must be the file the index names (checksum, leaves) and of the
 * same build as the first (scene, box, depth, tests, refine, slabs, certain
 * codes), and their union is taken cell by cell from the root: where one
 * piece splits a cell or holds a surface leaf, the others have the empty
 * OCT_OUTSIDE cell of a subtree they do not hold.  Two pieces with the same
 * leaf, or that disagree otherwise, are an error naming both and the cell.
 * The result is the tree of the single build: the same nodes, leaves (in
 * Morton order), slabs and certain codes; its node array is laid out in
 * depth-first order, so oct_save of it is not that file byte for byte.
 * Every piece is held in memory while the tree is put together. */
/* The number of pieces path's index names; 0 when path is not an index. */
int oct_index_pieces(const char *path);
/* The checksum that ends a tree file (the last 8 bytes, not verified). */
int oct_file_checksum(const char *path, uint64_t *sum, ivoct_error_t *err);
/* Write the index of n pieces (atomically, io_open/io_commit). */
int oct_save_index(const char *path, const char *const *sources, const uint64_t *leaves,
                   const uint64_t *checksums, int n, ivoct_error_t *err);

/* ---- settings by name (params.c) ----------------------------------------------
 * What scene files ([octree] depth, tests, refine) and the command line give.
 * Test lists are written "interval, lipschitz, ilie": names separated by
 * commas, blanks around them ignored. */

#define OCT_DEFAULT_DEPTH 8

/* depth OCT_DEFAULT_DEPTH, tests interval and lipschitz, refine 0 (off); every
 * other field 0 (all cores, no memory limit, no progress callback). */
void oct_params_default(oct_params_t *p);

/* Parse a test list into a bitmask of OCT_TEST_* (a name given twice counts
 * once).  Returns 0, or non-zero with *tests unchanged and err at the line and
 * column of text (1-based; lines end at '\n') with what was expected:
 * "unknown test 'foo'; expected interval, lipschitz or ilie". */
int oct_tests_parse(const char *text, unsigned *tests, ivoct_error_t *err);

/* The names of the bits of tests, cheapest first, joined by ", " into buf
 * (never more than n bytes with the terminating NUL); returns buf. */
char *oct_tests_format(unsigned tests, char *buf, size_t n);

/* Whether depth, tests and refine make a build (what oct_build refuses as bad
 * params, said for the user): 0, or non-zero with err set, e.g. "refine 0.1
 * needs the ilie test". */
int oct_params_check(const oct_params_t *p, ivoct_error_t *err);

#ifdef __cplusplus
}
#endif
#endif
