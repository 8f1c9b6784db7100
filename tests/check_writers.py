#!/usr/bin/python3
"""The writers' outputs against what their formats must hold, read with an
independent reader (run with /usr/bin/python3: Debian's vtk and numpy).

  check_writers.py --ivo F.ivo --cells F.csv [--vtu F.vtu] [--htg F.htg]

The .ivo file is decoded here from its documented layout (octree/file.c,
docs/DESIGN.md), checksum included, and is the reference: the tree's doubles.
Then
  - every CSV number parses back to exactly the double of the tree (bit for
    bit, signed zeros included): the leaf bounds are oct_coord's doubles
    (recomputed here: lo + (hi - lo) * (i * 2^-d), capped at hi), f_lo, f_hi
    and the slab fields are the stored ones (empty exactly where a leaf has no
    slab), error_bound is the slab's thickness, or the leaf's diagonal rounded
    up (not below it, at most 4e-15 relative above);
  - the .vtu's points at each voxel's corners are those bounds, its depth,
    f_lo, f_hi and normal arrays the tree's, its error_bound the CSV's;
  - the .htg's surface leaves carry the tree's f_lo and f_hi, and its node
    count is the tree's less the root.
Prints one line per failed check on stderr; exit 1 if any failed.
"""
import argparse
import ctypes
import ctypes.util
import csv
import math
import struct
import sys

import numpy as np

errors = []
passed = 0


def check(ok, what):
    global passed
    if ok:
        passed += 1
    else:
        errors.append(what)
    return ok


def fnv1a(data):
    h = 0xCBF29CE484222325
    for b in data:
        h = ((h ^ b) * 0x100000001B3) & 0xFFFFFFFFFFFFFFFF
    return h


def xxh3_64(data):
    """XXH3-64, seed 0, from Debian's libxxhash (libxxhash0, a dependency of
    libxxhash-dev) through ctypes: the library, not ivoct's code."""
    lib = ctypes.CDLL(ctypes.util.find_library("xxhash") or "libxxhash.so.0")
    lib.XXH3_64bits.restype = ctypes.c_uint64
    lib.XXH3_64bits.argtypes = [ctypes.c_char_p, ctypes.c_size_t]
    check(lib.XXH3_64bits(b"a", 1) == 0xE6C632B61E964E1F, "libxxhash: XXH3-64 of 'a'")
    return lib.XXH3_64bits(bytes(data), len(data))


def ivo_checksum(data):
    """The checksum the file's version names: XXH3-64 in versions 5 and 6,
    FNV-1a 64 in versions 2 to 4 (octree/file.c)."""
    version = struct.unpack("<I", data[8:12])[0]
    return xxh3_64(data[:-8]) if version in (5, 6) else fnv1a(data[:-8])


class Reader:
    def __init__(self, data):
        self.d, self.at = data, 0

    def take(self, n):
        if self.at + n > len(self.d):
            raise ValueError("truncated")
        b = self.d[self.at:self.at + n]
        self.at += n
        return b

    def u32(self):
        return struct.unpack("<I", self.take(4))[0]

    def f64(self):
        return struct.unpack("<d", self.take(8))[0]

    def text(self):
        return self.take(self.u32()).decode()


