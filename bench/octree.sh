#!/usr/bin/env bash
# Octree build benchmark, with the dense-sampling baseline side by side.
#
#   bash bench/octree.sh [--quick] [--build DIR] [--cap SECONDS] [--surfaces "a b ..."]
#
# For every comparison surface and depth (full: 6..10; --quick: 6..8), in one
# interleaved run so that both sides see the same machine load:
#   ivoct build SCENE --depth D --tests {interval | interval,lipschitz} --threads {1 | 2}
#       -> time_s, cells_visited, leaves, cells/s, bytes/leaf, peak bytes (from --stats)
#   ivoct build SCENE --depth D --tests interval,ilie --refine EPS_D --threads 2
#       EPS_D = the certified max error of the uniform depth-D builds (their
#       leaf diagonal, also the resolution of sampling at depth D): the refined
#       octree at equal certified error -> time_s, leaves, max_error_bound
#   ivoct_dense SCENE --depth D --threads 2 --octree (the interval,lipschitz 2-thread tree)
#       -> time of point sampling at the (2^D+1)^3 grid corners, cells with a sign
#          change, and the cells the octree keeps that sampling drops
# To keep the full run near 10 minutes on 2 cores: an octree build whose
# predicted time (5 x its time one depth lower) exceeds --cap seconds (default
# 30) is skipped, and so are its deeper runs; interval,lipschitz runs on 1
# thread only to depth 8 (its 2-thread run is the one compared with sampling).
# Dense sampling always runs (depth 10: 1.08e9 points, 20-40 s on 2 threads).
# The CSV marks what was skipped.
#
# Outputs (bench/results/ is git-ignored):
#   bench/results/octree-STAMP.csv   one row per octree build
#   bench/results/dense-STAMP.csv    one row per dense run, with the speed-up ratios
#   bench/results/octree-STAMP.md    the summary table (also printed)
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/.." && pwd)
build_dir=$root/build/release
quick=0
cap=30
surfaces="sphere drop chubs crosscap gumdrop horned-cube mcmullen-k3 kusner-schmitt"
while [ $# -gt 0 ]; do
    case $1 in
    --quick) quick=1 ;;
    --build) build_dir=$2; shift ;;
    --cap) cap=$2; shift ;;
    --surfaces) surfaces=$2; shift ;;
    -h | --help) sed -n '2,26p' "$0"; exit 0 ;;
    *) echo "bench/octree.sh: unknown option $1" >&2; exit 2 ;;
    esac
    shift
done
IVOCT=${IVOCT_BIN:-$build_dir/cli/ivoct}
DENSE=${IVOCT_DENSE:-$build_dir/bench/ivoct_dense}
for exe in "$IVOCT" "$DENSE"; do
    [ -x "$exe" ] || { echo "bench/octree.sh: $exe not built (make build, or --build DIR)" >&2; exit 2; }
done
if [ $quick = 1 ]; then depths="6 7 8"; else depths="6 7 8 9 10"; fi
PY=/usr/bin/python3

results=$root/bench/results
mkdir -p "$results"
stamp=$(date +%Y%m%d-%H%M%S)
ocsv=$results/octree-$stamp.csv
dcsv=$results/dense-$stamp.csv
md=$results/octree-$stamp.md
work=$(mktemp -d /tmp/ivoct-bench.XXXXXX)
trap 'rm -rf "$work"' EXIT

echo "surface,depth,tests,threads,time_s,cells_visited,leaves,cells_per_s,bytes_per_leaf,peak_bytes,max_error_bound,status" >"$ocsv"
echo "surface,depth,threads,points,dense_time_s,dense_cells,octree_cells,octree_only,octree_only_surface,dense_only,octree_interval_time_s,octree_lipschitz_time_s,octree_refine_time_s,speedup_interval,speedup_lipschitz,speedup_refine,refine_eps,refine_leaves,refine_max_error,status" >"$dcsv"

load() { cut -d' ' -f1-3 /proc/loadavg; }
echo "octree benchmark: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), load $(load)"
echo "  ivoct: $IVOCT"
echo "  depths: $depths; surfaces: $surfaces; cap ${cap}s per run"
t_start=$(date +%s)

# previous time per configuration, for the cap: prev[surface/tests/threads]
declare -A prev

# predicted_ok KEY GROWTH: 0 when the run is expected within the cap (its time one
# depth lower times GROWTH: an octree's cells follow the surface, about 4x per level)
predicted_ok() {
    local p=${prev[$1]:-0}
    "$PY" -c "import sys; sys.exit(0 if $2 * float('$p') <= float('$cap') else 1)"
}

