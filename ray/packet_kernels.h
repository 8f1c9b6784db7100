/* ivoct ray — the packet walk: the rays of a packet (packet_internal.h) down
 * the octree together, depth first, children front to back (k ^ mask).
 *
 * Included once by each packet_kernels_<target>.c, which defines
 * KERNEL_TARGET; compiled with that SIMD path's flags (cmake/IvoctModule.cmake,
 * ivoct_simd_kernels), so every path does the same IEEE operations and only
 * the vector width differs.  The lane loops run over the PK rays.
 *
 * What each ray gets is what traverse.c's per-ray walk yields for it
 * (beam_internal.h): its crossings are plane_t's, one product of the shared
 * rounded difference c - o by the bound of 1/d that plane_t picks (the pick
 * depends on the signs of d and of c - o, common to the packet), widened by
 * iv_down / iv_up; a child's per-axis range is its parent's split at the
 * mid-plane, as in expand; and a cell is dropped for a ray exactly where the
 * per-ray walk drops it: an empty range, or an entry at or after t_max. */
#ifndef KERNEL_TARGET
#error "packet_kernels.h is included by packet_kernels_<target>.c, which defines KERNEL_TARGET"
#endif

#include <string.h>

#include "packet_internal.h"

#define KCAT_(a, b) a##_##b
#define KCAT(a, b) KCAT_(a, b)
#define K(name) KCAT(name, KERNEL_TARGET)

/* plane_t's *lo for every ray, for the plane x_a = c */
static inline void plane_lo(const packet_rays_t *p, int a, double c, double *restrict out)
{
    double s = p->neg[a] ? iv_add_up(c, -p->o[a]) : iv_add_down(c, -p->o[a]);
    const double *inv = s >= 0 ? p->inv_lo[a] : p->inv_hi[a];
    for (int r = 0; r < PK; r++)
        out[r] = iv_down(s * inv[r]);
}

/* plane_t's *hi for every ray */
static inline void plane_hi(const packet_rays_t *p, int a, double c, double *restrict out)
{
    double s = p->neg[a] ? iv_add_down(c, -p->o[a]) : iv_add_up(c, -p->o[a]);
    const double *inv = s >= 0 ? p->inv_hi[a] : p->inv_lo[a];
    for (int r = 0; r < PK; r++)
        out[r] = iv_up(s * inv[r]);
}

/* traverse.c's cell_range, lane by lane: the entry (t >= 0, inside all three
 * slabs) and the exit of each ray, from the per-axis bounds */
static inline void range(const double *e0, const double *e1, const double *e2,
                         const double *x0, const double *x1, const double *x2,
                         double *restrict lo, double *restrict hi)
{
    for (int r = 0; r < PK; r++) {
        double l = e0[r] > 0.0 ? e0[r] : 0.0;
        l = e1[r] > l ? e1[r] : l;
        lo[r] = e2[r] > l ? e2[r] : l;
        double h = x0[r] < x1[r] ? x0[r] : x1[r];
        hi[r] = x2[r] < h ? x2[r] : h;
    }
}

/* The rays where a[r] <= b[r], and where a[r] < b[r], as bits (r: bit r);
 * false where either is NaN.  A lane loop, its results as wide as the
 * doubles so that it vectorises, gathered into bits; packet_kernels_avx512.c
 * has its own, one compare into a mask register each, and defines
 * PACKET_LANE_BITS. */
#ifndef PACKET_LANE_BITS
static inline uint32_t lane_bits(const int64_t *ok)
{
    uint32_t m = 0;
    for (int r = 0; r < PK; r++)
        m |= (uint32_t)ok[r] << r;
    return m;
}
static inline uint32_t bits_le(const double *a, const double *b)
{
    int64_t ok[PK];
    for (int r = 0; r < PK; r++)
        ok[r] = a[r] <= b[r];
    return lane_bits(ok);
}
static inline uint32_t bits_lt(const double *a, const double *b)
{
    int64_t ok[PK];
    for (int r = 0; r < PK; r++)
        ok[r] = a[r] < b[r];
    return lane_bits(ok);
}
#endif

/* The crossings of the mid-planes of the cell expanded last at one depth.
 * Its children point into them, and the walk is depth first: by the time
 * another cell of that depth is expanded, none of those children is left on
 * the stack.  So a pushed cell carries pointers, not its 6 arrays. */
typedef struct pframe {
    double mlo[3][PK], mhi[3][PK];
} pframe_t;