def read_ivo(path):
    data = open(path, "rb").read()
    check(data[:8] == b"IVOCTREE", "ivo: bad magic")
    check(ivo_checksum(data) == struct.unpack("<Q", data[-8:])[0], "ivo: checksum")
    r = Reader(data[:-8])
    r.take(8)
    t = {"version": r.u32(), "depth": r.u32(), "tests": r.u32(), "refine": r.f64()}
    has_slabs = r.u32()
    t["box"] = [r.f64() for _ in range(6)]
    t["name"] = r.text()
    t["lets"] = [(r.text(), r.text()) for _ in range(r.u32())]
    t["f"] = r.text()
    if t["version"] >= 3:  # the parametrization ("" for an implicit scene) and its patch
        t["param"] = [r.text() for _ in range(3)]
        t["patch"] = [r.f64() for _ in range(4)]
    n_nodes, n_leaves = r.u32(), r.u32()
    t["nodes"] = np.frombuffer(r.take(4 * n_nodes), dtype="<u4")
    leaves = np.frombuffer(r.take(25 * n_leaves), dtype=np.dtype(
        [("code", "<u8"), ("f_lo", "<f8"), ("f_hi", "<f8"), ("depth", "u1")]))
    t["leaves"] = leaves
    t["slabs"] = (np.frombuffer(r.take(48 * n_leaves), dtype="<f8").reshape(-1, 6)
                  if has_slabs else None)
    # versions 6 and 4: one witness code per leaf (octree/README.md)
    t["certain"] = (np.frombuffer(r.take(n_leaves), dtype="u1")
                    if t["version"] in (4, 6) else None)
    check(r.at == len(r.d), "ivo: %d bytes after the tree" % (len(r.d) - r.at))
    check(t["version"] in (2, 3, 4, 5, 6), "ivo: version %d" % t["version"])
    return t


def unmorton(code, depth):
    x = y = z = 0
    for level in range(depth - 1, -1, -1):
        c = (code >> (3 * level)) & 7
        x, y, z = x << 1 | (c & 1), y << 1 | (c >> 1 & 1), z << 1 | (c >> 2 & 1)
    return x, y, z


def oct_coord(lo, hi, i, depth):
    n = 1 << depth
    if i == 0:
        return lo
    if i >= n:
        return hi
    v = lo + (hi - lo) * (i * 2.0 ** -depth)
    return v if v < hi else hi


def leaf_bounds(t):
    """(n, 6) bounds x0 x1 y0 y1 z0 z1 of every leaf, as oct_coord gives them."""
    b = t["box"]
    out = np.empty((len(t["leaves"]), 6))
    for k, l in enumerate(t["leaves"]):
        d = int(l["depth"])
        ijk = unmorton(int(l["code"]), d)
        for a in range(3):
            out[k, 2 * a] = oct_coord(b[2 * a], b[2 * a + 1], ijk[a], d)
            out[k, 2 * a + 1] = oct_coord(b[2 * a], b[2 * a + 1], ijk[a] + 1, d)
    return out


def bits(x):
    return struct.pack("<d", x)


def same(a, b):
    """Equal as doubles, bit for bit (so 0.0 != -0.0 and nan == nan)."""
    return bits(a) == bits(b)


def rounded_up(x, ref):
    """x is ref's value rounded up by interval arithmetic: at least ref (the
    nearest double to the exact value, so at least ref's predecessor), at most a
    few parts in 10^15 above."""
    return math.nextafter(ref, -math.inf) <= x <= ref * (1 + 4e-15)


def witness(code):
    """(k0, k1) sample indices of a witness code, from the documented layout:
    0 none, 1 + k a zero at sample k, 16 + 14 k0 + (k1 if k1 < k0 else k1 - 1)
    a negative sample k0 and a positive k1."""
    if 1 <= code <= 15:
        return code - 1, None
    if 16 <= code < 16 + 210:
        k0, r = divmod(code - 16, 14)
        return k0, (r if r < k0 else r + 1)
    return None, None