json() { "$PY" -c "import json,sys; d=json.load(open(sys.argv[1])); print(${2})" "$1"; }

# the CSV fields of one build from its --stats file (the octree CSV's columns)
stats_row() {
    json "$1" "','.join(repr(x) for x in [d['time_s'], d['cells_visited'], d['leaves'], d['cells_visited'] / max(d['time_s'], 1e-9), d['bytes_per_leaf'], d['peak_bytes'], d['max_error_bound']])"
}

for d in $depths; do
    for s in $surfaces; do
        scene=$root/scenes/$s.ini
        declare -A t2=()
        eps=
        for tests in interval interval,lipschitz; do
            for th in 1 2; do
                key=$s/$tests/$th
                if [ "$tests" = interval,lipschitz ] && [ $th = 1 ] && [ "$d" -gt 8 ]; then
                    echo "$s,$d,\"$tests\",$th,,,,,,,,not run (1 thread only to depth 8)" >>"$ocsv"
                    continue
                fi
                if [ "${prev[$key]:-}" = skipped ] || ! predicted_ok "$key" 5; then
                    prev[$key]=skipped
                    echo "$s,$d,\"$tests\",$th,,,,,,,,skipped (predicted > ${cap}s)" >>"$ocsv"
                    continue
                fi
                save=()
                [ "$tests" = interval,lipschitz ] && [ $th = 2 ] && save=(--save "$work/tree.ivo")
                "$IVOCT" build "$scene" --depth "$d" --tests "$tests" --threads "$th" --quiet \
                    --stats "$work/st.json" "${save[@]}"
                row=$(stats_row "$work/st.json")
                echo "$s,$d,\"$tests\",$th,$row,ok" >>"$ocsv"
                time_s=${row%%,*}
                eps=${row##*,} # the uniform octree's certified error: its leaf diagonal
                prev[$key]=$time_s
                [ $th = 2 ] && t2[$tests]=$time_s
                printf '  %-15s depth %2d  %-18s %d thread(s): %8.3f s\n' "$s" "$d" "$tests" "$th" "$time_s"
            done
        done
        # the refined octree at the certified error of the uniform ones (all
        # uniform builds of a depth share it; none ran: no comparison)
        tr= rleaves= rerr=
        if [ -n "$eps" ] && [ "${prev[$s/refine]:-}" != skipped ] && predicted_ok "$s/refine" 5; then
            "$IVOCT" build "$scene" --depth "$d" --tests interval,ilie --refine "$eps" --threads 2 \
                --quiet --stats "$work/st.json"
            row=$(stats_row "$work/st.json")
            echo "$s,$d,\"interval,ilie refine $eps\",2,$row,ok" >>"$ocsv"
            IFS=, read -r tr _ rleaves _ _ _ rerr <<<"$row"
            prev[$s/refine]=$tr
            printf '  %-15s depth %2d  interval,ilie --refine %.3g, 2 threads: %8.3f s\n' "$s" "$d" "$eps" "$tr"
        else
            prev[$s/refine]=skipped
        fi
        # the dense baseline, right after the octrees of the same surface and depth
        # compared with the interval,lipschitz tree when it was built at this depth
        cmp_args=()
        [ -f "$work/tree.ivo" ] && cmp_args=(--octree "$work/tree.ivo")
        "$DENSE" "$scene" --depth "$d" --threads 2 "${cmp_args[@]}" >"$work/dense.json"
        rm -f "$work/tree.ivo"
        ti=${t2[interval]:-}
        tl=${t2[interval,lipschitz]:-}
        row=$(json "$work/dense.json" "','.join(str(d.get(k, '')) for k in ['points', 'dense_time_s', 'dense_cells', 'octree_cells', 'octree_only', 'octree_only_surface', 'dense_only'])")
        dt=$(json "$work/dense.json" "d['dense_time_s']")
        ratios=$("$PY" -c "
import sys
dt = float(sys.argv[1])
r = [('%.3f' % (dt / float(t)) if t else '') for t in sys.argv[2:]]
print(','.join(r))" "$dt" "$ti" "$tl" "$tr")
        echo "$s,$d,2,$row,$ti,$tl,$tr,$ratios,$eps,$rleaves,$rerr,ok" >>"$dcsv"
        printf '  %-15s depth %2d  dense sampling     2 threads: %8.3f s  (octree/dense speed-up: %s)\n' "$s" "$d" "$dt" "$ratios"
    done
done
t_end=$(date +%s)
echo "total $((t_end - t_start)) s, load $(load)"

"$PY" - "$ocsv" "$dcsv" "$md" "$quick" "$((t_end - t_start))" "$(load)" <<'EOF'
import csv, sys
ocsv, dcsv, md, quick, total, load = sys.argv[1:7]
oct_rows = list(csv.DictReader(open(ocsv)))
dense_rows = list(csv.DictReader(open(dcsv)))
out = []
def p(s=""):
    out.append(s)
p("Octree builds: time (s) and cells visited per second, per thread count; storage per leaf.")
p()
p("| surface | depth | tests | cells visited | leaves | 1 thread (s) | 2 threads (s) | 2 vs 1 | M cells/s (1 thread) | bytes/leaf |")
p("|---|---:|---|---:|---:|---:|---:|---:|---:|---:|")
key = lambda r: (r["surface"], int(r["depth"]), r["tests"])
groups = {}
for r in oct_rows:
    groups.setdefault(key(r), {})[r["threads"]] = r
for (s, d, t), g in groups.items():
    r1, r2 = g.get("1"), g.get("2")
    ok1 = r1 and r1["status"] == "ok"
    ok2 = r2 and r2["status"] == "ok"
    base = r1 if ok1 else r2 if ok2 else None
    if base is None:
        p(f"| {s} | {d} | {t} | skipped | | | | | | |")
        continue
    t1 = float(r1["time_s"]) if ok1 else None
    t2 = float(r2["time_s"]) if ok2 else None
    sp = f"{t1 / t2:.2f}x" if t1 and t2 else ""
    mcs = f"{float(r1['cells_per_s']) / 1e6:.2f}" if ok1 else ""
    fmt = lambda x: f"{x:.3f}" if x is not None else "-"
    p(f"| {s} | {d} | {t} | {int(base['cells_visited']):,} | {int(base['leaves']):,} | "
      f"{fmt(t1)} | {fmt(t2)} | {sp} | {mcs} | {float(base['bytes_per_leaf']):.1f} |")
p()
p("Dense sampling at the (2^d+1)^3 corners (2 threads) against the octree (2 threads):")
p()
p("| surface | depth | points | dense (s) | octree interval (s) | octree interval,lipschitz (s) | speed-up interval | speed-up i+l | sign-change cells | octree cells (i+l) | kept by octree, dropped by sampling | of which surface (5^3 sampling) | sign change, not in octree |")
p("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
f3 = lambda x: f"{float(x):.3f}" if x else "-"
n = lambda x: f"{int(x):,}" if x else "-"
for r in dense_rows:
    if r["status"] != "ok":
        p(f"| {r['surface']} | {r['depth']} | skipped | | | | | | | | | | |")
        continue
    p(f"| {r['surface']} | {r['depth']} | {float(r['points']):.3g} | {f3(r['dense_time_s'])} | "
      f"{f3(r['octree_interval_time_s'])} | {f3(r['octree_lipschitz_time_s'])} | "
      f"{r['speedup_interval'] or '-'} | {r['speedup_lipschitz'] or '-'} | {n(r['dense_cells'])} | "
      f"{n(r['octree_cells'])} | {n(r['octree_only'])} | {n(r['octree_only_surface'])} | {n(r['dense_only'])} |")
p()
p("At equal certified error: the refined octree (interval,ilie --refine EPS, EPS = the")
p("diagonal of a depth-d cell, the error bound of the uniform depth-d octree and the")
p("resolution of sampling at depth d) against dense sampling at depth d (2 threads each):")
p()
p("| surface | depth | EPS | dense (s) | refined octree (s) | speed-up | refined leaves | its certified max error | uniform i+l leaves |")
p("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
for r in dense_rows:
    if r["status"] != "ok":
        continue
    e = lambda x: f"{float(x):.3g}" if x else "-"
    p(f"| {r['surface']} | {r['depth']} | {e(r['refine_eps'])} | {f3(r['dense_time_s'])} | "
      f"{f3(r['octree_refine_time_s'])} | {r['speedup_refine'] or '-'} | {n(r['refine_leaves'])} | "
      f"{e(r['refine_max_error'])} | {n(r['octree_cells'])} |")
p()
p(f"Total {total} s; load average at the end {load}.")
text = "\n".join(out) + "\n"
open(md, "w").write(text)
print(text)
EOF
echo "results: $ocsv $dcsv $md"
