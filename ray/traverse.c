/* ivoct ray — the octree source: front-to-back traversal of the surface leaves
 * a ray meets (ray_octree_source, declared in ray.h).
 *
 * A parametric traversal in the spirit of Revelles, Ureña & Lastra (2000): a
 * cell is visited with the parameter range of the ray inside it, computed from
 * the parameters where the ray crosses the cell's planes, and its children
 * follow front to back (the order k ^ mask of the paper, mask the axes where
 * the direction is negative).  Unlike the published algorithm the next child
 * is not chosen by a state machine on rounded comparisons: the ranges of the
 * children are computed (from two plane crossings per axis, shared with the
 * parent) with outward rounding, and every child whose range is not provably
 * empty is kept.  No cell the ray meets is ever dropped; rounding can only add
 * a cell the ray misses by an ulp, and the renderer's rule (ray.h: every
 * segment is searched up to the best hit so far) makes the hit the first root
 * whatever the order.  ray/README.md has the full argument.
 *
 * The cell bounds are those of the build (oct_coord of the tree's box), so a
 * leaf here is the very closed box the build certified: every point of the
 * surface in the tree's box lies in a surface leaf. */
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "packet_internal.h"

/* A cell waiting on the stack.  r[a] = [entry, exit] parameters of the ray on
 * axis a (the lower bound of the crossing of the near plane, the upper bound
 * of the crossing of the far plane); lo the cell's entry (the largest entry,
 * and 0). */
typedef struct entry {
    double r[3][2];
    double lo;
    uint32_t i[3];     /* cell coordinates at depth */
    oct_node_t word;   /* the cell's node word */
    int depth;
} entry_t;

/* One axis of the ray. */
typedef struct axis {
    double o, d;
    double inv_lo, inv_hi; /* an enclosure of 1/d, when d is normal (recip) */
    int recip;
} axis_t;

typedef struct trav_state {
    axis_t ax[3];
    double o[3], d[3];
    unsigned mask;     /* bit a set when d[a] < 0: the near child is the upper one */
    int sp, cap;
    entry_t stack[];   /* cap entries */
} trav_state_t;

/* Enough for any walk: popping a cell pushes at most 8, so at depth k of the
 * walk at most 7 per level above plus 8 are waiting. */
static int stack_cap(int depth) { return 7 * (depth > 0 ? depth : 0) + 8; }

/* An enclosure [*lo, *hi] of the parameter (c - o) / d where the ray crosses
 * the plane x_a = c (d != 0).  Every operation is correctly rounded, and
 * iv_down / iv_up move a rounded result past the exact value.  (c - o) / d is
 * monotone in c - o; it is computed as (c - o) * [1/d] (a product of
 * intervals, bounds picked by sign), or divided where 1/d would overflow. */
static inline void plane_t(const axis_t *x, double c, double *lo, double *hi)
{
    double s_lo = iv_add_down(c, -x->o), s_hi = iv_add_up(c, -x->o);
    if (x->recip) {
        if (x->d > 0) {
            *lo = iv_down(s_lo * (s_lo >= 0 ? x->inv_lo : x->inv_hi));
            *hi = iv_up(s_hi * (s_hi >= 0 ? x->inv_hi : x->inv_lo));
        } else {
            *lo = iv_down(s_hi * (s_hi >= 0 ? x->inv_lo : x->inv_hi));
            *hi = iv_up(s_lo * (s_lo >= 0 ? x->inv_hi : x->inv_lo));
        }
    } else if (x->d > 0) {
        *lo = iv_down(s_lo / x->d);
        *hi = iv_up(s_hi / x->d);
    } else {
        *lo = iv_down(s_hi / x->d);
        *hi = iv_up(s_lo / x->d);
    }
}

/* The entry of a cell: t >= 0 and inside all three slabs; *hi its exit. */
static inline double cell_range(double r[3][2], double *hi)
{
    double lo = r[0][0] > 0.0 ? r[0][0] : 0.0;
    lo = r[1][0] > lo ? r[1][0] : lo;
    lo = r[2][0] > lo ? r[2][0] : lo;
    double h = r[0][1] < r[1][1] ? r[0][1] : r[1][1];
    *hi = r[2][1] < h ? r[2][1] : h;
    return lo;
}

