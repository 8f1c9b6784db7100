#!/usr/bin/env bash
# `mpirun -np N ivoct render` (cli/mpi.c, docs/cluster.md): the frames of --frames are dealt
# out to the ranks (frame k to rank k mod N).  For N = 1, 2, 3 on the CSG scene and a
# comparison surface, each rank loading the same --octree (and once building its own): every PNG and .vti is the single-process one (cmp), the stats' totals
# are the same; one frame over 2 ranks is the same image.  A missing folder: exit 1 on
# every rank, one message, no frame or stats left.
#
# Needs IVOCT_BIN, IVOCT_SOURCE_DIR and IVOCT_MPIEXEC (mpirun), as set by ctest.
set -u

. "$(dirname "${BASH_SOURCE[0]}")/../support/cli.sh"
cli_setup mpi-render
. "$(dirname "${BASH_SOURCE[0]}")/../support/mpi.sh"
size=48x36
totals() { grep -E '"(frames|rays|hits|tangent_hits|tape_evals|segments|leaves)"' "$1"; }

W=$TMP/w
mkdir -p "$W"
for sc in csg-64-spheres gumdrop; do
    # every rank loads the octree (built once here, shallow: the render is what is tested)
    run 0 "$sc: octree" -- build "$SCENES/$sc.ini" --depth 6 --save "$W/$sc.ivo" --quiet || continue
    oct=(--octree "$W/$sc.ivo")
    run 0 "$sc: single" -- render "$SCENES/$sc.ini" "${oct[@]}" --size $size --frames 4 \
        --png "$W/one.png" --vti "$W/one.vti" --stats "$W/one.json" --quiet || continue
    for np in 1 2 3; do
        rm -f "$W"/m*
        mpirun_ivoct $np 0 "$sc: $np ranks" -- render "$SCENES/$sc.ini" "${oct[@]}" --size $size --frames 4 \
            --png "$W/m.png" --vti "$W/m.vti" --stats "$W/m.json" --quiet || continue
        for k in 0 1 2 3; do
            cmp -s "$W/one_00$k.png" "$W/m_00$k.png" && cmp -s "$W/one_00$k.vti" "$W/m_00$k.vti" &&
                ok || fail "$sc, $np ranks: frame $k differs"
        done
        diff <(totals "$W/one.json") <(totals "$W/m.json") >/dev/null && ok ||
            fail "$sc, $np ranks: the stats' totals differ"
    done
done
run 0 "one frame: single" -- render "$SCENES/sphere.ini" --size $size --png "$W/s1.png" --quiet
mpirun_ivoct 2 0 "one frame, 2 ranks" -- render "$SCENES/sphere.ini" --size $size --png "$W/s2.png" &&
    { cmp -s "$W/s1.png" "$W/s2.png" && ok || fail "one frame over 2 ranks: the image differs"; }

# a missing folder: one message, one status, nothing left
F=$TMP/f
mkdir -p "$F"
mpirun_ivoct 3 1 "missing folder" -- render "$SCENES/sphere.ini" --size $size --frames 3 \
    --png "$F/none/x.png" --stats "$F/s.json"
n=$(ivoct_lines)
[ "$n" -eq 1 ] && ok || fail "missing folder: $n messages from ivoct, expected 1"
left=$(ls -A "$F")
[ -z "$left" ] && ok || fail "missing folder: left behind: $left"

cli_summary
