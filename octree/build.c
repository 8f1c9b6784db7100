/* ivoct — the octree builder: its two phases.
 *
 * A short breadth-first phase on one thread splits the box until there are
 * FRONTIER_CELLS cells to split (or none); then each of those cells' subtrees
 * is built by whichever thread is free, into a pool of its own, level by
 * level (a wavefront): all the cells of a level that share a tape are
 * classified in batches of CHAIN_BATCH children, so the evaluators get many
 * boxes per pass.  Pruned tapes are kept once per level (tape_set.h), so the
 * cells of a CSG scene whose pruned tapes are equal still share batches.  The
 * pools are concatenated in frontier order and the leaves put in Morton
 * order (pool.c), so the result depends neither on the number of threads nor
 * on how cells were batched (every lane of a pass is computed on its own). */
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "build_internal.h"
#include "tape_set.h"

/* Enough subtrees to keep 2..8 threads busy with dynamic scheduling; a fixed
 * number, so that the layout does not depend on the thread count. */
#define FRONTIER_CELLS 256

/* ---- workers ------------------------------------------------------------------- */

/* The chain's scratch: one block of CHAIN_BATCH entries of each array (the
 * arrays in decreasing alignment order, so each one starts aligned).  Returns
 * its size in bytes, 0 when out of memory. */
static size_t chain_scratch_init(chain_scratch_t *c)
{
    const size_t n = CHAIN_BATCH;
    size_t bytes = n * (sizeof *c->ilie + sizeof *c->open_ilie + sizeof *c->grad +
                        sizeof *c->open_grad + sizeof *c->open_boxes + sizeof *c->F +
                        sizeof *c->open_F + sizeof *c->centre + sizeof *c->open +
                        sizeof *c->thin);
    char *p = malloc(bytes);
    if (!p)
        return 0;
    c->ilie = (ilie_t *)p, p += n * sizeof *c->ilie;
    c->open_ilie = (ilie_t *)p, p += n * sizeof *c->open_ilie;
    c->grad = (iv_grad_t *)p, p += n * sizeof *c->grad;
    c->open_grad = (iv_grad_t *)p, p += n * sizeof *c->open_grad;
    c->open_boxes = (iv_box_t *)p, p += n * sizeof *c->open_boxes;
    c->F = (iv_t *)p, p += n * sizeof *c->F;
    c->open_F = (iv_t *)p, p += n * sizeof *c->open_F;
    c->centre = (double (*)[3])p, p += n * sizeof *c->centre;
    c->open = (int *)p, p += n * sizeof *c->open;
    c->thin = (int *)p;
    return bytes;
}

static struct wave *wave_new(void);
static void wave_free(build_t *b, struct wave *v);

static int worker_init(worker_t *w, build_t *b)
{
    memset(w, 0, sizeof *w);
    w->b = b;
    uint32_t n = b->tape->n;
    w->ws = tape_ws_new(n);
    w->scratch = malloc(3 * (size_t)n * sizeof *w->scratch);
    w->choices = b->choices ? malloc(CHAIN_BATCH * (size_t)n) : NULL;
    w->ilie_ws = (b->tests & OCT_TEST_ILIE) ? ilie_ws_new(n) : NULL;
    w->wave = wave_new();
    size_t chain_bytes = chain_scratch_init(&w->chain);
    if (!w->ws || !w->scratch || !w->wave || !chain_bytes || (b->choices && !w->choices) ||
        ((b->tests & OCT_TEST_ILIE) && !w->ilie_ws))
        return -1;
    build_account(b, (ptrdiff_t)((b->choices ? CHAIN_BATCH * (size_t)n : 0) +
                                 3 * (size_t)n * sizeof *w->scratch + chain_bytes +
                                 tape_ws_bytes(n) +
                                 ((b->tests & OCT_TEST_ILIE) ? ilie_ws_bytes(n) : 0)));
    return 0;
}