static void trav_begin(const void *ctx, void *state, const double o[3], const double d[3])
{
    const ray_octree_source_t *os = ctx;
    const oct_tree_t *tree = os->tree;
    trav_state_t *st = state;
    st->sp = 0;
    if (!tree || !tree->n_nodes || tree->depth < 0 || tree->depth > OCT_MAX_DEPTH)
        return;
    st->cap = stack_cap(tree->depth);
    st->mask = 0;
    entry_t *e = &st->stack[0];
    for (int a = 0; a < 3; a++) {
        e->i[a] = 0;
        if (!isfinite(o[a]) || !isfinite(d[a]))
            return;
        st->o[a] = o[a];
        st->d[a] = d[a];
        axis_t *x = &st->ax[a];
        x->o = o[a];
        x->d = d[a];
        /* 1/d and its enclosure normal and of d's sign */
        x->recip = fabs(d[a]) >= 0x1p-1000 && fabs(d[a]) <= 0x1p1000;
        x->inv_lo = x->recip ? iv_down(1.0 / d[a]) : 0;
        x->inv_hi = x->recip ? iv_up(1.0 / d[a]) : 0;
        double lo = tree->box[2 * a], hi = tree->box[2 * a + 1];
        if (d[a] == 0) {
            /* parallel to the planes: inside for every t, or never */
            if (o[a] < lo || o[a] > hi)
                return;
            e->r[a][0] = -INFINITY;
            e->r[a][1] = INFINITY;
            continue;
        }
        if (d[a] < 0)
            st->mask |= 1u << a;
        double near = d[a] > 0 ? lo : hi, far = d[a] > 0 ? hi : lo, dummy;
        plane_t(x, near, &e->r[a][0], &dummy);
        plane_t(x, far, &dummy, &e->r[a][1]);
    }
    double hi;
    e->lo = cell_range(e->r, &hi);
    if (!(e->lo <= hi))
        return;
    e->word = tree->nodes[0];
    e->depth = 0;
    st->sp = 1;
}

/* Push the children of interior cell p that the ray may meet.  Order: along
 * a ray every coordinate moves one way, so the children it passes through
 * have, after flipping the bits of the axes where d < 0 (mask), nested sets
 * of bits: increasing k ^ mask is front to back for them (Revelles et al.'s
 * order).  Children kept only because of rounding (their exact range is
 * empty) may come anywhere; the renderer's rule does not need the order. */
