#!/usr/bin/env bash
# Parametric scenes: each implicitization method's time and memory, the degree and
# terms of f, and the share of the whole pipeline (implicitize + build + render) each
# step takes.  CSV in bench/results/implicitize.csv, a Markdown table on stdout.
#
#   bash bench/implicitize.sh [--build DIR] [--reps N] [--depth D] [--size WxH]
#
# implicitize: `ivoct implicitize --method M --json` (its own "seconds"), the peak RSS
# of the whole command (/usr/bin/time -f %M, which includes loading the scene); build:
# `ivoct build --threads 1 --stats` ("time_s": the octree alone); render: `ivoct
# render --octree` of the saved tree, one thread ("time_s": the rays alone).  Each time
# is the minimum of --reps runs (default 3).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/.." && pwd)
build=$root/build/release
reps=3
depth=8
size=300x300
while [ $# -gt 0 ]; do
    case $1 in
    --build) build=$2; shift ;;
    --reps) reps=$2; shift ;;
    --depth) depth=$2; shift ;;
    --size) size=$2; shift ;;
    -h | --help) sed -n '2,12p' "$0"; exit 0 ;;
    *) echo "bench/implicitize.sh: unknown option $1" >&2; exit 2 ;;
    esac
    shift
done
bin=$build/cli/ivoct
py=/usr/bin/python3
out=$root/bench/results/implicitize.csv
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$root/bench/results"
field() { "$py" -c 'import json,sys; d=json.load(open(sys.argv[1])); print(d[sys.argv[2]])' "$@"; }
minimum() { "$py" -c 'import sys; print(min(float(a) for a in sys.argv[1:]))' "$@"; }

echo "scene,method,degree,terms,removed,implicitize_s,peak_rss_kb,build_s,render_s,leaves" >"$out"
echo "| scene | method | degree | terms | removed factors | implicitize (s) | peak RSS (MB) | build depth $depth (s) | render $size (s) | implicitize share |"
echo "|---|---|---|---|---|---|---|---|---|---|"
for scene in "$root"/scenes/param-*.ini; do
    name=$(basename "$scene" .ini)
    # the octree and the render do not depend on the method: once per scene
    "$bin" build "$scene" --depth "$depth" --threads 1 --quiet --save "$tmp/t.ivo" --stats "$tmp/b.json"
    bt=()
    for r in $(seq "$reps"); do
        "$bin" build "$scene" --depth "$depth" --threads 1 --quiet --stats "$tmp/b.json"
        bt+=("$(field "$tmp/b.json" time_s)")
    done
    rt=()
    for r in $(seq "$reps"); do
        "$bin" render "$scene" --octree "$tmp/t.ivo" --size "$size" --threads 1 --quiet \
            --png "$tmp/r.png" --stats "$tmp/r.json"
        rt+=("$(field "$tmp/r.json" time_s)")
    done
    build_s=$(minimum "${bt[@]}")
    render_s=$(minimum "${rt[@]}")
    leaves=$(field "$tmp/b.json" leaves)
    for method in resultant groebner; do
        it=() rss=()
        for r in $(seq "$reps"); do
            /usr/bin/time -f %M -o "$tmp/rss" "$bin" implicitize "$scene" --method "$method" \
                --json >"$tmp/i.json"
            it+=("$(field "$tmp/i.json" seconds)")
            rss+=("$(cat "$tmp/rss")")
        done
        imp_s=$(minimum "${it[@]}")
        rss_kb=$(minimum "${rss[@]}" | cut -d. -f1)
        degree=$(field "$tmp/i.json" degree)
        terms=$(field "$tmp/i.json" terms)
        # a long factor is shown by its size (the CSV has it whole)
        removed_all=$("$py" -c 'import json,sys; print(" ".join(json.load(open(sys.argv[1]))["removed"]) or "none")' "$tmp/i.json")
        removed=$("$py" -c 'import json,sys; r=json.load(open(sys.argv[1]))["removed"]; print(", ".join(f if len(f) <= 40 else "one of %d terms" % (f.count(" + ") + f.count(" - ") + 1) for f in r) or "none")' "$tmp/i.json")
        echo "$name,$method,$degree,$terms,\"$removed_all\",$imp_s,$rss_kb,$build_s,$render_s,$leaves" >>"$out"
        "$py" - "$name" "$method" "$degree" "$terms" "$removed" "$imp_s" "$rss_kb" "$build_s" "$render_s" <<'EOF'
import sys
n, m, deg, terms, removed, i, rss, b, r = sys.argv[1:]
i, b, r = float(i), float(b), float(r)
print(f"| {n} | {m} | {deg} | {terms} | {removed} | {i:.4f} | {float(rss) / 1024:.0f} | {b:.3f} | {r:.3f} | {100 * i / (i + b + r):.1f}% |")
EOF
    done
done
echo
echo "CSV: $out"