static void worker_free(worker_t *w)
{
    if (w->wave)
        wave_free(w->b, w->wave);
    pool_free(w->b, &w->work);
    arena_close(&w->arena);
    tape_ws_free(w->ws);
    ilie_ws_free(w->ilie_ws);
    free(w->chain.ilie); /* the chain's scratch block */
    free(w->scratch);
    free(w->choices);
}

static cell_t child_cell(cell_t p, int k)
{
    cell_t c = {2 * p.ix + (k & 1u), 2 * p.iy + (k >> 1 & 1u), 2 * p.iz + (k >> 2 & 1u),
                p.depth + 1, p.code << 3 | (uint64_t)k};
    return c;
}

static void count_split(worker_t *w, cell_t cell, const tape_t *t)
{
    w->st.split++;
    w->st.split_by_depth[cell.depth]++;
    w->st.tape_length_sum_by_depth[cell.depth] += t->n;
}

/* The node word of a child the chain decided is empty or a leaf (stored in
 * pool p); -1 on failure. */
static long settled_node(worker_t *w, pool_t *p, cell_t kid, const decision_t *d)
{
    if (d->kind == EMPTY)
        return (long)OCT_NODE(OCT_EMPTY, d->cls);
    long leaf = pool_leaf(w->b, p, kid, d);
    return leaf < 0 ? -1 : (long)OCT_NODE(OCT_LEAF, leaf);
}

/* ---- phase 2: a subtree, level by level ------------------------------------------- */

/* A cell of a level, to split: its tape is an id in the level's tape set, or
 * WAVE_OWN_TAPE for the subtree's own tape; slot is its node word in the
 * pool (WAVE_NO_SLOT for the subtree's root, whose block is returned). */
typedef struct wave_cell {
    cell_t cell;
    uint32_t tape;
    uint32_t slot;
} wave_cell_t;

#define WAVE_OWN_TAPE UINT32_MAX
#define WAVE_NO_SLOT UINT32_MAX

/* Parents per chain_classify call */
#define WAVE_PARENTS (CHAIN_BATCH / 8)

struct wave {
    wave_cell_t *cur, *next;
    size_t ncur, nnext, cap_cur, cap_next;
    uint32_t *order;      /* cur sorted by tape (stable) */
    size_t cap_order;
    uint32_t *first;      /* per tape id + 1: start of its run in order */
    size_t cap_first;
    tape_set_t sets[2];   /* cur's tapes, next's tapes */
    size_t set_bytes;     /* accounted so far */
    cell_t kids[CHAIN_BATCH];
    iv_box_t boxes[CHAIN_BATCH];
    decision_t dec[CHAIN_BATCH];
    long base[WAVE_PARENTS];
};
typedef struct wave wave_t;

static wave_t *wave_new(void) { return calloc(1, sizeof(wave_t)); }

static void wave_free(build_t *b, wave_t *v)
{
    build_account(b, -(ptrdiff_t)((v->cap_cur + v->cap_next) * sizeof *v->cur +
                                  v->cap_order * sizeof *v->order +
                                  v->cap_first * sizeof *v->first + v->set_bytes));
    free(v->cur), free(v->next), free(v->order), free(v->first);
    tape_set_free(&v->sets[0]);
    tape_set_free(&v->sets[1]);
    free(v);
}

static int wave_push(build_t *b, wave_t *v, cell_t c, uint32_t tape, size_t slot)
{
    wave_cell_t *q = build_grow(b, v->next, &v->cap_next, v->nnext + 1, sizeof *q);
    if (!q)
        return -1;
    v->next = q;
    q[v->nnext++] = (wave_cell_t){c, tape, (uint32_t)slot};
    return 0;
}

/* Order the level's cells by tape id (a counting sort, stable: the order
 * within a tape is the order of the level). */
