/* ivoct — the octree builder.
 *
 * Two phases.  A short breadth-first phase on one thread splits the box until
 * there are FRONTIER_CELLS cells to split (or none); then each of those cells'
 * subtrees is built depth-first by whichever thread is free, into a pool of
 * its own.  The pools are concatenated in frontier order and the leaves put
 * in Morton order by one depth-first pass, so the result does not depend on
 * the number of threads.
 *
 * Every cell is classified together with its 7 siblings: one interval
 * evaluation of the parent's (pruned) tape over the 8 boxes, then, for the
 * children it could not decide, one gradient evaluation and one evaluation at
 * the centres for the Lipschitz test.  Children that are split get the
 * parent's tape pruned to their own box. */
#include <math.h>
#include <omp.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "../ilie/ilie.h"
#include "octree.h"

/* Enough subtrees to keep 2..8 threads busy with dynamic scheduling; a fixed
 * number, so that the layout does not depend on the thread count. */
#define FRONTIER_CELLS 256

typedef struct cell {
    uint32_t ix, iy, iz;
    int depth;
    uint64_t code; /* Morton code at its depth */
} cell_t;

enum { SPLIT, LEAF, EMPTY };

typedef struct decision {
    int kind;
    oct_class_t cls;  /* EMPTY */
    iv_t F;           /* enclosure of f over the cell */
    const tape_t *tape; /* SPLIT: the tape for its children */
    int single_use;     /* SPLIT: tape_is_single_use(tape) */
    oct_slab_t slab;    /* LEAF: its slab (n = 0 when none) */
} decision_t;

typedef struct build {
    const tape_t *tape;
    double box[6];
    int max_depth;
    unsigned tests;
    double refine;
    int slabs_unused;           /* oct_params_t.slabs_unused */
    int choices;                /* the tape has min/max/abs to prune */
    int single_use;             /* the root tape is a single-use expression */
    size_t max_memory;
    atomic_size_t bytes, peak;
    atomic_int failed;          /* 1: memory budget, 2: out of memory */
} build_t;

typedef struct pool {
    oct_node_t *nodes;
    size_t n, cap;
    oct_leaf_t *leaves;
    oct_slab_t *slabs; /* parallel to leaves, with the ilie test */
    size_t nl, capl, caps;
} pool_t;

typedef struct worker {
    build_t *b;
    tape_ws_t *ws, *ws_centre;
    ilie_ws_t *ilie_ws;         /* only with the ilie test */
    tape_clause_t *tape_store;  /* (OCT_MAX_DEPTH + 1) * 8 pruned tapes */
    tape_t tapes[OCT_MAX_DEPTH + 1][8];
    uint32_t *scratch;
    /* Scratch of one classify call (8 cells at most), here rather than on the
     * stack: the passes fill only the entries of the cells still open, which
     * gcc's -Wmaybe-uninitialized cannot follow through the `open` indices. */
    iv_box_t open_boxes[8]; /* the open cells' boxes, packed, for one pass */
    iv_grad_t grad[8];      /* by cell: the gradient, where gradient_pass ran */
    oct_stats_t st;
} worker_t;

/* ---- memory accounting --------------------------------------------------------- */

static void account(build_t *b, ptrdiff_t delta)
{
    size_t now = atomic_fetch_add(&b->bytes, (size_t)delta) + (size_t)delta;
    size_t peak = atomic_load(&b->peak);
    while (now > peak && !atomic_compare_exchange_weak(&b->peak, &peak, now))
        ;
    if (b->max_memory && now > b->max_memory) {
        int expected = 0;
        atomic_compare_exchange_strong(&b->failed, &expected, 1);
    }
}

static void *grow(build_t *b, void *p, size_t *cap, size_t need, size_t size)
{
    if (need <= *cap)
        return p;
    size_t cap2 = *cap ? *cap : 64;
    while (cap2 < need)
        cap2 *= 2;
    void *q = realloc(p, cap2 * size);
    if (!q) {
        int expected = 0;
        atomic_compare_exchange_strong(&b->failed, &expected, 2);
        return NULL;
    }
    account(b, (ptrdiff_t)((cap2 - *cap) * size));
    *cap = cap2;
    return q;
}

