#!/usr/bin/env bash
# What a command costs before and around its work: whole-command wall times of
# small ivoct commands, where start-up (the dynamic loader, libraries' static
# initialisers) is most of the time.
#
#   bash bench/startup.sh [--build DIR] [--base BIN] [--reps N]
#
# Each command is run --reps times (default 20), this build's ivoct, then --base
# BIN (an earlier ivoct) when given, and the mean wall time and the standard
# error of the mean printed:
#   --version                               start-up alone
#   build sphere --depth 5                  a small build, no output
#   build sphere --depth 5 --vtu F          a VTK file written without VTK
#   build sphere --depth 5 --htg F          a VTK file (loads the VTK module)
#   build sphere --depth 5 --vdb F          an OpenVDB file (loads the OpenVDB module)
#   render sphere --size 32x32              a small render (the octree built in it)
#   info F.vtu, info F.vdb                  reading them back (each loads its module)
# Prints a table, with `uptime` before and after; the machine has 2 cores and is
# shared: run it with nothing else going.
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/.." && pwd)
build_dir=$root/build/release
base=
reps=20
while [ $# -gt 0 ]; do
    case $1 in
    --build) build_dir=$2; shift ;;
    --base) base=$2; shift ;;
    --reps) reps=$2; shift ;;
    -h | --help) sed -n '2,19p' "$0"; exit 0 ;;
    *) echo "bench/startup.sh: unknown option $1" >&2; exit 2 ;;
    esac
    shift
done
new=$build_dir/cli/ivoct
[ -x "$new" ] || { echo "bench/startup.sh: no $new (make build)" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
scene=$root/scenes/sphere.ini
"$new" build "$scene" --depth 5 --quiet --vdb "$work/read.vdb" --vtu "$work/read.vtu"

# the mean wall time of N runs of CMD..., and the standard error of that mean
mean_wall() {
    /usr/bin/python3 - "$reps" "$@" <<'PY'
import statistics, subprocess, sys, time
n, cmd = int(sys.argv[1]), sys.argv[2:]
t = []
for _ in range(n):
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    t.append(time.perf_counter() - t0)
sem = statistics.stdev(t) / len(t) ** 0.5 if len(t) > 1 else 0.0
print(f"{1000 * statistics.mean(t):.1f} ± {1000 * sem:.1f} ms")
PY
}

echo "load before: $(uptime)"
printf '%-28s %-26s %s\n' command "this build" "${base:+base}"
run_case() {
    local name=$1
    shift
    local a b=""
    a=$(mean_wall "$new" "$@")
    [ -n "$base" ] && b=$(mean_wall "$base" "$@")
    printf '%-28s %-26s %s\n' "$name" "$a" "$b"
}
run_case "--version" --version
run_case "build --depth 5" build "$scene" --depth 5 --quiet
run_case "build --depth 5 --vtu" build "$scene" --depth 5 --quiet --vtu "$work/x.vtu"
run_case "build --depth 5 --htg" build "$scene" --depth 5 --quiet --htg "$work/x.htg"
run_case "build --depth 5 --vdb" build "$scene" --depth 5 --quiet --vdb "$work/x.vdb"
run_case "render --size 32x32" render "$scene" --size 32x32 --quiet --png "$work/x.png"
run_case "info F.vtu" info "$work/read.vtu"
run_case "info F.vdb" info "$work/read.vdb"
echo "load after:  $(uptime)"
