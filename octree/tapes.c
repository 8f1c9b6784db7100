/* ivoct octree — a pruned tape for every surface leaf (see octree.h,
 * oct_leaf_tapes_build).
 *
 * One walk down the tree, as the build went: the children of an interior
 * node are evaluated together with the node's tape over their boxes grown by
 * the margin, recording the choices, and a child whose evaluation decided a
 * choice gets the tape pruned with them; the others share their parent's.
 * Pruning only shrinks a tape, and once every choice of a branch is decided
 * nothing more changes below; and the same tape comes out in many places (a
 * CSG leaf near the same few primitives, a shell's inside and outside), so
 * each distinct tape is stored once (a hash table of their clauses): few
 * tapes, and the renderer's evaluations stay in cache. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "octree.h"

/* A tape is stored as its first clause and length in one clause array, so
 * that the array can grow; pointers are made at the end. */
typedef struct stored {
    size_t first;
    uint32_t n;
    uint64_t hash;
} stored_t;

typedef struct walk {
    const oct_tree_t *tree;
    double margin;
    tape_ws_t *ws;
    uint32_t root_n;
    uint8_t *choices;   /* (OCT_MAX_DEPTH + 1) * 8 * root_n: one level per depth */
    uint32_t *scratch;  /* 3 * root_n */
    tape_clause_t *clauses;
    size_t n_clauses, cap_clauses;
    stored_t *tapes;    /* tapes[0]: the root tape (not copied) */
    size_t n_tapes, cap_tapes;
    uint32_t *table;    /* open addressing: tape index + 1, 0 empty */
    size_t table_cap;   /* a power of two, at least twice n_tapes */
    uint32_t *of_leaf;  /* tape index of each leaf */
    int limit;          /* interior nodes at this depth are not descended into */
    double probe_sum, probe_count; /* their tapes' lengths, and the leaves' above */
    int failed;
} walk_t;

static int reserve(walk_t *w, void **p, size_t *cap, size_t need, size_t size)
{
    if (need <= *cap)
        return 0;
    size_t cap2 = *cap ? *cap : 64;
    while (cap2 < need)
        cap2 *= 2;
    void *q = realloc(*p, cap2 * size);
    if (!q) {
        w->failed = 1;
        return -1;
    }
    *p = q;
    *cap = cap2;
    return 0;
}

/* The tape with index id (valid until the clause array grows). */
static tape_t tape_of(const walk_t *w, const tape_t *root, size_t id)
{
    if (id == 0)
        return *root;
    tape_t t = {w->clauses + w->tapes[id].first, w->tapes[id].n};
    return t;
}

/* FNV-1a over the clauses' fields (not their padding) */
static uint64_t hash_clauses(const tape_clause_t *c, uint32_t n)
{
    uint64_t h = 0xcbf29ce484222325ull;
    for (uint32_t i = 0; i < n; i++) {
        uint64_t w[4] = {(uint64_t)c[i].op << 32 | c[i].a, c[i].b, 0, 0};
        memcpy(&w[2], &c[i].c.lo, sizeof(double));
        memcpy(&w[3], &c[i].c.hi, sizeof(double));
        for (int k = 0; k < 4; k++)
            h = (h ^ w[k]) * 0x100000001b3ull;
    }
    return h;
}

static int same_clauses(const tape_clause_t *a, const tape_clause_t *b, uint32_t n)
{
    for (uint32_t i = 0; i < n; i++)
        if (a[i].op != b[i].op || a[i].a != b[i].a || a[i].b != b[i].b ||
            memcmp(&a[i].c.lo, &b[i].c.lo, sizeof(double)) ||
            memcmp(&a[i].c.hi, &b[i].c.hi, sizeof(double)))
            return 0;
    return 1;
}

/* The index of the stored tape equal to the one just written at the end of
 * the clause array (n clauses), which is then dropped; or a new index for it.
 * The root tape (index 0) is not in the table: a pruned tape equal to it is
 * stored once like any other.  0 with w->failed set when out of memory. */
static uint32_t intern(walk_t *w, uint32_t n)
{
    if (2 * (w->n_tapes + 1) > w->table_cap) {
        size_t cap = w->table_cap ? 2 * w->table_cap : 1024;
        uint32_t *t = calloc(cap, sizeof *t);
        if (!t) {
            w->failed = 1;
            return 0;
        }
        for (size_t i = 1; i < w->n_tapes; i++) {
            size_t j = w->tapes[i].hash & (cap - 1);
            while (t[j])
                j = (j + 1) & (cap - 1);
            t[j] = (uint32_t)i + 1;
        }
        free(w->table);
        w->table = t;
        w->table_cap = cap;
    }
    const tape_clause_t *mine = w->clauses + w->n_clauses;
    uint64_t h = hash_clauses(mine, n);
    size_t j = h & (w->table_cap - 1);
    for (; w->table[j]; j = (j + 1) & (w->table_cap - 1)) {
        const stored_t *o = &w->tapes[w->table[j] - 1];
        if (o->hash == h && o->n == n && same_clauses(w->clauses + o->first, mine, n))
            return w->table[j] - 1;
    }
    w->tapes[w->n_tapes] = (stored_t){w->n_clauses, n, h};
    w->n_clauses += n;
    w->table[j] = (uint32_t)w->n_tapes + 1;
    return (uint32_t)w->n_tapes++;
}

