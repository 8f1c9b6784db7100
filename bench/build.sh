#!/usr/bin/env bash
# Octree build: run time against certified error, per chain of tests.
#
#   bash bench/build.sh [--quick] [--build DIR] [--surfaces "a b ..."] [--threads N]
#                       [--eps "1e-2 1e-3 1e-4"]
#
# For every surface, ivoct_build_sweep (bench/build_sweep.c) builds the octree
#   - with each chain {interval} (depths 5-8: its leaf count grows ~4.5x per level,
#     depth 10 would need gigabytes), {interval, lipschitz}, {interval, lipschitz,
#     ilie} and {interval, ilie} (depths 5-10),
#   - with refine EPS for EPS = 1e-2 ... 1e-4 (chain interval, ilie; depth where a
#     leaf's diagonal is <= EPS).  1e-5 is left out of the default list: it costs
#     60-230 s per quartic on 2 cores (horned cube 233 s, gumdrop 132 s) for ~10x
#     the leaves of 1e-4, more than the rest of the sweep together (--eps adds it),
# and reports time, leaves, certified max error, and the share of leaves without
# surface (proven empty / proven surface / undecided, on 256 leaves per build).
# --quick: sphere and gumdrop, depths 5-7, EPS 1e-2 and 1e-3, 64 leaves.
#
# Outputs (bench/results/ is git-ignored): bench/results/build.csv, and with
# gnuplot docs/build-error.png (bench/results/build-error.png with --quick, so that
# a smoke run does not replace the documented plot).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/.." && pwd)
build=$root/build/release
quick=0
threads=2
surfaces="sphere drop chubs crosscap gumdrop horned-cube mcmullen-k3 kusner-schmitt"
eps=
while [ $# -gt 0 ]; do
    case $1 in
    --quick) quick=1 ;;
    --build) build=$2; shift ;;
    --surfaces) surfaces=$2; shift ;;
    --threads) threads=$2; shift ;;
    --eps) eps=$2; shift ;;
    -h | --help) sed -n '2,22p' "$0"; exit 0 ;;
    *) echo "bench/build.sh: unknown option $1" >&2; exit 2 ;;
    esac
    shift
done
sweep=$build/bench/ivoct_build_sweep
if [ "$quick" = 1 ]; then
    [ "$surfaces" = "sphere drop chubs crosscap gumdrop horned-cube mcmullen-k3 kusner-schmitt" ] &&
        surfaces="sphere gumdrop"
    idepths=5-7 depths=5-7 sample=64
    eps=${eps:-1e-2 1e-3}
else
    idepths=5-8 depths=5-10 sample=256
    eps=${eps:-1e-2 1e-3 1e-4}
fi
mkdir -p "$root/bench/results"
plot_dir=$root/docs
[ "$quick" = 1 ] && plot_dir=$root/bench/results
csv=$root/bench/results/build.csv
tmp=$(mktemp /tmp/ivoct-build-bench.XXXXXX)
trap 'rm -f "$tmp"' EXIT
echo "scene,chain,depth,refine,threads,time_s,leaves,cells_visited,max_error_bound,sampled,proven_empty,proven_surface,undecided" >"$tmp"
for s in $surfaces; do
    scene=$root/scenes/$s.ini
    "$sweep" "$scene" --chains interval --depths "$idepths" --eps "" --threads "$threads" \
        --sample "$sample" | tee -a "$tmp"
    "$sweep" "$scene" --chains "interval,lipschitz;interval,lipschitz,ilie;interval,ilie" \
        --depths "$depths" --eps "$eps" --threads "$threads" --sample "$sample" | tee -a "$tmp"
done
mv "$tmp" "$csv"
trap - EXIT
echo "results: bench/results/build.csv"

if command -v gnuplot >/dev/null; then
    # one data file per surface and series: error, time, leaves
    plotdir=$(mktemp -d /tmp/ivoct-build-plot.XXXXXX)
    trap 'rm -rf "$plotdir"' EXIT
    series=(interval interval+lipschitz interval+lipschitz+ilie interval+ilie refine)
    for s in $surfaces; do
        for k in 0 1 2 3 4; do
            awk -F, -v s="$s" -v chain="${series[$k]}" -v k=$k \
                '$1 == s && ((k < 4 && $2 == chain && $4 == 0) || (k == 4 && $4 > 0)) { print $9, $6, $7 }' \
                "$csv" >"$plotdir/$s-$k.dat"
        done
    done
    n=$(echo $surfaces | wc -w)
    cols=$(( n < 4 ? n : 4 )) rows=$(( (n + 3) / 4 ))
    gnuplot <<GPEOF
set terminal pngcairo size $((cols * 360)),$((rows * 320 + 40)) font ",9"
set output "$plot_dir/build-error.png"
set multiplot layout $rows,$cols title "Octree build: time (s, $threads threads) against certified max error"
set logscale xy
set format x "10^{%L}"
set grid
set key bottom left font ",7"
set xlabel "certified max error"
set ylabel "build time (s)"
do for [s in "$surfaces"] {
    set title s
    plot "$plotdir/".s."-0.dat" using 1:2 with linespoints pt 6 title "interval", \
         "$plotdir/".s."-1.dat" using 1:2 with linespoints pt 4 title "interval, lipschitz", \
         "$plotdir/".s."-2.dat" using 1:2 with linespoints pt 8 title "interval, lipschitz, ilie", \
         "$plotdir/".s."-3.dat" using 1:2 with linespoints pt 2 title "interval, ilie", \
         "$plotdir/".s."-4.dat" using 1:2 with linespoints pt 7 lw 2 title "interval, ilie, refine EPS"
}
unset multiplot
GPEOF
    echo "plot: $plot_dir/build-error.png"
fi