static int wave_order(build_t *b, wave_t *v, size_t ntapes)
{
    uint32_t *o = build_grow(b, v->order, &v->cap_order, v->ncur, sizeof *o);
    if (!o)
        return -1;
    v->order = o;
    uint32_t *f = build_grow(b, v->first, &v->cap_first, ntapes + 2, sizeof *f);
    if (!f)
        return -1;
    v->first = f;
    memset(f, 0, (ntapes + 2) * sizeof *f);
    /* WAVE_OWN_TAPE sorts last, as id ntapes */
#define WAVE_KEY(t) ((t) == WAVE_OWN_TAPE ? ntapes : (size_t)(t))
    for (size_t i = 0; i < v->ncur; i++)
        f[WAVE_KEY(v->cur[i].tape) + 1]++;
    for (size_t k = 1; k < ntapes + 2; k++)
        f[k] += f[k - 1];
    /* f[key] is the start of run key; placing advances it to the run's end */
    for (size_t i = 0; i < v->ncur; i++)
        o[f[WAVE_KEY(v->cur[i].tape)]++] = (uint32_t)i;
    /* shift the ends back to starts */
    for (size_t k = ntapes + 1; k > 0; k--)
        f[k] = f[k - 1];
    f[0] = 0;
#undef WAVE_KEY
    return 0;
}

/* Split the cells order[from..to) of the current level (all with tape t, id
 * tid) in batches: their children are classified together, settled ones
 * stored, the others pushed to the next level with their pruned tapes. */
static int wave_split_run(worker_t *w, wave_t *v, pool_t *p, const tape_t *t, int single_use,
                          uint32_t tid, size_t from, size_t to, long *root_base)
{
    build_t *b = w->b;
    tape_set_t *nset = &v->sets[1];
    long inherited = -1; /* t's id in the next set, once a child keeps it */
    for (size_t i0 = from; i0 < to; i0 += WAVE_PARENTS) {
        size_t np = to - i0 < WAVE_PARENTS ? to - i0 : WAVE_PARENTS;
        for (size_t j = 0; j < np; j++) {
            const wave_cell_t *e = &v->cur[v->order[i0 + j]];
            count_split(w, e->cell, t);
            v->base[j] = pool_block(b, p);
            if (v->base[j] < 0)
                return -1;
            if (e->slot == WAVE_NO_SLOT)
                *root_base = v->base[j];
            else
                p->nodes[e->slot] = OCT_NODE(OCT_INTERIOR, (size_t)v->base[j]);
            for (int k = 0; k < 8; k++)
                v->kids[8 * j + (size_t)k] = child_cell(e->cell, k);
            chain_children_boxes(b, e->cell, v->boxes + 8 * j);
        }
        int m = (int)(8 * np);
        chain_classify(w, t, single_use, v->kids, v->boxes, m, v->dec);
        for (int i = 0; i < m; i++) {
            size_t slot = (size_t)v->base[i / 8] + (size_t)(i % 8);
            const decision_t *d = &v->dec[i];
            if (d->kind != SPLIT) {
                long node = settled_node(w, p, v->kids[i], d);
                if (node < 0)
                    return -1;
                p->nodes[slot] = (oct_node_t)node;
                continue;
            }
            uint32_t kid_tape = WAVE_OWN_TAPE;
            tape_clause_t *room = b->choices ? tape_set_reserve(nset, t->n) : NULL;
            if (b->choices && !room)
                goto oom;
            tape_t pruned;
            if (b->choices && chain_prune(w, t, i, room, &pruned)) {
                long id = tape_set_commit(nset, pruned.n);
                if (id < 0)
                    goto oom;
                kid_tape = (uint32_t)id;
            } else if (tid != WAVE_OWN_TAPE) {
                /* keeps t: a copy in the next level's set, made once per run */
                if (inherited < 0) {
                    memcpy(room, t->clauses, t->n * sizeof *t->clauses);
                    inherited = tape_set_commit(nset, t->n);
                    if (inherited < 0)
                        goto oom;
                }
                kid_tape = (uint32_t)inherited;
            }
            p->nodes[slot] = 0; /* filled when its block is made */
            if (wave_push(b, v, v->kids[i], kid_tape, slot))
                return -1;
        }
    }
    return 0;
oom:
    atomic_store(&b->failed, BUILD_OUT_OF_MEMORY);
    return -1;
}

/* Build the subtree below a cell to split (tape t) into pool p.  Returns the
 * index of its children's block in the pool, or -1 on failure. */
