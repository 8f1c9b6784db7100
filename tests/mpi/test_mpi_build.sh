#!/usr/bin/env bash
# `mpirun -np N ivoct build` against the single-process build (cli/mpi.c, docs/cluster.md).
#
# For N = 1, 2, 3 (oversubscribed: the test machine has 2 cores) on the eight comparison
# surfaces and the CSG scene (three of them under the sanitizers), with the scene's tests and with interval,ilie and the
# refinement: the gathered .ivo is the single-process file byte for byte (cmp), the
# rows of the CSV pieces (.pcsv) are the single CSV's rows, the leaves of the pieces
# add up to the stats' leaves, the .pvtu read by VTK's vtkXMLPUnstructuredGridReader
# (python3-vtk9) has as many cells as the stats say leaves, and the stats' counts
# are the single build's; with --certain the pieces' rows, the .ivo and leaves_certain
# are the single build's.  Then the failures: a bad scene and a bad option (exit 2 on
# every rank, one message), an unwritable folder, pieces past --max-memory and a piece
# only one rank cannot write (exit 1, one message naming it), each leaving no piece, index, temporary,
# and a file that was at an output's path untouched.
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
        run 0 "$tag: single" -- build "$SCENES/$sc.ini" --depth $depth "${extra[@]}" \
            --save "$W/one.ivo" --cells "$W/one.csv" --stats "$W/one.json" --quiet || continue
        for np in 1 2 3; do
            rm -f "$W"/p*
            mpirun_ivoct $np 0 "$tag: $np ranks" -- build "$SCENES/$sc.ini" --depth $depth \
                "${extra[@]}" --save "$W/p.ivo" --cells "$W/p.pcsv" --vtu "$W/p.pvtu" \
                --stats "$W/p.json" --quiet || continue
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
            # VTK's parallel reader on the index: one comparison surface, the CSG scene
            if [ "$sc" = gumdrop ] || [ "$sc" = csg-64-spheres ]; then
                cells=$(vtk_cells "$W/p.pvtu")
                [ "$cells" = "$leaves" ] && ok || fail "$tag, $np ranks: the .pvtu has $cells cells, stats $leaves leaves"
            fi
        done
    done
done

# --certain: the pieces' rows (with their certain and witness columns) and the gathered
# .ivo are the single build's, the reduced leaves_certain too (with pieces and with the
# stats alone)
for sc in gumdrop csg-64-spheres; do
    run 0 "$sc --certain: single" -- build "$SCENES/$sc.ini" --depth $depth --certain \
        --save "$W/one.ivo" --cells "$W/one.csv" --stats "$W/one.json" --quiet || continue
    want=$(json_key "$W/one.json" "['leaves_certain']")
    [ "$want" -gt 0 ] && ok || fail "$sc --certain: no certain leaf in the single build"
    rm -f "$W"/p*
    mpirun_ivoct 3 0 "$sc --certain: 3 ranks" -- build "$SCENES/$sc.ini" --depth $depth --certain \
        --save "$W/p.ivo" --cells "$W/p.pcsv" --stats "$W/p.json" --quiet && {
        cmp -s "$W/one.ivo" "$W/p.ivo" && ok || fail "$sc --certain, 3 ranks: the .ivo differs"
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

# one-file exports over MPI are the single build's files
run 0 "single vtu" -- build "$SCENES/gumdrop.ini" --depth $depth --vtu "$W/one.vtu" --cells "$W/one.csv" --quiet
mpirun_ivoct 2 0 "gathered vtu" -- build "$SCENES/gumdrop.ini" --depth $depth --vtu "$W/g.vtu" \
    --cells "$W/g.csv" --quiet &&
    { cmp -s "$W/one.vtu" "$W/g.vtu" && cmp -s "$W/one.csv" "$W/g.csv" && ok ||
        fail "gathered .vtu or .csv differs from the single build's"; }

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
    left=$(cd "$F" && ls -A | grep -v -x -e keep.ivo -e p_1.vtu -e bad.ini | head -5)
    [ -z "$left" ] && ok || fail "$what: left behind: $left"
}
printf '[surface]\nf = x^2 +* y\nbox = -1 1 -1 1 -1 1\n' >"$F/bad.ini"
echo "old" >"$F/keep.ivo"
mpirun_ivoct 3 2 "bad scene" -- build "$F/bad.ini" --save "$F/keep.ivo" --vtu "$F/p.pvtu" &&
    one_message "bad scene" "bad.ini:2:10"
nothing_left "bad scene"
mpirun_ivoct 3 2 "bad option" -- build "$SCENES/sphere.ini" --depth 99 --cells "$F/p.pcsv" &&
    one_message "bad option" "--depth"
mpirun_ivoct 2 2 ".phtg" -- build "$SCENES/sphere.ini" --htg "$F/p.phtg" && one_message ".phtg" ".phtg"
mpirun_ivoct 3 1 "missing folder" -- build "$SCENES/sphere.ini" --depth 4 --save "$F/keep.ivo" \
    --vtu "$F/none/p.pvtu" && one_message "missing folder" "none/p_0.vtu"
nothing_left "missing folder"
# --max-memory holds for each rank's pieces: at 2 MB the build fits, the .vtu pieces do
# not (about 500 bytes a leaf beside the part: the rank with the larger part, which work
# sharing makes vary from run to run, has half of gumdrop's 10 000 leaves at depth 5 or
# more)
mpirun_ivoct 2 1 "pieces past the budget" -- build "$SCENES/gumdrop.ini" --depth $depth \
    --max-memory 2M --vtu "$F/p.pvtu" &&
    one_message "pieces past the budget" "--vtu needs" "past the memory budget of 2.0 MB"
nothing_left "pieces past the budget"
mpirun_ivoct 2 0 "pieces within the budget" -- build "$SCENES/gumdrop.ini" --depth $depth \
    --max-memory 64M --cells "$F/q.pcsv" --vtu "$F/q.pvtu" --quiet &&
    { [ -s "$F/q.pvtu" ] && [ -s "$F/q_1.vtu" ] && ok || fail "pieces within the budget: no files"; }
rm -f "$F"/q*
# only rank 1 cannot write its piece: the others' files must not stay either
mkdir "$F/p_1.vtu"
mpirun_ivoct 3 1 "one rank's piece" -- build "$SCENES/sphere.ini" --depth 4 --save "$F/keep.ivo" \
    --cells "$F/p.pcsv" --vtu "$F/p.pvtu" && one_message "one rank's piece" "p_1.vtu"
nothing_left "one rank's piece"
[ "$(cat "$F/keep.ivo")" = old ] && ok || fail "a file at an output's path was changed"

cli_summary
