#!/usr/bin/env bash
# Rendering with a pruned tape per leaf against the scene's tape in every leaf.
#   bash bench/leaf_tapes.sh [--build DIR] [--size WxH] [--reps N] [--threads N]
#                            [--scenes "csg-64-spheres thin-shell"] [--out NAME]
# For each scene (those whose tapes have min, max or abs): the octree is built once
# as ivoct render builds it (the scene's [octree] settings and ilie, ivoct build --save),
# then the same render (scene camera, newton-ah and mitchell) is timed with leaf tapes
# and with --no-leaf-tapes,
# interleaved so both see the same load; each time is the best of --reps renders
# (default 3): the stats' time_s (the render alone) plus, on the leaf-tape side,
# leaf_tapes_time_s (building the leaf tapes). The images must be identical: the script fails
# otherwise. Writes bench/results/NAME.csv and NAME.md (NAME defaults to leaf_tapes).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/.." && pwd)
build=${IVOCT_BUILD:-$root/build/release}
size=300x300
reps=3
threads=1
scenes="csg-64-spheres thin-shell"
methods="newton-ah mitchell"
name=leaf_tapes
while [ $# -gt 0 ]; do
    case $1 in
    --build) build=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    --reps) reps=$2; shift 2 ;;
    --threads) threads=$2; shift 2 ;;
    --scenes) scenes=$2; shift 2 ;;
    --out) name=$2; shift 2 ;;
    *) echo "bench/leaf_tapes.sh: unknown option $1" >&2; exit 2 ;;
    esac
done
bin=$build/cli/ivoct
[ -x "$bin" ] || { echo "bench/leaf_tapes.sh: no $bin (build first, or --build DIR)" >&2; exit 2; }
out=$root/bench/results
mkdir -p "$out"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

time_of() {
    /usr/bin/python3 -c 'import json, sys
s = json.load(open(sys.argv[1]))
print(s["time_s"] + s.get("leaf_tapes_time_s", 0))' "$1"
}

# the smaller of two times; the second may be empty (none yet)
smaller() { awk -v a="$1" -v b="$2" 'BEGIN { print (b == "" || a < b) ? a : b }'; }

csv=$out/$name.csv
echo "scene,method,size,threads,leaf_tapes_s,root_tape_s,speedup" > "$csv"
for s in $scenes; do
    scene=$root/scenes/$s.ini
    # as ivoct render builds it for itself (ray_octree_params): the scene's tests and ilie
    "$bin" build "$scene" --quiet --tests interval,lipschitz,ilie --save "$tmp/$s.ivo"
    for m in $methods; do
        best_lt= best_rt=
        for ((r = 0; r < reps; r++)); do
            for side in lt rt; do
                flag=
                [ $side = rt ] && flag=--no-leaf-tapes
                "$bin" render "$scene" --octree "$tmp/$s.ivo" --method "$m" --size "$size" \
                    --threads "$threads" --quiet $flag --png "$tmp/$side.png" \
                    --stats "$tmp/$side.json"
                t=$(time_of "$tmp/$side.json")
                if [ $side = lt ]; then best_lt=$(smaller "$t" "$best_lt"); else
                    best_rt=$(smaller "$t" "$best_rt"); fi
            done
            cmp -s "$tmp/lt.png" "$tmp/rt.png" ||
                { echo "bench/leaf_tapes.sh: $s $m: the images differ" >&2; exit 1; }
        done
        speedup=$(awk -v a="$best_lt" -v b="$best_rt" 'BEGIN { printf "%.2f", b / a }')
        echo "$s,$m,$size,$threads,$best_lt,$best_rt,$speedup" >> "$csv"
        echo "$s $m: leaf tapes $best_lt s, scene tape $best_rt s (${speedup}x)"
    done
done

{
    echo "| scene | method | leaf tapes (s) | scene's tape (s) | speed-up |"
    echo "|---|---|---|---|---|"
    tail -n +2 "$csv" | while IFS=, read -r s m sz th lt rt sp; do
        printf '| %s | %s | %.3f | %.3f | %s× |\n' "$s" "$m" "$lt" "$rt" "$sp"
    done
    echo
    echo "($size, $threads thread(s), best of $reps renders each, images identical)"
} > "$out/$name.md"
cat "$out/$name.md"