/* Reserve 8 contiguous nodes; returns the index of the first, or -1. */
static long pool_block(build_t *b, pool_t *p)
{
    oct_node_t *q = grow(b, p->nodes, &p->cap, p->n + 8, sizeof *q);
    if (!q)
        return -1;
    p->nodes = q;
    p->n += 8;
    return (long)(p->n - 8);
}

/* Are the leaves' slabs stored (in the array parallel to the leaves)? */
static int keeps_slabs(const build_t *b)
{
    return (b->tests & OCT_TEST_ILIE) && !b->slabs_unused;
}

static long pool_leaf(build_t *b, pool_t *p, cell_t c, const decision_t *d)
{
    iv_t F = d->F;
    oct_leaf_t *q = grow(b, p->leaves, &p->capl, p->nl + 1, sizeof *q);
    if (!q)
        return -1;
    p->leaves = q;
    if (keeps_slabs(b)) {
        oct_slab_t *sl = grow(b, p->slabs, &p->caps, p->nl + 1, sizeof *sl);
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

static void pool_free(build_t *b, pool_t *p)
{
    account(b, -(ptrdiff_t)(p->cap * sizeof *p->nodes + p->capl * sizeof *p->leaves +
                            p->caps * sizeof *p->slabs));
    free(p->nodes);
    free(p->leaves);
    free(p->slabs);
    memset(p, 0, sizeof *p);
}

/* ---- workers ------------------------------------------------------------------- */

static int worker_init(worker_t *w, build_t *b)
{
    memset(w, 0, sizeof *w);
    w->b = b;
    uint32_t n = b->tape->n;
    w->ws = tape_ws_new(n);
    w->ws_centre = tape_ws_new(n);
    w->scratch = malloc(3 * (size_t)n * sizeof *w->scratch);
    size_t ntapes = (size_t)(OCT_MAX_DEPTH + 1) * 8;
    w->tape_store = b->choices ? malloc(ntapes * n * sizeof *w->tape_store) : NULL;
    w->ilie_ws = (b->tests & OCT_TEST_ILIE) ? ilie_ws_new(n) : NULL;
    if (!w->ws || !w->ws_centre || !w->scratch || (b->choices && !w->tape_store) ||
        ((b->tests & OCT_TEST_ILIE) && !w->ilie_ws))
        return -1;
    if (b->choices)
        for (int d = 0; d <= OCT_MAX_DEPTH; d++)
            for (int k = 0; k < 8; k++)
                w->tapes[d][k].clauses = w->tape_store + ((size_t)d * 8 + (size_t)k) * n;
    /* the workspaces hold 8 lanes of every slot: interval, gradient, point */
    account(b, (ptrdiff_t)(w->b->choices ? ntapes * n * sizeof *w->tape_store : 0) +
                   (ptrdiff_t)(2 * (size_t)n * TAPE_LANES * (sizeof(double) + sizeof(iv_t) +
                                                             sizeof(iv_grad_t))));
    return 0;
}

static void worker_free(worker_t *w)
{
    tape_ws_free(w->ws);
    tape_ws_free(w->ws_centre);
    ilie_ws_free(w->ilie_ws);
    free(w->scratch);
    free(w->tape_store);
}

/* ---- the test chain -------------------------------------------------------------- */

/* Kalra-Barr: |f(c)| > L r with L >= sup |grad f| over the cell and r >= the
 * distance from c to any point of the cell: no zero in the cell.  Every
 * quantity is an interval bound taken on the safe side; an unbounded or
 * undefined gradient (a domain edge, a pole) gives L = inf: no decision. */
static int lipschitz_excludes(const iv_box_t *box, iv_t fc, const double c[3], iv_grad_t g,
                              oct_class_t *cls)
{
    double mig = fc.lo > 0 ? fc.lo : fc.hi < 0 ? -fc.hi : 0.0;
    if (!(mig > 0))
        return 0;
    const iv_t *ax[3] = {&box->x, &box->y, &box->z};
    const iv_t d[3] = {g.dx, g.dy, g.dz};
    iv_t r2 = {0, 0}, L2 = {0, 0};
    for (int k = 0; k < 3; k++) {
        double rk = iv_up(fmax(c[k] - ax[k]->lo, ax[k]->hi - c[k]));
        double gk = fmax(fabs(d[k].lo), fabs(d[k].hi));
        r2 = iv_add(r2, iv_sqr(iv_point(rk)));
        L2 = iv_add(L2, iv_sqr(iv_point(gk)));
    }
    double bound = iv_mul(iv_sqrt(L2), iv_sqrt(r2)).hi;
    if (!(mig > bound))
        return 0;
    *cls = fc.lo > 0 ? OCT_OUTSIDE : OCT_INSIDE;
    return 1;
}

static oct_class_t class_of(iv_t F)
{
    return iv_is_empty(F) ? OCT_UNDEFINED : F.lo > 0 ? OCT_OUTSIDE : OCT_INSIDE;
}

/* The boxes of the 8 children of a cell: 9 bounds per axis pair, computed once. */
static void children_boxes(const build_t *b, cell_t p, iv_box_t *boxes)
{
    uint32_t i[3] = {p.ix, p.iy, p.iz};
    double lo[3], mid[3], hi[3];
    for (int a = 0; a < 3; a++) {
        lo[a] = oct_coord(b->box[2 * a], b->box[2 * a + 1], 2 * (uint64_t)i[a], p.depth + 1);
        mid[a] = oct_coord(b->box[2 * a], b->box[2 * a + 1], 2 * (uint64_t)i[a] + 1, p.depth + 1);
        hi[a] = oct_coord(b->box[2 * a], b->box[2 * a + 1], 2 * (uint64_t)i[a] + 2, p.depth + 1);
    }
    for (int k = 0; k < 8; k++) {
        int s[3] = {k & 1, k >> 1 & 1, k >> 2 & 1};
        iv_t r[3];
        for (int a = 0; a < 3; a++)
            r[a] = s[a] ? iv_make(mid[a], hi[a]) : iv_make(lo[a], mid[a]);
        boxes[k] = (iv_box_t){r[0], r[1], r[2]};
    }
}

/* Gradient-adaptive refinement's "no fold" condition: every gradient in G
 * makes an angle below 60 degrees with the slab's normal a, i.e.
 * g.a > |g| |a| / 2 for every g in G, checked on the safe side. */
static int normals_within_60_degrees(const ilie_t *l, iv_grad_t G)
{
    iv_t a[3] = {iv_point(l->a[0]), iv_point(l->a[1]), iv_point(l->a[2])};
    iv_t g[3] = {G.dx, G.dy, G.dz};
    iv_t dot = iv_add(iv_add(iv_mul(g[0], a[0]), iv_mul(g[1], a[1])), iv_mul(g[2], a[2]));
    iv_t g2 = {0, 0}, a2 = {0, 0};
    for (int k = 0; k < 3; k++) {
        double m = fmax(fabs(g[k].lo), fabs(g[k].hi));
        g2 = iv_add(g2, iv_sqr(iv_point(m)));
        a2 = iv_add(a2, iv_sqr(a[k]));
    }
    double half = iv_mul(iv_point(0.5), iv_mul(iv_sqrt(g2), iv_sqrt(a2))).hi;
    return dot.lo > half; /* false on NaN */
}

/* The slab a leaf keeps: the ILIE's, when it is finite and -- for a leaf at the
 * max depth -- no thicker than the leaf's diagonal (else the diagonal is the
 * better bound and the leaf keeps no slab). */
static void make_slab(const ilie_t *l, const iv_box_t *box, int early, oct_slab_t *out)
{
    memset(out, 0, sizeof *out);
    if (!l)
        return;
    double n[3], lo, hi, thick = ilie_thickness(l);
    ilie_slab(l, n, &lo, &hi);
    if (!(n[0] || n[1] || n[2]) || !isfinite(lo) || !isfinite(hi) || !isfinite(thick))
        return;
    if (!early && thick > oct_box_diagonal(box))
        return;
    memcpy(out->n, n, sizeof n);
    out->d_lo = lo, out->d_hi = hi, out->thickness = thick;
}

/* The interval gradient over the open cells, into G[k]. */
static void gradient_pass(worker_t *w, const tape_t *t, const iv_box_t *boxes,
                          const int *open, int nopen, iv_grad_t *G)
{
    if (!nopen)
        return;
    iv_box_t *ob = w->open_boxes;
    iv_grad_t g[8];
    for (int j = 0; j < nopen; j++)
        ob[j] = boxes[open[j]];
    tape_eval_grad(t, w->ws, (size_t)nopen, ob, g);
    w->st.tape_clauses_evaluated += (uint64_t)nopen * t->n;
    for (int j = 0; j < nopen; j++)
        G[open[j]] = g[j];
}

/* The Lipschitz test on the open cells (gradients G from gradient_pass):
 * decided cells leave `open`; returns how many remain. */
static int lipschitz_pass(worker_t *w, const tape_t *t, const iv_box_t *boxes, int *open,
                          int nopen, const iv_grad_t *G, decision_t *out)
{
    if (!nopen)
        return 0;
    iv_box_t *cb = w->open_boxes;
    iv_t Fc[8];
    double c[8][3];
    for (int j = 0; j < nopen; j++) {
        const iv_box_t *x = &boxes[open[j]];
        c[j][0] = iv_mid(x->x), c[j][1] = iv_mid(x->y), c[j][2] = iv_mid(x->z);
        cb[j] = (iv_box_t){iv_point(c[j][0]), iv_point(c[j][1]), iv_point(c[j][2])};
    }
    tape_eval_interval(t, w->ws_centre, (size_t)nopen, cb, Fc);
    w->st.tape_clauses_evaluated += (uint64_t)nopen * t->n;
    int still = 0;
    for (int j = 0; j < nopen; j++) {
        int k = open[j];
        if (lipschitz_excludes(&boxes[k], Fc[j], c[j], G[k], &out[k].cls)) {
            out[k].kind = EMPTY;
            w->st.decided_lipschitz++;
        } else {
            open[still++] = k;
        }
    }
    return still;
}

/* ILIE on the open cells: a slab that misses its cell decides it empty; the
 * others keep their ILIE in L[k] (for the leaf's slab and the refinement).
 * Returns how many cells remain open. */
static int ilie_pass(worker_t *w, const tape_t *t, const iv_box_t *boxes, int *open, int nopen,
                     ilie_t *L, decision_t *out)
{
    if (!nopen)
        return 0;
    iv_box_t *ob = w->open_boxes;
    ilie_t l[8];
    for (int j = 0; j < nopen; j++)
        ob[j] = boxes[open[j]];
    ilie_eval(t, w->ilie_ws, (size_t)nopen, ob, l);
    w->st.tape_clauses_evaluated += (uint64_t)nopen * t->n;
    int still = 0;
    for (int j = 0; j < nopen; j++) {
        int k = open[j], sign;
        if (ilie_excludes_box(&l[j], &boxes[k], &sign)) {
            out[k].kind = EMPTY;
            out[k].cls = sign > 0 ? OCT_OUTSIDE : sign < 0 ? OCT_INSIDE : OCT_UNDEFINED;
            w->st.decided_ilie++;
        } else {
            L[k] = l[j];
            open[still++] = k;
        }
    }
    return still;
}

/* Run the chain on m cells (the 8 children of a cell, or the root alone) with
 * tape t; single_use: tape_is_single_use(t), when the range tests after the
 * interval one cannot decide anything it leaves open. */
static void classify(worker_t *w, const tape_t *t, int single_use, const cell_t *cells,
                     const iv_box_t *boxes, int m, decision_t *out)
{
    build_t *b = w->b;
    oct_stats_t *st = &w->st;
    iv_t F[8];
    tape_eval_interval(t, w->ws, (size_t)m, boxes, F);
    st->tape_clauses_evaluated += (uint64_t)m * t->n;
    st->cells_visited += (uint64_t)m;
    st->cells_by_depth[cells[0].depth] += (uint64_t)m;

    int open[8], nopen = 0;
    for (int k = 0; k < m; k++) {
        out[k].F = F[k];
        out[k].tape = t;
        out[k].single_use = single_use;
        int excluded = iv_is_empty(F[k]) || F[k].lo > 0 || F[k].hi < 0;
        if ((b->tests & OCT_TEST_INTERVAL) && excluded) {
            out[k].kind = EMPTY;
            out[k].cls = class_of(F[k]);
            st->decided_interval++;
        } else {
            open[nopen++] = k;
        }
    }

    int lipschitz = (b->tests & OCT_TEST_LIPSCHITZ) && !single_use;
    int ilie = (b->tests & OCT_TEST_ILIE) != 0;
    int refine = ilie && b->refine > 0;
    /* On a single-use tape ILIE cannot exclude more than the interval test, so
     * there it runs only where the slab itself is wanted: for the refinement
     * and for the leaves at the max depth, unless no one reads their slabs. */
    if (ilie && !refine && single_use &&
        (cells[0].depth < b->max_depth || b->slabs_unused))
        ilie = 0;

    /* Indexed by cell k, filled for the cells still open when computed.  The
     * gradient serves the Lipschitz test and the normal cone of the
     * refinement, and is computed at most once per cell. */
    iv_grad_t *G = w->grad;
    ilie_t L[8];
    int have_gradient = 0;
    if (lipschitz) {
        gradient_pass(w, t, boxes, open, nopen, G);
        have_gradient = 1;
        nopen = lipschitz_pass(w, t, boxes, open, nopen, G, out);
    }
    if (ilie)
        nopen = ilie_pass(w, t, boxes, open, nopen, L, out);
    /* Only a cell whose slab is thin enough can stop early: the normal cone
     * is checked for those alone. */
    int thin[8], nthin = 0;
    if (refine && !have_gradient && cells[0].depth < b->max_depth) {
        for (int j = 0; j < nopen; j++)
            if (ilie_thickness(&L[open[j]]) < b->refine)
                thin[nthin++] = open[j];
        gradient_pass(w, t, boxes, thin, nthin, G);
    }

    for (int j = 0; j < nopen; j++) {
        int k = open[j];
        int depth = cells[k].depth;
        int early = refine && depth < b->max_depth && ilie_thickness(&L[k]) < b->refine &&
                    normals_within_60_degrees(&L[k], G[k]);
        if (depth == b->max_depth || early) {
            out[k].kind = LEAF;
            if (early)
                st->decided_refine++;
            else
                st->decided_max_depth++;
            st->leaves_by_depth[depth]++;
            make_slab(ilie ? &L[k] : NULL, &boxes[k], early, &out[k].slab);
            double bound = out[k].slab.n[0] || out[k].slab.n[1] || out[k].slab.n[2]
                               ? out[k].slab.thickness
                               : oct_box_diagonal(&boxes[k]);
            if (bound > st->max_error_bound)
                st->max_error_bound = bound;
        } else {
            out[k].kind = SPLIT;
            if (b->choices) {
                /* ws still holds the slots of the first interval evaluation:
                 * the gradient used its own buffer */
                tape_t *child = &w->tapes[depth][k];
                tape_prune(t, w->ws, (unsigned)k, w->scratch, child);
                out[k].tape = child;
                out[k].single_use = single_use || tape_is_single_use(child, w->scratch);
            }
        }
    }
}

static cell_t child_cell(cell_t p, int k)
{
    cell_t c = {2 * p.ix + (k & 1u), 2 * p.iy + (k >> 1 & 1u), 2 * p.iz + (k >> 2 & 1u),
                p.depth + 1, p.code << 3 | (uint64_t)k};
    return c;
}

static void count_split(worker_t *w, cell_t c, const tape_t *t)
{
    w->st.split++;
    w->st.split_by_depth[c.depth]++;
    w->st.tape_length_sum_by_depth[c.depth] += t->n;
}

/* Build the subtree below a cell to split, depth-first, into pool p.
 * Returns the index of its children's block in the pool, or -1 on failure. */
static long build_subtree(worker_t *w, pool_t *p, cell_t cell, const tape_t *t,
                          int single_use)
{
    if (atomic_load_explicit(&w->b->failed, memory_order_relaxed))
        return -1;
    count_split(w, cell, t);
    cell_t kids[8];
    decision_t dec[8];
    iv_box_t boxes[8];
    for (int k = 0; k < 8; k++)
        kids[k] = child_cell(cell, k);
    children_boxes(w->b, cell, boxes);
    classify(w, t, single_use, kids, boxes, 8, dec);
    long base = pool_block(w->b, p);
    if (base < 0)
        return -1;
    for (int k = 0; k < 8; k++) {
        oct_node_t node;
        if (dec[k].kind == EMPTY) {
            node = OCT_NODE(OCT_EMPTY, dec[k].cls);
        } else if (dec[k].kind == LEAF) {
            long leaf = pool_leaf(w->b, p, kids[k], &dec[k]);
            if (leaf < 0)
                return -1;
            node = OCT_NODE(OCT_LEAF, leaf);
        } else {
            long sub = build_subtree(w, p, kids[k], dec[k].tape, dec[k].single_use);
            if (sub < 0)
                return -1;
            node = OCT_NODE(OCT_INTERIOR, sub);
        }
        p->nodes[base + k] = node;
    }
    return base;
}

/* ---- the two phases ---------------------------------------------------------------- */

typedef struct frontier {
    cell_t cell;
    tape_t tape;       /* owned copy when pruned, else points at the root tape */
    int owned;
    int single_use;
    size_t slot;       /* index in the top pool of the node word to fill */
    pool_t pool;       /* the subtree, built in phase 2 */
    long base;
} frontier_t;

static int frontier_push(build_t *b, frontier_t **f, size_t *n, size_t *cap, cell_t c,
                         const decision_t *d, size_t slot)
{
    const tape_t *t = d->tape;
    frontier_t *q = grow(b, *f, cap, *n + 1, sizeof *q);
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
            atomic_store(&b->failed, 2);
            return -1;
        }
        memcpy(e->tape.clauses, t->clauses, t->n * sizeof *t->clauses);
        e->owned = 1;
        account(b, (ptrdiff_t)(t->n * sizeof *t->clauses));
    }
    return 0;
}

