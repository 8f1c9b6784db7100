#!/usr/bin/python3
"""Read a partitioned HyperTreeGrid (`mpirun ... ivoct build --htg P.phtg`) back with
VTK's parallel reader (python3-vtk9's vtkXMLPHyperTreeGridReader: run with
/usr/bin/python3) and check it against the single-process build's .htg and stats.

  check_phtg.py --phtg P.phtg --htg ONE.htg --stats S.json

- each piece the index names reads alone (VTK's serial reader), and each tree of
  the grid is in one piece only (VTK's parallel reader cannot merge a tree from
  several); the parallel reader's output has the pieces' cells, with no error or
  warning, and a grid of 2^g trees per axis over the box of the .htg;
- its surface leaves (leaf cells of class 3) are as many as the stats' leaves, by
  depth as the stats say;
- its leaves, located by the HTG geometry (the voxels of
  vtkHyperTreeGridToUnstructuredGrid: their bounds turned into the cell's integer
  coordinates at the depth of its `depth` array, and checked against them), are the
  leaves of the single .htg at depth g or below, each with the same cell data
  (depth, f_center, f_lo, f_hi, surface, class, certain when there);
- its cells, leaves or not, have the values of the single .htg's cells at depth g or
  below (the same rows of cell data, as multisets).
Prints one line per failed check on stderr; exit 1 if any failed.
"""
import argparse
import json
import os
import re
import sys

import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy

errors = []
passed = 0
ARRAYS = ("depth", "f_center", "f_lo", "f_hi", "surface", "class", "certain")


def check(ok, what):
    global passed
    if ok:
        passed += 1
    else:
        errors.append(what)
    return ok


def read(reader_class, path):
    r = reader_class()
    messages = []
    r.AddObserver("ErrorEvent", lambda o, e, *a: messages.append(e))
    r.AddObserver("WarningEvent", lambda o, e, *a: messages.append(e))
    r.SetFileName(path)
    r.Update()
    check(not messages, "%s: the reader reported errors" % path)
    return r.GetOutput()


def arrays_of(fd, n, what):
    """The cell arrays of ARRAYS that fd has, as numpy arrays of n values."""
    out = {}
    for name in ARRAYS:
        a = fd.GetArray(name)
        if a is not None and check(a.GetNumberOfTuples() == n, "%s: %s has %d values for %d cells"
                                   % (what, name, a.GetNumberOfTuples(), n)):
            out[name] = vtk_to_numpy(a)
    return out


def grid_of(htg, what):
    """g (2^g trees per axis) and the box of the grid."""
    dims = [0, 0, 0]
    htg.GetCellDims(dims)
    g = max(int(dims[0]).bit_length() - 1, 0)
    check(dims == [1 << g] * 3, "%s: %s trees, not 2^g per axis" % (what, dims))
    coords = [vtk_to_numpy(a) for a in (htg.GetXCoordinates(), htg.GetYCoordinates(),
                                        htg.GetZCoordinates())]
    return g, np.array([[c[0], c[-1]] for c in coords])


def leaves_of(htg, box, what):
    """The leaves: integer keys (depth, ix, iy, iz) from their geometry, sorted, and
    their cell arrays in that order."""
    ug_filter = vtk.vtkHyperTreeGridToUnstructuredGrid()
    ug_filter.SetInputData(htg)
    ug_filter.Update()
    ug = ug_filter.GetOutput()
    n = ug.GetNumberOfCells()
    check(n == htg.GetNumberOfLeaves(), "%s: %d voxels for %d leaves" % (what, n,
                                                                         htg.GetNumberOfLeaves()))
    arrays = arrays_of(ug.GetCellData(), n, what + " leaves")
    if "depth" not in arrays:
        check(False, "%s: no depth array" % what)
        return np.zeros((0, 4), dtype=np.int64), {}
    pts = vtk_to_numpy(ug.GetPoints().GetData()).astype(np.float64)
    conn = vtk_to_numpy(ug.GetCells().GetConnectivityArray()).reshape(n, 8)
    corners = pts[conn]                                   # (n, 8, 3)
    lo, hi = corners.min(axis=1), corners.max(axis=1)     # (n, 3)
    depth = arrays["depth"].astype(np.int64)
    size = box[:, 1] - box[:, 0]
    cells = (1 << depth)[:, None].astype(np.float64)
    ix = np.rint((lo - box[:, 0]) / size * cells).astype(np.int64)
    # the voxel is the cell (ix, iy, iz) of its depth, up to the points' float precision
    tol = 1e-6 * size
    off = (np.abs(lo - (box[:, 0] + size * ix / cells)) > tol) | \
          (np.abs(hi - (box[:, 0] + size * (ix + 1) / cells)) > tol)
    check(not off.any(), "%s: %d leaves whose bounds are not the cell of their depth"
          % (what, off.any(axis=1).sum()))
    keys = np.column_stack([depth, ix])
    order = np.lexsort(keys.T[::-1])
    keys = keys[order]
    check(len(keys) == 0 or np.all(np.any(keys[1:] != keys[:-1], axis=1)),
          "%s: two leaves at one place" % what)
    return keys, {k: v[order] for k, v in arrays.items()}


