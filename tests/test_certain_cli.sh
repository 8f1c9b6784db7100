#!/usr/bin/env bash
# ivoct build --certain: the leaves that surely hold surface in every output.
#  - the counts agree: the CSV's certain = 1 rows, the .vtu's and the .htg's
#    certain arrays (read back with /usr/bin/python3 and vtk) and the
#    stats' leaves_certain (and its share), and ivoct info on the .ivo;
#  - the same CSV (flags and witnesses, byte for byte) for --threads 1 and 2
#    and for IVOCT_SIMD=portable and avx2 (where the CPU has it);
#  - without --certain nothing changes: 15 CSV columns, no certain array, no
#    stats key; --help documents the option; under mpirun it is refused
#    (not tested here).
# The witnesses themselves are checked against MPFI in test_octree_certain.c,
# the CSV columns against the .ivo in test_writers_roundtrip.sh.
set -u

. "$(dirname "${BASH_SOURCE[0]}")/support/cli.sh"
cli_setup certain
depth=6
[ -n "${IVOCT_ASAN:-}" ] && [ "${IVOCT_ASAN}" != 0 ] && depth=5

run 0 "--help" -- build --help
grep -q -- "--certain" "$TMP/out" && ok || fail "build --help does not document --certain"

for name in sphere gumdrop csg-64-spheres; do
    o=$TMP/$name
    if ! run 0 "$name --certain" -- build "$SCENES/$name.ini" --depth $depth --quiet --certain \
        --threads 2 --cells "$o.csv" --vtu "$o.vtu" --htg "$o.htg" --stats "$o.json" --save "$o.ivo"; then
        continue
    fi
    if "$PY" - "$o" >"$TMP/out" 2>"$TMP/err" <<'PYEOF'; then ok; else
import csv, json, sys
import vtk
from vtk.util.numpy_support import vtk_to_numpy
o = sys.argv[1]
st = json.load(open(o + ".json"))
n, leaves = st["leaves_certain"], st["leaves"]
assert n > 0, "no certain leaf"
assert st["leaves_certain_share"] == n / leaves, (st["leaves_certain_share"], n / leaves)
rows = list(csv.reader(open(o + ".csv", newline="")))
assert rows[0][15:] == ["certain", "wx0", "wy0", "wz0", "wx1", "wy1", "wz1"], rows[0]
assert len(rows) == leaves + 1
assert all(r[15] in ("0", "1") for r in rows[1:])
assert all(r[16] == "" and r[19] == "" for r in rows[1:] if r[15] == "0")
c = sum(r[15] == "1" for r in rows[1:])
assert c == n, ("csv", c, n)
r = vtk.vtkXMLUnstructuredGridReader(); r.SetFileName(o + ".vtu"); r.Update()
v = int(vtk_to_numpy(r.GetOutput().GetCellData().GetArray("certain")).sum())
assert v == n, ("vtu", v, n)
h = vtk.vtkXMLHyperTreeGridReader(); h.SetFileName(o + ".htg"); h.Update()
v = int(vtk_to_numpy(h.GetOutput().GetCellData().GetArray("certain")).sum())
assert v == n, ("htg", v, n)
print(n)
PYEOF
        fail "$name: the certain counts disagree (below)"
        sed 's/^/    /' "$TMP/err" >&2
    fi
    want=$(grep -o '"leaves_certain": [0-9]*' "$o.json" | grep -o '[0-9]*$')
    run 0 "$name info" -- info "$o.ivo"
    grep -q "^certain:  $want of" "$TMP/out" && ok || fail "$name: ivoct info does not show $want certain leaves"
    # threads and SIMD paths: the same flags and witnesses
    run 0 "$name --threads 1" -- build "$SCENES/$name.ini" --depth $depth --quiet --certain \
        --threads 1 --cells "$o.1.csv"
    cmp -s "$o.csv" "$o.1.csv" && ok || fail "$name: --threads 1 and 2 give different certain leaves"
    for path in portable avx2; do
        IVOCT_SIMD=$path "$BIN" eval -e x >/dev/null 2>&1 || continue
        [ "$path" = avx2 ] && ! grep -q avx2 /proc/cpuinfo && continue
        if IVOCT_SIMD=$path "$BIN" build "$SCENES/$name.ini" --depth $depth --quiet --certain \
            --threads 2 --cells "$o.$path.csv" 2>"$TMP/err"; then
            cmp -s "$o.csv" "$o.$path.csv" && ok || fail "$name: IVOCT_SIMD=$path differs"
        else
            fail "$name: IVOCT_SIMD=$path build failed"
        fi
    done
done

# without --certain: the outputs as before
o=$TMP/plain
if run 0 "without --certain" -- build "$SCENES/sphere.ini" --depth 4 --quiet --cells "$o.csv" \
    --vtu "$o.vtu" --stats "$o.json" --save "$o.ivo"; then
    [ "$(head -1 "$o.csv")" = "x0,x1,y0,y1,z0,z1,depth,f_lo,f_hi,nx,ny,nz,d_lo,d_hi,error_bound" ] &&
        ok || fail "without --certain: CSV header $(head -1 "$o.csv")"
    grep -q certain "$o.json" && fail "without --certain: a certain key in the stats" || ok
    run 0 "info vtu" -- info "$o.vtu"
    grep -q "^arrays:.* certain" "$TMP/out" && fail "without --certain: a certain array in the .vtu" || ok
    run 0 "info ivo" -- info "$o.ivo"
    grep -q "^certain" "$TMP/out" && fail "without --certain: ivoct info shows certain leaves" || ok
fi

cli_summary
