/* The OpenVDB baseline of bench/ray_error.c: a narrow-band level set sampled from f,
 * ray cast with openvdb::tools::LevelSetRayIntersector (bench/vdb_raycast.cpp).
 *
 * The grid: uniform voxels of edge h (default: the smallest edge of the
 * scene box / 2^depth, i.e. no coarser than the octree's finest cells on any
 * axis), voxel (i, j, k) centred at box_min + (i + 1/2, j + 1/2, k + 1/2)·h.
 * The band: the voxels that meet a surface leaf of ivoct's octree (so the
 * dense grid is never sampled), dilated by half_width voxels (26-neighbour
 * steps, i.e. a Chebyshev distance), clipped to the box.  Each band voxel gets
 * f/|∇f| at its centre (value and gradient in doubles from
 * tape_eval_point_grad, as ivoct's .vdb writer), clamped to ±background;
 * background = half_width·h; the inside is then flood-filled with -background (tools::signedFloodFill).
 * Grid class GRID_LEVEL_SET, a linear transform with uniform scale.
 *
 * The cast: one ray per pixel, from cam->eye along ray_camera_dir (the rays of
 * ray/camera.c exactly), through LevelSetRayIntersector<FloatGrid> with its
 * defaults (LinearSearchImpl: linear interpolation of trilinearly interpolated
 * values between the steps of the HDDA, no extra iterations) and
 * intersectsWS(ray, xyz, t): t is the world-space distance along the unit
 * direction, as ivoct's.  Threads each use their own copy of the intersector.
 *
 * Benchmark support, C++ behind this C header: errors are returned with a
 * message, never printed. */
#ifndef IVOCT_BENCH_VDB_RAYCAST_H
#define IVOCT_BENCH_VDB_RAYCAST_H

#include <stddef.h>
#include <stdint.h>

#include "../expr/tape.h"
#include "../octree/octree.h"
#include "../ray/ray.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct vdb_rc_opts {
    double voxel;   /* voxel edge; <= 0: min box edge / 2^tree->depth */
    int half_width; /* band half-width in voxels; <= 0: 3 */
    int threads;    /* for sampling the band; <= 0: OpenMP's default */
} vdb_rc_opts_t;

typedef struct vdb_rc_build_stats {
    double voxel;             /* the voxel edge used */
    double background;        /* half_width * voxel */
    uint64_t seed_voxels;     /* voxels meeting a surface leaf */
    uint64_t active_voxels;   /* the band */
    size_t mem_bytes;         /* the grid's memory usage */
    double time_s;            /* wall clock: band topology + sampling + flood fill
                               * (the octree build is not included) */
    double sample_s;          /* of which sampling f/|∇f| */
    int threads;
} vdb_rc_build_stats_t;

typedef struct vdb_rc vdb_rc_t;

/* Build the level set of tape (the surface tree was built from) over
 * tree->box.  Returns 0 and a new grid, or non-zero with a message. */
int vdb_rc_build(const tape_t *tape, const oct_tree_t *tree, const vdb_rc_opts_t *opts,
                 vdb_rc_t **out, vdb_rc_build_stats_t *st, char *msg, size_t msg_len);

/* Ray cast cam (one ray per pixel) with `threads` threads (<= 0: OpenMP's
 * default; 1: a plain loop).  t gets cam->width*cam->height distances, row 0
 * at the top, NaN on a miss; *time_s the wall clock of the cast alone, *hits
 * the hits.  Returns 0, or non-zero with a message. */
int vdb_rc_cast(const vdb_rc_t *g, const ray_camera_t *cam, int threads, double *t,
                double *time_s, uint64_t *hits, char *msg, size_t msg_len);

void vdb_rc_free(vdb_rc_t *g);

#ifdef __cplusplus
}
#endif
#endif
