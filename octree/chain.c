/* ivoct octree — the test chain.
 *
 * Cells are classified in batches that share a tape (up to CHAIN_BATCH: the
 * children of many cells of one level): one interval evaluation over all
 * their boxes, which also records the min/max/abs choices decided over each
 * box; then, for the cells it could not decide, the range tests the build
 * runs (a gradient pass and a pass at the centres for the Lipschitz test, an
 * affine pass for ILIE), each one pass over the cells still open; then the
 * refinement's stopping rule.  A cell that is split gets the tape pruned
 * with its own choices (chain_prune). */
#include <math.h>
#include <string.h>

#include "../lipschitz/lipschitz.h"
#include "build_internal.h"

static oct_class_t class_of(iv_t F)
{
    return iv_is_empty(F) ? OCT_UNDEFINED : F.lo > 0 ? OCT_OUTSIDE : OCT_INSIDE;
}

/* 9 bounds per axis, computed once for the 8 boxes. */
void chain_children_boxes(const build_t *b, cell_t p, iv_box_t *boxes)
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

/* Raise m->d2 to cell_diagonal_squared of a leaf's box when larger.  That
 * grows with each of the box's rounded-up widths (cell_diagonal_squared_of),
 * so a leaf whose widths are all within those of the leaf that set m->d2
 * cannot raise it: most leaves of a build are settled by three subtractions
 * and three comparisons. */
static void note_leaf_diagonal(leaf_diagonal_t *m, const iv_box_t *b)
{
    double u[3];
    cell_widths_up(b, u);
    if (u[0] <= m->u[0] && u[1] <= m->u[1] && u[2] <= m->u[2])
        return;
    double d2 = cell_diagonal_squared_of(u);
    if (d2 > m->d2) {
        m->d2 = d2;
        memcpy(m->u, u, sizeof u);
    }
}

/* The interval gradient over the open cells, into G[k]. */
static void gradient_pass(worker_t *w, const tape_t *t, const iv_box_t *boxes,
                          const int *open, int nopen, iv_grad_t *G)
{
    if (!nopen)
        return;
    iv_box_t *ob = w->chain.open_boxes;
    iv_grad_t *g = w->chain.open_grad;
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
    iv_box_t *cb = w->chain.open_boxes;
    iv_t *Fc = w->chain.open_F;
    double (*c)[3] = w->chain.centre;
    for (int j = 0; j < nopen; j++) {
        const iv_box_t *x = &boxes[open[j]];
        c[j][0] = iv_mid(x->x), c[j][1] = iv_mid(x->y), c[j][2] = iv_mid(x->z);
        cb[j] = (iv_box_t){iv_point(c[j][0]), iv_point(c[j][1]), iv_point(c[j][2])};
    }
    tape_eval_interval(t, w->ws, (size_t)nopen, cb, Fc);
    w->st.tape_clauses_evaluated += (uint64_t)nopen * t->n;
    int still = 0;
    for (int j = 0; j < nopen; j++) {
        int k = open[j];
        int sign = lip_cell_excludes(&boxes[k], c[j], Fc[j], G[k]);
        if (sign) {
            out[k].kind = EMPTY;
            out[k].cls = sign > 0 ? OCT_OUTSIDE : OCT_INSIDE;
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
    iv_box_t *ob = w->chain.open_boxes;
    ilie_t *l = w->chain.open_ilie;
    for (int j = 0; j < nopen; j++)
        ob[j] = boxes[open[j]];
    ilie_eval(t, w->ilie_ws, (size_t)nopen, ob, l);
    w->st.tape_clauses_evaluated += (uint64_t)nopen * t->n;
    bool ex[CHAIN_BATCH];
    int sg[CHAIN_BATCH];
    ilie_excludes_boxes((size_t)nopen, l, ob, ex, sg);
    int still = 0;
    for (int j = 0; j < nopen; j++) {
        int k = open[j], sign = sg[j];
        if (ex[j]) {
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

/* single_use: the range tests after the interval one cannot decide anything
 * it leaves open. */
void chain_classify(worker_t *w, const tape_t *t, int single_use, const cell_t *cells,
                    const iv_box_t *boxes, int m, decision_t *out)
{
    build_t *b = w->b;
    oct_stats_t *st = &w->st;
    iv_t *F = w->chain.F;
    tape_eval_interval_choices(t, w->ws, (size_t)m, boxes, F, b->choices ? w->choices : NULL);
    st->tape_clauses_evaluated += (uint64_t)m * t->n;
    st->cells_visited += (uint64_t)m;
    st->cells_by_depth[cells[0].depth] += (uint64_t)m;

    int *open = w->chain.open, nopen = 0;
    for (int k = 0; k < m; k++) {
        out[k].F = F[k];
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
    iv_grad_t *G = w->chain.grad;
    ilie_t *L = w->chain.ilie;
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
    int *thin = w->chain.thin, nthin = 0;
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
                    lip_normals_within_60_degrees(G[k], L[k].a);
        if (depth == b->max_depth || early) {
            out[k].kind = LEAF;
            if (early)
                st->decided_refine++;
            else
                st->decided_max_depth++;
            st->leaves_by_depth[depth]++;
            make_slab(ilie ? &L[k] : NULL, &boxes[k], early, &out[k].slab);
            if (out[k].slab.n[0] || out[k].slab.n[1] || out[k].slab.n[2]) {
                if (out[k].slab.thickness > st->max_error_bound)
                    st->max_error_bound = out[k].slab.thickness;
            } else {
                note_leaf_diagonal(&w->diagonal, &boxes[k]);
            }
        } else {
            out[k].kind = SPLIT;
        }
    }
}

int chain_prune(worker_t *w, const tape_t *t, int k, tape_clause_t *clauses, tape_t *out)
{
    if (!w->b->choices)
        return 0;
    const uint8_t *c = w->choices + (size_t)k * t->n;
    uint32_t i = 0;
    while (i < t->n && c[i] == TAPE_CHOICE_BOTH)
        i++;
    if (i == t->n)
        return 0;
    out->clauses = clauses;
    tape_prune(t, c, w->scratch, out);
    return 1;
}
