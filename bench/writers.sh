#!/usr/bin/env bash
# The writers of `ivoct build`: seconds per output, against the build's own time.
#
#   bash bench/writers.sh [--build DIR] [--base IVOCT] [--depth N] [--reps N]
#                         [--surfaces "gumdrop ..."] [--outputs "cells vtu ..."]
#                         [--threads N] [--quick]
#   bash bench/writers.sh --same-values --base IVOCT [--build DIR]
#
# Each output (--cells, --save, --vtu, --htg, --vdb; --outputs: only those) is written by its own
# command, `ivoct build SCENE --depth N --stats F.json OUTPUT`; the writer's time
# is the command's wall time less the build's time_s from the same run (what
# is left: the writer, loading the scene, exiting), and net_write_s that less the
# same for the command without output (MB/s from it).  The minimum over --reps
# runs (default 3) is kept: the machine may be shared.  --base IVOCT: another
# binary (e.g. the main branch's) measured the same way, interleaved run by run
# in alternating order, so both see the same load; it opens the VTK and OpenVDB
# modules of its own build (IVOCT/../lib/ivoct/, where they are: a binary run from
# outside its build tree would otherwise open this build's).  Also the command's CPU time
# (user + sys, min over the runs) and the writer's share of it, cpu_s less that
# of the same command without output: with --threads 1 the least load-dependent
# number; and its peak resident size.  Writes bench/results/writers.csv (binary,
# surface, output, bytes, build_s, write_s, net_write_s, mb_per_s, cpu_s,
# write_cpu_s, peak_mb) and prints it as a
# table, with `uptime` before and after.  Default: gumdrop at depth 9; --quick:
# depth 7, 1 run.
#
# --same-values: no timing; every scenes/*.ini (or --surfaces) at depth 6, with the scene's chain
# and with every test and --refine 0.01, written by both binaries: the CSV and
# .ivo must be byte-identical (the .ivo but for its version and checksum: ivo_payload),
# the .vtu/.htg hold the same data bit for bit (tests/same_vtk.py: whatever the compressor),
# the .vdb byte-identical but for OpenVDB's random UUID (a --vdb that fails in both is
# skipped).  Exit 1 if any differs.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/.." && pwd)
build=$root/build/release
base=""
depth=9
reps=3
threads=""
surfaces="gumdrop"
outputs="cells save vtu htg vdb"
same=0
surfaces_given=0
while [ $# -gt 0 ]; do
    case $1 in
    --build) build=$2; shift ;;
    --base) base=$(realpath "$2"); shift ;;
    --depth) depth=$2; shift ;;
    --reps) reps=$2; shift ;;
    --threads) threads=$2; shift ;;
    --surfaces) surfaces=$2 surfaces_given=1; shift ;;
    --outputs) outputs=$2; shift ;;
    --quick) depth=7 reps=1 ;;
    --same-values) same=1 ;;
    -h | --help) sed -n '2,31p' "$0"; exit 0 ;;
    *) echo "bench/writers.sh: unknown option $1" >&2; exit 2 ;;
    esac
    shift
