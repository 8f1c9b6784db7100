#!/usr/bin/env bash
# Ray casting with and without the octree, side by side in one run.
#   bash bench/ray.sh [--build DIR] [--size WxH] [--reps N] [--surfaces "sphere gumdrop"]
#                     [--methods "mitchell lipschitz"] [--tests LIST] [--out NAME]
#                     [--baseline DIR] [--no-vdb]
# For each comparison surface: the octree is built once as ivoct render builds it for
# itself, the scene's [octree] settings with ilie added to its tests (ray_octree_params:
# every scene here has the tests interval, lipschitz; ivoct build --save: the build time
# is reported apart), then for each method
# the same render (scene camera, --size, default 300x300) is timed with the saved octree
# (2 threads and 1 thread) and with --no-octree (2 threads), interleaved so both sides see
# the same machine load; each time is the best of --reps runs (default 2) of the render
# alone (the stats' time_s: no loading, no output).  --tests overrides those tests for
# the build (e.g. interval,lipschitz: leaves without slabs).  Writes
# bench/results/NAME.csv and NAME.md (a Markdown table); NAME defaults to ray.
# Then NAME-florez.md: the same one-thread times in the layout of Flórez's table
# (rows the methods, columns the surfaces; with the octree, without it, the ratio to
# Mitchell, build + render as "total"; the published Pentium 4 table beside).
# --baseline DIR: another build directory (e.g. an older commit built apart) whose
# ivoct renders the same scenes from the same saved octree on one thread, right
# after this build's renders, so both see the same load; its tables come too, with
# the speed-up (baseline time / this build's time) per cell.
# Also on one thread, in the same run: the octree render without beams (--no-beams)
# and with a point light (--light, to the side of the target: scene_light.sh), the
# share of rays a beam decided and microseconds per ray; and, unless --no-vdb, OpenVDB's
# LevelSetRayIntersector casting the same rays, once per surface (1 and 2 threads,
# best of --reps): build/release/bench/ivoct_ray_error --methods lipschitz, which also
# computes its MPFR reference (seconds per surface at 300x300, a minute at 1024x1024).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/.." && pwd)
build=${IVOCT_BUILD:-$root/build/release}
size=300x300
reps=2
surfaces="sphere drop chubs crosscap gumdrop horned-cube mcmullen-k3 kusner-schmitt"
methods="mitchell newton newton-ah mrfro mrfro-newton lipschitz sampling"
tests=interval,lipschitz,ilie
name=ray
baseline=
vdb=1
while [ $# -gt 0 ]; do
    case $1 in
    --build) build=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    --reps) reps=$2; shift 2 ;;
    --surfaces) surfaces=$2; shift 2 ;;
    --methods) methods=$2; shift 2 ;;
    --tests) tests=$2; shift 2 ;;
    --out) name=$2; shift 2 ;;
    --baseline) baseline=$2; shift 2 ;;
    --no-vdb) vdb=0; shift ;;
    *) echo "bench/ray.sh: unknown option $1" >&2; exit 2 ;;
    esac
done
bin=$build/cli/ivoct
[ -x "$bin" ] || { echo "bench/ray.sh: no $bin (build first, or --build DIR)" >&2; exit 2; }
base_bin=
if [ -n "$baseline" ]; then
    base_bin=$baseline/cli/ivoct
    [ -x "$base_bin" ] || { echo "bench/ray.sh: no $base_bin (--baseline DIR)" >&2; exit 2; }
fi
vdb_bin=$build/bench/ivoct_ray_error
if [ "$vdb" = 1 ] && [ ! -x "$vdb_bin" ]; then
    echo "bench/ray.sh: no $vdb_bin (OpenVDB or MPFR not found at build time): no OpenVDB column" >&2
    vdb=0
fi
# light_of SCENE: the light of the --light column
# shellcheck source=bench/scene_light.sh
. "$here/scene_light.sh"
out=$root/bench/results
mkdir -p "$out"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# best time_s of $reps renders with $exe; the stats of the last one stay in $tmp/r.json
exe=$bin
best() {
    local b=
    for _ in $(seq "$reps"); do
        "$exe" render "$@" --size "$size" --stats "$tmp/r.json" --quiet
        local t
        t=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["time_s"])' "$tmp/r.json")
        b=$(python3 -c 'import sys; a=sys.argv[1]; print(sys.argv[2] if not a else min(float(a), float(sys.argv[2])))' "$b" "$t")
    done
    cp "$tmp/r.json" "$tmp/last.json"
    echo "$b"
}

