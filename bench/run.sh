#!/usr/bin/env bash
# `make bench`: every benchmark, results in bench/results/ (git-ignored).
#   bash bench/run.sh [--quick]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/.." && pwd)
build=${IVOCT_BUILD:-$root/build/release}
mkdir -p "$root/bench/results"
comparison="sphere drop chubs crosscap gumdrop horned-cube mcmullen-k3 kusner-schmitt"

echo "== evaluators: ns per clause per box (issue 2)"
scenes=()
for s in $comparison; do scenes+=("$root/scenes/$s.ini"); done
"$build/bench/ivoct_bench_eval" "${scenes[@]}" | tee "$root/bench/results/eval.txt"

echo "== octree build against dense sampling (issue 3)"
bash "$here/octree.sh" --build "$build" "$@"

echo "== render time against hit error, and the OpenVDB level-set baseline (issue 7)"
if [ -x "$build/bench/ivoct_ray_error" ]; then
    quick=()
    for a in "$@"; do [ "$a" = --quick ] && quick=(--quick); done
    bash "$here/ray_error.sh" --build "$build" ${quick[@]+"${quick[@]}"}
else
    echo "(skipped: no $build/bench/ivoct_ray_error; it needs export/ and MPFR)"
fi
