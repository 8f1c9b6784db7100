#!/usr/bin/env bash
# Gradient-adaptive refinement against a uniform octree at equal certified error (issue 4).
#
#   bash bench/refine.sh [--build DIR] [--surfaces "sphere gumdrop mcmullen-k3"] [--eps "1e-2 1e-3 1e-4 1e-5"]
#
# For each surface and tolerance EPS:
#   refined:  ivoct build SCENE --tests interval,lipschitz,ilie --refine EPS --depth D
#             where D is the depth at which a uniform leaf's diagonal is <= EPS, so that
#             every leaf (early or not) has a certified error bound <= EPS;
#   uniform:  ivoct build SCENE --tests interval,lipschitz --depth D (no refinement): its
#             certified error is the leaf diagonal. Built when D <= 10; deeper ones are
#             extrapolated from the depth-10 count by 4x per level (a surface's leaf count
#             grows with its area / cell area) and marked "extrapolated".
# Also: ilie against interval,lipschitz at depth 9 without refinement (time, cells).
# Writes bench/results/refine-STAMP.csv and, with gnuplot, docs/refine.png.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/.." && pwd)
build=$root/build/release
surfaces="sphere gumdrop mcmullen-k3"
eps_list="1e-2 1e-3 1e-4 1e-5"
while [ $# -gt 0 ]; do
    case $1 in
    --build) build=$2; shift ;;
    --surfaces) surfaces=$2; shift ;;
    --eps) eps_list=$2; shift ;;
    -h | --help) sed -n '2,18p' "$0"; exit 0 ;;
    *) echo "bench/refine.sh: unknown option $1" >&2; exit 2 ;;
    esac
    shift
done
IVOCT=${IVOCT_BIN:-$build/cli/ivoct}
PY=/usr/bin/python3
mkdir -p "$root/bench/results"
stamp=$(date +%Y%m%d-%H%M%S)
csv=$root/bench/results/refine-$stamp.csv
work=$(mktemp -d /tmp/ivoct-refine.XXXXXX)
trap 'rm -rf "$work"' EXIT

stat() { $PY -c 'import json,sys; d=json.load(open(sys.argv[1])); print(d[sys.argv[2]] if sys.argv[2] in d else d["decided_by"][sys.argv[2][11:]])' "$1" "$2"; }

echo "surface,eps,depth,refined_leaves,refined_time_s,refined_max_error,uniform_leaves,uniform_time_s,uniform_error,uniform_kind,leaf_ratio" >"$csv"
for s in $surfaces; do
    scene=$root/scenes/$s.ini
    diag=$($PY - "$scene" <<'PYEOF'
import sys
for line in open(sys.argv[1]):
    line = line.split(";")[0].strip()
    if line.startswith("box"):
        b = [float(v) for v in line.split("=")[1].split()]
        print(((b[1]-b[0])**2 + (b[3]-b[2])**2 + (b[5]-b[4])**2) ** 0.5)
PYEOF
)
    declare -A uni_leaves=() uni_time=()
    for eps in $eps_list; do
        depth=$($PY -c 'import math,sys; print(max(0, math.ceil(math.log2(float(sys.argv[1]) / float(sys.argv[2])))))' "$diag" "$eps")
        "$IVOCT" build "$scene" --depth "$depth" --tests interval,lipschitz,ilie --refine "$eps" \
            --stats "$work/r.json" --quiet
        rl=$(stat "$work/r.json" leaves) rt=$(stat "$work/r.json" time_s) re=$(stat "$work/r.json" max_error_bound)
        if [ "$depth" -le 10 ]; then
            "$IVOCT" build "$scene" --depth "$depth" --tests interval,lipschitz --stats "$work/u.json" --quiet
            ul=$(stat "$work/u.json" leaves) ut=$(stat "$work/u.json" time_s) ue=$(stat "$work/u.json" max_error_bound)
            kind=built
        else
            "$IVOCT" build "$scene" --depth 10 --tests interval,lipschitz --stats "$work/u.json" --quiet
            ul=$($PY -c 'import sys; print(int(float(sys.argv[1]) * 4 ** (int(sys.argv[2]) - 10)))' "$(stat "$work/u.json" leaves)" "$depth")
            ut=NA ue=$($PY -c 'import sys; print(float(sys.argv[1]) / 2 ** int(sys.argv[2]))' "$diag" "$depth")
            kind=extrapolated
        fi
        ratio=$($PY -c 'import sys; print("%.1f" % (float(sys.argv[1]) / float(sys.argv[2])))' "$ul" "$rl")
        echo "$s,$eps,$depth,$rl,$rt,$re,$ul,$ut,$ue,$kind,$ratio" | tee -a "$csv"
    done
done

echo "== ilie against interval,lipschitz at depth 9 (no refinement)"
echo "surface,tests,time_s,cells_visited,leaves,decided_ilie,split,max_depth" >"$work/ilie.csv"
for s in $surfaces; do
    for t in interval,lipschitz interval,lipschitz,ilie; do
        "$IVOCT" build "$root/scenes/$s.ini" --depth 9 --tests $t --stats "$work/i.json" --quiet
        echo "$s,\"$t\",$(stat "$work/i.json" time_s),$(stat "$work/i.json" cells_visited),$(stat "$work/i.json" leaves),$(stat "$work/i.json" decided_by.ilie),$(stat "$work/i.json" split),$(stat "$work/i.json" decided_by.max_depth)" | tee -a "$work/ilie.csv"
    done
done
cp "$work/ilie.csv" "$root/bench/results/ilie-$stamp.csv"

if command -v gnuplot >/dev/null; then
    gnuplot <<GPEOF
set terminal pngcairo size 900,420 font ",10"
set output "$root/docs/refine.png"
set datafile separator ","
set multiplot layout 1,2 title "Gradient-adaptive refinement vs uniform octree (certified error)"
set logscale xy
set xlabel "certified max error"
set ylabel "surface leaves"
set key left bottom
set grid
plot for [s in "$surfaces"] "< grep '^".s.",' $csv" using 6:4 with linespoints title s." refined", \
     for [s in "$surfaces"] "< grep '^".s.",' $csv" using 9:7 with linespoints dashtype 2 title s." uniform"
set ylabel "build time (s)"
plot for [s in "$surfaces"] "< grep '^".s.",' $csv" using 6:5 with linespoints title s." refined", \
     for [s in "$surfaces"] "< grep '^".s.",.*,built,' $csv" using 9:8 with linespoints dashtype 2 title s." uniform"
unset multiplot
GPEOF
    echo "plot: docs/refine.png"
fi
echo "results: $csv"
