/* ivoct — writing an octree for VTK, ParaView and OpenVDB (prefix exp_).
 *
 * The writers read a built octree (and, where they need values of f the tree
 * does not store, its tape) and never change it.  They are C++17 inside
 * (VTK and OpenVDB are C++ libraries) behind this C interface: every C++
 * exception is caught here and becomes an error, and nothing is printed.
 *
 * Binary data in the VTK files is LZ4-compressed (VTK's vtkLZ4DataCompressor,
 * read by VTK >= 8.2 and ParaView >= 5.6), UInt64 headers.
 *
 * Every file is written to a temporary name beside the destination and
 * renamed once complete (io/io.h), so a failure never leaves a partial file;
 * a device (/dev/full, /dev/stdout) is written in place.
 *
 * All functions return 0 on success, non-zero with err set on failure
 * ("cannot write PATH: reason", "out of memory", ...).
 */
#ifndef IVOCT_EXPORT_H
#define IVOCT_EXPORT_H

#include <stddef.h>
#include <stdio.h>

#include "../expr/error.h"
#include "../expr/tape.h"
#include "../octree/octree.h"

#ifdef __cplusplus
extern "C" {
#endif

/* What the scene was (oct_source_t: its name, let.NAME definitions and f as
 * written) is stored in the files' metadata: field data in VTK files, file and
 * grid metadata in .vdb.  Any of its pointers may be NULL; src itself may be NULL. */

/* Half width of the narrow band of the sdf grid, in voxels (OpenVDB's default). */
#define EXP_SDF_HALF_WIDTH 3

/* The cell list (`ivoct build --cells F.csv`): a header line
 *   x0,x1,y0,y1,z0,z1,depth,f_lo,f_hi,nx,ny,nz,d_lo,d_hi,error_bound
 * then one row per surface leaf in leaf (Morton) order: its bounds (the
 * doubles of oct_coord), depth, enclosure of f, ILIE slab (five empty fields
 * where the leaf has none) and oct_leaf_error_bound.  Numbers as printf's
 * %.17g writes them (17 significant digits: they read back to the same
 * doubles).  When tree->certain is set (oct_certify), the header and every
 * row go on with ,certain,wx0,wy0,wz0,wx1,wy1,wz1: 1 and the witness points
 * of the leaf's code (oct_leaf_sample of the leaf's box: f < 0 at w0 and
 * f > 0 at w1, or f = 0 at w0 with the w1 fields empty), or 0 and six empty
 * fields.  Rows are formatted by `threads` threads (<= 0: one per core);
 * the file is the same for any count. */
int exp_cells(const oct_tree_t *tree, const char *path, int threads, ivoct_error_t *err);
/* The bytes of buffers exp_cells(tree, ..., threads, ...) allocates (its
 * threads' ring of text blocks and the bounds tables): the CLI's memory
 * budget picks the thread count from it. */
size_t exp_cells_memory(const oct_tree_t *tree, int threads);

/* .vtu: an UnstructuredGrid of the surface leaves as VTK_VOXEL cells (points
 * shared between neighbours, coordinates the exact doubles of oct_coord), in
 * leaf (Morton) order, cell data
 *   depth (Int32), f_lo, f_hi, error_bound (Float64: oct_leaf_error_bound),
 *   normal (3 x Float64, the slab's unit normal, 0 0 0 for a leaf without one;
 *           only when the tree has slabs),
 *   certain (UInt8, 1 where the leaf's code is not 0; only when tree->certain),
 * field data scene, f, lets (strings), box (6 doubles), depth (Int32). */
int exp_vtu(const oct_tree_t *tree, const oct_source_t *src, const char *path,
            ivoct_error_t *err);

/* The index of a partitioned .vtu (ivoct build over MPI): a .pvtu naming the
 * pieces sources[0..n) (paths relative to the index's folder) and declaring
 * their arrays as the file `piece` (any one of them, already written) has
 * them; VTK's vtkXMLPUnstructuredGridReader and ParaView read it. */
int exp_pvtu_index(const char *path, const char *piece, const char *const *sources, int n,
                   ivoct_error_t *err);
/* The index of a partitioned cell list (.pcsv): a comment line, then one line
 * `source,leaves` per piece (CSV files as exp_cells writes them), in order:
 * their rows together are the single file's rows (each piece in Morton order;
 * the pieces of ranks that shared work interleave). */
int exp_cells_index(const char *path, const char *const *sources, const uint64_t *leaves, int n,
                    ivoct_error_t *err);
/* .htg: a HyperTreeGrid of the whole octree: the root split into a 2x2x2 grid
 * of trees (one tree, the root, when the root is not split), every node a cell,
 * coarse ones included, cell data
 *   depth (Int32, depth in the octree: the trees' roots are depth 1),
 *   f_center (Float64, f at the cell's centre, point evaluation),
 *   f_lo, f_hi (Float64, an enclosure of f over the cell: the leaf's own for a
 *               surface leaf, else the interval evaluation of the whole tape),
 *   surface (UInt8: 1 for a surface leaf and for a split cell with a surface
 *            leaf below, else 0),
 *   class (Int8: 0 inside, 1 outside, 2 undefined (empty leaves, oct_class_t),
 *          3 surface leaf, 4 split),
 *   certain (UInt8: 1 on the surface leaves whose code is not 0, 0 on every
 *            other cell; only when tree->certain),
 * and the field data of the .vtu.  Written in VTK's binary (not appended) mode:
 * VTK 9.1's appended mode writes .htg files it cannot read back. */
int exp_htg(const oct_tree_t *tree, const tape_t *tape, const oct_source_t *src,
            const char *path, ivoct_error_t *err);

/* A piece of a partitioned .htg (ivoct build over MPI, `--htg F.phtg`): the
 * HyperTreeGrid of one process's part of the tree (oct_plan_finish with
 * OCT_PLAN_PART) over a grid of 2^g x 2^g x 2^g trees, the cells of the box
 * at depth g, each tree the subtree of `part` below its cell, every node a
 * cell with the cell data (values and meaning) and field data of exp_htg.
 * VTK 9.1's parallel reader cannot put one tree together from several pieces
 * (it rebuilds each piece's trees whole, masks dropped: a tree met twice is
 * renumbered over the first piece's cells), so each tree is in exactly one
 * piece:
 *   g = depth, the frontier's (oct_plan_subtree_depth) when n > 0, with
 *       frontier[0..n) the Morton codes at that depth of every frontier cell
 *       (increasing: oct_plan_subtree_code), held or not; when n == 0 (no
 *       frontier: the top is the whole tree) the grid of exp_htg (2x2x2 when
 *       the root is split, else one tree) and depth is ignored;
 *   the piece has a tree at each node of part at depth g that is a frontier
 *       cell held by the part (split there; a frontier cell not held is an
 *       empty cell) or, when `top` (the part with the top's leaves: rank 0's),
 *       a node that is not a frontier cell (a leaf of the top at depth g);
 *       the grid cells covered by leaves above depth g, and the nodes above
 *       it, are in no piece (their cells of the grid have no tree).
 * So the pieces of all the parts (the same frontier, `top` on one of them)
 * hold every node of the tree at depth g or below once, with exp_htg's
 * values.  A surface leaf of part above depth g is an error (no cell of the
 * grid is its box): the top of a build only has one when --refine stops
 * there.  Written in binary mode, in VTK's HyperTreeGrid file format 0.0
 * (exp_htg writes 2.0): the only one whose writer puts NumberOfVertices (the
 * piece's nodes) on the HyperTreeGrid element, which VTK 9.1's parallel
 * reader needs to size its arrays, and whose reader numbers a tree's nodes
 * depth first, as the parallel reader rebuilds them before copying a piece's
 * arrays as read (from 1.0 and 2.0 files the values land on other cells).
 * Every piece has the whole grid's coordinates (the reader takes the grid
 * from the first piece), a piece without a tree included. */
int exp_htg_piece(const oct_tree_t *part, const tape_t *tape, const oct_source_t *src, int depth,
                  const uint64_t *frontier, size_t n, int top, const char *path,
                  ivoct_error_t *err);
/* The index of a partitioned .htg: a .phtg (VTKFile type PHyperTreeGrid, as
 * vtkXMLPHyperTreeGridWriter writes it) naming the pieces sources[0..n)
 * (paths relative to the index's folder), read by VTK's
 * vtkXMLPHyperTreeGridReader (ParaView's reader of .phtg files).  `piece` is
 * any one of them, already written: its byte order and header type are
 * copied, and it must be an exp_htg_piece file (a HyperTreeGrid with
 * NumberOfVertices: else an error).  The reader's source keeps the pieces'
 * node offsets in an int: the pieces together should have fewer than 2^31
 * nodes. */
int exp_phtg_index(const char *path, const char *piece, const char *const *sources, int n,
                   ivoct_error_t *err);

/* .vdb: two FloatGrids on the voxels of the max depth D (voxel (i, j, k) is the
 * depth-D cell (i, j, k); the transform maps index space onto the scene box,
 * voxel centres at integer coordinates):
 *   surface  active where a surface leaf is: a leaf of depth d is a filled
 *            region (a tile where aligned) of 8^(D-d) voxels, value d;
 *            background 0;
 *   sdf      a narrow-band level set (grid class level set, background
 *            EXP_SDF_HALF_WIDTH voxels): active voxels are the surface leaves
 *            dilated by EXP_SDF_HALF_WIDTH voxels (within the box), valued with
 *            the first-order distance estimate f / |grad f| at the voxel
 *            centre (f and its gradient in doubles, tape_eval_point_grad),
 *            clamped to the background; the sign of every voxel
 *            outside the surface leaves, active or not, is the octree's
 *            certified class (inside negative; outside, undefined and beyond
 *            the box positive).
 * File and grid metadata: scene, expression, let.NAME, box_min, box_max
 * (vec3d), depth (int), creator. */
int exp_vdb(const oct_tree_t *tree, const tape_t *tape, const oct_source_t *src,
            const char *path, ivoct_error_t *err);

/* A triangle mesh of the surface, extracted by OpenVDB's volumeToMesh at
 * isovalue 0 from the sdf grid of exp_vdb (quads split in two), in world
 * coordinates.  The format follows the extension: .vtp (VTK PolyData), .ply
 * (binary little-endian), .obj.  Outward-facing triangles. */
int exp_mesh(const oct_tree_t *tree, const tape_t *tape, const oct_source_t *src,
             const char *path, ivoct_error_t *err);

/* A triangle mesh given by its points (x y z per vertex) and triangles (3
 * indices each), written like exp_mesh but with double-precision points (.ply
 * "property double", .obj 17 significant digits, .vtp Float64), and with
 * tri_depth (may be NULL) as the .vtp cell array "depth".  For the certified
 * mesh (mesh/mesh.h), whose vertices are on the surface to a double's
 * precision. */
int exp_mesh_write(const double *points, size_t n_points, const uint32_t *tris,
                   const int *tri_depth, size_t n_tris, const oct_source_t *src, const char *path,
                   ivoct_error_t *err);

/* Is path's extension one exp_mesh and exp_mesh_write write? */
int exp_mesh_supported(const char *path);

/* Summarise a .vtu, .htg, .vtp or .vdb file, or a .pvtu or .phtg index with
 * its pieces read through VTK's parallel readers (recognised by content, not
 * by name) on out.  Returns 0 when done, 1 when the file is none of these (nothing
 * printed, err untouched: the caller may try other formats), -1 with err set
 * when it is one of them but cannot be read. */
int exp_info(const char *path, FILE *out, ivoct_error_t *err);

#ifdef __cplusplus
}
#endif
#endif
