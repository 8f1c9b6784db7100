/* ivoct — the octree builder: its two phases.
 *
 * A short breadth-first phase on one thread splits the box until there are
 * FRONTIER_CELLS cells to split (or none); then each of those cells' subtrees
 * is built depth-first by whichever thread is free, into a pool of its own.
 * The pools are concatenated in frontier order and the leaves put in Morton
 * order (pool.c), so the result does not depend on the number of threads.
 * Both phases split a cell the same way (split_cell): the chain (chain.c)
 * classifies its 8 children, empty ones and leaves are stored at once, and
 * each child to split goes to the phase's own continuation: into the next
 * frontier, or down the depth-first recursion. */
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "build_internal.h"

/* Enough subtrees to keep 2..8 threads busy with dynamic scheduling; a fixed
 * number, so that the layout does not depend on the thread count. */
#define FRONTIER_CELLS 256

/* ---- workers ------------------------------------------------------------------- */

static int worker_init(worker_t *w, build_t *b)
{
    memset(w, 0, sizeof *w);
    w->b = b;
    uint32_t n = b->tape->n;
    w->ws = tape_ws_new(n);
    w->scratch = malloc(3 * (size_t)n * sizeof *w->scratch);
    w->choices = b->choices ? malloc(8 * (size_t)n) : NULL;
    size_t ntapes = (size_t)(OCT_MAX_DEPTH + 1) * 8;
    w->tape_store = b->choices ? malloc(ntapes * n * sizeof *w->tape_store) : NULL;
    w->ilie_ws = (b->tests & OCT_TEST_ILIE) ? ilie_ws_new(n) : NULL;
    if (!w->ws || !w->scratch ||
        (b->choices && (!w->tape_store || !w->choices)) ||
        ((b->tests & OCT_TEST_ILIE) && !w->ilie_ws))
        return -1;
    if (b->choices)
        for (int d = 0; d <= OCT_MAX_DEPTH; d++)
            for (int k = 0; k < 8; k++)
                w->tapes[d][k].clauses = w->tape_store + ((size_t)d * 8 + (size_t)k) * n;
    /* the workspace holds TAPE_LANES lanes of every slot: interval, gradient, point */
    build_account(b, (ptrdiff_t)(w->b->choices ? ntapes * n * sizeof *w->tape_store + 8 * n : 0) +
                   (ptrdiff_t)((size_t)n * TAPE_LANES * (sizeof(double) + sizeof(iv_t) +
                                                         sizeof(iv_grad_t))));
    return 0;
}

static void worker_free(worker_t *w)
{
    tape_ws_free(w->ws);
    ilie_ws_free(w->ilie_ws);
    free(w->scratch);
    free(w->tape_store);
    free(w->choices);
}

static cell_t child_cell(cell_t p, int k)
{
    cell_t c = {2 * p.ix + (k & 1u), 2 * p.iy + (k >> 1 & 1u), 2 * p.iz + (k >> 2 & 1u),
                p.depth + 1, p.code << 3 | (uint64_t)k};
    return c;
}

/* What a phase does with a child to split, whose node word is p->nodes[slot]:
 * returns the word to store there, or -1 on failure. */
typedef long (*split_fn)(worker_t *w, pool_t *p, cell_t kid, const decision_t *d, size_t slot,
                         void *ctx);

/* Split cell (tape t) into a new block of 8 nodes in pool p: classify the
 * children, store the empty ones and the leaves, hand each child to split to
 * on_split, in child order.  Returns the index of the block, or -1. */
static long split_cell(worker_t *w, pool_t *p, cell_t cell, const tape_t *t, int single_use,
                       split_fn on_split, void *ctx)
{
    w->st.split++;
    w->st.split_by_depth[cell.depth]++;
    w->st.tape_length_sum_by_depth[cell.depth] += t->n;
    cell_t kids[8];
    decision_t dec[8];
    iv_box_t boxes[8];
    for (int k = 0; k < 8; k++)
        kids[k] = child_cell(cell, k);
    chain_children_boxes(w->b, cell, boxes);
    chain_classify(w, t, single_use, kids, boxes, 8, dec);
    long base = pool_block(w->b, p);
    if (base < 0)
        return -1;
    for (int k = 0; k < 8; k++) {
        long node;
        if (dec[k].kind == EMPTY) {
            node = OCT_NODE(OCT_EMPTY, dec[k].cls);
        } else if (dec[k].kind == LEAF) {
            long leaf = pool_leaf(w->b, p, kids[k], &dec[k]);
            node = leaf < 0 ? -1 : (long)OCT_NODE(OCT_LEAF, leaf);
        } else {
            node = on_split(w, p, kids[k], &dec[k], (size_t)base + (size_t)k, ctx);
        }
        if (node < 0)
            return -1;
        p->nodes[base + k] = (oct_node_t)node;
    }
    return base;
}

/* ---- phase 2: a subtree, depth-first ----------------------------------------------- */

static long build_subtree(worker_t *w, pool_t *p, cell_t cell, const tape_t *t,
                          int single_use);

