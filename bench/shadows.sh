#!/usr/bin/env bash
# What certified shadows cost: the same render with and without a point light.
#   bash bench/shadows.sh [--build DIR] [--size WxH] [--reps N] [--threads N]
#                         [--methods "newton-ah lipschitz"] [--scenes "..."] [--out NAME]
# For each scene (default: the eight comparison surfaces and the CSG union) the octree is
# built once (the scene's [octree] settings, ivoct build --save); then the render (scene
# camera, each method) is timed without a light and with one (--light: to the side of
# the target, as far from it as the eye, as in tests/test_ray_shadows.c),
# interleaved so both see the same load; each time is the best of --reps renders (default
# 3), the stats' time_s (the render alone). Reported: both times, their ratio, the tape
# passes of the primary rays and of the shadow rays (shadow_tape_evals: counts, not
# times, so not disturbed by the load), the shadowed and undecided hits. Writes
# bench/results/NAME.csv and NAME.md (NAME defaults to shadows).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/.." && pwd)
build=${IVOCT_BUILD:-$root/build/release}
size=300x300
reps=3
threads=1
scenes="sphere drop chubs crosscap gumdrop horned-cube mcmullen-k3 kusner-schmitt csg-64-spheres"
methods="newton-ah lipschitz"
name=shadows
while [ $# -gt 0 ]; do
    case $1 in
    --build) build=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    --reps) reps=$2; shift 2 ;;
    --threads) threads=$2; shift 2 ;;
    --methods) methods=$2; shift 2 ;;
    --scenes) scenes=$2; shift 2 ;;
    --out) name=$2; shift 2 ;;
    *) echo "bench/shadows.sh: unknown option $1" >&2; exit 2 ;;
    esac
done
bin=$build/cli/ivoct
[ -x "$bin" ] || { echo "bench/shadows.sh: no $bin (build first, or --build DIR)" >&2; exit 2; }
out=$root/bench/results
mkdir -p "$out"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# the light of a scene: target + r (0.8 right + 0.6 up), r = |eye - target|, in the camera's
# frame (right = fwd x up, up re-orthogonalised), as ray_camera_init builds it
light_of() {
    /usr/bin/python3 - "$1" <<'EOF'
import configparser, math, sys
c = configparser.ConfigParser(inline_comment_prefixes=(";", "#"), strict=False)
c.read(sys.argv[1])
v = lambda k, d: [float(x) for x in c.get("camera", k, fallback=d).split()]
eye, target, up = v("eye", ""), v("target", "0 0 0"), v("up", "0 0 1")
sub = lambda a, b: [a[i] - b[i] for i in range(3)]
cross = lambda a, b: [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
unit = lambda a: [x / math.sqrt(sum(y * y for y in a)) for x in a]
fwd = unit(sub(target, eye)); right = unit(cross(fwd, up)); vup = cross(right, fwd)
r = math.sqrt(sum(x * x for x in sub(eye, target)))
print(" ".join("%.6g" % (target[i] + r * (0.8 * right[i] + 0.6 * vup[i])) for i in range(3)))
EOF
}

field() { /usr/bin/python3 -c 'import json, sys; print(json.load(open(sys.argv[1])).get(sys.argv[2], 0))' "$1" "$2"; }
smaller() { awk -v a="$1" -v b="$2" 'BEGIN { print (b == "" || a < b) ? a : b }'; }

csv=$out/$name.csv
echo "scene,method,size,threads,light,no_light_s,light_s,ratio,primary_evals,shadow_evals,evals_ratio,hits,shadowed,undecided" >"$csv"
for s in $scenes; do
    scene=$root/scenes/$s.ini
    "$bin" build "$scene" --quiet --save "$tmp/$s.ivo"
    light=$(light_of "$scene")
    for m in $methods; do
        best0= best1=
        for ((r = 0; r < reps; r++)); do
            "$bin" render "$scene" --octree "$tmp/$s.ivo" --method "$m" --size "$size" \
                --threads "$threads" --stats "$tmp/n.json" --png "$tmp/n.png" --quiet
            # shellcheck disable=SC2086
            "$bin" render "$scene" --octree "$tmp/$s.ivo" --method "$m" --size "$size" \
                --threads "$threads" --light $light --stats "$tmp/l.json" --png "$tmp/l.png" --quiet
            best0=$(smaller "$(field "$tmp/n.json" time_s)" "$best0")
            best1=$(smaller "$(field "$tmp/l.json" time_s)" "$best1")
        done
        all=$(field "$tmp/l.json" tape_evals)
        sh=$(field "$tmp/l.json" shadow_tape_evals)
        prim=$(field "$tmp/n.json" tape_evals)
        awk -v s="$s" -v m="$m" -v sz="$size" -v th="$threads" -v L="$light" -v a="$best0" \
            -v b="$best1" -v p="$prim" -v q="$sh" -v h="$(field "$tmp/l.json" hits)" \
            -v d="$(field "$tmp/l.json" shadowed)" -v u="$(field "$tmp/l.json" shadow_undecided)" \
            'BEGIN { printf "%s,%s,%s,%s,%s,%.4f,%.4f,%.2f,%d,%d,%.2f,%d,%d,%d\n", s, m, sz, th, L, a, b, b / a, p, q, q / p, h, d, u }' >>"$csv"
        [ "$all" -gt "$sh" ] || { echo "bench/shadows.sh: $s $m: odd stats" >&2; exit 1; }
    done
done

md=$out/$name.md
{
    echo "| scene | method | no light (s) | light (s) | ratio | shadow passes / primary passes | hits | shadowed | undecided |"
    echo "|---|---|---:|---:|---:|---:|---:|---:|---:|"
    tail -n +2 "$csv" | awk -F, '{ printf "| %s | %s | %s | %s | %s | %s | %s | %s | %s |\n", $1, $2, $6, $7, $8, $11, $12, $13, $14 }'
} >"$md"
cat "$md"