static long build_subtree(worker_t *w, wave_t *v, pool_t *p, cell_t cell, const tape_t *t,
                          int single_use)
{
    build_t *b = w->b;
    long root_base = -1;
    v->ncur = v->nnext = 0;
    tape_set_clear(&v->sets[0]);
    tape_set_clear(&v->sets[1]);
    if (wave_push(b, v, cell, WAVE_OWN_TAPE, WAVE_NO_SLOT))
        return -1;
    while (v->nnext > 0) {
        if (atomic_load_explicit(&b->failed, memory_order_relaxed))
            return -1;
        /* the next level becomes the current one */
        wave_cell_t *tc = v->cur;
        size_t tcap = v->cap_cur;
        v->cur = v->next, v->cap_cur = v->cap_next, v->ncur = v->nnext;
        v->next = tc, v->cap_next = tcap, v->nnext = 0;
        tape_set_t ts = v->sets[0];
        v->sets[0] = v->sets[1];
        v->sets[1] = ts;
        tape_set_clear(&v->sets[1]);

        size_t ntapes = v->sets[0].n_tapes;
        if (wave_order(b, v, ntapes))
            return -1;
        for (size_t key = 0; key <= ntapes; key++) {
            size_t from = v->first[key], to = v->first[key + 1];
            if (from == to)
                continue;
            uint32_t tid = key == ntapes ? WAVE_OWN_TAPE : (uint32_t)key;
            tape_t run_tape = tid == WAVE_OWN_TAPE ? *t : tape_set_get(&v->sets[0], tid);
            int su = tid == WAVE_OWN_TAPE ? single_use
                                          : single_use || v->sets[0].tapes[tid].single_use;
            if (wave_split_run(w, v, p, &run_tape, su, tid, from, to, &root_base))
                return -1;
        }
        size_t bytes = tape_set_bytes(&v->sets[0]) + tape_set_bytes(&v->sets[1]);
        build_account(b, (ptrdiff_t)bytes - (ptrdiff_t)v->set_bytes);
        v->set_bytes = bytes;
    }
    return root_base;
}

/* ---- phase 1: the top of the tree, breadth-first ----------------------------------------- */

typedef struct next_level {
    frontier_t *f;
    size_t n, cap;
} next_level_t;

