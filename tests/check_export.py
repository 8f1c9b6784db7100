#!/usr/bin/python3
"""Read the exports of `ivoct build` back with Debian's VTK and OpenVDB Python
modules (python3-vtk9, python3-openvdb: run with /usr/bin/python3) and check
them against the build's --stats and --cells outputs.

  check_export.py --stats S.json --cells C.csv [--vtu F] [--htg F] [--vdb F]
                  [--mesh F ...] [--sphere]

--sphere: the scene is the unit sphere x^2+y^2+z^2-1: the sdf is compared with
the true distance and the mesh with the sphere (within a voxel, area within 1%).
Prints one line per failed check on stderr; exit 1 if any failed.
"""
import argparse
import csv
import json
import math
import sys

import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy

errors = []
passed = 0


def check(ok, what):
    global passed
    if ok:
        passed += 1
    else:
        errors.append(what)
    return ok


def read_cells(path):
    """The --cells CSV: boxes (n, 6), depth (n), f_lo, f_hi, and the optional
    slab normal / error_bound columns of later versions."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    col = {name: i for i, name in enumerate(header)}
    cells = {
        "box": np.array([[float(v) for v in r[:6]] for r in body]).reshape(-1, 6),
        "depth": np.array([int(r[col["depth"]]) for r in body], dtype=int),
        "f_lo": np.array([float(r[col["f_lo"]]) for r in body]),
        "f_hi": np.array([float(r[col["f_hi"]]) for r in body]),
    }
    if "error_bound" in col:
        cells["error_bound"] = np.array([float(r[col["error_bound"]]) for r in body])
    if "nx" in col:
        cells["normal"] = np.array(
            [[float(r[col[k]]) if r[col[k]] else 0.0 for k in ("nx", "ny", "nz")] for r in body]
        ).reshape(-1, 3)
    return cells


class Quiet:
    """VTK readers print their errors; collect them instead."""

    def __init__(self, obj):
        self.messages = []
        obj.AddObserver("ErrorEvent", lambda o, e, *a: self.messages.append(e))
        obj.AddObserver("WarningEvent", lambda o, e, *a: self.messages.append(e))


def read_vtk(reader_class, path):
    r = reader_class()
    q = Quiet(r)
    r.SetFileName(path)
    r.Update()
    check(not q.messages, "%s: the reader reported errors" % path)
    return r.GetOutput()


def field_string(fd, name):
    a = fd.GetAbstractArray(name) if fd else None
    return a.GetValue(0) if a is not None and a.GetNumberOfValues() else None


# ---- .vtu ---------------------------------------------------------------------------------
def check_vtu(path, st, cells):
    ug = read_vtk(vtk.vtkXMLUnstructuredGridReader, path)
    n = st["leaves"]
    if not check(ug.GetNumberOfCells() == n,
                 "vtu: %d cells, stats say %d leaves" % (ug.GetNumberOfCells(), n)):
        return
    types = vtk_to_numpy(ug.GetCellTypesArray())
    check(np.all(types == vtk.VTK_VOXEL), "vtu: cells that are not VTK_VOXEL")
    pts = vtk_to_numpy(ug.GetPoints().GetData())
    check(pts.dtype == np.float64, "vtu: points are %s, not doubles" % pts.dtype)
    conn = vtk_to_numpy(ug.GetCells().GetConnectivityArray()).reshape(n, 8)
    corners = pts[conn]  # (n, 8, 3)
    # VTK_VOXEL order: point k is at x1 if k & 1, y1 if k & 2, z1 if k & 4
    box = cells["box"]
    want = np.empty((n, 8, 3))
    for k in range(8):
        want[:, k, 0] = box[:, 1] if k & 1 else box[:, 0]
        want[:, k, 1] = box[:, 3] if k & 2 else box[:, 2]
        want[:, k, 2] = box[:, 5] if k & 4 else box[:, 4]
    bad = np.nonzero(np.any(corners != want, axis=(1, 2)))[0]
    check(len(bad) == 0, "vtu: %d voxels whose corners differ from their octree cell "
          "(first: cell %s)" % (len(bad), bad[:1]))
    cd = ug.GetCellData()
    arrays = {cd.GetArrayName(i) for i in range(cd.GetNumberOfArrays())}
    for name in ("depth", "f_lo", "f_hi", "error_bound"):
        if not check(name in arrays, "vtu: no cell array %s" % name):
            continue
        a = vtk_to_numpy(cd.GetArray(name))
        if name in cells:
            check(np.array_equal(a, cells[name]), "vtu: %s differs from the --cells file" % name)
    if "error_bound" in arrays:
        eb = vtk_to_numpy(cd.GetArray("error_bound"))
        check(np.all(eb > 0) and eb.max() == st["max_error_bound"],
              "vtu: error_bound max %r, stats say %r" % (eb.max(), st["max_error_bound"]))
    if "normal" in arrays and "normal" in cells:
        check(np.array_equal(vtk_to_numpy(cd.GetArray("normal")), cells["normal"]),
              "vtu: normal differs from the --cells file")
    by_depth = np.bincount(vtk_to_numpy(cd.GetArray("depth")), minlength=len(st["leaves_by_depth"]))
    check(list(by_depth) == st["leaves_by_depth"], "vtu: leaves by depth %s, stats say %s"
          % (list(by_depth), st["leaves_by_depth"]))
    fd = ug.GetFieldData()
    check(field_string(fd, "scene") == st["scene"], "vtu: field data scene %r" % field_string(fd, "scene"))
    d = fd.GetArray("depth")
    check(d is not None and d.GetValue(0) == st["depth"], "vtu: field data depth")


# ---- .htg ---------------------------------------------------------------------------------
def walk_htg(htg):
    """Every node of the HyperTreeGrid: (global index, level, is leaf, bounds)."""
    out = []
    cursor = vtk.vtkHyperTreeGridNonOrientedGeometryCursor()
    bounds = [0.0] * 6

    def visit():
        cursor.GetBounds(bounds)
        leaf = cursor.IsLeaf()
        out.append((cursor.GetGlobalNodeIndex(), cursor.GetLevel(), leaf, tuple(bounds)))
        if not leaf:
            for c in range(8):
                cursor.ToChild(c)
                visit()
                cursor.ToParent()

    for tree in range(htg.GetMaxNumberOfTrees()):
        if htg.GetTree(tree) is not None:
            htg.InitializeNonOrientedGeometryCursor(cursor, tree)
            visit()
    return out


def check_htg(path, st, cells):
    htg = read_vtk(vtk.vtkXMLHyperTreeGridReader, path)
    n_nodes = st["cells_visited"] - 1  # every cell but the root
    check(htg.GetNumberOfVertices() == n_nodes,
          "htg: %d nodes, stats say %d cells besides the root" % (htg.GetNumberOfVertices(), n_nodes))
    dims = [0, 0, 0]
    htg.GetCellDims(dims)
    check(dims == [2, 2, 2], "htg: %s trees, expected 2 x 2 x 2" % dims)
    cd = htg.GetCellData()
    arr = {}
    for name in ("depth", "f_center", "f_lo", "f_hi", "surface", "class"):
        a = cd.GetArray(name)
        if check(a is not None and a.GetNumberOfTuples() == htg.GetNumberOfVertices(),
                 "htg: no cell array %s for every node" % name):
            arr[name] = vtk_to_numpy(a)
    if len(arr) < 6:
        return None
    nodes = walk_htg(htg)
    idx = np.array([g for g, _, _, _ in nodes])
    level = np.array([l for _, l, _, _ in nodes])
    leaf = np.array([lf for _, _, lf, _ in nodes], dtype=bool)
    bounds = np.array([b for _, _, _, b in nodes])
    check(len(nodes) == n_nodes and len(set(idx.tolist())) == n_nodes,
          "htg: the walk found %d nodes" % len(nodes))
    depth, cls, surface = arr["depth"][idx], arr["class"][idx], arr["surface"][idx]
    check(np.array_equal(depth, level + 1), "htg: depth is not the level + 1")
    check(np.array_equal(leaf, cls != 4), "htg: class 4 (split) is not exactly the non-leaves")
    by_depth = np.bincount(depth, minlength=st["depth"] + 1)
    check(list(by_depth[1:]) == st["cells_by_depth"][1:],
          "htg: nodes by depth %s, stats say %s" % (list(by_depth[1:]), st["cells_by_depth"][1:]))
    surf_leaf = leaf & (cls == 3)
    check(surf_leaf.sum() == st["leaves"], "htg: %d surface leaves, stats say %d"
          % (surf_leaf.sum(), st["leaves"]))
    lbd = np.bincount(depth[surf_leaf], minlength=st["depth"] + 1)
    check(list(lbd) == st["leaves_by_depth"], "htg: surface leaves by depth %s, stats say %s"
          % (list(lbd), st["leaves_by_depth"]))
    check(np.array_equal(surface[leaf] == 1, cls[leaf] == 3), "htg: surface on leaves != class 3")
    check(np.all(surface[~leaf] <= 1), "htg: surface not 0/1")
    # surface leaves: the same cells as the octree's (HTG geometry is summed halvings:
    # equal up to rounding), with the leaves' own F interval
    scale = max(abs(v) for v in st_box(cells)) or 1.0
    order = np.lexsort(bounds[surf_leaf][:, [0, 2, 4]].T)
    ours = bounds[surf_leaf][order]
    theirs = cells["box"][np.lexsort(cells["box"][:, [0, 2, 4]].T)]
    if check(ours.shape == theirs.shape, "htg: surface leaf count differs from --cells"):
        check(np.allclose(ours, theirs, rtol=0, atol=1e-12 * scale),
              "htg: surface leaf bounds differ from the octree cells")
        flo = arr["f_lo"][idx][surf_leaf][order]
        want = cells["f_lo"][np.lexsort(cells["box"][:, [0, 2, 4]].T)]
        check(np.array_equal(flo, want), "htg: f_lo of surface leaves differs from --cells")
    flo, fhi, fc = arr["f_lo"][idx], arr["f_hi"][idx], arr["f_center"][idx]
    ok = np.isfinite(fc)
    check(np.all((flo[ok] <= fc[ok]) & (fc[ok] <= fhi[ok])), "htg: f_center outside [f_lo, f_hi]")
    # an empty cell decided by a test other than the interval one may have an
    # enclosure holding 0, but never one of the wrong sign
    check(np.all(flo[cls == 0] < 0) and np.all(fhi[cls == 1] > 0),
          "htg: an inside cell with f_lo >= 0 or an outside one with f_hi <= 0")
    check(np.all(fc[cls == 0] < 0) and np.all(fc[cls == 1] > 0),
          "htg: f_center sign disagrees with the class")
    return {"bounds": bounds, "class": cls, "f_center": fc, "depth": depth, "leaf": leaf}


def st_box(cells):
    b = cells["box"]
    return [b[:, 0].min(), b[:, 1].max(), b[:, 2].min(), b[:, 3].max(), b[:, 4].min(), b[:, 5].max()]


# ---- .vdb ---------------------------------------------------------------------------------
def check_vdb(path, st, cells, htg, sphere):
    import pyopenvdb as vdb

    meta = vdb.readMetadata(path)
    check(meta.get("scene") == st["scene"], "vdb: metadata scene %r" % meta.get("scene"))
    check(meta.get("depth") == st["depth"], "vdb: metadata depth %r" % meta.get("depth"))
    check("expression" in meta and "box_min" in meta and "box_max" in meta,
          "vdb: metadata without expression or box: %s" % sorted(meta))
    names = sorted(g.name for g in vdb.readAllGridMetadata(path))
    check(names == ["sdf", "surface"], "vdb: grids %s" % names)
    surf, sdf = vdb.read(path, "surface"), vdb.read(path, "sdf")
    D = st["depth"]
    lo, hi = np.array(meta["box_min"]), np.array(meta["box_max"])
    h = (hi - lo) / 2 ** D
    for g in (surf, sdf):
        xf = g.transform
        check(np.allclose(xf.voxelSize(), h, rtol=1e-12, atol=0), "vdb %s: voxel size %s, expected %s"
              % (g.name, xf.voxelSize(), h))
        check(np.allclose(xf.indexToWorld((0, 0, 0)), lo + h / 2, rtol=0, atol=1e-12 * np.abs(hi).max()),
              "vdb %s: voxel (0,0,0) is not the first cell of the box" % g.name)
    # surface: 8^(D - d) voxels per leaf, value d, on the leaf's cell
    want = int(sum(8 ** (D - int(d)) for d in cells["depth"]))
    check(surf.activeVoxelCount() == want, "vdb surface: %d active voxels, expected %d"
          % (surf.activeVoxelCount(), want))
    n = 2 ** D
    dense = np.zeros((n, n, n), dtype=np.float32)
    surf.copyToArray(dense, ijk=(0, 0, 0))
    ijk = np.floor((cells["box"][:, [0, 2, 4]] - lo) / h + 0.5).astype(int)  # lower corner voxel
    check(np.array_equal(dense[ijk[:, 0], ijk[:, 1], ijk[:, 2]], cells["depth"].astype(np.float32)),
          "vdb surface: a leaf's voxel does not hold its depth")
    check(np.count_nonzero(dense) == want, "vdb surface: values outside the leaves")
    # sdf: a level set; signs at the centres of the empty cells are their class
    check(sdf.gridClass == vdb.GridClass.LEVEL_SET, "vdb sdf: grid class %r" % sdf.gridClass)
    bg = sdf.background
    check(math.isclose(bg, 3 * h.max(), rel_tol=1e-6), "vdb sdf: background %r, expected 3 voxels" % bg)
    dist = np.zeros((n, n, n), dtype=np.float32)
    sdf.copyToArray(dist, ijk=(0, 0, 0))
    check(np.all(np.abs(dist) <= bg * (1 + 1e-6)), "vdb sdf: values beyond the background")
    # the band: the sdf's active voxels are the surface leaves' voxels dilated by 3
    # voxels (Chebyshev distance, OpenVDB's 26-neighbour dilation 3 times), within the box
    leaves = np.zeros((n, n, n), dtype=bool)
    size = (2 ** (D - cells["depth"].astype(int)))
    deepest = size == 1
    leaves[ijk[deepest, 0], ijk[deepest, 1], ijk[deepest, 2]] = True
    for (i, j, k), w in zip(ijk[~deepest], size[~deepest]):
        leaves[i:i + w, j:j + w, k:k + w] = True
    band = leaves
    for axis in range(3):
        grown = band.copy()
        for step in range(1, 4):
            lo_, hi_ = [slice(None)] * 3, [slice(None)] * 3
            lo_[axis], hi_[axis] = slice(step, None), slice(None, -step)
            grown[tuple(lo_)] |= band[tuple(hi_)]
            grown[tuple(hi_)] |= band[tuple(lo_)]
        band = grown
    active = np.zeros((n, n, n), dtype=bool)
    for item in sdf.iterOnValues():
        (i0, j0, k0), (i1, j1, k1) = item["min"], item["max"]
        active[i0:i1 + 1, j0:j1 + 1, k0:k1 + 1] = True
    check(np.array_equal(active, band), "vdb sdf: %d active voxels, %d in the dilated surface, %d differ"
          % (np.count_nonzero(active), np.count_nonzero(band), np.count_nonzero(active != band)))
    if htg is not None:
        b, cls = htg["bounds"], htg["class"]
        centre = (b[:, [0, 2, 4]] + b[:, [1, 3, 5]]) / 2
        v = np.clip(np.floor((centre - lo) / h).astype(int), 0, n - 1)
        s = dist[v[:, 0], v[:, 1], v[:, 2]]
        inside, outside = cls == 0, cls == 1
        check(np.all(s[inside] < 0), "vdb sdf: %d inside cells with sdf >= 0 at the centre"
              % np.count_nonzero(s[inside] >= 0))
        check(np.all(s[outside] > 0), "vdb sdf: %d outside cells with sdf <= 0 at the centre"
              % np.count_nonzero(s[outside] <= 0))
        check(np.count_nonzero(inside) > 0 and np.count_nonzero(outside) > 0,
              "vdb sdf: no inside or no outside cells to check")
        fc = htg["f_center"]
        check(np.all(np.sign(s[inside | outside]) == np.sign(fc[inside | outside])),
              "vdb sdf: sign differs from f at a cell centre")
    if sphere:
        # within the surface leaves the estimate f/|grad f| = (r^2-1)/(2r) is within
        # (r-1)^2/(2r) of the distance r - 1
        c = lo + (ijk + 0.5) * h
        r = np.linalg.norm(c, axis=1)
        s = dist[ijk[:, 0], ijk[:, 1], ijk[:, 2]]
        err = np.abs(s - np.clip(r - 1, -bg, bg))  # clipping only brings them closer
        check(np.all(err <= (r - 1) ** 2 / (2 * r) + 1e-6), "vdb sdf: distance estimate off by %g" % err.max())


# ---- meshes -------------------------------------------------------------------------------
def read_mesh(path):
    ext = path.rsplit(".", 1)[-1].lower()
    reader = {"vtp": vtk.vtkXMLPolyDataReader, "ply": vtk.vtkPLYReader, "obj": vtk.vtkOBJReader}[ext]
    pd = read_vtk(reader, path)
    pts = vtk_to_numpy(pd.GetPoints().GetData()).astype(np.float64)
    polys = pd.GetPolys()
    offsets = vtk_to_numpy(polys.GetOffsetsArray())
    check(np.all(np.diff(offsets) == 3), "%s: polygons that are not triangles" % path)
    tris = vtk_to_numpy(polys.GetConnectivityArray()).reshape(-1, 3).astype(np.int64)
    return pts, tris


def check_mesh(paths, st, sphere):
    ref = None
    for path in paths:
        pts, tris = read_mesh(path)
        if not check(len(tris) > 0, "%s: no triangles" % path):
            continue
        if ref is None:
            ref = (path, pts, tris)
        else:
            check(np.array_equal(tris, ref[2]) and np.allclose(pts, ref[1], rtol=0, atol=1e-6),
                  "%s: not the same mesh as %s" % (path, ref[0]))
            continue
        # closed and consistently oriented: every directed edge once, its reverse once
        e = np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]])
        key = e[:, 0] * len(pts) + e[:, 1]
        rkey = e[:, 1] * len(pts) + e[:, 0]
        check(len(np.unique(key)) == len(key), "%s: a directed edge twice (orientation)" % path)
        check(np.array_equal(np.sort(key), np.sort(rkey)), "%s: an edge with no opposite: not closed" % path)
        a, b, c = pts[tris[:, 0]], pts[tris[:, 1]], pts[tris[:, 2]]
        area = np.linalg.norm(np.cross(b - a, c - a), axis=1).sum() / 2
        volume = np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6
        check(volume > 0, "%s: signed volume %g: triangles face inwards" % (path, volume))
        if sphere:
            box = st_box(CELLS)
            h = max((box[1] - box[0]), (box[3] - box[2]), (box[5] - box[4])) / 2 ** st["depth"]
            r = np.linalg.norm(pts, axis=1)
            check(np.all(np.abs(r - 1) <= h), "%s: a vertex %g from the sphere, voxel %g"
                  % (path, np.abs(r - 1).max(), h))
            check(abs(area - 4 * math.pi) <= 0.01 * 4 * math.pi,
                  "%s: area %.6f, 4 pi = %.6f" % (path, area, 4 * math.pi))
            check(abs(volume - 4 / 3 * math.pi) <= 0.01 * 4 / 3 * math.pi,
                  "%s: volume %.6f, 4/3 pi = %.6f" % (path, volume, 4 / 3 * math.pi))
            print("  mesh %s: %d triangles, area %.6f (4 pi %.6f), max | |p| - 1 | %.2g (voxel %.2g)"
                  % (path, len(tris), area, 4 * math.pi, np.abs(r - 1).max(), h))


def main():
    global CELLS
    p = argparse.ArgumentParser()
    p.add_argument("--stats", required=True)
    p.add_argument("--cells", required=True)
    p.add_argument("--vtu")
    p.add_argument("--htg")
    p.add_argument("--vdb")
    p.add_argument("--mesh", action="append", default=[])
    p.add_argument("--sphere", action="store_true")
    a = p.parse_args()
    with open(a.stats) as f:
        st = json.load(f)
    CELLS = cells = read_cells(a.cells)
    check(len(cells["depth"]) == st["leaves"], "cells: %d rows, stats say %d" % (len(cells["depth"]), st["leaves"]))
    if a.vtu:
        check_vtu(a.vtu, st, cells)
    htg = check_htg(a.htg, st, cells) if a.htg else None
    if a.vdb:
        check_vdb(a.vdb, st, cells, htg, a.sphere)
    if a.mesh:
        check_mesh(a.mesh, st, a.sphere)
    if a.mesh and a.vdb:
        # the mesh is OpenVDB's own mesher on the sdf grid: pyopenvdb's gives the same
        import pyopenvdb as vdb

        points, quads = vdb.read(a.vdb, "sdf").convertToQuads()
        pts, tris = read_mesh(a.mesh[0])
        check(len(pts) == len(points) and len(tris) == 2 * len(quads),
              "mesh: %d points, %d triangles; volumeToMesh of the sdf grid: %d points, %d quads"
              % (len(pts), len(tris), len(points), len(quads)))
    for e in errors:
        print("  " + e, file=sys.stderr)
    print("  check_export: %d checks passed, %d failed" % (passed, len(errors)))
    return 1 if errors else 0


CELLS = None
if __name__ == "__main__":
    sys.exit(main())
