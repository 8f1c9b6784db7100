#!/usr/bin/env bash
# `ivoct build --vtu --htg --vdb --mesh` and `ivoct info` on them, from the outside.
#
# Every export is read back with Debian's VTK and OpenVDB Python modules
# (python3-vtk9, python3-openvdb, run by /usr/bin/python3, not the python3 on
# PATH) by tests/check_export.py and compared with --stats and --cells: cell
# counts, each voxel's bounds, the HyperTreeGrid's nodes and leaves per depth,
# the vdb surface's active voxels, the sdf's signs, the mesh of the sphere
# (closed, outward, within a voxel of the sphere, area within 1% of 4 pi, the same as
# pyopenvdb's own mesher gives); OpenVDB's vdb_print reads the .vdb too.
# Every .htg is also compared byte for byte with what VTK's own writer writes of it
# (tests/same_as_vtk_htg.py; test_vtk_number checks its numbers on their own).
# Then the failures: a full device, a missing folder, a file too large
# (ulimit -f: a write that fails midway) give exit 1, one line on stderr, and
# no file or temporary left behind; corrupt files give `ivoct info` exit 2.
#
# Needs IVOCT_BIN (the CLI) and IVOCT_SOURCE_DIR (the source tree), as set by ctest.
set -u

. "$(dirname "${BASH_SOURCE[0]}")/support/cli.sh"
cli_setup export
CHECK=$SRC/tests/check_export.py

no_files() {
    local what=$1 f
    shift
    for f in "$@"; do
        [ -e "$f" ] && fail "$what: $f exists" || ok
    done
}

no_temporaries() {
    local what=$1 left
    left=$(find "$TMP" -name '*.tmp.*' | head -5)
    [ -n "$left" ] && fail "$what: temporary files left behind: $left" || ok
}

# check_export ARGS...: the Python read-back
check_export() {
    local what=$1
    shift
    if "$PY" "$CHECK" "$@"; then ok; else fail "$what: read-back checks (above)"; fi
}

if ! "$PY" -c 'import vtk, pyopenvdb, numpy' 2>"$TMP/err"; then
    fail "/usr/bin/python3 cannot import vtk, pyopenvdb and numpy (make deps installs python3-vtk9, python3-openvdb): $(tail -1 "$TMP/err")"
    echo "$checks checks passed, $failures failed"
    exit 1
fi

# ---- the sphere at depth 7: every export, read back -----------------------------------------
S=$TMP/sphere
if run 0 "sphere depth 7" -- build "$SCENES/sphere.ini" --depth 7 --quiet \
    --stats "$S.json" --cells "$S.csv" --vtu "$S.vtu" --htg "$S.htg" --vdb "$S.vdb" --mesh "$S.vtp"; then
    no_temporaries "sphere depth 7"
    # the other mesh formats hold the same mesh
    run 0 "sphere .ply" -- build "$SCENES/sphere.ini" --depth 7 --quiet --mesh "$S.ply"
    run 0 "sphere .obj" -- build "$SCENES/sphere.ini" --depth 7 --quiet --mesh "$S.OBJ"
    check_export "sphere depth 7" --stats "$S.json" --cells "$S.csv" --vtu "$S.vtu" --htg "$S.htg" \
        --vdb "$S.vdb" --mesh "$S.vtp" --mesh "$S.ply" --mesh "$S.OBJ" --sphere

    leaves=$("$PY" -c 'import json,sys; print(json.load(open(sys.argv[1]))["leaves"])' "$S.json")
    for f in "$S.vtu" "$S.htg"; do
        if run 0 "info ${f##*.}" -- info "$f"; then
            grep -q "^leaves: *$leaves$" "$TMP/out" || fail "info ${f##*.}: no 'leaves: $leaves' in: $(cat "$TMP/out")"
            grep -q "^leaves by depth: 7:$leaves$" "$TMP/out" || fail "info ${f##*.}: no leaves by depth"
        fi
    done
    if run 0 "info vdb" -- info "$S.vdb"; then
        grep -q "^scene: *Sphere$" "$TMP/out" || fail "info vdb: no scene"
        grep -q "^depth: *7$" "$TMP/out" || fail "info vdb: no depth"
        grep -q "^grid: *surface (float, class unknown): $leaves active voxels" "$TMP/out" \
            || fail "info vdb: no surface grid with $leaves voxels in: $(cat "$TMP/out")"
        grep -q "^grid: *sdf (float, class level set)" "$TMP/out" || fail "info vdb: no sdf grid"
    fi
    # OpenVDB's own tools read the file (Debian: libopenvdb-tools)
    if vdb_print -l "$S.vdb" >"$TMP/out" 2>&1; then
        grep -q "^Name: sdf" "$TMP/out" && grep -q "^Name: surface" "$TMP/out" && ok \
            || fail "vdb_print: no grids sdf and surface in: $(head -5 "$TMP/out")"
    else
        fail "vdb_print -l cannot read the .vdb: $(head -3 "$TMP/out")"
    fi
    run 0 "info vtp" -- info "$S.vtp" && { grep -q "^polygons: *[1-9]" "$TMP/out" || fail "info vtp: no polygons"; }
    # a file is recognised by content, whatever its name
    cp "$S.vdb" "$TMP/grids.bin"
    run 0 "info vdb under another name" -- info "$TMP/grids.bin"

    # corrupt files: exit 2, one line
    for ext in vtu htg vdb; do
        size=$(stat -c %s "$S.$ext")
        head -c $((size / 2)) "$S.$ext" >"$TMP/trunc.$ext"
        run 2 "info on a truncated .$ext" -- info "$TMP/trunc.$ext" && one_line_error "info truncated .$ext" "trunc.$ext"
    done