static void frontier_free(build_t *b, frontier_t *f, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        if (f[i].owned) {
            account(b, -(ptrdiff_t)(f[i].tape.n * sizeof *f[i].tape.clauses));
            free(f[i].tape.clauses);
        }
        pool_free(b, &f[i].pool);
    }
    free(f);
}

/* Phase 1: breadth-first from the root until FRONTIER_CELLS cells are to be
 * split.  Fills the top pool (root at 0) and the frontier. */
static int top_phase(worker_t *w, pool_t *top, frontier_t **front, size_t *nfront)
{
    build_t *b = w->b;
    size_t ncur = 0, capcur = 0;
    frontier_t *cur = NULL;
    *front = NULL;
    *nfront = 0;

    /* the root goes through the chain alone */
    oct_node_t *q = grow(b, top->nodes, &top->cap, 1, sizeof *q);
    if (!q)
        return -1;
    top->nodes = q;
    top->n = 1;
    cell_t root = {0, 0, 0, 0, 0};
    iv_box_t root_box = oct_cell_box(b->box, 0, 0, 0, 0);
    decision_t dec;
    classify(w, b->tape, b->single_use, &root, &root_box, 1, &dec);
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
    if (frontier_push(b, &cur, &ncur, &capcur, root, &dec, 0))
        goto fail;

    while (ncur > 0 && ncur < FRONTIER_CELLS) {
        frontier_t *next = NULL;
        size_t nnext = 0, capnext = 0;
        for (size_t i = 0; i < ncur; i++) {
            frontier_t *e = &cur[i];
            count_split(w, e->cell, &e->tape);
            cell_t kids[8];
            decision_t d8[8];
            iv_box_t boxes[8];
            for (int k = 0; k < 8; k++)
                kids[k] = child_cell(e->cell, k);
            children_boxes(b, e->cell, boxes);
            classify(w, &e->tape, e->single_use, kids, boxes, 8, d8);
            long base = pool_block(b, top);
            if (base < 0) {
                frontier_free(b, next, nnext);
                goto fail;
            }
            top->nodes[e->slot] = OCT_NODE(OCT_INTERIOR, base);
            for (int k = 0; k < 8; k++) {
                oct_node_t node = 0;
                if (d8[k].kind == EMPTY) {
                    node = OCT_NODE(OCT_EMPTY, d8[k].cls);
                } else if (d8[k].kind == LEAF) {
                    long leaf = pool_leaf(b, top, kids[k], &d8[k]);
                    if (leaf < 0) {
                        frontier_free(b, next, nnext);
                        goto fail;
                    }
                    node = OCT_NODE(OCT_LEAF, leaf);
                } else if (frontier_push(b, &next, &nnext, &capnext, kids[k], &d8[k],
                                         (size_t)base + (size_t)k)) {
                    frontier_free(b, next, nnext);
                    goto fail;
                }
                top->nodes[base + k] = node;
            }
        }
        frontier_free(b, cur, ncur);
        cur = next, ncur = nnext, capcur = capnext;
    }
    *front = cur;
    *nfront = ncur;
    return 0;
fail:
    frontier_free(b, cur, ncur);
    return -1;
}

