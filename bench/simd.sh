#!/usr/bin/env bash
# The evaluators' SIMD paths and the level-by-level builder, against a
# previous ivoct, side by side in one run.
#
#   bash bench/simd.sh [--base BIN] [--build DIR] [--depths "8 9 10"] [--reps N]
#                      [--surfaces "a b ..."]
#
# BIN (optional; `make bench` passes $IVOCT_BENCH_BASE) is an ivoct built from an earlier commit (e.g. the one before the SIMD
# work: git worktree add /tmp/base COMMIT && cmake -S /tmp/base -B /tmp/base/b
# && cmake --build /tmp/base/b --target ivoct).  In one interleaved run, so
# that every side sees the same machine load, the best of --reps runs of:
#   1. ivoct_bench_eval on each surface: ns per clause per lane of the point,
#      interval, gradient and affine evaluators on every SIMD path;
#   2. for each surface, depth and chain (interval; interval,ilie), one thread:
#      BIN build, then IVOCT_SIMD=P ivoct build for every path P the CPU runs
#      -> M cells/s per core (cells_visited / time_s of --stats);
#   3. the default path with 2 threads against 1 (depth 9, interval);
#   4. the uniform octree (interval, 1 thread) against dense point sampling
#      (ivoct_dense, 1 thread) at the deepest depth;
#   and, on a CPU with AVX-512, ivoct_round_avx512: the interval product with
#   the outward widening against AVX-512's per-instruction rounding.
# Output: bench/results/simd-STAMP.md (also printed).  The machine has 2
# cores and is shared: check `uptime` (printed at the start and the end).
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/.." && pwd)
build_dir=$root/build/release
base=
depths="8 9 10"
reps=3
surfaces="sphere drop chubs crosscap gumdrop horned-cube mcmullen-k3 kusner-schmitt csg-64-spheres"
while [ $# -gt 0 ]; do
    case $1 in
    --base) base=$2; shift ;;
    --build) build_dir=$2; shift ;;
    --depths) depths=$2; shift ;;
    --reps) reps=$2; shift ;;
    --surfaces) surfaces=$2; shift ;;
    -h | --help) sed -n '2,23p' "$0"; exit 0 ;;
    *) echo "bench/simd.sh: unknown option $1" >&2; exit 2 ;;
    esac
    shift
