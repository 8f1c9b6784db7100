#!/usr/bin/env bash
# Two threads against one, and what the machine allows two threads to gain.
#
#   bash bench/threads.sh [--build DIR] [--base BIN] [--depth N] [--reps N]
#                         [--tests CHAIN] [--surfaces "a b ..."]
#
# For each surface, best of --reps (default 5) interleaved runs of
#   1. `ivoct build SCENE --depth N --tests CHAIN --threads 1`  (alone)
#   2. the same with --threads 2
#   3. two copies of (1) started together, as separate processes: the time of
#      the slower.  They share nothing but the hardware, so (1) / (3) is what
#      the two cores give two independent jobs, and 2 · (1) / (3) the speed-up
#      two threads could reach at best here ("ceiling").  On a 2-vCPU virtual
#      machine whose vCPUs share a physical core, or its caches and memory
#      bandwidth, the ceiling is well below 2.
# and the same for --base BIN (an earlier ivoct) when given.  Times are the
# build's own (time_s of --stats).  Default: depth 9, --tests interval,
# gumdrop and mcmullen-k3.  Prints a table, with `uptime` before and after; the
# machine has 2 cores and is shared: run it with nothing else going.
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/.." && pwd)
build_dir=$root/build/release
base=
depth=9
reps=5
tests=interval
surfaces="gumdrop mcmullen-k3"
while [ $# -gt 0 ]; do
    case $1 in
    --build) build_dir=$2; shift ;;
    --base) base=$2; shift ;;
    --depth) depth=$2; shift ;;
    --reps) reps=$2; shift ;;
    --tests) tests=$2; shift ;;
    --surfaces) surfaces=$2; shift ;;
    -h | --help) sed -n '2,19p' "$0"; exit 0 ;;
    *) echo "bench/threads.sh: unknown option $1" >&2; exit 2 ;;
    esac
    shift
done
bin=$build_dir/cli/ivoct
[ -x "$bin" ] || { echo "bench/threads.sh: no $bin (make build first)" >&2; exit 2; }
[ -z "$base" ] || [ -x "$base" ] || { echo "bench/threads.sh: --base $base is not an executable" >&2; exit 2; }
tmp=$(mktemp -d /tmp/ivoct-bench-threads.XXXXXX)
trap 'rm -rf "$tmp"' EXIT

time_of() { /usr/bin/python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["time_s"])' "$1"; }
min() { awk -v a="$1" -v b="$2" 'BEGIN{print (a<b)?a:b}'; }
max() { awk -v a="$1" -v b="$2" 'BEGIN{print (a>b)?a:b}'; }

echo "load before: $(uptime)"
printf '%-8s %-14s %9s %9s %9s %9s %9s\n' binary surface 1_thread 2_threads pair speedup ceiling
for s in $surfaces; do
    scene=$root/scenes/$s.ini
    bins=("new=$bin")
    [ -z "$base" ] || bins+=("base=$base")
    declare -A one two pair
    for b in "${bins[@]}"; do one[${b%%=*}]=1e99 two[${b%%=*}]=1e99 pair[${b%%=*}]=1e99; done
    for _ in $(seq "$reps"); do
        for b in "${bins[@]}"; do
            name=${b%%=*} exe=${b#*=}
            args=(build "$scene" --depth "$depth" --tests "$tests" --quiet)
            "$exe" "${args[@]}" --threads 1 --stats "$tmp/1.json" > /dev/null
            one[$name]=$(min "${one[$name]}" "$(time_of "$tmp/1.json")")
            "$exe" "${args[@]}" --threads 2 --stats "$tmp/2.json" > /dev/null
            two[$name]=$(min "${two[$name]}" "$(time_of "$tmp/2.json")")
            "$exe" "${args[@]}" --threads 1 --stats "$tmp/a.json" > /dev/null &
            "$exe" "${args[@]}" --threads 1 --stats "$tmp/b.json" > /dev/null
            wait
            p=$(max "$(time_of "$tmp/a.json")" "$(time_of "$tmp/b.json")")
            pair[$name]=$(min "${pair[$name]}" "$p")
        done
    done
    for b in "${bins[@]}"; do
        name=${b%%=*}
        awk -v n="$name" -v s="$s" -v a="${one[$name]}" -v t="${two[$name]}" -v p="${pair[$name]}" \
            'BEGIN{printf "%-8s %-14s %9.3f %9.3f %9.3f %9.2f %9.2f\n", n, s, a, t, p, a / t, 2 * a / p}'
    done
    unset one two pair
done
echo "load after:  $(uptime)"