static long descend(worker_t *w, pool_t *p, cell_t kid, const decision_t *d, size_t slot,
                    void *ctx)
{
    (void)slot, (void)ctx;
    long sub = build_subtree(w, p, kid, d->tape, d->single_use);
    return sub < 0 ? -1 : (long)OCT_NODE(OCT_INTERIOR, sub);
}

/* Build the subtree below a cell to split into pool p.  Returns the index of
 * its children's block in the pool, or -1 on failure. */
static long build_subtree(worker_t *w, pool_t *p, cell_t cell, const tape_t *t,
                          int single_use)
{
    if (atomic_load_explicit(&w->b->failed, memory_order_relaxed))
        return -1;
    return split_cell(w, p, cell, t, single_use, descend, NULL);
}

/* ---- phase 1: the top of the tree, breadth-first ----------------------------------------- */

static int frontier_push(build_t *b, frontier_t **f, size_t *n, size_t *cap, cell_t c,
                         const decision_t *d, size_t slot)
{
    const tape_t *t = d->tape;
    frontier_t *q = build_grow(b, *f, cap, *n + 1, sizeof *q);
    if (!q)
        return -1;
    *f = q;
    frontier_t *e = &q[(*n)++];
    memset(e, 0, sizeof *e);
    e->cell = c;
    e->slot = slot;
    e->single_use = d->single_use;
    if (t == b->tape) {
        e->tape = *t;
    } else {
        e->tape.n = t->n;
        e->tape.clauses = malloc(t->n * sizeof *t->clauses);
        if (!e->tape.clauses) {
            atomic_store(&b->failed, BUILD_OUT_OF_MEMORY);
            return -1;
        }
        memcpy(e->tape.clauses, t->clauses, t->n * sizeof *t->clauses);
        e->owned = 1;
        build_account(b, (ptrdiff_t)(t->n * sizeof *t->clauses));
    }
    return 0;
}

static void frontier_free(build_t *b, frontier_t *f, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        if (f[i].owned) {
            build_account(b, -(ptrdiff_t)(f[i].tape.n * sizeof *f[i].tape.clauses));
            free(f[i].tape.clauses);
        }
        pool_free(b, &f[i].pool);
    }
    free(f);
}

typedef struct next_level {
    frontier_t *f;
    size_t n, cap;
} next_level_t;

static long defer(worker_t *w, pool_t *p, cell_t kid, const decision_t *d, size_t slot,
                  void *ctx)
{
    (void)p;
    next_level_t *next = ctx;
    if (frontier_push(w->b, &next->f, &next->n, &next->cap, kid, d, slot))
        return -1;
    return 0; /* filled by the assembly */
}

/* Breadth-first from the root until FRONTIER_CELLS cells are to be split.
 * Fills the top pool (root at 0) and the frontier. */
static int top_phase(worker_t *w, pool_t *top, frontier_t **front, size_t *nfront)
{
    build_t *b = w->b;
    *front = NULL;
    *nfront = 0;

    /* the root goes through the chain alone */
    oct_node_t *q = build_grow(b, top->nodes, &top->cap, 1, sizeof *q);
    if (!q)
        return -1;
    top->nodes = q;
    top->n = 1;
    cell_t root = {0, 0, 0, 0, 0};
    iv_box_t root_box = oct_cell_box(b->box, 0, 0, 0, 0);
    decision_t dec;
    chain_classify(w, b->tape, b->single_use, &root, &root_box, 1, &dec);
    if (dec.kind == EMPTY) {
        top->nodes[0] = OCT_NODE(OCT_EMPTY, dec.cls);
        return 0;
    }
    if (dec.kind == LEAF) {
        long leaf = pool_leaf(b, top, root, &dec);
        if (leaf < 0)
            return -1;
        top->nodes[0] = OCT_NODE(OCT_LEAF, leaf);
        return 0;
    }
    next_level_t cur = {0};
    if (frontier_push(b, &cur.f, &cur.n, &cur.cap, root, &dec, 0))
        goto fail;

    while (cur.n > 0 && cur.n < FRONTIER_CELLS) {
        next_level_t next = {0};
        for (size_t i = 0; i < cur.n; i++) {
            frontier_t *e = &cur.f[i];
            long base = split_cell(w, top, e->cell, &e->tape, e->single_use, defer, &next);
            if (base < 0) {
                frontier_free(b, next.f, next.n);
                goto fail;
            }
            top->nodes[e->slot] = OCT_NODE(OCT_INTERIOR, base);
        }
        frontier_free(b, cur.f, cur.n);
        cur = next;
    }
    *front = cur.f;
    *nfront = cur.n;
    return 0;
fail:
    frontier_free(b, cur.f, cur.n);
    return -1;
}