def same(a, b):
    return a.shape == b.shape and np.array_equal(a, b, equal_nan=a.dtype.kind == "f")


def rows(arrays, keep):
    """The cells' rows of cell data (keep: a mask), sorted: a multiset."""
    names = sorted(arrays)
    table = np.column_stack([arrays[k][keep].astype(np.float64) for k in names])
    return table[np.lexsort(table.T[::-1])] if len(table) else table


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--phtg", required=True)
    p.add_argument("--htg", required=True)
    p.add_argument("--stats", required=True)
    a = p.parse_args()
    with open(a.stats) as f:
        st = json.load(f)

    # the pieces: each read alone, the trees of the grid shared out
    with open(a.phtg) as f:
        sources = re.findall(r'<Piece Source="([^"]*)"', f.read())
    check(len(sources) > 0, "phtg: no piece")
    owner = {}
    vertices = 0
    for s in sources:
        piece = read(vtk.vtkXMLHyperTreeGridReader, os.path.join(os.path.dirname(a.phtg), s))
        vertices += piece.GetNumberOfVertices()
        for tree in range(piece.GetMaxNumberOfTrees()):
            if piece.GetTree(tree) is not None:
                check(tree not in owner, "phtg: tree %d in %s and %s" % (tree, owner.get(tree), s))
                owner[tree] = s

    whole = read(vtk.vtkXMLPHyperTreeGridReader, a.phtg)
    check(whole.GetNumberOfVertices() == vertices,
          "phtg: %d cells read, the pieces have %d" % (whole.GetNumberOfVertices(), vertices))
    single = read(vtk.vtkXMLHyperTreeGridReader, a.htg)
    g, box = grid_of(whole, "phtg")
    _, single_box = grid_of(single, "htg")
    check(np.array_equal(box, single_box), "phtg: box %s, the .htg's %s" % (box.tolist(),
                                                                              single_box.tolist()))
    check(not whole.HasMask(), "phtg: masked cells")

    keys, values = leaves_of(whole, box, "phtg")
    ref_keys, ref_values = leaves_of(single, single_box, "htg")

    # the surface leaves: the stats' count, by depth
    if "class" in values:
        surface = values["class"] == 3
        check(surface.sum() == st["leaves"], "phtg: %d surface leaves, stats say %d"
              % (surface.sum(), st["leaves"]))
        by_depth = np.bincount(keys[surface, 0], minlength=len(st["leaves_by_depth"]))
        check(list(by_depth) == st["leaves_by_depth"],
              "phtg: surface leaves by depth %s, stats say %s"
              % (list(by_depth), st["leaves_by_depth"]))
    check(values.keys() == ref_values.keys(), "phtg: arrays %s, the .htg %s"
          % (sorted(values), sorted(ref_values)))

    # the leaves at depth g or below: the same cells with the same values
    below = ref_keys[:, 0] >= g
    if check(np.array_equal(keys, ref_keys[below]),
             "phtg: %d leaves, the .htg %d at depth %d or below (or at other places)"
             % (len(keys), below.sum(), g)):
        for name in sorted(values.keys() & ref_values.keys()):
            check(same(values[name], ref_values[name][below]),
                  "phtg: %s of the leaves differs from the .htg's" % name)

    # every cell at depth g or below, leaf or not: the same rows of values
    cells = arrays_of(whole.GetCellData(), whole.GetNumberOfVertices(), "phtg")
    ref_cells = arrays_of(single.GetCellData(), single.GetNumberOfVertices(), "htg")
    if "depth" in cells and "depth" in ref_cells and cells.keys() == ref_cells.keys():
        check(np.all(cells["depth"] >= g), "phtg: cells above depth %d" % g)
        check(same(rows(cells, cells["depth"] >= g), rows(ref_cells, ref_cells["depth"] >= g)),
              "phtg: the cells' values differ from the .htg's cells at depth %d or below" % g)

    for e in errors:
        print("  " + e, file=sys.stderr)
    print("  check_phtg: %d pieces, trees of depth %d, %d cells, %d leaves: %d checks passed, "
          "%d failed" % (len(sources), g, whole.GetNumberOfVertices(), len(keys), passed,
                         len(errors)))
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