/* Append cell c (tape t, copied unless it is the root tape) to the level. */
static int frontier_push(build_t *b, next_level_t *l, cell_t c, const tape_t *t, int single_use,
                         size_t slot)
{
    frontier_t **f = &l->f;
    size_t *n = &l->n, *cap = &l->cap;
    frontier_t *q = build_grow(b, *f, cap, *n + 1, sizeof *q);
    if (!q)
        return -1;
    *f = q;
    frontier_t *e = &q[(*n)++];
    memset(e, 0, sizeof *e);
    e->cell = c;
    e->slot = slot;
    e->single_use = single_use;
    if (t->clauses == b->tape->clauses) {
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

/* Split cell e of the top phase into a new block of the top pool: its
 * children are classified, the settled ones stored, the others pushed to
 * next with their pruned tapes (room: t->n clauses).  The block's index, or
 * -1. */
static long top_split(worker_t *w, pool_t *top, const frontier_t *e, next_level_t *next,
                      tape_clause_t *room)
{
    build_t *b = w->b;
    cell_t kids[8];
    decision_t dec[8];
    iv_box_t boxes[8];
    count_split(w, e->cell, &e->tape);
    for (int k = 0; k < 8; k++)
        kids[k] = child_cell(e->cell, k);
    chain_children_boxes(b, e->cell, boxes);
    chain_classify(w, &e->tape, e->single_use, kids, boxes, 8, dec);
    long base = pool_block(b, top);
    if (base < 0)
        return -1;
    for (int k = 0; k < 8; k++) {
        size_t slot = (size_t)base + (size_t)k;
        if (dec[k].kind != SPLIT) {
            long node = settled_node(w, top, kids[k], &dec[k]);
            if (node < 0)
                return -1;
            top->nodes[slot] = (oct_node_t)node;
            continue;
        }
        tape_t pruned;
        const tape_t *kt = &e->tape;
        int su = e->single_use;
        if (chain_prune(w, &e->tape, k, room, &pruned)) {
            kt = &pruned;
            su = su || tape_is_single_use(&pruned, w->scratch);
        }
        top->nodes[slot] = 0; /* filled by the assembly */
        if (frontier_push(b, next, kids[k], kt, su, slot))
            return -1;
    }
    return base;
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
    tape_clause_t *room = malloc(b->tape->n * sizeof *room);
    if (!room) {
        atomic_store(&b->failed, BUILD_OUT_OF_MEMORY);
        return -1;
    }
    if (frontier_push(b, &cur, root, b->tape, b->single_use, 0))
        goto fail;

    while (cur.n > 0 && cur.n < FRONTIER_CELLS) {
        next_level_t next = {0};
        for (size_t i = 0; i < cur.n; i++) {
            frontier_t *e = &cur.f[i];
            long base = top_split(w, top, e, &next, room);
            if (base < 0) {
                frontier_free(b, next.f, next.n);
                goto fail;
            }
            top->nodes[e->slot] = OCT_NODE(OCT_INTERIOR, base);
        }
        frontier_free(b, cur.f, cur.n);
        cur = next;
    }
    free(room);
    *front = cur.f;
    *nfront = cur.n;
    return 0;
fail:
    free(room);
    frontier_free(b, cur.f, cur.n);
    return -1;
}

void oct_stats_add(oct_stats_t *to, const oct_stats_t *from)
{
    to->cells_visited += from->cells_visited;
    to->split += from->split;
    to->decided_interval += from->decided_interval;
    to->decided_lipschitz += from->decided_lipschitz;
    to->decided_ilie += from->decided_ilie;
    to->decided_refine += from->decided_refine;
    to->decided_max_depth += from->decided_max_depth;
    to->tape_clauses_evaluated += from->tape_clauses_evaluated;
    to->leaves_certain += from->leaves_certain;
    to->certain_time_s += from->certain_time_s;
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

/* ---- the plan: oct_build in parts (octree.h) ---------------------------------------- */

struct oct_plan {
    build_t b;
    oct_params_t params;
    int nthreads;
    worker_t *workers; /* their stats count the top phase only */
    pool_t top;
    frontier_t *front;
    size_t nfront;
    double t0;
    int finished;      /* oct_plan_finish took the pools */
    arena_chunk_t *put_arena; /* the chunk oct_plan_put copies subtrees to */
};

/* The build's failure as a message; 0 when it has not failed. */
static int plan_failed(oct_plan_t *pl, ivoct_error_t *err)
{
    int failed = atomic_load(&pl->b.failed);
    if (failed == BUILD_OVER_BUDGET)
        ivoct_error_set(err, "memory budget of %zu bytes exceeded (raise --max-memory)",
                        pl->b.max_memory);
    else if (failed)
        ivoct_error_set(err, "out of memory");
    return failed ? -1 : 0;
}

void oct_plan_free(oct_plan_t *pl)
{
    if (!pl)
        return;
    frontier_free(&pl->b, pl->front, pl->nfront);
    arena_close(&pl->put_arena);
    pool_free(&pl->b, &pl->top);
    if (pl->workers)
        for (int i = 0; i < pl->nthreads; i++)
            worker_free(&pl->workers[i]);
    free(pl->workers);
    free(pl);
}

int oct_plan_new(const tape_t *t, const double box[6], const oct_params_t *params,
                 oct_plan_t **out, ivoct_error_t *err)
{
    *out = NULL;
    if (check_params(t, box, params, err))
        return -1;
    oct_plan_t *pl = calloc(1, sizeof *pl);
    if (!pl) {
        ivoct_error_set(err, "out of memory");
        return -1;
    }
    pl->t0 = omp_get_wtime();
    pl->params = *params;
    build_t *b = &pl->b;
    b->tape = t;
    memcpy(b->box, box, sizeof b->box);
    b->max_depth = params->depth;
    b->tests = params->tests;
    b->refine = params->refine;
    b->slabs_unused = params->slabs_unused;
    b->choices = tape_has_choices(t);
    b->max_memory = params->max_memory;
    atomic_init(&b->bytes, 0);
    atomic_init(&b->peak, 0);
    atomic_init(&b->failed, 0);

    pl->nthreads = params->threads > 0 ? params->threads : omp_get_num_procs();
    pl->workers = calloc((size_t)pl->nthreads, sizeof *pl->workers);
    int ok = pl->workers != NULL;
    for (int i = 0; ok && i < pl->nthreads; i++)
        ok = worker_init(&pl->workers[i], b) == 0;
    if (!ok) {
        ivoct_error_set(err, "out of memory");
        oct_plan_free(pl);
        return -1;
    }
    b->single_use = tape_is_single_use(t, pl->workers[0].scratch);
    if (top_phase(&pl->workers[0], &pl->top, &pl->front, &pl->nfront)) {
        if (!plan_failed(pl, err))
            ivoct_error_set(err, "out of memory");
        oct_plan_free(pl);
        return -1;
    }
    *out = pl;
    return 0;
}

size_t oct_plan_subtrees(const oct_plan_t *pl) { return pl->nfront; }

int oct_plan_subtree_depth(const oct_plan_t *pl)
{
    return pl->nfront ? pl->front[0].cell.depth : 0;
}

uint64_t oct_plan_subtree_code(const oct_plan_t *pl, size_t i) { return pl->front[i].cell.code; }

int oct_plan_has(const oct_plan_t *pl, size_t i)
{
    return i < pl->nfront && pl->front[i].present;
}

int oct_plan_build(oct_plan_t *pl, const size_t *which, size_t n, ivoct_error_t *err)
{
    if (pl->finished) {
        ivoct_error_set(err, "the plan is finished");
        return -1;
    }
    for (size_t k = 0; k < n; k++)
        if (which[k] >= pl->nfront) {
            ivoct_error_set(err, "no subtree %zu (the plan has %zu)", which[k], pl->nfront);
            return -1;
        }
    const oct_params_t *params = &pl->params;
    atomic_size_t finished;
    atomic_init(&finished, 0);
    /* dynamic: subtrees differ in cost by orders of magnitude */
#pragma omp parallel for num_threads(pl->nthreads) schedule(dynamic, 1)
    for (size_t k = 0; k < n; k++) {
        frontier_t *e = &pl->front[which[k]];
        if (e->present)
            continue;
        worker_t *w = &pl->workers[omp_get_thread_num()];
        /* the subtree's counts on their own, so that a part of the tree (or a
           subtree sent elsewhere) carries its own; the worker keeps the top's */
        oct_stats_t kept = w->st;
        leaf_diagonal_t kept_diagonal = w->diagonal;
        memset(&w->st, 0, sizeof w->st);
        w->diagonal = (leaf_diagonal_t){0, {0, 0, 0}};
        pool_clear(&w->work);
        e->base = build_subtree(w, w->wave, &w->work, e->cell, &e->tape, e->single_use);
        if (e->base >= 0) {
            const pool_t *p = &w->work;
            oct_subtree_t built = {.base = (uint32_t)e->base,
                                   .n_nodes = (uint32_t)p->n,
                                   .n_leaves = (uint32_t)p->nl,
                                   .nodes = p->nodes,
                                   .leaves = p->leaves,
                                   .slabs = build_keeps_slabs(w->b) ? p->slabs : NULL};
            if (pool_morton(w->b, &built, 0, &w->arena, &e->pool))
                e->base = -1;
        }
        e->st = w->st;
        e->max_diagonal2 = w->diagonal.d2;
        e->present = e->base >= 0;
        w->st = kept;
        w->diagonal = kept_diagonal;
        size_t done = atomic_fetch_add(&finished, 1) + 1;
        if (params->progress && omp_get_thread_num() == 0)
            params->progress(params->progress_user, (double)done / (double)n);
    }
    /* the workers' pools are not needed until the next call */
    for (int i = 0; i < pl->nthreads; i++) {
        pool_free(&pl->b, &pl->workers[i].work);
        arena_close(&pl->workers[i].arena);
    }
    return plan_failed(pl, err);
}

int oct_plan_get(const oct_plan_t *pl, size_t i, oct_subtree_t *out)
{
    if (!oct_plan_has(pl, i) || pl->finished)
        return -1;
    const frontier_t *e = &pl->front[i];
    out->base = (uint32_t)e->base;
    out->n_nodes = (uint32_t)e->pool.n;
    out->n_leaves = (uint32_t)e->pool.nl;
    out->nodes = e->pool.nodes;
    out->leaves = e->pool.leaves;
    out->slabs = build_keeps_slabs(&pl->b) ? e->pool.slabs : NULL;
    out->stats = e->st;
    out->max_diagonal2 = e->max_diagonal2;
    return 0;
}

/* A subtree's words index its own arrays, the children of each interior word
 * after it (as the build makes them), and base is a block. */
static int subtree_valid(const oct_subtree_t *s)
{
    if (s->n_nodes < 8 || s->base > s->n_nodes - 8 || s->base % 8)
        return 0;
    for (uint32_t j = 0; j < s->n_nodes; j++) {
        oct_node_t v = s->nodes[j];
        uint32_t kind = OCT_NODE_KIND(v), val = OCT_NODE_VALUE(v);
        if ((kind == OCT_INTERIOR && (val > s->n_nodes - 8 || val % 8 || val <= j)) ||
            (kind == OCT_LEAF && val >= s->n_leaves) || (kind == OCT_EMPTY && val > OCT_UNDEFINED) ||
            kind > OCT_EMPTY)
            return 0;
    }
    return 1;
}

int oct_plan_put(oct_plan_t *pl, size_t i, const oct_subtree_t *in, ivoct_error_t *err)
{
    if (pl->finished || i >= pl->nfront) {
        ivoct_error_set(err, "no subtree %zu to put (the plan has %zu)", i, pl->nfront);
        return -1;
    }
    int slabs = build_keeps_slabs(&pl->b);
    if (!subtree_valid(in) || (slabs && in->n_leaves && !in->slabs)) {
        ivoct_error_set(err, "subtree %zu is corrupt", i);
        return -1;
    }
    frontier_t *e = &pl->front[i];
    pool_free(&pl->b, &e->pool);
    e->present = 0;
    /* another process's subtree: its leaves may come in any order */
    oct_subtree_t src = *in;
    if (!slabs)
        src.slabs = NULL;
    int morton = pool_morton(&pl->b, &src, 1, &pl->put_arena, &e->pool);
    if (morton == -2) {
        ivoct_error_set(err, "subtree %zu is corrupt", i);
        return -1;
    }
    if (morton)
        return plan_failed(pl, err) ? -1 : (ivoct_error_set(err, "out of memory"), -1);
    e->base = (long)in->base;
    e->st = in->stats;
    e->max_diagonal2 = in->max_diagonal2;
    e->present = 1;
    return 0;
}

int oct_plan_finish(oct_plan_t *pl, unsigned flags, oct_tree_t **out, ivoct_error_t *err)
{
    *out = NULL;
    if (pl->finished) {
        ivoct_error_set(err, "the plan is finished");
        return -1;
    }
    int part = (flags & OCT_PLAN_PART) != 0;
    int top = !part || !(flags & OCT_PLAN_NO_TOP);
    size_t held = 0;
    for (size_t i = 0; i < pl->nfront; i++)
        held += pl->front[i].present != 0;
    if (!part && held < pl->nfront) {
        ivoct_error_set(err, "%zu of the %zu subtrees are missing", pl->nfront - held, pl->nfront);
        return -1;
    }
    oct_tree_t *tree = calloc(1, sizeof *tree);
    frontier_t *front = pl->front;
    if (held < pl->nfront)
        front = malloc((held ? held : 1) * sizeof *front);
    if (!tree || (held < pl->nfront && !front)) {
        free(tree);
        if (front != pl->front)
            free(front);
        ivoct_error_set(err, "out of memory");
        return -1;
    }
    if (front != pl->front) {
        /* the subtrees held, in frontier order (the assembly's Morton walk
           relies on it); the others' cells are left empty */
        size_t k = 0;
        for (size_t i = 0; i < pl->nfront; i++) {
            if (pl->front[i].present)
                front[k++] = pl->front[i];
            else
                pl->top.nodes[pl->front[i].slot] = OCT_NODE(OCT_EMPTY, OCT_OUTSIDE);
        }
    }
    if (!top) {
        /* the leaves above the frontier stay out of this part */
        for (size_t j = 0; j < pl->top.n; j++)
            if (OCT_NODE_KIND(pl->top.nodes[j]) == OCT_LEAF)
                pl->top.nodes[j] = OCT_NODE(OCT_EMPTY, OCT_OUTSIDE);
        pl->top.nl = 0;
    }
    pl->finished = 1;
    arena_close(&pl->put_arena); /* so that the assembly frees it with its last pool */
    pool_assemble(&pl->b, &pl->top, front, held, tree);
    if (front != pl->front) {
        /* the held pools belong to the copies now: the assembly freed some */
        for (size_t k = 0; k < held; k++)
            pool_free(&pl->b, &front[k].pool);
        for (size_t i = 0; i < pl->nfront; i++)
            if (pl->front[i].present)
                memset(&pl->front[i].pool, 0, sizeof pl->front[i].pool);
        free(front);
    }
    if (plan_failed(pl, err)) {
        oct_free(tree);
        return -1;
    }
    const oct_params_t *params = &pl->params;
    memcpy(tree->box, pl->b.box, sizeof tree->box);
    tree->depth = params->depth;
    tree->tests = params->tests;
    tree->refine = params->refine;
    double d2 = 0;
    if (top)
        for (int i = 0; i < pl->nthreads; i++) {
            oct_stats_add(&tree->stats, &pl->workers[i].st);
            d2 = pl->workers[i].diagonal.d2 > d2 ? pl->workers[i].diagonal.d2 : d2;
        }
    for (size_t i = 0; i < pl->nfront; i++)
        if (pl->front[i].present) {
            oct_stats_add(&tree->stats, &pl->front[i].st);
            d2 = pl->front[i].max_diagonal2 > d2 ? pl->front[i].max_diagonal2 : d2;
        }
    /* the leaves without a slab: their largest diagonal (cell.c) */
    double diagonal = d2 > 0 ? cell_diagonal_of_squared(d2) : 0.0;
    if (diagonal > tree->stats.max_error_bound)
        tree->stats.max_error_bound = diagonal;
    tree->stats.threads = pl->nthreads;
    tree->stats.peak_bytes = atomic_load(&pl->b.peak);
    tree->stats.time_s = omp_get_wtime() - pl->t0;
    if (params->progress)
        params->progress(params->progress_user, 1.0);
    *out = tree;
    return 0;
}

int oct_build(const tape_t *t, const double box[6], const oct_params_t *params,
              oct_tree_t **out, ivoct_error_t *err)
{
    *out = NULL;
    oct_plan_t *pl;
    if (oct_plan_new(t, box, params, &pl, err))
        return -1;
    size_t n = oct_plan_subtrees(pl);
    size_t *all = malloc((n ? n : 1) * sizeof *all);
    int rc = all ? 0 : -1;
    if (!all)
        ivoct_error_set(err, "out of memory");
    for (size_t i = 0; i < n && all; i++)
        all[i] = i;
    if (!rc)
        rc = oct_plan_build(pl, all, n, err);
    free(all);
    if (!rc)
        rc = oct_plan_finish(pl, 0, out, err);
    oct_plan_free(pl);
    return rc;
}

void oct_free(oct_tree_t *tree)
{
    if (!tree)
        return;
    free(tree->nodes);
    free(tree->leaves);
    free(tree->slabs);
    free(tree->certain);
    free(tree);
}