/* Every leaf of the subtree at node word `word` gets tape id. */
static void assign(walk_t *w, oct_node_t word, uint32_t id)
{
    const oct_tree_t *tree = w->tree;
    if (OCT_NODE_KIND(word) == OCT_LEAF) {
        if (OCT_NODE_VALUE(word) < tree->n_leaves)
            w->of_leaf[OCT_NODE_VALUE(word)] = id;
    } else if (OCT_NODE_KIND(word) == OCT_INTERIOR) {
        uint32_t first = OCT_NODE_VALUE(word);
        if (tree->n_nodes >= 8 && first <= tree->n_nodes - 8)
            for (int k = 0; k < 8; k++)
                assign(w, tree->nodes[first + k], id);
    }
}

static iv_box_t grown(const iv_box_t *b, double margin)
{
    iv_box_t g = {{iv_down(b->x.lo - margin), iv_up(b->x.hi + margin)},
                  {iv_down(b->y.lo - margin), iv_up(b->y.hi + margin)},
                  {iv_down(b->z.lo - margin), iv_up(b->z.hi + margin)}};
    return g;
}

/* The children of the interior node whose first child is nodes[first], cell
 * (depth, ix, iy, iz), evaluated with tape id. */
static void descend(walk_t *w, const tape_t *root, uint32_t first, int depth, uint32_t ix,
                    uint32_t iy, uint32_t iz, uint32_t id)
{
    const oct_tree_t *tree = w->tree;
    if (w->failed || depth >= OCT_MAX_DEPTH || tree->n_nodes < 8 || first > tree->n_nodes - 8)
        return;
    tape_t t = tape_of(w, root, id);
    if (!tape_has_choices(&t)) { /* nothing left to decide below: the subtree shares it */
        for (int k = 0; k < 8; k++)
            assign(w, tree->nodes[first + k], id);
        return;
    }
    iv_box_t boxes[8];
    for (int k = 0; k < 8; k++) {
        iv_box_t b = oct_cell_box(tree->box, depth + 1, 2 * ix + (k & 1u), 2 * iy + (k >> 1 & 1u),
                                  2 * iz + (k >> 2 & 1u));
        boxes[k] = grown(&b, w->margin);
    }
    uint8_t *choices = w->choices + (size_t)depth * 8 * w->root_n;
    iv_t F[8];
    tape_eval_interval_choices(&t, w->ws, 8, boxes, F, choices);
    for (int k = 0; k < 8; k++) {
        oct_node_t word = tree->nodes[first + k];
        if (OCT_NODE_KIND(word) != OCT_INTERIOR && OCT_NODE_KIND(word) != OCT_LEAF)
            continue;
        const uint8_t *c = choices + (size_t)k * t.n;
        uint32_t kid = id;
        int decided = 0;
        for (uint32_t i = 0; i < t.n && !decided; i++)
            decided = c[i] != TAPE_CHOICE_BOTH;
        if (decided) {
            if (reserve(w, (void **)&w->clauses, &w->cap_clauses, w->n_clauses + t.n,
                        sizeof *w->clauses) ||
                reserve(w, (void **)&w->tapes, &w->cap_tapes, w->n_tapes + 1, sizeof *w->tapes))
                return;
            t = tape_of(w, root, id); /* the clause array may have moved */
            tape_t out = {w->clauses + w->n_clauses, 0};
            tape_prune(&t, c, w->scratch, &out);
            kid = intern(w, out.n);
            if (w->failed)
                return;
        }
        uint32_t cx = 2 * ix + (k & 1u), cy = 2 * iy + (k >> 1 & 1u), cz = 2 * iz + (k >> 2 & 1u);
        if (OCT_NODE_KIND(word) == OCT_LEAF || depth + 1 >= w->limit) {
            w->probe_sum += kid ? w->tapes[kid].n : root->n;
            w->probe_count++;
        }
        if (OCT_NODE_KIND(word) == OCT_LEAF)
            assign(w, word, kid);
        else if (depth + 1 < w->limit)
            descend(w, root, OCT_NODE_VALUE(word), depth + 1, cx, cy, cz, kid);
        t = tape_of(w, root, id);
    }
}