def sample(b, k):
    """Sample k of the bounds b (x0 x1 y0 y1 z0 z1): the 8 corners (bit a of k
    the upper end of axis a), the centre (8), the face centres (9..14)."""
    if k < 8:
        t = [2 if k >> a & 1 else 0 for a in range(3)]
    else:
        t = [1, 1, 1]
        if k > 8:
            t[(k - 9) // 2] = 2 if (k - 9) & 1 else 0
    p = []
    for a in range(3):
        lo, hi = b[2 * a], b[2 * a + 1]
        m = min(max(lo + (hi - lo) * 0.5, lo), hi)
        p.append(lo if t[a] == 0 else hi if t[a] == 2 else m)
    return p


def check_cells(path, t, bounds):
    rows = list(csv.reader(open(path, newline="")))
    certain = t["certain"]
    header = ["x0", "x1", "y0", "y1", "z0", "z1", "depth", "f_lo", "f_hi",
              "nx", "ny", "nz", "d_lo", "d_hi", "error_bound"]
    if certain is not None:
        header += ["certain", "wx0", "wy0", "wz0", "wx1", "wy1", "wz1"]
    check(rows and rows[0] == header, "csv: header %r" % (rows[:1],))
    body = rows[1:]
    leaves, slabs = t["leaves"], t["slabs"]
    if not check(len(body) == len(leaves), "csv: %d rows, the tree has %d leaves"
                 % (len(body), len(leaves))):
        return None
    eb = np.empty(len(body))
    bad = []
    for k, r in enumerate(body):
        l = leaves[k]
        ok = len(r) == len(header) and all(same(float(r[a]), bounds[k, a]) for a in range(6))
        if ok and certain is not None:
            k0, k1 = witness(int(certain[k]))
            want = ["0" if k0 is None else "1"]
            for kk in (k0, k1):
                want += [""] * 3 if kk is None else [None] * 3
            ok = r[15] == want[0]
            for j, kk in enumerate((k0, k1)):
                if kk is None:
                    ok = ok and r[16 + 3 * j:19 + 3 * j] == ["", "", ""]
                else:
                    q = sample(bounds[k], kk)
                    ok = ok and all(same(float(r[16 + 3 * j + a]), q[a]) for a in range(3))
        ok = ok and r[6] == str(int(l["depth"]))
        ok = ok and same(float(r[7]), float(l["f_lo"])) and same(float(r[8]), float(l["f_hi"]))
        has = slabs is not None and bool(np.any(slabs[k, :3] != 0))
        if has:
            ok = ok and all(same(float(r[9 + j]), float(slabs[k, j])) for j in range(5))
            ok = ok and same(float(r[14]), float(slabs[k, 5]))
        elif ok:
            ok = all(v == "" for v in r[9:14])
            b = bounds[k]
            diag = math.sqrt((b[1] - b[0]) ** 2 + (b[3] - b[2]) ** 2 + (b[5] - b[4]) ** 2)
            ok = ok and rounded_up(float(r[14]), diag)
        if not ok:
            bad.append(k)
            continue
        eb[k] = float(r[14])
    check(not bad, "csv: %d rows differ from the tree (first: row %s: %r)"
          % (len(bad), bad[:1], body[bad[0]] if bad else None))
    return eb


def check_vtu(path, t, bounds, eb):
    import vtk
    from vtk.util.numpy_support import vtk_to_numpy

    r = vtk.vtkXMLUnstructuredGridReader()
    r.SetFileName(path)
    r.Update()
    ug = r.GetOutput()
    n = len(t["leaves"])
    if not check(ug.GetNumberOfCells() == n, "vtu: %d cells, tree %d leaves"
                 % (ug.GetNumberOfCells(), n)):
        return
    if n == 0:
        return
    pts = vtk_to_numpy(ug.GetPoints().GetData())
    conn = vtk_to_numpy(ug.GetCells().GetConnectivityArray()).reshape(n, 8)
    corners = pts[conn]
    for k in range(8):
        want = np.stack([bounds[:, 1 if k & 1 else 0], bounds[:, 3 if k & 2 else 2],
                         bounds[:, 5 if k & 4 else 4]], axis=1)
        check(np.array_equal(corners[:, k, :], want), "vtu: corner %d of the voxels differs" % k)
    check(len(np.unique(pts, axis=0)) == len(pts), "vtu: a point twice")
    cd = ug.GetCellData()
    lv = t["leaves"]
    for name, want in (("depth", lv["depth"].astype(np.int32)), ("f_lo", lv["f_lo"]),
                       ("f_hi", lv["f_hi"]), ("error_bound", eb)):
        a = cd.GetArray(name)
        if check(a is not None, "vtu: no array %s" % name) and want is not None:
            got = vtk_to_numpy(a)
            check(got.tobytes() == np.ascontiguousarray(want, dtype=got.dtype).tobytes(),
                  "vtu: %s differs from the tree" % name)
    a = cd.GetArray("certain")
    if t["certain"] is not None:
        if check(a is not None, "vtu: no certain array (the tree has certain leaves)"):
            check(np.array_equal(vtk_to_numpy(a), (t["certain"] != 0).astype(np.uint8)),
                  "vtu: certain differs from the tree")
    else:
        check(a is None, "vtu: a certain array without certain leaves")
    a = cd.GetArray("normal")
    if t["slabs"] is not None:
        if check(a is not None, "vtu: no normal array (the tree has slabs)"):
            check(vtk_to_numpy(a).tobytes() == np.ascontiguousarray(t["slabs"][:, :3]).tobytes(),
                  "vtu: normal differs from the tree's slabs")
    else:
        check(a is None, "vtu: a normal array without slabs")


def check_htg(path, t, bounds):
    import vtk
    from vtk.util.numpy_support import vtk_to_numpy

    r = vtk.vtkXMLHyperTreeGridReader()
    r.SetFileName(path)
    r.Update()
    h = r.GetOutput()
    check(h.GetNumberOfVertices() == len(t["nodes"]) - 1 or len(t["nodes"]) == 1,
          "htg: %d nodes, the tree has %d besides the root" % (h.GetNumberOfVertices(),
                                                              len(t["nodes"]) - 1))
    cd = h.GetCellData()
    cls, flo, fhi = (vtk_to_numpy(cd.GetArray(k)) for k in ("class", "f_lo", "f_hi"))
    # surface leaves in the order of the tree's leaves: by their bounds
    cur = vtk.vtkHyperTreeGridNonOrientedGeometryCursor()
    b = [0.0] * 6
    found = {}

    def visit():
        if cur.IsLeaf():
            g = cur.GetGlobalNodeIndex()
            if cls[g] == 3:
                cur.GetBounds(b)
                found[g] = tuple(b)
            return
        for c in range(8):
            cur.ToChild(c)
            visit()
            cur.ToParent()

    for tree in range(h.GetMaxNumberOfTrees()):
        if h.GetTree(tree) is not None:
            h.InitializeNonOrientedGeometryCursor(cur, tree)
            visit()
    lv = t["leaves"]
    if not check(len(found) == len(lv), "htg: %d surface leaves, tree %d" % (len(found), len(lv))):
        return
    if not lv.size:
        return
    g = np.array(list(found))
    hb = np.array([found[k] for k in g])
    # HTG geometry is VTK's own halvings: matched to the tree's leaves by position
    scale = max(abs(v) for v in t["box"]) or 1.0
    oh = np.lexsort(np.round(hb[:, [0, 2, 4]] / (1e-9 * scale)).T)
    ot = np.lexsort(np.round(bounds[:, [0, 2, 4]] / (1e-9 * scale)).T)
    check(np.allclose(hb[oh], bounds[ot], rtol=0, atol=1e-12 * scale), "htg: leaf bounds differ")
    check(np.array_equal(flo[g[oh]], lv["f_lo"][ot]) and np.array_equal(fhi[g[oh]], lv["f_hi"][ot]),
          "htg: f_lo / f_hi of the surface leaves differ from the tree's")
    a = cd.GetArray("certain")
    if t["certain"] is not None:
        if check(a is not None, "htg: no certain array (the tree has certain leaves)"):
            c = vtk_to_numpy(a)
            check(np.array_equal(c[g[oh]], (t["certain"][ot] != 0).astype(np.uint8)),
                  "htg: certain of the surface leaves differs from the tree's")
            check(int(c.sum()) == int(np.count_nonzero(t["certain"])),
                  "htg: certain set on cells that are not certain leaves")
    else:
        check(a is None, "htg: a certain array without certain leaves")


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--ivo", required=True)
    p.add_argument("--cells", required=True)
    p.add_argument("--vtu")
    p.add_argument("--htg")
    a = p.parse_args()
    t = read_ivo(a.ivo)
    bounds = leaf_bounds(t)
    eb = check_cells(a.cells, t, bounds)
    if a.vtu:
        check_vtu(a.vtu, t, bounds, eb)
    if a.htg:
        check_htg(a.htg, t, bounds)
    for e in errors:
        print("  " + e, file=sys.stderr)
    print("  check_writers: %d checks passed, %d failed" % (passed, len(errors)))
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
