#!/usr/bin/env bash
# What certified shadows cost: the same render with and without a point light.
#   bash bench/shadows.sh [--build DIR] [--size WxH] [--reps N] [--threads N]
#                         [--methods "newton-ah lipschitz"] [--scenes "..."] [--out NAME]
# For each scene (default: the eight comparison surfaces and the CSG union) the octree is
# built once as ivoct render builds it (the scene's [octree] settings and ilie, ivoct
# build --save); then the render (scene camera, each method) is timed without a light
# and with one (--light: to the side of the target, as far from it as the eye, as in
# tests/test_ray_shadows.c),
# interleaved so both see the same load; each time is the best of --reps renders (default
# 3), the stats' time_s (the render alone). Reported: both times, their ratio, the tape
# passes of the primary rays and of the shadow rays (shadow_tape_evals: counts, not
# times, so not disturbed by the load), the shadowed and undecided hits. Writes
# bench/results/NAME.csv and NAME.md (NAME defaults to shadows).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/.." && pwd)
build=${IVOCT_BUILD:-$root/build/release}
size=300x300
reps=3
threads=1
scenes="sphere drop chubs crosscap gumdrop horned-cube mcmullen-k3 kusner-schmitt csg-64-spheres"
methods="newton-ah lipschitz"
name=shadows
while [ $# -gt 0 ]; do
    case $1 in
    --build) build=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    --reps) reps=$2; shift 2 ;;
    --threads) threads=$2; shift 2 ;;
    --methods) methods=$2; shift 2 ;;
    --scenes) scenes=$2; shift 2 ;;
    --out) name=$2; shift 2 ;;
    *) echo "bench/shadows.sh: unknown option $1" >&2; exit 2 ;;
    esac
done
bin=$build/cli/ivoct
[ -x "$bin" ] || { echo "bench/shadows.sh: no $bin (build first, or --build DIR)" >&2; exit 2; }
out=$root/bench/results
mkdir -p "$out"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# light_of SCENE: the light to the side of the target (scene_light.sh)
# shellcheck source=bench/scene_light.sh
. "$here/scene_light.sh"

field() { /usr/bin/python3 -c 'import json, sys; print(json.load(open(sys.argv[1])).get(sys.argv[2], 0))' "$1" "$2"; }
smaller() { awk -v a="$1" -v b="$2" 'BEGIN { print (b == "" || a < b) ? a : b }'; }

csv=$out/$name.csv
echo "scene,method,size,threads,light,no_light_s,light_s,ratio,primary_evals,shadow_evals,evals_ratio,hits,shadowed,undecided" >"$csv"
for s in $scenes; do
    scene=$root/scenes/$s.ini
    # as ivoct render builds it for itself (ray_octree_params): the scene's tests and ilie
    "$bin" build "$scene" --quiet --tests interval,lipschitz,ilie --save "$tmp/$s.ivo"
    light=$(light_of "$scene")
    for m in $methods; do
        best0= best1=
        for ((r = 0; r < reps; r++)); do
            "$bin" render "$scene" --octree "$tmp/$s.ivo" --method "$m" --size "$size" \
                --threads "$threads" --stats "$tmp/n.json" --png "$tmp/n.png" --quiet
            # shellcheck disable=SC2086
            "$bin" render "$scene" --octree "$tmp/$s.ivo" --method "$m" --size "$size" \
                --threads "$threads" --light $light --stats "$tmp/l.json" --png "$tmp/l.png" --quiet
            best0=$(smaller "$(field "$tmp/n.json" time_s)" "$best0")
            best1=$(smaller "$(field "$tmp/l.json" time_s)" "$best1")
        done
        all=$(field "$tmp/l.json" tape_evals)
        sh=$(field "$tmp/l.json" shadow_tape_evals)
        prim=$(field "$tmp/n.json" tape_evals)
        awk -v s="$s" -v m="$m" -v sz="$size" -v th="$threads" -v L="$light" -v a="$best0" \
            -v b="$best1" -v p="$prim" -v q="$sh" -v h="$(field "$tmp/l.json" hits)" \
            -v d="$(field "$tmp/l.json" shadowed)" -v u="$(field "$tmp/l.json" shadow_undecided)" \
            'BEGIN { printf "%s,%s,%s,%s,%s,%.4f,%.4f,%.2f,%d,%d,%.2f,%d,%d,%d\n", s, m, sz, th, L, a, b, b / a, p, q, q / p, h, d, u }' >>"$csv"
        [ "$all" -gt "$sh" ] || { echo "bench/shadows.sh: $s $m: odd stats" >&2; exit 1; }
    done
done

md=$out/$name.md
{
    echo "| scene | method | no light (s) | light (s) | ratio | shadow passes / primary passes | hits | shadowed | undecided |"
    echo "|---|---|---:|---:|---:|---:|---:|---:|---:|"
    tail -n +2 "$csv" | awk -F, '{ printf "| %s | %s | %s | %s | %s | %s | %s | %s | %s |\n", $1, $2, $6, $7, $8, $11, $12, $13, $14 }'
} >"$md"
cat "$md"