static void expand(const oct_tree_t *tree, trav_state_t *st, const entry_t *p, double t_max)
{
    uint32_t first = OCT_NODE_VALUE(p->word);
    int depth = p->depth + 1;
    /* a corrupt tree (a file not from oct_build) must not send us out of
     * bounds or into a cycle: children exist and depth stays within the tree */
    if ((uint64_t)first + 8 > tree->n_nodes || depth > tree->depth)
        return;
    const oct_node_t *kids = tree->nodes + first;

    /* per axis, the ranges of the lower (h = 0) and upper (h = 1) halves, and
     * the children whose three halves can meet the ray within the parent's
     * range [p->lo, phi]: most of the 8 are ruled out here, cheaply */
    double r[3][2][2];
    double phi = p->r[0][1] < p->r[1][1] ? p->r[0][1] : p->r[1][1];
    phi = p->r[2][1] < phi ? p->r[2][1] : phi;
    static const unsigned half_mask[3][2] = {{0x55u, 0xaau}, {0x33u, 0xccu}, {0x0fu, 0xf0u}};
    unsigned feasible = 0xffu;
    for (int a = 0; a < 3; a++) {
        double blo = tree->box[2 * a], bhi = tree->box[2 * a + 1];
        double d = st->ax[a].d, o = st->ax[a].o;
        double mid = oct_coord(blo, bhi, 2 * (uint64_t)p->i[a] + 1, depth);
        if (d == 0) {
            double clo = oct_coord(blo, bhi, 2 * (uint64_t)p->i[a], depth);
            double chi = oct_coord(blo, bhi, 2 * (uint64_t)p->i[a] + 2, depth);
            int in0 = clo <= o && o <= mid, in1 = mid <= o && o <= chi;
            r[a][0][0] = r[a][1][0] = -INFINITY;
            r[a][0][1] = r[a][1][1] = INFINITY;
            feasible &= (in0 ? half_mask[a][0] : 0u) | (in1 ? half_mask[a][1] : 0u);
            continue;
        }
        double mlo, mhi;
        plane_t(&st->ax[a], mid, &mlo, &mhi);
        int near = d < 0; /* the half the ray enters first */
        r[a][near][0] = p->r[a][0];
        r[a][near][1] = mhi;
        r[a][!near][0] = mlo;
        r[a][!near][1] = p->r[a][1];
        unsigned m = 0;
        for (int h = 0; h < 2; h++)
            if (r[a][h][0] <= phi && r[a][h][1] >= p->lo)
                m |= half_mask[a][h];
        feasible &= m;
    }

    /* pushed back to front, so the front one is popped first */
    int sp = st->sp;
    for (int j = 7; j >= 0; j--) {
        unsigned k = (unsigned)j ^ st->mask;
        if (!(feasible >> k & 1u))
            continue;
        oct_node_t w = kids[k];
        if (OCT_NODE_KIND(w) == OCT_EMPTY)
            continue;
        unsigned hx = k & 1u, hy = k >> 1 & 1u, hz = k >> 2 & 1u;
        double lo = r[0][hx][0] > 0.0 ? r[0][hx][0] : 0.0;
        lo = r[1][hy][0] > lo ? r[1][hy][0] : lo;
        lo = r[2][hz][0] > lo ? r[2][hz][0] : lo;
        double hi = r[0][hx][1] < r[1][hy][1] ? r[0][hx][1] : r[1][hy][1];
        hi = r[2][hz][1] < hi ? r[2][hz][1] : hi;
        if (!(lo <= hi) || !(lo < t_max) || sp >= st->cap)
            continue;
        entry_t *e = &st->stack[sp++];
        e->r[0][0] = r[0][hx][0], e->r[0][1] = r[0][hx][1];
        e->r[1][0] = r[1][hy][0], e->r[1][1] = r[1][hy][1];
        e->r[2][0] = r[2][hz][0], e->r[2][1] = r[2][hz][1];
        e->lo = lo;
        e->i[0] = 2 * p->i[0] + hx;
        e->i[1] = 2 * p->i[1] + hy;
        e->i[2] = 2 * p->i[2] + hz;
        e->word = w;
        e->depth = depth;
    }
    st->sp = sp;
}

/* Narrow [*lo, *hi] to the t where d_lo <= n·(o + t·d) <= d_hi: with
 * A ∋ n·o and B ∋ n·d (iv_dot3), t ∈ ([d_lo, d_hi] − A) / B when 0 ∉ B.
 * When B may be 0 the slab does not narrow, but the leaf is dropped when
 * n·(o + T·d) over the whole range T provably misses [d_lo, d_hi].  Returns
 * 0 when the ray provably misses the slab inside the range. */
static int slab_narrow(const oct_slab_t *s, const double o[3], const double d[3], double *lo,
                       double *hi)
{
    iv_t A = iv_dot3(s->n, o), B = iv_dot3(s->n, d);
    iv_t D = iv_make(s->d_lo, s->d_hi);
    if (B.lo > 0 || B.hi < 0) {
        iv_t T = iv_div(iv_sub(D, A), B);
        if (T.lo > *lo) /* false on NaN: no narrowing */
            *lo = T.lo;
        if (T.hi < *hi)
            *hi = T.hi;
        return *lo <= *hi;
    }
    iv_t V = iv_add(A, iv_mul(iv_make(*lo, *hi), B));
    return !(V.hi < D.lo || V.lo > D.hi);
}