void K(packet_walk)(packet_rays_t *p)
{
    const oct_tree_t *tree = p->tree;
    pcell_t *stack = p->stack;
    double tm[PK], lo[PK], hi[PK], ren[3][PK], rex[3][PK];
    pframe_t frame[OCT_MAX_DEPTH + 1];
    memcpy(tm, p->t_max, sizeof tm);

    /* the root: the tree's box (oct_coord's planes 0 and 2^depth) */
    pcell_t *root = &stack[0];
    for (int a = 0; a < 3; a++) {
        double blo = tree->box[2 * a], bhi = tree->box[2 * a + 1];
        plane_lo(p, a, p->neg[a] ? bhi : blo, ren[a]);
        plane_hi(p, a, p->neg[a] ? blo : bhi, rex[a]);
        root->en[a] = ren[a];
        root->ex[a] = rex[a];
        root->i[a] = 0;
    }
    range(root->en[0], root->en[1], root->en[2], root->ex[0], root->ex[1], root->ex[2], lo, hi);
    root->word = tree->nodes[0];
    root->depth = 0;
    root->active = bits_le(lo, hi) & ((1u << p->n) - 1u);
    int sp = root->active != 0;

    pcell_t c;
    while (sp > 0) {
        c = stack[--sp]; /* a copy: the children go where it was */
        range(c.en[0], c.en[1], c.en[2], c.ex[0], c.ex[1], c.ex[2], lo, hi);
        /* the roots of a ray in the cell lie at t >= lo: none can come first */
        uint32_t act = c.active & bits_lt(lo, tm);
        if (!act)
            continue;
        if (OCT_NODE_KIND(c.word) == OCT_LEAF) {
            uint32_t li = OCT_NODE_VALUE(c.word);
            if (li >= tree->n_leaves)
                continue;
            for (int r = 0; r < PK; r++)
                if (act >> r & 1u)
                    tm[r] = p->leaf(p->ctx, li, r, lo[r], hi[r]);
            continue;
        }
        if (OCT_NODE_KIND(c.word) != OCT_INTERIOR)
            continue;
        /* expand's rules for a corrupt tree: children exist, depth stays
         * within the tree */
        uint32_t first = OCT_NODE_VALUE(c.word);
        int depth = c.depth + 1;
        if ((uint64_t)first + 8 > tree->n_nodes || depth > tree->depth)
            continue;
        double(*mlo)[PK] = frame[c.depth].mlo, (*mhi)[PK] = frame[c.depth].mhi;
        /* the children's words first: the load often misses the cache, and
         * the crossings below hide part of it */
        oct_node_t kids[8];
        memcpy(kids, tree->nodes + first, sizeof kids);

        /* per axis and half h, each ray's [entry, exit]: the near half from
         * the cell's entry to the mid-plane, the far one from there on; and
         * the rays for which the half can meet the cell's range at all (what
         * a child needs on every axis: most children are ruled out here) */
        const double *hl[3][2], *hh[3][2];
        uint32_t half[3][2];
        for (int a = 0; a < 3; a++) {
            double blo = tree->box[2 * a], bhi = tree->box[2 * a + 1];
            double mid = oct_coord(blo, bhi, 2 * (uint64_t)c.i[a] + 1, depth);
            plane_lo(p, a, mid, mlo[a]);
            plane_hi(p, a, mid, mhi[a]);
            int near = p->neg[a];
            hl[a][near] = c.en[a], hh[a][near] = mhi[a];
            hl[a][!near] = mlo[a], hh[a][!near] = c.ex[a];
            for (int h = 0; h < 2; h++) {
                const double *l = hl[a][h], *x = hh[a][h];
                half[a][h] = bits_le(l, hi) & bits_le(lo, x);
            }
        }
#ifdef __GNUC__
        /* what each child's pop reads: an interior child's children's
         * words, a leaf's slab (the leaves' records are far apart in
         * memory).  Asked for all the children before any is pushed: the
         * front child is pushed last and popped at once, too soon for a
         * prefetch at its own push to arrive; and after the crossings, which
         * hide the wait for the words read here (docs/BENCHMARKS.md: 5-8 %
         * of a render's time, for 3 % more instructions) */
        for (int k = 0; k < 8; k++) {
            oct_node_t w = kids[k];
            if (OCT_NODE_KIND(w) == OCT_INTERIOR && OCT_NODE_VALUE(w) < tree->n_nodes)
                __builtin_prefetch(tree->nodes + OCT_NODE_VALUE(w));
            else if (OCT_NODE_KIND(w) == OCT_LEAF && tree->slabs &&
                     OCT_NODE_VALUE(w) < tree->n_leaves)
                __builtin_prefetch(tree->slabs + OCT_NODE_VALUE(w));
        }
#endif
        /* pushed back to front, so the front one is popped first */
        for (int j = 7; j >= 0; j--) {
            unsigned k = (unsigned)j ^ p->mask;
            unsigned hx = k & 1u, hy = k >> 1 & 1u, hz = k >> 2 & 1u;
            uint32_t can = act & half[0][hx] & half[1][hy] & half[2][hz];
            oct_node_t w = kids[k];
            if (!can || OCT_NODE_KIND(w) == OCT_EMPTY || sp >= p->cap)
                continue;
            const double *e0 = hl[0][hx], *e1 = hl[1][hy], *e2 = hl[2][hz];
            const double *x0 = hh[0][hx], *x1 = hh[1][hy], *x2 = hh[2][hz];
            double cl[PK], ch[PK];
            range(e0, e1, e2, x0, x1, x2, cl, ch);
            uint32_t kact = can & bits_le(cl, ch) & bits_lt(cl, tm);
            if (!kact)
                continue;
            pcell_t *e = &stack[sp++];
            e->en[0] = e0, e->en[1] = e1, e->en[2] = e2;
            e->ex[0] = x0, e->ex[1] = x1, e->ex[2] = x2;
            e->i[0] = 2 * c.i[0] + hx;
            e->i[1] = 2 * c.i[1] + hy;
            e->i[2] = 2 * c.i[2] + hz;
            e->word = w;
            e->depth = depth;
            e->active = kact;
        }
    }
}
