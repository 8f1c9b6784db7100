#!/usr/bin/env bash
# ivoct build --mesh-certified: the command line of the certified mesh.
#  - the three formats (.ply, .obj, .vtp) hold the same mesh: the same
#    triangles, points equal to the last bit (.ply and .vtp are binary doubles,
#    .obj has 17 digits; the .vtp read with /usr/bin/python3 and vtk, the .ply
#    and .obj parsed here, as VTK's readers keep floats only); a closed manifold
#    (no boundary or non-manifold edge, vtkFeatureEdges) with the surface's
#    Euler characteristic; the .vtp's cell array depth within
#    [--mesh-min-depth, --depth]; the stats' mesh_certified figures agree;
#  - a singular surface (chubs): exit 3, the failed cells listed on stderr in
#    12 regions (one per singular point) with their reasons, and no output at all (neither the mesh nor the other
#    outputs of the command);
#  - a --max-memory too small for the mesh: exit 1, one line, nothing written;
#  - usage errors: exit 2 and one line (a bad extension, a depth over 20,
#    --mesh-min-depth alone or deeper than --depth); --help documents both
#    options.
# The meshes themselves are checked in test_mesh_certified.c.
set -u

. "$(dirname "${BASH_SOURCE[0]}")/support/cli.sh"
cli_setup mesh-certified
depth=7

run 0 "--help" -- build --help
for opt in --mesh-certified --mesh-min-depth; do
    grep -q -- "$opt" "$TMP/out" && ok || fail "build --help does not document $opt"
done

# name euler: torus-like gumdrop is two spheres and a torus
for case in "sphere 2" "gumdrop 4" "mcmullen-k3 2"; do
    set -- $case
    name=$1 euler=$2 o=$TMP/$1
    ok_all=1
    for ext in ply obj vtp; do
        run 0 "$name .$ext" -- build "$SCENES/$name.ini" --depth $depth --quiet \
            --mesh-certified "$o.$ext" --mesh-min-depth 3 --stats "$o-$ext.json" || ok_all=0
    done
    [ "$ok_all" = 1 ] || continue
    if "$PY" - "$o" "$euler" $depth >"$TMP/out" 2>"$TMP/err" <<'PYEOF'; then ok; else
import json, sys
import vtk
from vtk.util.numpy_support import vtk_to_numpy
o, euler, depth = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])

r = vtk.vtkXMLPolyDataReader()
r.SetFileName(o + ".vtp")
r.Update()
vtp = r.GetOutput()