static int trav_next(const void *ctx, void *state, ray_segment_t *seg, uint64_t *leaves)
{
    const ray_octree_source_t *os = ctx;
    const oct_tree_t *tree = os->tree;
    trav_state_t *st = state;
    const double t_max = seg->t_max;
    while (st->sp > 0) {
        entry_t e = st->stack[--st->sp];
        /* its roots lie at t >= e.lo >= t_max: none can come first */
        if (!(e.lo < t_max))
            continue;
        switch (OCT_NODE_KIND(e.word)) {
        case OCT_INTERIOR:
            expand(tree, st, &e, t_max);
            break;
        case OCT_LEAF: {
            uint32_t li = OCT_NODE_VALUE(e.word);
            if (li >= tree->n_leaves)
                break;
            double hi, lo = cell_range(e.r, &hi);
            if (os->use_slabs && oct_leaf_has_slab(tree, li) &&
                !slab_narrow(&tree->slabs[li], st->o, st->d, &lo, &hi))
                break;
            if (!(lo < t_max))
                break;
            seg->t_in = lo;
            seg->t_out = hi;
            seg->tape = os->tapes && li < os->tapes->n_leaves ? os->tapes->of_leaf[li] : NULL;
            seg->leaf = li;
            if (leaves)
                ++*leaves;
            return 1;
        }
        default: /* OCT_EMPTY (never pushed) or invalid */
            break;
        }
    }
    return 0;
}

/* ---- packets (beam_internal.h; the walk itself: packet_kernels.h) ------------------- */

struct ray_packet_ws {
    int cap;
    pcell_t stack[];
};

ray_packet_ws_t *ray_packet_ws_new(const oct_tree_t *tree)
{
    int depth = tree && tree->depth > 0 && tree->depth <= OCT_MAX_DEPTH ? tree->depth : 0;
    ray_packet_ws_t *ws = malloc(sizeof *ws + (size_t)stack_cap(depth) * sizeof(pcell_t));
    if (ws)
        ws->cap = stack_cap(depth);
    return ws;
}

void ray_packet_ws_free(ray_packet_ws_t *ws) { free(ws); }

int ray_packet_ray(const double o[3], const double d[3], unsigned *mask)
{
    *mask = 0;
    for (int a = 0; a < 3; a++) {
        /* trav_begin's reciprocal case: 2^-1000 <= |d_a| <= 2^1000 */
        if (!isfinite(o[a]) || !(fabs(d[a]) >= 0x1p-1000 && fabs(d[a]) <= 0x1p1000))
            return 0;
        if (d[a] < 0)
            *mask |= 1u << a;
    }
    return 1;
}

/* The walk of the SIMD path in use (expr/'s choice, tape_simd_name). */
static packet_walk_fn packet_walk_in_use(void)
{
#ifdef IVOCT_SIMD_X86
    const char *name = tape_simd_name();
    if (!strcmp(name, "avx512"))
        return packet_walk_avx512;
    if (!strcmp(name, "avx2"))
        return packet_walk_avx2;
#endif
    return packet_walk_portable;
}

typedef struct packet_ctx {
    const ray_octree_source_t *os;
    const double *o;
    const double (*d)[3];
    double *t_max;
    ray_packet_leaf_fn leaf;
    void *ctx;
    uint64_t *leaves;
} packet_ctx_t;

/* Ray r meets leaf li over [lo, hi], lo < t_max[r]: trav_next's leaf. */
static double packet_leaf(void *ctx, uint32_t li, int r, double lo, double hi)
{
    const packet_ctx_t *pc = ctx;
    const ray_octree_source_t *os = pc->os;
    const oct_tree_t *tree = os->tree;
    if (os->use_slabs && oct_leaf_has_slab(tree, li) &&
        !slab_narrow(&tree->slabs[li], pc->o, pc->d[r], &lo, &hi))
        return pc->t_max[r];
    if (!(lo < pc->t_max[r]))
        return pc->t_max[r];
    ray_segment_t seg = {lo, hi, NULL, pc->t_max[r], li};
    seg.tape = os->tapes && li < os->tapes->n_leaves ? os->tapes->of_leaf[li] : NULL;
    if (pc->leaves)
        ++*pc->leaves;
    pc->leaf(pc->ctx, r, &seg);
    return pc->t_max[r];
}

