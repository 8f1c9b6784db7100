#!/usr/bin/env bash
# `mpirun -np N ivoct build` against the single-process build (cli/mpi.c, docs/cluster.md).
#
# For N = 1, 2, 3 (oversubscribed: the test machine has 2 cores) on the eight comparison
# surfaces and the CSG scene (three of them under the sanitizers), with the scene's tests and with interval,ilie and the
# refinement: the gathered .ivo is the single-process file byte for byte (cmp), the
# rows of the CSV pieces (.pcsv) are the single CSV's rows, the leaves of the pieces
# add up to the stats' leaves, the .pvtu read by VTK's vtkXMLPUnstructuredGridReader
# (python3-vtk9) has as many cells as the stats say leaves, the .phtg read by VTK's
# vtkXMLPHyperTreeGridReader has the stats' surface leaves and the single .htg's cells
# from the frontier down, value for value (tests/check_phtg.py), and the stats' counts
# are the single build's; with --certain the pieces' rows and arrays, the .ivo and
# leaves_certain are the single build's; a tree without a frontier (all of it the top)
# makes .htg pieces too.  Then the failures: a bad scene and a bad option (exit 2 on
# every rank, one message), an unwritable folder, pieces past --max-memory, a piece
# only one rank cannot write and a surface leaf above the frontier in .htg pieces (exit
# 1, one message naming it), each leaving no piece, index, temporary, and a file that
# was at an output's path untouched.
#
# Needs IVOCT_BIN, IVOCT_SOURCE_DIR and IVOCT_MPIEXEC (mpirun), as set by ctest.
set -u

. "$(dirname "${BASH_SOURCE[0]}")/../support/cli.sh"
cli_setup mpi
. "$(dirname "${BASH_SOURCE[0]}")/../support/mpi.sh"
# the sanitizer build is ~10x slower: shallower trees there
depth=6
[ "${IVOCT_ASAN:-0}" = 1 ] && depth=5

# The counts of a stats file that do not depend on how the build ran.
counts() {
    grep -E '"(leaves|leaves_by_depth|cells_visited|cells_by_depth|split|decided_by|nodes|max_error_bound|tape_clauses_evaluated|mean_tape_length_by_depth)"' "$1"
}

# The rows of CSV files (headers dropped), sorted.
rows() { local f; for f in "$@"; do tail -n +2 "$f"; done | LC_ALL=C sort; }

vtk_cells() {
    "$PY" - "$1" <<'PY'
import sys, vtk
r = vtk.vtkXMLPUnstructuredGridReader()
r.SetFileName(sys.argv[1])
r.Update()
print(r.GetOutput().GetNumberOfCells())
PY
}

# check_phtg P.phtg ONE.htg STATS WHAT: the .phtg against the single .htg
check_phtg() {
    if "$PY" "$SRC/tests/check_phtg.py" --phtg "$1" --htg "$2" --stats "$3" >"$TMP/check" 2>&1; then
        ok
    else
        fail "$4: tests/check_phtg.py:"
        sed 's/^/    /' "$TMP/check" >&2
    fi
}

json_key() { "$PY" -c "import json,sys; d=json.load(open(sys.argv[1])); print(eval('d'+sys.argv[2]))" "$1" "$2"; }