done
[ -z "$base" ] || [ -x "$base" ] || { echo "bench/simd.sh: --base $base is not an executable" >&2; exit 2; }
bin=$build_dir/cli/ivoct
[ -x "$bin" ] || { echo "bench/simd.sh: no $bin (make build first)" >&2; exit 2; }
mkdir -p "$root/bench/results"
out=$root/bench/results/simd-$(date +%Y%m%d-%H%M%S).md
tmp=$(mktemp -d /tmp/ivoct-bench-simd.XXXXXX)
trap 'rm -rf "$tmp"' EXIT
paths=$(sed -n 's/.*this build has: \(.*\))$/\1/p' < <("$bin" --version))
run_paths=()
for p in $paths; do IVOCT_SIMD=$p "$bin" --version > /dev/null 2>&1 && run_paths+=("$p"); done
deepest=${depths##* }

# best cells/s (millions) of `BIN build ARGS` over $reps runs; "time cells" on stdout
best_build() {
    local best_t=1e99 cells=0 t c
    for _ in $(seq "$reps"); do
        "$@" --quiet --stats "$tmp/s.json" > /dev/null
        read -r t c < <(/usr/bin/python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); print(d["time_s"], d["cells_visited"])' "$tmp/s.json")
        best_t=$(awk -v a="$t" -v b="$best_t" 'BEGIN{print (a<b)?a:b}')
        cells=$c
    done
    echo "$best_t $cells"
}
mcps() { awk -v t="$1" -v c="$2" 'BEGIN{printf "%.2f", c / t / 1e6}'; }

{
echo "# SIMD evaluators and the level-by-level builder ($(date -u +%Y-%m-%d))"
echo
echo "Command: \`bash bench/simd.sh${base:+ --base $base} --depths \"$depths\" --reps $reps\`;"
echo "paths of this build: $paths; this CPU runs: ${run_paths[*]}; load at start: $(cut -d' ' -f1-3 /proc/loadavg)."
echo
echo "## Evaluators: ns per clause per lane (calls of TAPE_BATCH boxes)"
echo
echo '```'
scene_files=()
for s in $surfaces; do scene_files+=("$root/scenes/$s.ini"); done
"$build_dir/bench/ivoct_bench_eval" --seconds 0.6 "${scene_files[@]}"
echo '```'
echo
if [ -x "$build_dir/bench/ivoct_round_avx512" ]; then
    echo "## The interval product: outward widening against AVX-512's per-instruction rounding"
    echo
    echo '```'
    "$build_dir/bench/ivoct_round_avx512" 1
    echo '```'
    echo
fi
echo "## Build, one thread: M cells/s per core (best of $reps)"
echo
header="| surface | depth | tests |"
sep="|---|---|---|"
[ -n "$base" ] && header="$header base |" && sep="$sep---|"
for p in "${run_paths[@]}"; do
    header="$header $p |"
    sep="$sep---|"
    [ -n "$base" ] && header="$header $p / base |" && sep="$sep---|"
done
echo "$header"
echo "$sep"
for s in $surfaces; do
    for d in $depths; do
        for tests in interval interval,ilie; do
            [ "$d" = "$deepest" ] && [ "$tests" != interval ] && continue
            row="| $s | $d | $tests |"
            if [ -n "$base" ]; then
                read -r bt bc < <(best_build "$base" build "$root/scenes/$s.ini" --depth "$d" --tests "$tests" --threads 1)
                row="$row $(mcps "$bt" "$bc") |"
            fi
            for p in "${run_paths[@]}"; do
                read -r t c < <(best_build env IVOCT_SIMD="$p" "$bin" build "$root/scenes/$s.ini" --depth "$d" --tests "$tests" --threads 1)
                row="$row $(mcps "$t" "$c") |"
                [ -n "$base" ] && row="$row $(awk -v a="$bt" -v b="$t" 'BEGIN{printf "%.2f", a / b}') |"
            done
            echo "$row"
        done
    done
done
echo
echo "## Threads: default path, depth 9, interval (best of $reps)"
echo
echo "| surface | 1 thread s | 2 threads s | speed-up |"
echo "|---|---|---|---|"
for s in $surfaces; do
    read -r t1 _ < <(best_build "$bin" build "$root/scenes/$s.ini" --depth 9 --tests interval --threads 1)
    read -r t2 _ < <(best_build "$bin" build "$root/scenes/$s.ini" --depth 9 --tests interval --threads 2)
    echo "| $s | $t1 | $t2 | $(awk -v a="$t1" -v b="$t2" 'BEGIN{printf "%.2f", a / b}') |"
done
echo
echo "## Uniform octree against dense point sampling, depth $deepest, one core each"
echo
echo "| surface | octree s (interval) | dense s | dense / octree |"
echo "|---|---|---|---|"
for s in $surfaces; do
    read -r t _ < <(best_build "$bin" build "$root/scenes/$s.ini" --depth "$deepest" --tests interval --threads 1)
    dt=$("$build_dir/bench/ivoct_dense" "$root/scenes/$s.ini" --depth "$deepest" --threads 1 |
        /usr/bin/python3 -c 'import json,sys; print(json.load(sys.stdin)["dense_time_s"])')
    echo "| $s | $t | $dt | $(awk -v a="$dt" -v b="$t" 'BEGIN{printf "%.2f", a / b}') |"
done
echo
echo "Load at the end: $(cut -d' ' -f1-3 /proc/loadavg)."
} | tee "$out"