/* Concatenate the top pool and the subtrees' pools, then renumber the leaves
 * in Morton order (the order of a depth-first walk with children 0..7). */
static int assemble(build_t *b, pool_t *top, frontier_t *front, size_t nfront, oct_tree_t *tree)
{
    int with_slabs = keeps_slabs(b);
    size_t nn = top->n, nl = top->nl;
    for (size_t i = 0; i < nfront; i++)
        nn += front[i].pool.n, nl += front[i].pool.nl;
    if (nn > 0x3fffffffu || nl > 0x3fffffffu) {
        atomic_store(&b->failed, 2);
        return -1;
    }
    size_t ml = nl ? nl : 1;
    oct_node_t *nodes = malloc(nn * sizeof *nodes);
    oct_leaf_t *staged = malloc(ml * sizeof *staged), *leaves = malloc(ml * sizeof *leaves);
    oct_slab_t *staged_slabs = with_slabs ? malloc(ml * sizeof *staged_slabs) : NULL;
    oct_slab_t *slabs = with_slabs ? malloc(ml * sizeof *slabs) : NULL;
    if (!nodes || !staged || !leaves || (with_slabs && (!staged_slabs || !slabs))) {
        free(nodes), free(staged), free(leaves), free(staged_slabs), free(slabs);
        atomic_store(&b->failed, 2);
        return -1;
    }
    size_t leaf_bytes = sizeof *leaves + (with_slabs ? sizeof *slabs : 0);
    account(b, (ptrdiff_t)(nn * sizeof *nodes + 2 * nl * leaf_bytes));

    /* concatenate: the top pool, then each subtree's pool, indices shifted */
    memcpy(nodes, top->nodes, top->n * sizeof *nodes);
    if (top->nl) { /* memcpy from NULL is undefined even for 0 bytes */
        memcpy(staged, top->leaves, top->nl * sizeof *staged);
        if (with_slabs)
            memcpy(staged_slabs, top->slabs, top->nl * sizeof *staged_slabs);
    }
    size_t on = top->n, ol = top->nl;
    for (size_t i = 0; i < nfront; i++) {
        pool_t *p = &front[i].pool;
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
    account(b, -(ptrdiff_t)(nl * leaf_bytes));
    tree->nodes = nodes;
    tree->n_nodes = (uint32_t)nn;
    tree->leaves = leaves;
    tree->slabs = slabs;
    tree->n_leaves = (uint32_t)nl;
    return 0;
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
    if (p->depth < 0 || p->depth > OCT_MAX_DEPTH) {
        ivoct_error_set(err, "depth %d out of range 0..%d", p->depth, OCT_MAX_DEPTH);
        return -1;
    }
    if (!(p->refine >= 0) || (p->refine > 0 && !(p->tests & OCT_TEST_ILIE))) {
        ivoct_error_set(err, "refine needs the ilie test and a tolerance >= 0");
        return -1;
    }
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
        assemble(&b, &top, front, nfront, tree);
    failed = atomic_load(&b.failed);
    if (failed == 1) {
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