scenes=(sphere drop chubs crosscap gumdrop horned-cube mcmullen-k3 kusner-schmitt csg-64-spheres)
# under the sanitizers each mpirun takes ~10 s (3 instrumented processes on 2 cores): the
# memory checks run on three of them, the release build checks all nine
[ "${IVOCT_ASAN:-0}" = 1 ] && scenes=(sphere gumdrop csg-64-spheres)
variants=("" "--tests interval,ilie --refine 1e-2")
W=$TMP/w
mkdir -p "$W"
for sc in "${scenes[@]}"; do
    for v in "${variants[@]}"; do
        # shellcheck disable=SC2206
        extra=($v)
        tag="$sc${v:+ (refine)}"
        # VTK's parallel readers on the indexes: one comparison surface, the CSG scene
        # (under the sanitizers the .htg pieces of the first alone: VTK's 0.0 writer makes
        # many small allocations, which cost ~7 s a run there with full stacks)
        vtk_read=0 htg_read=0
        { [ "$sc" = gumdrop ] || [ "$sc" = csg-64-spheres ]; } && vtk_read=1
        [ $vtk_read = 1 ] && htg_read=1
        [ "${IVOCT_ASAN:-0}" = 1 ] && { [ "$sc" != gumdrop ] || [ -n "$v" ]; } && htg_read=0
        one_htg=() p_htg=()
        [ $htg_read = 1 ] && one_htg=(--htg "$W/one.htg") p_htg=(--htg "$W/p.phtg")
        run 0 "$tag: single" -- build "$SCENES/$sc.ini" --depth $depth "${extra[@]}" \
            --save "$W/one.ivo" --cells "$W/one.csv" --stats "$W/one.json" "${one_htg[@]}" \
            --quiet || continue
        for np in 1 2 3; do
            rm -f "$W"/p*
            mpirun_ivoct $np 0 "$tag: $np ranks" -- build "$SCENES/$sc.ini" --depth $depth \
                "${extra[@]}" --save "$W/p.ivo" --cells "$W/p.pcsv" --vtu "$W/p.pvtu" \
                "${p_htg[@]}" --stats "$W/p.json" --quiet || continue
            cmp -s "$W/one.ivo" "$W/p.ivo" && ok || fail "$tag, $np ranks: the .ivo differs"
            pieces=("$W"/p_*.csv)
            [ ${#pieces[@]} -eq $np ] && ok || fail "$tag, $np ranks: ${#pieces[@]} CSV pieces"
            [ "$(rows "$W/one.csv" | md5sum)" = "$(rows "${pieces[@]}" | md5sum)" ] && ok ||
                fail "$tag, $np ranks: the pieces' rows are not the single CSV's"
            diff <(counts "$W/one.json") <(counts "$W/p.json") >/dev/null && ok ||
                fail "$tag, $np ranks: the stats' counts differ from the single build's"
            leaves=$(json_key "$W/p.json" "['leaves']")
            indexed=$(awk -F, 'NR > 1 { s += $2 } END { print s + 0 }' "$W/p.pcsv")
            [ "$indexed" = "$leaves" ] && ok || fail "$tag, $np ranks: .pcsv says $indexed leaves, stats $leaves"
            subtrees=$(json_key "$W/p.json" "['mpi']['subtrees']")
            taken=$(json_key "$W/p.json" "['mpi']['rank_subtrees']" | tr -d '[] ' | tr , '\n' |
                awk '{ s += $1 } END { print s + 0 }')
            [ "$taken" = "$subtrees" ] && ok || fail "$tag, $np ranks: ranks built $taken of $subtrees subtrees"
            if [ $vtk_read = 1 ]; then
                cells=$(vtk_cells "$W/p.pvtu")
                [ "$cells" = "$leaves" ] && ok || fail "$tag, $np ranks: the .pvtu has $cells cells, stats $leaves leaves"
                info=$("$BIN" info "$W/p.pvtu" | sed -n 's/^leaves: *//p')
                [ "$info" = "$leaves" ] && ok || fail "$tag, $np ranks: ivoct info of the .pvtu says '$info' leaves, stats $leaves"
            fi
            if [ $htg_read = 1 ]; then
                pieces=("$W"/p_*.htg)
                [ ${#pieces[@]} -eq $np ] && ok || fail "$tag, $np ranks: ${#pieces[@]} .htg pieces"
                check_phtg "$W/p.phtg" "$W/one.htg" "$W/p.json" "$tag, $np ranks"
                info=$("$BIN" info "$W/p.phtg" | sed -n 's/^leaves: *//p')
                [ "$info" = "$leaves" ] && ok || fail "$tag, $np ranks: ivoct info of the .phtg says '$info' leaves, stats $leaves"
            fi
        done
    done
done

# --certain: the pieces' rows (with their certain and witness columns), the .htg pieces'
# certain array and the gathered .ivo are the single build's, the reduced leaves_certain
# too (with pieces and with the stats alone)
for sc in gumdrop csg-64-spheres; do
    one_htg=(--htg "$W/one.htg") p_htg=(--htg "$W/p.phtg")
    [ "${IVOCT_ASAN:-0}" = 1 ] && [ "$sc" != gumdrop ] && one_htg=() p_htg=()
    run 0 "$sc --certain: single" -- build "$SCENES/$sc.ini" --depth $depth --certain \
        --save "$W/one.ivo" --cells "$W/one.csv" "${one_htg[@]}" --stats "$W/one.json" \
        --quiet || continue
    want=$(json_key "$W/one.json" "['leaves_certain']")
    [ "$want" -gt 0 ] && ok || fail "$sc --certain: no certain leaf in the single build"
    rm -f "$W"/p*
    mpirun_ivoct 3 0 "$sc --certain: 3 ranks" -- build "$SCENES/$sc.ini" --depth $depth --certain \
        --save "$W/p.ivo" --cells "$W/p.pcsv" "${p_htg[@]}" --stats "$W/p.json" --quiet && {
        cmp -s "$W/one.ivo" "$W/p.ivo" && ok || fail "$sc --certain, 3 ranks: the .ivo differs"
        [ ${#p_htg[@]} = 0 ] || check_phtg "$W/p.phtg" "$W/one.htg" "$W/p.json" "$sc --certain, 3 ranks"
        [ "$(rows "$W/one.csv" | md5sum)" = "$(rows "$W"/p_*.csv | md5sum)" ] && ok ||
            fail "$sc --certain, 3 ranks: the pieces' rows are not the single CSV's"
        [ "$(json_key "$W/p.json" "['leaves_certain']")" = "$want" ] && ok ||
            fail "$sc --certain, 3 ranks: leaves_certain $(json_key "$W/p.json" "['leaves_certain']"), single $want"
    }
    mpirun_ivoct 2 0 "$sc --certain: stats alone" -- build "$SCENES/$sc.ini" --depth $depth \
        --certain --stats "$W/s.json" --quiet && {
        [ "$(json_key "$W/s.json" "['leaves_certain']")" = "$want" ] && ok ||
            fail "$sc --certain, stats alone: leaves_certain $(json_key "$W/s.json" "['leaves_certain']"), single $want"
    }
done

# --mesh-certified needs no tree (it subdivides on its own, from the tape, on rank 0): the
# same file over 2 ranks as in one process, alone beside the stats (no tree gathered) and
# with the gathered CSV
run 0 "sphere --mesh-certified: single" -- build "$SCENES/sphere.ini" --depth $depth \
    --mesh-certified "$W/one.ply" --quiet && {
    for with in "" "--cells $W/m.csv"; do
        rm -f "$W/m.ply"
        # shellcheck disable=SC2086
        mpirun_ivoct 2 0 "sphere --mesh-certified ${with:+with the CSV }: 2 ranks" -- build \
            "$SCENES/sphere.ini" --depth $depth --mesh-certified "$W/m.ply" --stats "$W/m.json" \
            $with --quiet && {
            cmp -s "$W/one.ply" "$W/m.ply" && ok ||
                fail "sphere --mesh-certified ${with:+with the CSV}, 2 ranks: the mesh differs"
            [ "$(json_key "$W/m.json" "['mesh_certified']['certified']")" = True ] && ok ||
                fail "sphere --mesh-certified, 2 ranks: no mesh_certified in the stats"
        }
    done
}

# --save F.pivo: one .ivo piece per rank and the index, which `ivoct info` and `ivoct render
# --octree` read as the whole tree (tests/test_octree_pieces.c checks it leaf for leaf,
# tests/mpi/test_mpi_render_tiles.sh renders from it): its summary is the single file's, the
# index's leaves are the stats', and each piece is an .ivo of its own
info_tree() { "$BIN" info "$1" | grep -v '^file:'; }
printf '[surface]\nf = min(z - 0.3, (x - 0.4)^2 + (y - 0.4)^2 + (z - 0.7)^2 - 0.04)\nbox = -1 1 -1 1 -1 1\n' \
    >"$W/flat.ini"
pivo_cases=("gumdrop.ini" "gumdrop.ini --certain" "csg-64-spheres.ini --tests interval,ilie --refine 1e-2")
# the flat scene has surface leaves above the frontier (--refine stops on the plane at depth
# 2 to 5): they are in piece 0 alone
pivo_cases+=("$W/flat.ini --depth 7 --tests interval,ilie --refine 1e-3")
[ "${IVOCT_ASAN:-0}" = 1 ] && pivo_cases=("${pivo_cases[1]}" "${pivo_cases[3]}")
for c in "${pivo_cases[@]}"; do
    # shellcheck disable=SC2206
    args=($c)
    scene=${args[0]}
    [ "${scene#/}" = "$scene" ] && scene=$SCENES/$scene
    tag=".pivo: ${c##*/}"
    run 0 "$tag: single" -- build "$scene" --depth $depth "${args[@]:1}" --save "$W/one.ivo" \
        --quiet || continue
    rm -f "$W"/p*
    mpirun_ivoct 3 0 "$tag: 3 ranks" -- build "$scene" --depth $depth "${args[@]:1}" \
        --save "$W/p.pivo" --stats "$W/p.json" --quiet || continue
    pieces=("$W"/p_*.ivo)
    [ ${#pieces[@]} -eq 3 ] && ok || fail "$tag: ${#pieces[@]} .ivo pieces"
    diff <(info_tree "$W/one.ivo") <(info_tree "$W/p.pivo") >/dev/null && ok ||
        fail "$tag: ivoct info of the pieces: $(diff <(info_tree "$W/one.ivo") <(info_tree "$W/p.pivo") | tr '\n' ' ')"
    "$BIN" info "$W/p.pivo" | grep -q '^file: .*(ivoct octree in 3 pieces)' && ok ||
        fail "$tag: ivoct info does not say 3 pieces"
    leaves=$(json_key "$W/p.json" "['leaves']")
    indexed=$(awk -F, 'NR > 1 && !/^#/ { s += $2 } END { print s + 0 }' "$W/p.pivo")
    [ "$indexed" = "$leaves" ] && ok || fail "$tag: the .pivo says $indexed leaves, stats $leaves"
    "$BIN" info "$W/p_1.ivo" >/dev/null && ok || fail "$tag: a piece is not an .ivo of its own"
done

# one-file exports over MPI are the single build's files
run 0 "single vtu" -- build "$SCENES/gumdrop.ini" --depth $depth --vtu "$W/one.vtu" --cells "$W/one.csv" --quiet
mpirun_ivoct 2 0 "gathered vtu" -- build "$SCENES/gumdrop.ini" --depth $depth --vtu "$W/g.vtu" \
    --cells "$W/g.csv" --quiet &&
    { cmp -s "$W/one.vtu" "$W/g.vtu" && cmp -s "$W/one.csv" "$W/g.csv" && ok ||
        fail "gathered .vtu or .csv differs from the single build's"; }

# no frontier (a build too shallow to have 256 cells to split: the top is the whole
# tree, on rank 0): its .htg piece has the single .htg's 2x2x2 trees, the others none
run 0 "single, no frontier" -- build "$SCENES/gumdrop.ini" --depth 2 --htg "$W/one.htg" \
    --stats "$W/one.json" --quiet
rm -f "$W"/p*
mpirun_ivoct 2 0 "no frontier, 2 ranks" -- build "$SCENES/gumdrop.ini" --depth 2 --htg "$W/p.phtg" \
    --stats "$W/p.json" --quiet && {
    [ "$(json_key "$W/p.json" "['mpi']['subtrees']")" = 0 ] && ok || fail "no frontier: the build has one"
    check_phtg "$W/p.phtg" "$W/one.htg" "$W/p.json" "no frontier, 2 ranks"
}

# the stats alone (nothing gathered, no pieces): the counts reduced over the ranks
run 0 "single stats" -- build "$SCENES/csg-64-spheres.ini" --depth $depth --stats "$W/one.json" --quiet
for np in 2 3; do
    mpirun_ivoct $np 0 "stats alone, $np ranks" -- build "$SCENES/csg-64-spheres.ini" --depth $depth \
        --stats "$W/r.json" &&
        { diff <(counts "$W/one.json") <(counts "$W/r.json") >/dev/null && ok ||
            fail "stats alone, $np ranks: the counts differ from the single build's"; }
    grep -q "$np ranks" "$TMP/out" && ok || fail "stats alone, $np ranks: summary line: $(cat "$TMP/out")"
done

# ---- failures: one message, one status, nothing left -------------------------------------
F=$TMP/f
mkdir -p "$F"
one_message() {
    local what=$1 n
    shift
    n=$(ivoct_lines)
    [ "$n" -eq 1 ] && ok || { fail "$what: $n messages from ivoct, expected 1"; sed 's/^/    stderr: /' "$TMP/err" >&2; }
    local word
    for word in "$@"; do
        grep '^ivoct' "$TMP/err" | grep -qF -- "$word" && ok || fail "$what: '$word' not in the message"
    done
}
nothing_left() {
    local what=$1 left
    left=$(cd "$F" && ls -A | grep -v -x -e keep.ivo -e p_1.vtu -e p_1.htg -e p_1.ivo -e bad.ini -e flat.ini | head -5)
    [ -z "$left" ] && ok || fail "$what: left behind: $left"
}
printf '[surface]\nf = x^2 +* y\nbox = -1 1 -1 1 -1 1\n' >"$F/bad.ini"
echo "old" >"$F/keep.ivo"
mpirun_ivoct 3 2 "bad scene" -- build "$F/bad.ini" --save "$F/keep.ivo" --vtu "$F/p.pvtu" &&
    one_message "bad scene" "bad.ini:2:10"
nothing_left "bad scene"
mpirun_ivoct 3 2 "bad option" -- build "$SCENES/sphere.ini" --depth 99 --cells "$F/p.pcsv" &&
    one_message "bad option" "--depth"
mpirun_ivoct 3 1 "missing folder" -- build "$SCENES/sphere.ini" --depth 4 --save "$F/keep.ivo" \
    --vtu "$F/none/p.pvtu" && one_message "missing folder" "none/p_0.vtu"
nothing_left "missing folder"
# --max-memory holds for each rank's pieces.  Gumdrop at depth 6: the whole build fits in
# 3 MB (not in 2.5 MB), so a rank's part does however work sharing splits the tree (it
# varies from run to run; at 2 MB the rank with the larger part could exceed the budget in
# the build itself); the pieces do not: the larger part holds at least half of the 28 928
# leaves and 100 000 cells, and a .vtu piece needs about 500 bytes a leaf beside it (7 MB),
# an .htg piece 75 bytes a node (3.7 MB)
mpirun_ivoct 2 1 "pieces past the budget" -- build "$SCENES/gumdrop.ini" --depth 6 \
    --max-memory 3M --vtu "$F/p.pvtu" &&
    one_message "pieces past the budget" "--vtu needs" "past the memory budget of 3.0 MB"
nothing_left "pieces past the budget"
mpirun_ivoct 2 1 ".htg pieces past the budget" -- build "$SCENES/gumdrop.ini" --depth 6 \
    --max-memory 3M --htg "$F/p.phtg" &&
    one_message ".htg pieces past the budget" "--htg needs" "past the memory budget of 3.0 MB"
nothing_left ".htg pieces past the budget"
mpirun_ivoct 2 0 "pieces within the budget" -- build "$SCENES/gumdrop.ini" --depth $depth \
    --max-memory 64M --cells "$F/q.pcsv" --vtu "$F/q.pvtu" --htg "$F/q.phtg" --quiet &&
    { [ -s "$F/q.pvtu" ] && [ -s "$F/q_1.vtu" ] && [ -s "$F/q.phtg" ] && [ -s "$F/q_1.htg" ] &&
        ok || fail "pieces within the budget: no files"; }
rm -f "$F"/q*
# only rank 1 cannot write its piece: the others' files must not stay either
mkdir "$F/p_1.vtu"
mpirun_ivoct 3 1 "one rank's piece" -- build "$SCENES/sphere.ini" --depth 4 --save "$F/keep.ivo" \
    --cells "$F/p.pcsv" --vtu "$F/p.pvtu" && one_message "one rank's piece" "p_1.vtu"
nothing_left "one rank's piece"
rmdir "$F/p_1.vtu"
mkdir "$F/p_1.htg"
mpirun_ivoct 3 1 "one rank's .htg piece" -- build "$SCENES/sphere.ini" --depth 4 \
    --save "$F/keep.ivo" --vtu "$F/p.pvtu" --htg "$F/p.phtg" &&
    one_message "one rank's .htg piece" "p_1.htg"
nothing_left "one rank's .htg piece"
rmdir "$F/p_1.htg"
mkdir "$F/p_1.ivo"
mpirun_ivoct 3 1 "one rank's .ivo piece" -- build "$SCENES/sphere.ini" --depth 4 \
    --cells "$F/p.pcsv" --save "$F/p.pivo" && one_message "one rank's .ivo piece" "p_1.ivo"
nothing_left "one rank's .ivo piece"
rmdir "$F/p_1.ivo"
# a surface leaf above the frontier (--refine stops on the plane at depth 2 to 5, the
# small sphere makes the frontier at depth 6): no tree of the .htg pieces' grid is its
# cell, so the .phtg is refused (a .htg is written whole)
printf '[surface]\nf = min(z - 0.3, (x - 0.4)^2 + (y - 0.4)^2 + (z - 0.7)^2 - 0.04)\nbox = -1 1 -1 1 -1 1\n' \
    >"$F/flat.ini"
mpirun_ivoct 2 1 "a leaf above the frontier" -- build "$F/flat.ini" --depth 7 --tests interval,ilie \
    --refine 1e-3 --vtu "$F/p.pvtu" --htg "$F/p.phtg" &&
    one_message "a leaf above the frontier" "p_0.htg" "a surface leaf of depth"
nothing_left "a leaf above the frontier"
[ "$(cat "$F/keep.ivo")" = old ] && ok || fail "a file at an output's path was changed"

cli_summary