done
new=${IVOCT_BIN:-$build/cli/ivoct}
# side_cmd a|b: into cmd, this build's ivoct (a), or the base (b) with its own modules
side_cmd() {
    if [ "$1" = a ]; then
        cmd=("$new")
        return
    fi
    local lib
    lib=$(dirname "$base")/../lib/ivoct
    cmd=(env)
    [ -e "$lib/libivoct_vtk.so" ] && cmd+=("IVOCT_VTK_MODULE=$lib/libivoct_vtk.so")
    [ -e "$lib/libivoct_openvdb.so" ] && cmd+=("IVOCT_OPENVDB_MODULE=$lib/libivoct_openvdb.so")
    cmd+=("$base")
}
mkdir -p "$root/bench/results"
out=$root/bench/results/writers.csv
work=$(mktemp -d /tmp/ivoct-writers.XXXXXX)
trap 'rm -rf "$work"' EXIT
# An .ivo without its checksum, its version as its layout (tests/ivo_payload.py).
ivo_payload() { /usr/bin/python3 "$root/tests/ivo_payload.py" "$1"; }
if [ "$same" = 1 ]; then
    [ -n "$base" ] || { echo "bench/writers.sh: --same-values needs --base IVOCT" >&2; exit 2; }
    strip_uuid() { perl -0777 -pe 's/[0-9a-f]{8}-[0-9a-f]{4}-[0-9a-f]{4}-[0-9a-f]{4}-[0-9a-f]{12}/UUID/' "$1"; }
    n=0 bad=0
    list=("$root"/scenes/*.ini)
    if [ "$surfaces_given" = 1 ]; then
        list=()
        for s in $surfaces; do list+=("$root/scenes/$s.ini"); done
    fi
    for scene in "${list[@]}"; do
        name=$(basename "$scene" .ini)
        for v in chain slabs; do
            opts=()
            [ $v = slabs ] && opts=(--tests interval,lipschitz,ilie --refine 0.01)
            for side in a b; do
                side_cmd $side
                "${cmd[@]}" build "$scene" --depth 6 --quiet "${opts[@]}" --save "$work/$side.ivo" \
                    --cells "$work/$side.csv" --vtu "$work/$side.vtu" --htg "$work/$side.htg"
                "${cmd[@]}" build "$scene" --depth 6 --quiet "${opts[@]}" --vdb "$work/$side.vdb" \
                    2>/dev/null || rm -f "$work/$side.vdb"
            done
            differ() { echo "differ: $name ($v) .$1"; bad=$((bad + 1)); }
            n=$((n + 2))
            cmp -s "$work/a.csv" "$work/b.csv" || differ csv
            cmp -s <(ivo_payload "$work/a.ivo") <(ivo_payload "$work/b.ivo") || differ ivo
            for f in vtu htg; do
                n=$((n + 1))
                /usr/bin/python3 "$root/tests/same_vtk.py" "$work/a.$f" "$work/b.$f" || differ $f
            done
            if [ -e "$work/a.vdb" ] || [ -e "$work/b.vdb" ]; then
                n=$((n + 1))
                cmp -s <(strip_uuid "$work/a.vdb") <(strip_uuid "$work/b.vdb") || differ vdb
            fi
            rm -f "$work"/a.* "$work"/b.*
        done
    done
    echo "$n files compared, $bad differ"
    [ "$bad" = 0 ]
    exit
fi

bins=(new)
[ -n "$base" ] && bins+=(base)
thr=()
[ -n "$threads" ] && thr=(--threads "$threads")

echo "load before: $(uptime)"
echo "binary,surface,output,bytes,build_s,write_s,net_write_s,mb_per_s,cpu_s,write_cpu_s,peak_mb" > "$out"
declare -A none_c=() none_w=()
for s in $surfaces; do
    scene=$root/scenes/$s.ini
    for o in none $outputs; do
        case $o in
        none) args=() file="" ;;
        cells) args=(--cells "$work/x.csv") file=$work/x.csv ;;
        save) args=(--save "$work/x.ivo") file=$work/x.ivo ;;
        vtu) args=(--vtu "$work/x.vtu") file=$work/x.vtu ;;
        htg) args=(--htg "$work/x.htg") file=$work/x.htg ;;
        vdb) args=(--vdb "$work/x.vdb") file=$work/x.vdb ;;
        esac
        declare -A best_w=() best_b=() best_c=() size=() peak=()
        for r in $(seq "$reps"); do
            # the order alternates: on a virtual machine the second of two runs
            # back to back gets the pages the first gave back, faster than fresh ones
            order=("${bins[@]}")
            [ $((r % 2)) = 0 ] && [ ${#bins[@]} = 2 ] && order=("${bins[1]}" "${bins[0]}")
            for b in "${order[@]}"; do
                if [ "$b" = base ]; then side_cmd b; else side_cmd a; fi
                t0=$(date +%s.%N)
                /usr/bin/time -f "%U %S %M" -o "$work/cpu" "${cmd[@]}" build "$scene" --depth "$depth" \
                    --quiet "${thr[@]}" --stats "$work/s.json" "${args[@]}"
                t1=$(date +%s.%N)
                c=$(awk '{print $1 + $2}' "$work/cpu")
                m=$(awk '{printf "%.0f", $3 / 1024}' "$work/cpu")
                if [ -z "${peak[$b]:-}" ] || [ "$m" -gt "${peak[$b]}" ]; then
                    peak[$b]=$m
                fi
                if [ -z "${best_c[$b]:-}" ] || /usr/bin/python3 -c "import sys; sys.exit(not $c < ${best_c[$b]})"; then
                    best_c[$b]=$c
                fi
                bt=$(/usr/bin/python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["time_s"])' \
                    "$work/s.json")
                w=$(/usr/bin/python3 -c "print(max(0.0, $t1 - $t0 - $bt))")
                if [ -z "${best_w[$b]:-}" ] || /usr/bin/python3 -c "import sys; sys.exit(not $w < ${best_w[$b]})"; then
                    best_w[$b]=$w
                fi
                if [ -z "${best_b[$b]:-}" ] || /usr/bin/python3 -c "import sys; sys.exit(not $bt < ${best_b[$b]})"; then
                    best_b[$b]=$bt
                fi
                size[$b]=0
                [ -n "$file" ] && size[$b]=$(stat -c %s "$file") && rm -f "$file"
            done
        done
        for b in "${bins[@]}"; do
            [ $o = none ] && none_w[$b]=${best_w[$b]}
            net=$(/usr/bin/python3 -c "print('%.3f' % max(0.0, ${best_w[$b]} - ${none_w[$b]}))")
            mbs=$(/usr/bin/python3 -c "w=$net; print('%.0f' % (${size[$b]} / 1e6 / w) if w > 0 and ${size[$b]} else '')")
            [ $o = none ] && none_c[$b]=${best_c[$b]} none_w[$b]=${best_w[$b]}
            wc=$(/usr/bin/python3 -c "print('%.3f' % max(0.0, ${best_c[$b]} - ${none_c[$b]}))")
            printf '%s,%s,%s,%s,%.3f,%.3f,%s,%s,%.3f,%s,%s\n' "$b" "$s" "$o" "${size[$b]}" \
                "${best_b[$b]}" "${best_w[$b]}" "$net" "$mbs" "${best_c[$b]}" "$wc" "${peak[$b]}" >> "$out"
        done
        unset best_w best_b best_c size peak
    done
done
echo "load after:  $(uptime)"
echo
column -s, -t < "$out"
