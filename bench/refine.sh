#!/usr/bin/env bash
# Gradient-adaptive refinement against a uniform octree at equal certified error.
#
#   bash bench/refine.sh [--build DIR] [--surfaces "sphere gumdrop mcmullen-k3"]
#                        [--eps "1e-2 1e-3 1e-4 1e-5 1e-6"] [--threads N]
#                        [--plot-dir DIR] [--plot-only CSV]
#
# For each surface and tolerance EPS:
#   refined:  ivoct build SCENE --tests interval,ilie --refine EPS --depth D
#             where D is the depth at which a uniform leaf's diagonal is <= EPS (at most
#             21), so that every leaf (early or not) has a certified error bound <= EPS;
#   uniform:  ivoct build SCENE --tests interval,lipschitz --depth D (no refinement, no
#             slabs): its certified error is the leaf diagonal. Built when D <= 10; deeper
#             ones are extrapolated from the depth-10 count by 4x per level (a surface's
#             leaf count grows with its area / cell area) and marked "extrapolated".
# Also, at depth 9 without refinement: the chains interval,lipschitz / interval,ilie /
# interval,lipschitz,ilie (time, cells, and the share of the cells interval+lipschitz
# leave open that ilie decides).
# Writes bench/results/refine-STAMP.csv and, with gnuplot, DIR/refine.png (default docs/).
# --plot-only CSV: only draw the plot from an earlier CSV (or several concatenated).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/.." && pwd)
build=$root/build/release
surfaces="sphere gumdrop mcmullen-k3"
eps_list="1e-2 1e-3 1e-4 1e-5 1e-6"
threads=1
plot_dir=$root/docs
plot_only=
while [ $# -gt 0 ]; do
    case $1 in
    --build) build=$2; shift ;;
    --surfaces) surfaces=$2; shift ;;
    --eps) eps_list=$2; shift ;;
    --threads) threads=$2; shift ;;
    --plot-dir) plot_dir=$2; shift ;;
    --plot-only) plot_only=$2; shift ;;
    -h | --help) sed -n '2,23p' "$0"; exit 0 ;;
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

if [ -n "$plot_only" ]; then csv=$plot_only surfaces=$(cut -d, -f1 "$csv" | grep -v '^surface$' | uniq | tr '\n' ' '); fi
[ -z "$plot_only" ] && echo "surface,eps,depth,refined_leaves,refined_time_s,refined_max_error,uniform_leaves,uniform_time_s,uniform_error,uniform_kind,leaf_ratio" >"$csv"
for s in $surfaces; do
    [ -n "$plot_only" ] && break
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
        depth=$($PY -c 'import math,sys; print(min(21, max(0, math.ceil(math.log2(float(sys.argv[1]) / float(sys.argv[2]))))))' "$diag" "$eps")
        "$IVOCT" build "$scene" --depth "$depth" --tests interval,ilie --refine "$eps" \
            --threads "$threads" --stats "$work/r.json" --quiet
        rl=$(stat "$work/r.json" leaves) rt=$(stat "$work/r.json" time_s) re=$(stat "$work/r.json" max_error_bound)
        if [ "$depth" -le 10 ]; then
            "$IVOCT" build "$scene" --depth "$depth" --tests interval,lipschitz --threads "$threads" \
                --stats "$work/u.json" --quiet
            ul=$(stat "$work/u.json" leaves) ut=$(stat "$work/u.json" time_s) ue=$(stat "$work/u.json" max_error_bound)
            kind=built
        else
            "$IVOCT" build "$scene" --depth 10 --tests interval,lipschitz --threads "$threads" \
                --stats "$work/u.json" --quiet
            ul=$($PY -c 'import sys; print(int(float(sys.argv[1]) * 4 ** (int(sys.argv[2]) - 10)))' "$(stat "$work/u.json" leaves)" "$depth")
            ut=NA ue=$($PY -c 'import sys; print(float(sys.argv[1]) / 2 ** int(sys.argv[2]))' "$diag" "$depth")
            kind=extrapolated
        fi
        ratio=$($PY -c 'import sys; print("%.1f" % (float(sys.argv[1]) / float(sys.argv[2])))' "$ul" "$rl")
        echo "$s,$eps,$depth,$rl,$rt,$re,$ul,$ut,$ue,$kind,$ratio" | tee -a "$csv"
    done
done

[ -z "$plot_only" ] && echo "== the chains at depth 9 (no refinement)"
echo "surface,tests,time_s,cells_visited,leaves,decided_lipschitz,decided_ilie,split,ilie_share" >"$work/ilie.csv"
for s in $surfaces; do
    [ -n "$plot_only" ] && break
    for t in interval,lipschitz interval,ilie interval,lipschitz,ilie; do
        "$IVOCT" build "$root/scenes/$s.ini" --depth 9 --tests $t --threads "$threads" \
            --stats "$work/i.json" --quiet
        $PY - "$work/i.json" "$s" "$t" <<'PYEOF' | tee -a "$work/ilie.csv"
import json, sys
d = json.load(open(sys.argv[1])); by = d["decided_by"]
# ilie_share: of the cells interval+lipschitz leave open, those ilie decides
# (meaningful for interval,lipschitz,ilie, where ilie runs after both)
share = by["ilie"] / (by["ilie"] + d["split"] + by["max_depth"]) if "lipschitz,ilie" in sys.argv[3] else ""
print('%s,"%s",%.3f,%d,%d,%d,%d,%d,%s' % (sys.argv[2], sys.argv[3], d["time_s"], d["cells_visited"],
      d["leaves"], by["lipschitz"], by["ilie"], d["split"], "%.3f" % share if share != "" else ""))
PYEOF
    done
done
[ -z "$plot_only" ] && cp "$work/ilie.csv" "$root/bench/results/ilie-$stamp.csv"

if command -v gnuplot >/dev/null; then
    gnuplot <<GPEOF
set terminal pngcairo size 900,420 font ",10"
set output "$plot_dir/refine.png"
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
    echo "plot: $plot_dir/refine.png"
fi
echo "results: $csv"
