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

#endif
