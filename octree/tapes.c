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
 * each distinct tape is stored once (tape_set.h): few
 * tapes, and the renderer's evaluations stay in cache. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "octree.h"
#include "tape_set.h"

typedef struct walk {
    const oct_tree_t *tree;
    double margin;
    tape_ws_t *ws;
    uint32_t root_n;
    uint8_t *choices;   /* (OCT_MAX_DEPTH + 1) * 8 * root_n: one level per depth */
    uint32_t *scratch;  /* 3 * root_n */
    tape_set_t set;     /* the pruned tapes: id k + 1 is set entry k, id 0 the root tape */
    uint32_t *of_leaf;  /* tape id of each leaf */
    int limit;          /* interior nodes at this depth are not descended into */
    double probe_sum, probe_count; /* their tapes' lengths, and the leaves' above */
    int failed;
} walk_t;

/* The tape with id id (valid until the set's clause array grows). */
static tape_t tape_of(const walk_t *w, const tape_t *root, size_t id)
{
    return id == 0 ? *root : tape_set_get(&w->set, id - 1);
}

/* Its length. */
static uint32_t tape_length(const walk_t *w, const tape_t *root, size_t id)
{
    return id == 0 ? root->n : w->set.tapes[id - 1].n;
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
            tape_t out = {tape_set_reserve(&w->set, t.n), 0};
            if (!out.clauses) {
                w->failed = 1;
                return;
            }
            t = tape_of(w, root, id); /* the clause array may have moved */
            tape_prune(&t, c, w->scratch, &out);
            long got = tape_set_commit(&w->set, out.n);
            if (got < 0) {
                w->failed = 1;
                return;
            }
            kid = (uint32_t)got + 1;
        }
        uint32_t cx = 2 * ix + (k & 1u), cy = 2 * iy + (k >> 1 & 1u), cz = 2 * iz + (k >> 2 & 1u);
        if (OCT_NODE_KIND(word) == OCT_LEAF || depth + 1 >= w->limit) {
            w->probe_sum += tape_length(w, root, kid);
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
    tape_set_clear(&w->set);
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
    w.failed = !lt || !w.ws || !w.choices || !w.scratch || !w.of_leaf;
    if (!w.failed) {
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
        lt->n_tapes = w.set.n_tapes;
        lt->n_clauses = w.set.n_clauses;
        lt->tapes = malloc((w.set.n_tapes + 1) * sizeof *lt->tapes);
        lt->of_leaf = malloc(nl * sizeof *lt->of_leaf);
        w.failed = !lt->tapes || !lt->of_leaf;
    }
    if (!w.failed) {
        lt->tapes[0] = *tape;
        for (size_t i = 0; i < w.set.n_tapes; i++)
            lt->tapes[i + 1] = tape_set_get(&w.set, i);
        double sum = 0;
        for (uint32_t i = 0; i < tree->n_leaves; i++) {
            lt->of_leaf[i] = &lt->tapes[w.of_leaf[i]];
            sum += lt->of_leaf[i]->n;
        }
        lt->mean_clauses = tree->n_leaves ? sum / tree->n_leaves : tape->n;
        lt->clauses = w.set.clauses; /* the leaf tapes own the set's clauses */
        w.set.clauses = NULL;
    }
    tape_ws_free(w.ws);
    free(w.choices);
    free(w.scratch);
    free(w.of_leaf);
    tape_set_free(&w.set);
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