fi
# files that crash VTK's or OpenVDB's reader, or make it allocate gigabytes (found by
# tests/fuzz/): exit 2, one line
for f in "$SRC"/tests/fuzz/corpus/vtk/[ct]* "$SRC"/tests/fuzz/corpus/vdb/[ct]*; do
    [ -f "$f" ] || continue
    run 2 "info on ${f#"$SRC"/}" -- info "$f" && one_line_error "info on ${f#"$SRC"/}" "cannot read"
done

# ---- coarse leaves (ilie + refine) with slabs: tiles in the vdb, normals in the vtu ---------
R=$TMP/refine
if run 0 "sphere refine" -- build "$SCENES/sphere.ini" --depth 7 --tests interval,lipschitz,ilie \
    --refine 0.01 --quiet --stats "$R.json" --cells "$R.csv" --vtu "$R.vtu" --htg "$R.htg" \
    --vdb "$R.vdb" --mesh "$R.ply"; then
    "$PY" -c 'import json,sys; d=json.load(open(sys.argv[1]))["leaves_by_depth"]; sys.exit(0 if sum(d[:-1]) > 0 else 1)' "$R.json" \
        || fail "sphere refine: no leaf above the max depth: the coarse-leaf paths are not tested"
    check_export "sphere refine" --stats "$R.json" --cells "$R.csv" --vtu "$R.vtu" --htg "$R.htg" \
        --vdb "$R.vdb" --mesh "$R.ply" --sphere
fi

# ---- other shapes: a torus (genus 1), a CSG union with a box that cuts no surface -----------
for s in gumdrop csg-64-spheres; do
    G=$TMP/$s
    run 0 "$s depth 6" -- build "$SCENES/$s.ini" --depth 6 --quiet --stats "$G.json" --cells "$G.csv" \
        --vtu "$G.vtu" --htg "$G.htg" --vdb "$G.vdb" --mesh "$G.obj" &&
        check_export "$s depth 6" --stats "$G.json" --cells "$G.csv" --vtu "$G.vtu" --htg "$G.htg" \
            --vdb "$G.vdb" --mesh "$G.obj"
done

