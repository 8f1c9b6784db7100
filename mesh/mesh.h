/* ivoct — a triangle mesh of f = 0 with certified topology (prefix msh_).
 *
 * msh_build meshes the surface f = 0 inside a box in the manner of Plantinga
 * and Vegter (2004): an octree of its own, subdivided until every cell either
 * holds no surface (0 not in F(C)) or has a gradient enclosure G with
 * 0 not in <G, G> (any two gradients in the cell make an acute angle, so f is
 * strictly monotone along a direction d in G), 2:1-balanced between the cells
 * that may hold surface, then meshed cell by cell from the certified signs of
 * f at the cells' corners.  mesh/README.md gives the construction, why the
 * mesh has the topology of the surface, and where that claim stops.
 *
 * What the result guarantees when msh_build returns 0 (every cell certified):
 *  - the triangles form an embedded (no two triangles meet except in their
 *    shared vertices or edge), consistently oriented 2-manifold, closed where
 *    the surface does not meet the boundary of the mesh box;
 *  - it is isotopic to the surface in the mesh box, for f that is C^1 on
 *    every cell that may hold surface (checked per cell: tape_check_continuous)
 *    and whose zero set is a regular surface there (the subdivision stops only
 *    where the gradient condition holds, so a singular point is never in a
 *    certified cell);
 *  - every vertex lies in the cell that made it, and on the surface to the
 *    precision of a double: where f changes sign along a cell edge, the
 *    bracket is cut with certified signs (regula falsi, Illinois) down to
 *    adjacent doubles or to a point where the interval of f holds 0; the apex
 *    of each cell's fan is found the same way on a line along d (stats.apex_off_surface counts the rare
 *    apexes that could not be, at the max depth);
 *  - triangles face the side where f > 0.
 * Where a cell cannot be certified (at the max depth the gradient condition
 * fails, a corner's sign is not certified, a face of a cell crosses the
 * surface ambiguously, or a cell's boundary holds several loops), msh_build
 * returns 1 and lists those cells in failures; the mesh is still returned,
 * with no triangles in those cells, for inspection only.
 *
 * The mesh box is the box given, grown by about 0.1% (see msh_mesh_box), so
 * that the grid points avoid the round coordinates hand-written surfaces tend
 * to pass through exactly (a corner where f is exactly 0 is fine — it counts
 * as positive, a symbolic perturbation — but a corner where the enclosure of
 * f straddles 0 cannot be certified).
 *
 * Deterministic: one thread, the same mesh for any SIMD path (the evaluators
 * compute the same bits on every path).  The library never prints. */
#ifndef IVOCT_MESH_H
#define IVOCT_MESH_H

#include <stddef.h>
#include <stdint.h>

#include "../expr/error.h"
#include "../expr/interval.h"
#include "../expr/tape.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Deepest octree: grid coordinates (0..2^depth) of three axes pack into 63 bits. */
#define MSH_MAX_DEPTH 20

typedef struct msh_params {
    int max_depth;      /* 1..MSH_MAX_DEPTH: cells are never split below it */
    int min_depth;      /* 0..max_depth: cells are split at least down to it (a finer mesh) */
    size_t max_memory;  /* bytes; 0 = no limit */
} msh_params_t;

/* Why a cell could not be certified. */
typedef enum msh_reason {
    MSH_FAIL_GRADIENT = 0, /* at the max depth, 0 in <G, G> (or f not C^1 on the cell) */
    MSH_FAIL_SIGN,         /* the sign of f at a corner of the cell is not certified */
    MSH_FAIL_FACE,         /* at the max depth, a face crosses the surface more than once */
    MSH_FAIL_LOOPS,        /* at the max depth, the cell's boundary holds several loops */
} msh_reason_t;

typedef struct msh_failure {
    iv_box_t box;
    int depth;
    msh_reason_t reason;
    uint32_t region; /* 0 .. n_regions - 1: failed cells that touch (a face, an edge
                        or a corner), transitively, share a region (a singular
                        point makes one); numbered in the order of their first cell */
} msh_failure_t;

typedef struct msh_stats {
    uint64_t cells_evaluated;   /* cells whose enclosures were computed */
    uint64_t leaves_empty;      /* leaves with 0 not in F */
    uint64_t leaves_surface;    /* leaves where the gradient condition holds */
    uint64_t leaves_unresolved; /* leaves at the max depth where it does not */
    uint64_t split_balance;     /* cells split to keep the tree 2:1 balanced */
    uint64_t split_face;        /* cells split because a face crossed the surface twice */
    uint64_t split_loops;       /* cells split because their boundary held several loops */
    uint64_t split_apex;        /* cells split because no apex on the surface was found */
    uint64_t passes;            /* construction passes (each after a round of splits) */
    uint64_t sign_evaluations;  /* certified signs of f at points */
    uint64_t apex_off_surface;  /* fan apexes left off the surface (at the max depth) */
    double seconds;
} msh_stats_t;

typedef struct msh_mesh {
    double *points;         /* x y z per vertex */
    size_t n_points;
    uint32_t *tris;         /* 3 vertex indices per triangle, facing f > 0 */
    size_t n_tris;
    uint32_t *tri_cell;     /* per triangle: the index in cells of the cell that made it */
    iv_box_t *cells;        /* the cells that hold triangles */
    int *cell_depth;
    size_t n_cells;
    msh_failure_t *failures;
    size_t n_failures, n_regions;
    iv_box_t box;           /* the mesh box */
    msh_stats_t stats;
} msh_mesh_t;

/* The box msh_build meshes for a given box: each axis grown by 0.123% of its
 * width below and 0.077% above. */
iv_box_t msh_mesh_box(const iv_box_t *box);

/* Mesh f = 0 in the mesh box of box.  0: every cell certified (the guarantees
 * above); 1: the mesh is built but out->failures lists the cells where the
 * guarantee fails; -1 with err set: bad parameters, out of memory or over
 * p->max_memory (out is then empty).  out is always safe to msh_free. */
int msh_build(const tape_t *t, const iv_box_t *box, const msh_params_t *p, msh_mesh_t *out,
              ivoct_error_t *err);

void msh_free(msh_mesh_t *m);

/* "gradient", "sign", "face", "loops". */
const char *msh_reason_name(msh_reason_t r);

#ifdef __cplusplus
}
#endif
#endif