static void add_stats(oct_stats_t *to, const oct_stats_t *from)
{
    to->cells_visited += from->cells_visited;
    to->split += from->split;
    to->decided_interval += from->decided_interval;
    to->decided_lipschitz += from->decided_lipschitz;
    to->decided_ilie += from->decided_ilie;
    to->decided_refine += from->decided_refine;
    to->decided_max_depth += from->decided_max_depth;
    to->tape_clauses_evaluated += from->tape_clauses_evaluated;
    for (int d = 0; d <= OCT_MAX_DEPTH; d++) {
        to->leaves_by_depth[d] += from->leaves_by_depth[d];
        to->cells_by_depth[d] += from->cells_by_depth[d];
        to->tape_length_sum_by_depth[d] += from->tape_length_sum_by_depth[d];
        to->split_by_depth[d] += from->split_by_depth[d];
    }
    if (from->max_error_bound > to->max_error_bound)
        to->max_error_bound = from->max_error_bound;
}

static int check_params(const tape_t *t, const double box[6], const oct_params_t *p,
                        ivoct_error_t *err)
{
    if (!t || t->n == 0) {
        ivoct_error_set(err, "no expression to build");
        return -1;
    }
    if (oct_params_check(p, err))
        return -1;
    for (int k = 0; k < 3; k++)
        if (!isfinite(box[2 * k]) || !isfinite(box[2 * k + 1]) || box[2 * k] > box[2 * k + 1]) {
            ivoct_error_set(err, "box: bad %c range [%g, %g]", "xyz"[k], box[2 * k],
                            box[2 * k + 1]);
            return -1;
        }
    return 0;
}

int oct_build(const tape_t *t, const double box[6], const oct_params_t *params,
              oct_tree_t **out, ivoct_error_t *err)
{
    *out = NULL;
    if (check_params(t, box, params, err))
        return -1;
    double t0 = omp_get_wtime();
    build_t b;
    memset(&b, 0, sizeof b);
    b.tape = t;
    memcpy(b.box, box, sizeof b.box);
    b.max_depth = params->depth;
    b.tests = params->tests;
    b.refine = params->refine;
    b.slabs_unused = params->slabs_unused;
    b.choices = tape_has_choices(t);
    b.max_memory = params->max_memory;
    atomic_init(&b.bytes, 0);
    atomic_init(&b.peak, 0);
    atomic_init(&b.failed, 0);

    int nthreads = params->threads > 0 ? params->threads : omp_get_num_procs();
    worker_t *workers = calloc((size_t)nthreads, sizeof *workers);
    oct_tree_t *tree = calloc(1, sizeof *tree);
    pool_t top = {0};
    frontier_t *front = NULL;
    size_t nfront = 0;
    int ok = workers && tree;
    for (int i = 0; ok && i < nthreads; i++)
        ok = worker_init(&workers[i], &b) == 0;
    if (!ok) {
        ivoct_error_set(err, "out of memory");
        goto done;
    }

    b.single_use = tape_is_single_use(t, workers[0].scratch);
    if (top_phase(&workers[0], &top, &front, &nfront) == 0 && nfront > 0) {
        atomic_size_t finished;
        atomic_init(&finished, 0);
#pragma omp parallel for num_threads(nthreads) schedule(dynamic, 1)
        for (size_t i = 0; i < nfront; i++) {
            worker_t *w = &workers[omp_get_thread_num()];
            frontier_t *e = &front[i];
            e->base = build_subtree(w, &e->pool, e->cell, &e->tape, e->single_use);
            size_t done = atomic_fetch_add(&finished, 1) + 1;
            if (params->progress && omp_get_thread_num() == 0)
                params->progress(params->progress_user, (double)done / (double)nfront);
        }
    }

    int failed = atomic_load(&b.failed);
    if (!failed)
        pool_assemble(&b, &top, front, nfront, tree);
    failed = atomic_load(&b.failed);
    if (failed == BUILD_OVER_BUDGET) {
        ivoct_error_set(err, "memory budget of %zu bytes exceeded (raise --max-memory)",
                        b.max_memory);
        ok = 0;
    } else if (failed) {
        ivoct_error_set(err, "out of memory");
        ok = 0;
    }
    if (ok) {
        memcpy(tree->box, box, sizeof tree->box);
        tree->depth = params->depth;
        tree->tests = params->tests;
        tree->refine = params->refine;
        for (int i = 0; i < nthreads; i++)
            add_stats(&tree->stats, &workers[i].st);
        tree->stats.threads = nthreads;
        tree->stats.peak_bytes = atomic_load(&b.peak);
        tree->stats.time_s = omp_get_wtime() - t0;
        if (params->progress)
            params->progress(params->progress_user, 1.0);
    }

done:
    frontier_free(&b, front, nfront);
    pool_free(&b, &top);
    if (workers)
        for (int i = 0; i < nthreads; i++)
            worker_free(&workers[i]);
    free(workers);
    if (!ok) {
        oct_free(tree);
        return -1;
    }
    *out = tree;
    return 0;
}

void oct_free(oct_tree_t *tree)
{
    if (!tree)
        return;
    free(tree->nodes);
    free(tree->leaves);
    free(tree->slabs);
    free(tree);
}