void ray_packet_walk(const ray_octree_source_t *os, ray_packet_ws_t *ws, const double o[3],
                     int n, const double (*d)[3], double t_max[], ray_packet_leaf_fn leaf,
                     void *ctx, uint64_t *leaves)
{
    const oct_tree_t *tree = os->tree;
    if (!tree || !tree->n_nodes || tree->depth < 0 || tree->depth > OCT_MAX_DEPTH || n < 1 ||
        n > PK)
        return;
    packet_ctx_t pc = {os, o, d, t_max, leaf, ctx, leaves};
    packet_rays_t p = {.tree = tree, .n = n, .leaf = packet_leaf, .ctx = &pc,
                       .stack = ws->stack, .cap = ws->cap};
    for (int a = 0; a < 3; a++) {
        p.o[a] = o[a];
        p.neg[a] = d[0][a] < 0;
        p.mask |= (unsigned)p.neg[a] << a;
        /* trav_begin's enclosure of 1/d; the lanes past n copy ray 0 */
        for (int r = 0; r < PK; r++) {
            double inv = 1.0 / d[r < n ? r : 0][a];
            p.inv_lo[a][r] = iv_down(inv);
            p.inv_hi[a][r] = iv_up(inv);
        }
    }
    for (int r = 0; r < PK; r++)
        p.t_max[r] = r < n ? t_max[r] : -INFINITY;
    packet_walk_in_use()(&p);
}

void ray_octree_params(oct_params_t *p, double rays)
{
    if (!(rays >= RAY_SLAB_RAYS))
        return;
    p->tests |= OCT_TEST_ILIE;
    p->slabs_unused = 0;
}

ray_source_t ray_octree_source(ray_octree_source_t *os, const oct_tree_t *tree)
{
    os->tree = tree;
    os->use_slabs = 1;
    os->tapes = NULL;
    int depth = tree && tree->depth > 0 && tree->depth <= OCT_MAX_DEPTH ? tree->depth : 0;
    ray_source_t s = {os,
                      offsetof(trav_state_t, stack) + (size_t)stack_cap(depth) * sizeof(entry_t),
                      trav_begin, trav_next};
    return s;
}

const ray_octree_source_t *ray_source_octree(const ray_source_t *src)
{
    return src && src->begin == trav_begin && src->next == trav_next ? src->ctx : NULL;
}

double ray_tape_margin(const ray_camera_t *cam, const double box[6])
{
    /* every view of the turntable has its eye at the same distance from the
     * target: |o_i| <= |target|_inf + |eye - target|, and t <= |o - c| +
     * diag/2 <= |target - c| + |eye - target| + diag/2 (c the box centre) */
    double reach = 0, far = 0, diag = 0, tmax = 0;
    for (int a = 0; a < 3; a++) {
        double c = 0.5 * box[2 * a] + 0.5 * box[2 * a + 1];
        reach += (cam->eye[a] - cam->target[a]) * (cam->eye[a] - cam->target[a]);
        far += (cam->target[a] - c) * (cam->target[a] - c);
        diag += (box[2 * a + 1] - box[2 * a]) * (box[2 * a + 1] - box[2 * a]);
        tmax = fmax(tmax, fabs(cam->target[a]));
    }
    double o = tmax + sqrt(reach) * (1 + 0x1p-40);
    double t = (sqrt(far) + sqrt(reach) + 0.5 * sqrt(diag)) * (1 + 0x1p-40);
    return iv_up(0x1p-40 * (o + 2 * t));
}

double ray_light_tape_margin(const double light[3], const double box[6])
{
    /* a shadow ray starts at the light, the piece searched first for an
     * attached shadow at a point before q (within rounding of the box), and
     * both end at q, in the box: |o_i| <= max(|light|_inf, the box's largest
     * |coordinate|) and |t·d_i| <= |q_i - light_i| <= |light|_inf + that
     * coordinate, for t in [0, 1] */
    double b = 0, l = 0;
    for (int a = 0; a < 3; a++) {
        b = fmax(b, fmax(fabs(box[2 * a]), fabs(box[2 * a + 1])));
        l = fmax(l, fabs(light[a]));
    }
    double o = fmax(l, b) * (1 + 0x1p-40), t = (l + b) * (1 + 0x1p-40);
    return iv_up(0x1p-40 * (o + 2 * t));
}