def read_ply(path):
    """Points and triangles of a binary little-endian PLY with double vertices
    (VTK 9.1's reader turns doubles into floats, so it is read here)."""
    import struct
    data = open(path, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    head = data[:end].decode().split("\n")
    assert head[1] == "format binary_little_endian 1.0", head[1]
    nv = int([l for l in head if l.startswith("element vertex")][0].split()[2])
    nt = int([l for l in head if l.startswith("element face")][0].split()[2])
    assert "property double x" in head, head
    pts = struct.unpack_from("<%dd" % (3 * nv), data, end)
    off, tris = end + 24 * nv, []
    for _ in range(nt):
        n, a, b, c = struct.unpack_from("<Biii", data, off)
        assert n == 3
        tris.append((a, b, c))
        off += 13
    assert off == len(data)
    return pts, tris

def read_obj(path):
    """Points and triangles of the .obj (VTK's reader keeps floats only)."""
    pts, tris = [], []
    for line in open(path):
        w = line.split()
        if w and w[0] == "v":
            pts += [float(x) for x in w[1:4]]
        elif w and w[0] == "f":
            tris.append(tuple(int(x) - 1 for x in w[1:4]))
    return pts, tris

assert vtp.GetPoints().GetData().GetDataType() == vtk.VTK_DOUBLE
pts = list(vtk_to_numpy(vtp.GetPoints().GetData()).reshape(-1))
tris = [tuple(vtp.GetCell(i).GetPointIds().GetId(k) for k in range(3))
        for i in range(vtp.GetNumberOfCells())]
for ext, (p, t) in (("ply", read_ply(o + ".ply")), ("obj", read_obj(o + ".obj"))):
    assert list(p) == pts, ext + ": points differ"
    assert t == tris, ext + ": triangles differ"
nv, nt = vtp.GetNumberOfPoints(), vtp.GetNumberOfCells()
edges = vtk.vtkExtractEdges()
edges.SetInputData(vtp)
edges.Update()
ne = edges.GetOutput().GetNumberOfCells()
assert nv - ne + nt == euler, (nv, ne, nt, euler)
fe = vtk.vtkFeatureEdges()
fe.SetInputData(vtp)
fe.BoundaryEdgesOn()
fe.NonManifoldEdgesOn()
fe.FeatureEdgesOff()
fe.ManifoldEdgesOff()
fe.Update()
assert fe.GetOutput().GetNumberOfCells() == 0, "boundary or non-manifold edges"
d = vtk_to_numpy(vtp.GetCellData().GetArray("depth"))
assert d.min() >= 3 and d.max() <= depth, (d.min(), d.max())
for ext in ("ply", "obj", "vtp"):
    st = json.load(open(o + "-" + ext + ".json"))["mesh_certified"]
    assert st["certified"] is True and st["failures"] == 0
    assert st["vertices"] == nv and st["triangles"] == nt, st
    assert st["max_depth"] == depth and st["min_depth"] == 3
    assert st["leaves_unresolved"] == 0 and st["apex_off_surface"] == 0
PYEOF
        fail "$name: $(cat "$TMP/err")"
    fi
done

# the default --mesh-min-depth is --depth - 2
run 0 "default min depth" -- build "$SCENES/sphere.ini" --depth 5 --quiet \
    --mesh-certified "$TMP/d.ply" --stats "$TMP/d.json"
"$PY" -c 'import json,sys; s=json.load(open(sys.argv[1]))["mesh_certified"]; sys.exit(s["min_depth"] != 3)' \
    "$TMP/d.json" && ok || fail "the default --mesh-min-depth is not --depth - 2"

# a singular surface: exit 3, the cells listed, nothing written
rm -f "$TMP"/chubs.*
run 3 "chubs (singular)" -- build "$SCENES/chubs.ini" --depth 6 --quiet \
    --mesh-certified "$TMP/chubs.ply" --stats "$TMP/chubs.json" --cells "$TMP/chubs.csv"
grep -q "not certified in .* in 12 regions" "$TMP/err" && ok ||
    fail "chubs: not the 12 singular points: $(head -3 "$TMP/err")"
[ "$(grep -cE '^  [0-9]+ cells? in \[.*\]: gradient [0-9]+$' "$TMP/err")" = 12 ] && ok ||
    fail "chubs: not 12 regions listed: $(cat "$TMP/err")"
[ -z "$(ls "$TMP" | grep chubs)" ] && ok || fail "chubs: files left: $(ls "$TMP" | grep chubs)"

# a memory budget too small for the mesh: exit 1, one line, nothing written
run 1 "--max-memory" -- build "$SCENES/gumdrop.ini" --depth 8 --quiet --max-memory 20M \
    --mesh-certified "$TMP/m.ply" --stats "$TMP/m.json"
one_line_error "--max-memory" "memory budget" "--max-memory"
[ -z "$(ls "$TMP" | grep '^m\.')" ] && ok || fail "--max-memory: files left: $(ls "$TMP")"

# usage errors
run 2 "bad extension" -- build "$SCENES/sphere.ini" --mesh-certified "$TMP/x.stl"
one_line_error "bad extension" "--mesh-certified" ".ply"
run 2 "too deep" -- build "$SCENES/sphere.ini" --depth 21 --mesh-certified "$TMP/x.ply"
one_line_error "too deep" "--mesh-certified" "depth"
run 2 "min depth alone" -- build "$SCENES/sphere.ini" --mesh-min-depth 3
one_line_error "min depth alone" "--mesh-min-depth"
run 2 "min depth too deep" -- build "$SCENES/sphere.ini" --depth 4 --mesh-min-depth 5 \
    --mesh-certified "$TMP/x.ply"
one_line_error "min depth too deep" "--mesh-min-depth"
[ ! -e "$TMP/x.ply" ] && ok || fail "a usage error left x.ply"

cli_summary