csv=$out/$name.csv
echo "surface,method,build_s,leaves,octree_2t_s,octree_1t_s,none_2t_s,speedup_2t,leaves_per_ray,evals_per_ray_octree,evals_per_ray_none,hits,none_1t_s,base_octree_1t_s,base_none_1t_s,no_beams_1t_s,light_1t_s,decided_by_beam,us_per_ray_1t,vdb_1t_s,vdb_2t_s" >"$csv"
echo "load average at start: $(cut -d' ' -f1-3 /proc/loadavg)" >"$out/$name.load"
for s in $surfaces; do
    scene=$root/scenes/$s.ini
    "$bin" build "$scene" --threads 2 --tests "$tests" --save "$tmp/$s.ivo" \
        --stats "$tmp/b.json" --quiet
    read -r build_s leaves < <(python3 -c 'import json,sys; b=json.load(open(sys.argv[1])); print(b["time_s"], b["leaves"])' "$tmp/b.json")
    light=$(light_of "$scene")
    v1=nan v2=nan
    # (no OpenVDB column for a scene the MPFR reference cannot take: min, max, abs)
    if [ "$vdb" = 1 ] && "$vdb_bin" --scenes "$root/scenes" --surfaces "$s" --methods lipschitz \
        --size "$size" --reps "$reps" --csv "$tmp/vdb.csv" >/dev/null 2>"$tmp/vdb.err"; then
        read -r v1 v2 < <(python3 -c '
import csv, sys
t = {r["threads"]: float(r["time_s"]) for r in csv.DictReader(open(sys.argv[1])) if r["variant"] == "openvdb"}
print(t.get("1", float("nan")), t.get("2", float("nan")))' "$tmp/vdb.csv")
    fi
    for m in $methods; do
        o2=$(best "$scene" --octree "$tmp/$s.ivo" --method "$m" --threads 2)
        cp "$tmp/last.json" "$tmp/o.json"
        o1=$(best "$scene" --octree "$tmp/$s.ivo" --method "$m" --threads 1)
        nb1=$(best "$scene" --octree "$tmp/$s.ivo" --method "$m" --threads 1 --no-beams)
        # shellcheck disable=SC2086 # the light is three numbers
        l1=$(best "$scene" --octree "$tmp/$s.ivo" --method "$m" --threads 1 --light $light)
        n2=$(best "$scene" --no-octree --method "$m" --threads 2)
        cp "$tmp/last.json" "$tmp/n.json"
        n1=$(best "$scene" --no-octree --method "$m" --threads 1)
        bo1=nan bn1=nan
        if [ -n "$base_bin" ]; then
            exe=$base_bin
            bo1=$(best "$scene" --octree "$tmp/$s.ivo" --method "$m" --threads 1)
            bn1=$(best "$scene" --no-octree --method "$m" --threads 1)
            exe=$bin
        fi
        python3 - "$tmp/o.json" "$tmp/n.json" "$s" "$m" "$build_s" "$leaves" "$o2" "$o1" "$n2" "$n1" "$bo1" "$bn1" \
            "$nb1" "$l1" "$v1" "$v2" >>"$csv" <<'EOF'
import json, sys
o, n = (json.load(open(p)) for p in sys.argv[1:3])
s, m, build_s, leaves = sys.argv[3:7]
o2, o1, n2, n1, bo1, bn1, nb1, l1, v1, v2 = map(float, sys.argv[7:17])
r = o["rays"]
print("%s,%s,%.3f,%s,%.4f,%.4f,%.4f,%.1f,%.2f,%.1f,%.1f,%d,%.4f,%.4f,%.4f,%.4f,%.4f,%.3f,%.3f,%.4f,%.4f" % (
    s, m, float(build_s), leaves, o2, o1, n2, n2 / o2, o["leaves_visited"] / r,
    o["tape_evals"] / r, n["tape_evals"] / r, o["hits"], n1, bo1, bn1, nb1, l1,
    o["rays_decided_by_beam"] / r, o1 / r * 1e6, v1, v2))
EOF
        tail -1 "$csv"
    done
done
echo "load average at end: $(cut -d' ' -f1-3 /proc/loadavg)" >>"$out/$name.load"

python3 - "$csv" >"$out/$name.md" <<'EOF'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
print("| surface | build s | method | octree 2t s | octree 1t s | none 2t s | speedup | leaves/ray | evals/ray octree | evals/ray none |")
print("|---|---:|---|---:|---:|---:|---:|---:|---:|---:|")
for r in rows:
    print("| %s | %s | %s | %.3f | %.3f | %.3f | %.1f× | %s | %s | %s |" % (
        r["surface"], r["build_s"], r["method"], float(r["octree_2t_s"]), float(r["octree_1t_s"]),
        float(r["none_2t_s"]), float(r["speedup_2t"]), r["leaves_per_ray"],
        r["evals_per_ray_octree"], r["evals_per_ray_none"]))
print()
print("One thread: with beams, without them, with a light, without the octree; OpenVDB's cast of the same rays.")
print()
print("| surface | method | octree ms | µs/ray | decided by a beam | --no-beams ms | light ms | light / none | --no-octree ms | octree speed-up | OpenVDB 1t ms | OpenVDB 2t ms | ivoct / OpenVDB |")
print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
for r in rows:
    o1, v1 = float(r["octree_1t_s"]), float(r["vdb_1t_s"])
    print("| %s | %s | %.1f | %s | %.0f %% | %.1f | %.1f | %.2f | %.1f | %.1f× | %.1f | %.1f | %.2f |" % (
        r["surface"], r["method"], 1e3 * o1, r["us_per_ray_1t"], 100 * float(r["decided_by_beam"]),
        1e3 * float(r["no_beams_1t_s"]), 1e3 * float(r["light_1t_s"]),
        float(r["light_1t_s"]) / o1, 1e3 * float(r["none_1t_s"]), float(r["none_1t_s"]) / o1,
        1e3 * v1, 1e3 * float(r["vdb_2t_s"]), o1 / v1))
EOF
python3 "$here/florez_table.py" "$csv" >"$out/$name-florez.md"
cat "$out/$name-florez.md"
cat "$out/$name.load"
echo "wrote $csv, $out/$name.md and $out/$name-florez.md"
