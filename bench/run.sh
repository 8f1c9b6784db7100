#!/usr/bin/env bash
# `make bench`: every benchmark, CSV in bench/results/ (git-ignored), plots in docs/.
#
#   bash bench/run.sh [--quick] [--build DIR]
#
# Full: under 30 minutes on a quiet 2-core machine; --quick: a few surfaces at low
# depth and small images, about 3 minutes (a smoke run of every part, not numbers
# to quote).  Each part can be run alone; see the header of each script.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/.." && pwd)
build=$root/build/release
quick=0
while [ $# -gt 0 ]; do
    case $1 in
    --quick) quick=1 ;;
    --build) build=$2; shift ;;
    -h | --help) sed -n '2,9p' "$0"; exit 0 ;;
    *) echo "bench/run.sh: unknown option $1" >&2; exit 2 ;;
    esac
    shift
done
export IVOCT_BIN=$build/cli/ivoct
mkdir -p "$root/bench/results"
q=()
[ "$quick" = 1 ] && q=(--quick)
start=$(date +%s)
part() { echo; echo "== $1 ($(($(date +%s) - start)) s)"; }

part "tape evaluators: ns per clause per box (bench/bench_eval.c)"
if [ "$quick" = 1 ]; then surfaces="sphere gumdrop"; else
    surfaces="sphere drop chubs crosscap gumdrop horned-cube mcmullen-k3 kusner-schmitt"; fi
scenes=()
for s in $surfaces; do scenes+=("$root/scenes/$s.ini"); done
"$build/bench/ivoct_bench_eval" "${scenes[@]}" | tee "$root/bench/results/eval.txt"

part "SIMD paths and the level-by-level builder, against \$IVOCT_BENCH_BASE when set (bench/simd.sh)"
if [ "$quick" = 1 ]; then
    bash "$here/simd.sh" --build "$build" ${IVOCT_BENCH_BASE:+--base "$IVOCT_BENCH_BASE"} \
        --surfaces "sphere gumdrop" --depths "6 7" --reps 1
else
    bash "$here/simd.sh" --build "$build" ${IVOCT_BENCH_BASE:+--base "$IVOCT_BENCH_BASE"} \
        --depths "8 9" --reps 2
fi

part "octree build against dense sampling (bench/octree.sh)"
bash "$here/octree.sh" --build "$build" "${q[@]}"

part "octree build: time against certified error, per chain (bench/build.sh)"
bash "$here/build.sh" --build "$build" "${q[@]}"

part "refinement against a uniform octree at equal certified error (bench/refine.sh)"
if [ "$quick" = 1 ]; then
    bash "$here/refine.sh" --build "$build" --surfaces sphere --eps "1e-2 1e-3" \
        --plot-dir "$root/bench/results"
else
    # 1e-5 on gumdrop and McMullen takes minutes each: run refine.sh alone for it
    bash "$here/refine.sh" --build "$build" --eps "1e-2 1e-3 1e-4" --threads 2
fi

part "ray casting, Florez's layout (bench/ray.sh)"
if [ "$quick" = 1 ]; then
    bash "$here/ray.sh" --build "$build" --size 100x100 --reps 1 --surfaces "sphere gumdrop" \
        --methods "mitchell lipschitz" --out ray-quick
else
    bash "$here/ray.sh" --build "$build" --reps 1
fi

part "leaf tapes against the scene's tape in every leaf (bench/leaf_tapes.sh)"
if [ "$quick" = 1 ]; then
    bash "$here/leaf_tapes.sh" --build "$build" --size 100x100 --reps 1 --out leaf_tapes-quick
else
    bash "$here/leaf_tapes.sh" --build "$build"
fi

part "certified shadows: the render with and without a point light (bench/shadows.sh)"
if [ "$quick" = 1 ]; then
    bash "$here/shadows.sh" --build "$build" --size 100x100 --reps 1 --scenes "sphere gumdrop" \
        --out shadows-quick
else
    bash "$here/shadows.sh" --build "$build"
fi

part "render time against hit error, and the OpenVDB level-set baseline (bench/ray_error.sh)"
if [ -x "$build/bench/ivoct_ray_error" ]; then
    # one repetition (ray.sh above has timed the same renders already)
    bash "$here/ray_error.sh" --build "$build" "${q[@]}" --reps 1
else
    echo "(skipped: no $build/bench/ivoct_ray_error; it needs export/ and MPFR)"
fi

part "the writers of ivoct build: seconds per output against the build (bench/writers.sh)"
bash "$here/writers.sh" --build "$build" "${q[@]}"

part "start-up: whole small commands, against \$IVOCT_BENCH_BASE when set (bench/startup.sh)"
if [ "$quick" = 1 ]; then
    bash "$here/startup.sh" --build "$build" ${IVOCT_BENCH_BASE:+--base "$IVOCT_BENCH_BASE"} --reps 5
else
    bash "$here/startup.sh" --build "$build" ${IVOCT_BENCH_BASE:+--base "$IVOCT_BENCH_BASE"}
fi

part "parametric scenes: implicitization against build and render (bench/implicitize.sh)"
if [ "$quick" = 1 ]; then
    bash "$here/implicitize.sh" --build "$build" --reps 1 --depth 5 --size 64x64
else
    bash "$here/implicitize.sh" --build "$build"
fi

part "the certified mesh against OpenVDB's: time, topology, distance to the surface (bench/mesh.sh)"
if [ -x "$build/bench/ivoct_mesh_quality" ]; then
    # --reps 2 (the documented table is mesh.sh alone, best of 3): about 3 minutes
    if [ "$quick" = 1 ]; then bash "$here/mesh.sh" --build "$build" --quick
    else bash "$here/mesh.sh" --build "$build" --reps 2; fi
else
    echo "(skipped: no $build/bench/ivoct_mesh_quality; it is built with the tests)"
fi

part "certain leaves: point witnesses against modal intervals, by depth (bench/certain.sh)"
if [ "$quick" = 1 ]; then
    bash "$here/certain.sh" --build "$build" --quick
else
    # one run each, no configuration predicted over 20 s (most of depth 10 is left
    # out): about 2 minutes (the documented table is certain.sh alone: best of 2, up
    # to 60 s each)
    bash "$here/certain.sh" --build "$build" --reps 1 --cap 20
fi

part "numerical stability stress cases (bench/stability.sh)"
bash "$here/stability.sh" --build "$build"

part "done"