/* Back to no tape stored and every leaf with the root tape. */
static void walk_reset(walk_t *w)
{
    w->n_tapes = 1;
    w->n_clauses = 0;
    if (w->table)
        memset(w->table, 0, w->table_cap * sizeof *w->table);
    memset(w->of_leaf, 0, (w->tree->n_leaves ? w->tree->n_leaves : 1) * sizeof *w->of_leaf);
    w->probe_sum = w->probe_count = 0;
}

/* The depth of the probe: few nodes, and deep enough that a CSG cell meets
 * only some of the primitives. */
#define PROBE_DEPTH 3

int oct_leaf_tapes_build(const oct_tree_t *tree, const tape_t *tape, double margin,
                         double max_ratio, oct_leaf_tapes_t **out, ivoct_error_t *err)
{
    *out = NULL;
    if (!tree || !tape || tape->n == 0 || !(margin >= 0) || !isfinite(margin)) {
        ivoct_error_set(err, "leaf tapes: no tree, no tape or a bad margin");
        return -1;
    }
    oct_leaf_tapes_t *lt = calloc(1, sizeof *lt);
    walk_t w = {.tree = tree, .margin = margin, .root_n = tape->n};
    size_t nl = tree->n_leaves ? tree->n_leaves : 1;
    w.ws = tape_ws_new(tape->n);
    w.choices = malloc((size_t)(OCT_MAX_DEPTH + 1) * 8 * tape->n);
    w.scratch = malloc(3 * (size_t)tape->n * sizeof *w.scratch);
    w.of_leaf = calloc(nl, sizeof *w.of_leaf);
    w.failed = !lt || !w.ws || !w.choices || !w.scratch || !w.of_leaf ||
               reserve(&w, (void **)&w.tapes, &w.cap_tapes, 1, sizeof *w.tapes);
    if (!w.failed) {
        w.tapes[0] = (stored_t){0, tape->n, 0};
        w.n_tapes = 1;
        /* the root: pruned over the grown tree box when that decides anything */
        oct_node_t root = tree->n_nodes ? tree->nodes[0] : OCT_NODE(OCT_EMPTY, 0);
        int walk = tape_has_choices(tape) && OCT_NODE_KIND(root) == OCT_INTERIOR;
        if (walk && max_ratio < 1 && tree->depth > PROBE_DEPTH) {
            /* the probe: the tapes of the top levels only */
            w.limit = PROBE_DEPTH;
            descend(&w, tape, OCT_NODE_VALUE(root), 0, 0, 0, 0, 0);
            walk = w.probe_count > 0 && w.probe_sum <= max_ratio * tape->n * w.probe_count;
            walk_reset(&w);
        }
        w.limit = OCT_MAX_DEPTH + 1;
        if (walk && !w.failed)
            descend(&w, tape, OCT_NODE_VALUE(root), 0, 0, 0, 0, 0);
        else
            assign(&w, root, 0);
    }
    if (!w.failed) {
        lt->n_leaves = tree->n_leaves;
        lt->n_tapes = w.n_tapes - 1;
        lt->n_clauses = w.n_clauses;
        lt->clauses = w.clauses;
        lt->tapes = malloc(w.n_tapes * sizeof *lt->tapes);
        lt->of_leaf = malloc(nl * sizeof *lt->of_leaf);
        w.failed = !lt->tapes || !lt->of_leaf;
    }
    if (!w.failed) {
        lt->tapes[0] = *tape;
        for (size_t i = 1; i < w.n_tapes; i++)
            lt->tapes[i] = (tape_t){w.clauses + w.tapes[i].first, w.tapes[i].n};
        double sum = 0;
        for (uint32_t i = 0; i < tree->n_leaves; i++) {
            lt->of_leaf[i] = &lt->tapes[w.of_leaf[i]];
            sum += lt->of_leaf[i]->n;
        }
        lt->mean_clauses = tree->n_leaves ? sum / tree->n_leaves : tape->n;
        w.clauses = NULL;
    }
    tape_ws_free(w.ws);
    free(w.choices);
    free(w.scratch);
    free(w.of_leaf);
    free(w.tapes);
    free(w.table);
    free(w.clauses);
    if (w.failed) {
        oct_leaf_tapes_free(lt);
        ivoct_error_set(err, "out of memory");
        return -1;
    }
    *out = lt;
    return 0;
}

void oct_leaf_tapes_free(oct_leaf_tapes_t *lt)
{
    if (!lt)
        return;
    free(lt->clauses);
    free(lt->tapes);
    free(lt->of_leaf);
    free(lt);
}
