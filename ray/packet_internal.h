/* ivoct ray — the packet walk's kernel interface, internal to ray/
 * (traverse.c calls it; packet_kernels.h is its body, compiled once per SIMD
 * path).  What the walk yields: beam_internal.h, "packets". */
#ifndef IVOCT_RAY_PACKET_INTERNAL_H
#define IVOCT_RAY_PACKET_INTERNAL_H

#include "beam_internal.h"

#define PK RAY_PACKET

/* A cell waiting on the stack: per axis, where its rays' [entry, exit] of
 * the ray parameter are (plane_t's bounds of the crossings of the cell's near
 * and far planes, a lane per ray), and the rays that may meet it.  The
 * arrays are those of the level where each plane was a mid-plane
 * (packet_kernels.h: a frame per depth), or the root's. */
typedef struct pcell {
    const double *en[3], *ex[3];
    uint32_t i[3];   /* cell coordinates at depth */
    oct_node_t word;
    int depth;
    uint32_t active; /* bit r: ray r may meet the cell */
} pcell_t;

/* One walk.  The rays share the origin o and the signs of their directions
 * (neg[a]: d_a < 0 for all of them); per axis and ray, [inv_lo, inv_hi]
 * encloses 1/d_a (traverse.c's axis_t).  Lanes n..PK-1 are padding: t_max
 * -inf, never active. */
typedef struct packet_rays {
    const oct_tree_t *tree;
    double o[3];
    int neg[3];
    unsigned mask;  /* bit a: neg[a] */
    int n;
    double inv_lo[3][PK], inv_hi[3][PK];
    double t_max[PK];
    /* Ray r meets leaf li over [lo, hi] with lo < t_max[r]: returns r's
     * t_max afterwards (traverse.c: the slab, the segment, the caller's
     * leaf function). */
    double (*leaf)(void *ctx, uint32_t li, int r, double lo, double hi);
    void *ctx;
    pcell_t *stack; /* cap entries */
    int cap;
} packet_rays_t;

typedef void (*packet_walk_fn)(packet_rays_t *p);
void packet_walk_portable(packet_rays_t *p);
#ifdef IVOCT_SIMD_X86
void packet_walk_avx2(packet_rays_t *p);
void packet_walk_avx512(packet_rays_t *p);
#endif

#endif
