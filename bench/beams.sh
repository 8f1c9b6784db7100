#!/usr/bin/env bash
# What beams save: the render with and without --no-beams, in instructions.
#   bash bench/beams.sh [--build DIR] [--size WxH] [--method M] [--scenes "..."] [--out NAME]
# For each scene (default: the eight comparison surfaces and the CSG union) the octree is
# built once as ivoct render builds it (the scene's [octree] settings and ilie, ivoct
# build --save); then callgrind counts the instructions of
# `ivoct render --octree S.ivo --threads 1` at --size (default 300x300)
# with beams (the default) and with --no-beams, and at 1x1 (loading the scene and the
# octree, and the leaf tapes of a CSG scene: the same in both).  The render alone is the
# difference; wall times on a shared machine move too much to compare a few percent.
# Also checked: the PNGs with and without beams are identical.  Reported: both counts,
# their ratio, the rays decided by a beam (of all rays and of the misses) and the beam
# walks.  Writes bench/results/NAME.md (NAME defaults to beams).  Needs valgrind.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/.." && pwd)
build=${IVOCT_BUILD:-$root/build/release}
size=300x300
method=newton-ah
scenes="sphere drop chubs crosscap gumdrop horned-cube mcmullen-k3 kusner-schmitt csg-64-spheres"
name=beams
while [ $# -gt 0 ]; do
    case $1 in
    --build) build=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    --method) method=$2; shift 2 ;;
    --scenes) scenes=$2; shift 2 ;;
    --out) name=$2; shift 2 ;;
    *) echo "bench/beams.sh: unknown option $1" >&2; exit 2 ;;
    esac
done
bin=$build/cli/ivoct
[ -x "$bin" ] || { echo "bench/beams.sh: no $bin (build first, or --build DIR)" >&2; exit 2; }
command -v valgrind >/dev/null || { echo "bench/beams.sh: needs valgrind" >&2; exit 2; }
out=$root/bench/results
mkdir -p "$out"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# instructions of one ivoct command under callgrind
instr() {
    valgrind --tool=callgrind --callgrind-out-file=/dev/null "$bin" "$@" 2>&1 >/dev/null |
        sed -n 's/.*refs: *\([0-9,]*\).*/\1/p' | tr -d ,
}

{
    echo "| scene | no beams (M instr.) | beams (M instr.) | ratio | rays decided by a beam | of the misses | beam walks |"
    echo "|---|---:|---:|---:|---:|---:|---:|"
    for s in $scenes; do
        ini=$root/scenes/$s.ini
        # as ivoct render builds it for itself (ray_octree_params): the scene's tests and ilie
        "$bin" build "$ini" --tests interval,lipschitz,ilie --save "$tmp/$s.ivo" --quiet
        common=(render "$ini" --octree "$tmp/$s.ivo" --threads 1 --method "$method" --quiet)
        base=$(instr "${common[@]}" --size 1x1)
        nb=$(instr "${common[@]}" --size "$size" --no-beams --png "$tmp/nb.png")
        bm=$(instr "${common[@]}" --size "$size" --png "$tmp/bm.png" --stats "$tmp/bm.json")
        cmp -s "$tmp/nb.png" "$tmp/bm.png" || { echo "bench/beams.sh: $s: images differ" >&2; exit 1; }
        python3 - "$tmp/bm.json" "$s" "$((nb - base))" "$((bm - base))" <<'PY'
import json, sys
st, s, nb, bm = json.load(open(sys.argv[1])), sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
rays, hits, dec = st["rays"], st["hits"], st["rays_decided_by_beam"]
print(f"| {s} | {nb / 1e6:,.0f} | {bm / 1e6:,.0f} | {bm / nb:.3f} | {dec / rays:.1%} | "
      f"{dec / max(rays - hits, 1):.1%} | {st['beams']} |".replace(",", " "))
PY
    done
} | tee "$out/$name.md"
