#!/usr/bin/python3
"""Do two VTK XML files (.vtu, .htg, .vtp) hold the same data, whatever their
encoding (compressor, block size, appended or inline)?  Run with /usr/bin/python3.

  same_vtk.py A B

Compared bit for bit: the points, the cells (connectivity, offsets, types),
every cell, point and field data array by name; for a HyperTreeGrid the grid
of trees, the coordinates, and every tree's structure walked depth first
(global index, level, leaf or not).  Exit 0 when the same, 1 with what differs.
"""
import sys

import vtk
from vtk.util.numpy_support import vtk_to_numpy


def read(path):
    head = open(path, "rb").read(1024)
    r = (vtk.vtkXMLHyperTreeGridReader() if b'type="HyperTreeGrid"' in head
         else vtk.vtkXMLGenericDataObjectReader())
    r.SetFileName(path)
    r.Update()
    return r.GetOutput()


def arrays(fd):
    out = {}
    if fd is None:
        return out
    for i in range(fd.GetNumberOfArrays()):
        a = fd.GetAbstractArray(i)
        if isinstance(a, vtk.vtkStringArray):
            out[a.GetName()] = ("str", tuple(a.GetValue(k) for k in range(a.GetNumberOfValues())))
        else:
            n = vtk_to_numpy(a)
            out[a.GetName()] = (str(n.dtype), n.shape, n.tobytes())
    return out


def walk(h):
    cur = vtk.vtkHyperTreeGridNonOrientedCursor()
    out = []

    def visit():
        leaf = cur.IsLeaf()
        out.append((cur.GetGlobalNodeIndex(), cur.GetLevel(), leaf))
        if not leaf:
            for c in range(8):
                cur.ToChild(c)
                visit()
                cur.ToParent()

    for t in range(h.GetMaxNumberOfTrees()):
        if h.GetTree(t) is not None:
            h.InitializeNonOrientedCursor(cur, t)
            visit()
    return out


def describe(obj):
    d = {"class": obj.GetClassName(), "field": arrays(obj.GetFieldData())}
    if hasattr(obj, "GetCellData"):
        d["cell"] = arrays(obj.GetCellData())
    if isinstance(obj, vtk.vtkPointSet):
        d["point"] = arrays(obj.GetPointData())
        d["points"] = vtk_to_numpy(obj.GetPoints().GetData()).tobytes() if obj.GetPoints() else b""
    if isinstance(obj, vtk.vtkUnstructuredGrid):
        c = obj.GetCells()
        d["connectivity"] = vtk_to_numpy(c.GetConnectivityArray()).tobytes()
        d["offsets"] = vtk_to_numpy(c.GetOffsetsArray()).tobytes()
        d["types"] = vtk_to_numpy(obj.GetCellTypesArray()).tobytes()
    if isinstance(obj, vtk.vtkPolyData):
        c = obj.GetPolys()
        d["connectivity"] = vtk_to_numpy(c.GetConnectivityArray()).tobytes()
        d["offsets"] = vtk_to_numpy(c.GetOffsetsArray()).tobytes()
    if isinstance(obj, vtk.vtkHyperTreeGrid):
        dims = [0, 0, 0]
        obj.GetCellDims(dims)
        d["dims"] = tuple(dims)
        d["coords"] = tuple(vtk_to_numpy(c).tobytes() for c in
                            (obj.GetXCoordinates(), obj.GetYCoordinates(), obj.GetZCoordinates()))
        d["vertices"] = obj.GetNumberOfVertices()
        d["walk"] = walk(obj)
    return d


def main():
    a, b = describe(read(sys.argv[1])), describe(read(sys.argv[2]))
    diff = [k for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k)]
    for k in ("field", "cell", "point"):
        if k in diff:
            names = sorted(set(a.get(k, {})) | set(b.get(k, {})))
            diff[diff.index(k)] = "%s arrays %s" % (k, [n for n in names if a[k].get(n) != b[k].get(n)])
    if diff:
        print("%s and %s differ: %s" % (sys.argv[1], sys.argv[2], ", ".join(diff)))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