# ---- the .htg is what VTK's own writer writes (tests/same_as_vtk_htg.py) ------------------------
# every scene at depth 5, a tree with certain leaves, and the coarse leaves above
H=$TMP/htg
mkdir -p "$H"
for s in "$SCENES"/*.ini; do
    n=$(basename "$s" .ini)
    run 0 "$n depth 5 --htg" -- build "$s" --depth 5 --quiet --htg "$H/$n.htg"
done
run 0 "sphere --certain --htg" -- build "$SCENES/sphere.ini" --depth 6 --certain --quiet \
    --htg "$H/sphere-certain.htg"
if "$PY" "$SRC/tests/same_as_vtk_htg.py" "$H"/*.htg "$R.htg"; then ok; else
    fail ".htg not byte for byte what VTK's writer writes (above)"
fi

# ---- usage errors: exit 2 before any build ----------------------------------------------------
run 2 "--mesh .stl" -- build "$SCENES/sphere.ini" --depth 4 --mesh "$TMP/m.stl" \
    && one_line_error "--mesh .stl" "m.stl" ".vtp, .ply or .obj"
run 2 "--mesh /dev/full (no extension)" -- build "$SCENES/sphere.ini" --depth 4 --mesh /dev/full
run 2 "--vtu without value" -- build "$SCENES/sphere.ini" --depth 4 --vtu
no_files "--mesh .stl" "$TMP/m.stl"

# a crafted .vdb whose tree OpenVDB reads for 30 s of CPU (found by fuzzing): the
# reader's CPU time is bounded by the file's size
run 2 "info of a .vdb whose reader spins" -- info "$SRC/tests/fuzz/corpus/vdb/timeout-root-tiles-30s" &&
    one_line_error "info of a .vdb whose reader spins" "did not finish in 5 s of CPU"

# ---- write errors: exit 1, a clear message, no file left ---------------------------------------
for opt in vtu htg vdb mesh; do
    case $opt in mesh) ext=ply ;; *) ext=$opt ;; esac
    if [ "$opt" != mesh ]; then  # --mesh needs an extension
        run 1 "--$opt /dev/full" -- build "$SCENES/sphere.ini" --depth 4 --quiet "--$opt" /dev/full \
            && one_line_error "--$opt /dev/full" "/dev/full" "No space left on device"
    fi
    run 1 "--$opt in a missing folder" -- build "$SCENES/sphere.ini" --depth 4 --quiet \
        "--$opt" "$TMP/no-such-dir/out.$ext" && one_line_error "--$opt in a missing folder" "no-such-dir/out.$ext"
    : >"$TMP/plain-file"
    run 1 "--$opt under a file" -- build "$SCENES/sphere.ini" --depth 4 --quiet \
        "--$opt" "$TMP/plain-file/out.$ext" && one_line_error "--$opt under a file" "plain-file/out.$ext"
    # a write that fails midway (the file size limit stands for a full disk; SIGXFSZ
    # ignored, so write() fails with EFBIG): the temporary is removed
    if (
        trap '' XFSZ
        ulimit -f 64  # KiB; every output of depth 6 is larger
        exec "$BIN" build "$SCENES/sphere.ini" --depth 6 --quiet "--$opt" "$TMP/big.$ext"
    ) >"$TMP/out" 2>"$TMP/err"; then
        fail "--$opt past the file size limit: exit 0"
    else
        [ $? -eq 1 ] && ok || fail "--$opt past the file size limit: exit not 1"
        one_line_error "--$opt past the file size limit" "big.$ext" "too large"
    fi
    no_files "--$opt errors" "$TMP/no-such-dir" "$TMP/big.$ext"
    no_temporaries "--$opt errors"
done

# ---- the modules (export/module.h): loaded by the outputs that need them only -----------------
# The CLI links neither libopenvdb nor VTK (its start-up would pay for them): a .vdb, a
# mesh and `ivoct info` of a .vdb load libivoct_openvdb.so; a .vtp and `ivoct info` of a
# VTK file load libivoct_vtk.so; the CSV, the .vtu and the .htg need neither.
if readelf -d "$BIN" | grep -q 'NEEDED.*\(libopenvdb\|libvtk\)'; then
    fail "ivoct links libopenvdb or VTK (they belong to the modules)"
else
    ok
fi
# loaded_by WHAT WANT_OPENVDB WANT_VTK -- ARGS...: which modules `ivoct ARGS` loads
loaded_by() {
    local what=$1 want_vdb=$2 want_vtk=$3 got_vdb=0 got_vtk=0
    shift 4
    LD_DEBUG=files "$BIN" "$@" 2>"$TMP/ld" >/dev/null || fail "$what: exit $?"
    grep -q 'file=.*libivoct_openvdb.so' "$TMP/ld" && got_vdb=1
    grep -q 'file=.*libivoct_vtk.so' "$TMP/ld" && got_vtk=1
    [ "$got_vdb$got_vtk" = "$want_vdb$want_vtk" ] && ok ||
        fail "$what: loaded the OpenVDB module $got_vdb, the VTK module $got_vtk; expected $want_vdb, $want_vtk"
}
M=$TMP/modules
loaded_by "--cells --vtu --htg --save" 0 0 -- build "$SCENES/sphere.ini" --depth 4 --quiet \
    --cells "$M.csv" --vtu "$M.vtu" --htg "$M.htg" --save "$M.ivo"
loaded_by "--vdb" 1 0 -- build "$SCENES/sphere.ini" --depth 4 --quiet --vdb "$M.vdb"
loaded_by "--mesh .ply" 1 0 -- build "$SCENES/sphere.ini" --depth 4 --quiet --mesh "$M.ply"
loaded_by "--mesh .vtp" 1 1 -- build "$SCENES/sphere.ini" --depth 4 --quiet --mesh "$M.vtp"
loaded_by "info .vdb" 1 0 -- info "$M.vdb"
loaded_by "info .vtu" 0 1 -- info "$M.vtu"
loaded_by "info .ivo" 0 0 -- info "$M.ivo"
loaded_by "render" 0 0 -- render "$SCENES/sphere.ini" --size 16x16 --quiet --png "$M.png"
# without a module: the outputs that need it fail, clearly, and leave nothing; the others work
for case in "IVOCT_OPENVDB_MODULE vdb vdb libivoct_openvdb.so" "IVOCT_OPENVDB_MODULE mesh ply libivoct_openvdb.so" \
    "IVOCT_VTK_MODULE mesh vtp libivoct_vtk.so"; do
    set -- $case
    var=$1 opt=$2 ext=$3 module=$4
    env "$var=$TMP/no-such-module.so" "$BIN" build "$SCENES/sphere.ini" --depth 4 --quiet \
        --cells "$TMP/nomod.csv" "--$opt" "$TMP/nomod.$ext" >"$TMP/out" 2>"$TMP/err"
    [ $? -eq 1 ] && ok || fail "--$opt without $module: exit not 1"
    one_line_error "--$opt without $module" "$module" "no-such-module.so"
    no_files "--$opt without $module" "$TMP/nomod.csv" "$TMP/nomod.$ext"
    no_temporaries "--$opt without $module"
done
IVOCT_OPENVDB_MODULE=$SRC/README.md run 1 "--vdb with a file that is not the module" -- \
    build "$SCENES/sphere.ini" --depth 4 --quiet --vdb "$TMP/nomod.vdb" &&
    one_line_error "--vdb with a file that is not the module" "cannot load" "README.md"
IVOCT_VTK_MODULE=$(dirname "$BIN")/../lib/ivoct/libivoct_openvdb.so \
    run 1 "--mesh .vtp with the other module" -- \
    build "$SCENES/sphere.ini" --depth 4 --quiet --mesh "$TMP/nomod.vtp" &&
    one_line_error "--mesh .vtp with the other module" "is not the libivoct_vtk.so of this ivoct"
IVOCT_OPENVDB_MODULE=$TMP/no-such-module.so run 2 "info of a .vdb without its module" -- \
    info "$M.vdb" && one_line_error "info of a .vdb without its module" "libivoct_openvdb.so"
IVOCT_VTK_MODULE=$TMP/no-such-module.so run 2 "info of a .vtu without its module" -- \
    info "$M.vtu" && one_line_error "info of a .vtu without its module" "libivoct_vtk.so"
env IVOCT_OPENVDB_MODULE="$TMP/no-such-module.so" IVOCT_VTK_MODULE="$TMP/no-such-module.so" \
    "$BIN" build "$SCENES/sphere.ini" --depth 4 --quiet --vtu "$TMP/nomod.vtu" --cells "$TMP/nomod.csv" \
    >/dev/null 2>"$TMP/err" && ok || fail "--vtu --cells without the modules: $(cat "$TMP/err")"

# ---- the .vdb written as OpenVDB's io::Stream writes it (export/vdb.cpp, VdbStream) ---------
# the same bytes but the UUID (bytes 21-56: magic, versions, the offsets flag, then the
# UUID's 36 characters), with the delayed-load metadata read off the compressed leaves:
# shallow and deep trees, a box without surface, coarse leaves, 1 and 2 threads
sed 's/^box .*/box = 2 3 2 3 2 3/' "$SCENES/sphere.ini" >"$TMP/nosurface.ini"
same_vdb() {  # what, build arguments...
    local what=$1
    shift
    if "$BIN" build "$@" --quiet --vdb "$TMP/ours.vdb" 2>"$TMP/err" &&
        IVOCT_VDB_STREAM=openvdb "$BIN" build "$@" --quiet --vdb "$TMP/openvdb.vdb" 2>>"$TMP/err"; then
        if cmp -s <(head -c 21 "$TMP/ours.vdb"; tail -c +58 "$TMP/ours.vdb") \
            <(head -c 21 "$TMP/openvdb.vdb"; tail -c +58 "$TMP/openvdb.vdb"); then
            ok
        else
            fail "$what: the .vdb differs from io::Stream's beyond the UUID"
        fi
    else
        fail "$what: $(cat "$TMP/err")"
    fi
}
for depth in 0 2 6; do
    same_vdb "gumdrop depth $depth" "$SCENES/gumdrop.ini" --depth $depth
done
same_vdb "kusner-schmitt depth 5, 1 thread" "$SCENES/kusner-schmitt.ini" --depth 5 --threads 1
same_vdb "a box without surface" "$TMP/nosurface.ini" --depth 4
same_vdb "coarse leaves" "$SCENES/sphere.ini" --depth 7 --tests interval,ilie --refine 0.01

cli_summary
