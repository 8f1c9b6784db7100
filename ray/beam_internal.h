/* ivoct ray — beams of rays through the octree, internal to ray/ (render.c,
 * beam.c, traverse.c).  See ray/README.md, "Beams".
 *
 * A beam is the set of rays o + t·d, t >= 0, with one origin o and every
 * direction d in an interval box D (per-component [dlo, dhi]: the hull of the
 * doubles ray_camera_dir gives for a rectangle of pixels).  The beam walk
 * goes down the octree like the per-ray walk of traverse.c, with the plane
 * crossings enclosed over all of D, and widened so that they also hold every
 * crossing the per-ray walk computes (its own outward rounding) for a ray of
 * the beam.  So every surface leaf the per-ray walk yields for a ray of the
 * beam is reached by the beam walk: a beam that reaches none decides all its
 * rays as misses, for every method, without a single evaluation. */
#ifndef IVOCT_RAY_BEAM_INTERNAL_H
#define IVOCT_RAY_BEAM_INTERNAL_H

#include "ray.h"

/* The octree source behind src (traverse.c), or NULL for any other source. */
const ray_octree_source_t *ray_source_octree(const ray_source_t *src);

/* A beam walk's workspace (its stack, sized from the tree's depth); one per
 * thread.  NULL when out of memory. */
typedef struct ray_beam_ws ray_beam_ws_t;
ray_beam_ws_t *ray_beam_ws_new(const oct_tree_t *tree);
void ray_beam_ws_free(ray_beam_ws_t *ws);

/* Does the beam (origin o, directions in [dlo, dhi] per component) reach a
 * surface leaf of tree?  0 is a proof that the per-ray walk of the octree
 * source (ray_octree_source, with or without slabs, any t_max) yields no leaf
 * for any ray o + t·d with d in the box.  1 says nothing (it may be a
 * rounding artefact).  ws must come from ray_beam_ws_new for a tree of this
 * depth. */
int ray_beam_reaches(const oct_tree_t *tree, ray_beam_ws_t *ws, const double o[3],
                     const double dlo[3], const double dhi[3]);

/* ---- packets: the rays of a beam walked through the octree together ----------------
 * (traverse.c.)  Up to RAY_PACKET rays with one origin and the same signs of
 * direction go down the tree as one walk: a cell is popped, and its children
 * computed, once for all the rays that may meet it, each ray with its own
 * plane crossings lane by lane.  Each ray is handed the very segments the
 * per-ray walk (ray_octree_source) yields for it, bit for bit, in the same
 * order, given the same t_max at each step: a ray's crossings of a plane are
 * plane_t's, the cells are visited in the same depth-first order (children
 * by k ^ mask, the mask common to the packet), and a cell is dropped for a
 * ray by the same tests.  So a render is the same with packets as without. */
#define RAY_PACKET 8

typedef struct ray_packet_ws ray_packet_ws_t;
ray_packet_ws_t *ray_packet_ws_new(const oct_tree_t *tree); /* NULL when out of memory */
void ray_packet_ws_free(ray_packet_ws_t *ws);

/* Can the ray o + t·d join a packet?  o and d finite, and every component of
 * d of magnitude in [2^-1000, 2^1000] (the per-ray walk's reciprocal case;
 * the others, an axis-parallel ray among them, walk alone).  *mask: bit a set
 * when d_a < 0.  The rays of one packet share o and the mask. */
int ray_packet_ray(const double o[3], const double d[3], unsigned *mask);

/* Called for each segment of ray r, front to back as the per-ray walk yields
 * them; it may lower t_max[r] (a hit), or set it to -inf to end the ray. */
typedef void (*ray_packet_leaf_fn)(void *ctx, int r, const ray_segment_t *seg);

/* Walk the n (1..RAY_PACKET) rays o + t·d[r], each accepted by ray_packet_ray
 * with one mask, through os's tree.  t_max[r] is ray r's bound (a cell that
 * starts at or after it is skipped for r), read afresh after every call of
 * leaf.  *leaves counts the segments handed out (the per-ray walk's count).
 * ws must come from ray_packet_ws_new for a tree of this depth. */
void ray_packet_walk(const ray_octree_source_t *os, ray_packet_ws_t *ws, const double o[3],
                     int n, const double (*d)[3], double t_max[], ray_packet_leaf_fn leaf,
                     void *ctx, uint64_t *leaves);

#endif
