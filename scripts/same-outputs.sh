#!/usr/bin/env bash
# Do two ivoct binaries give byte-identical outputs?  For refactors that must
# not change behaviour: every scene is built with every output (.ivo, cells,
# .vtu, .htg, .vdb, stats), and again with every test and the refinement, and
# rendered with every method, with and without the octree, by both binaries; the files are compared byte for byte (the
# stats without their timing and memory keys, which vary from run to run; the .ivo
# without its version and checksum, so that binaries from before and after the
# checksum change compare: ivo_payload).
#
# Usage: scripts/same-outputs.sh IVOCT_A IVOCT_B [SCENE...]
#   (default: every scenes/*.ini; depth 6, images 96x72; WORK keeps the files;
#   RENDER_ARGS_A / RENDER_ARGS_B: extra options for one side's renders, e.g. an
#   option the other binary does not have)
# Exit 0 when every output is identical, 1 otherwise (the differing files listed).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

if [ $# -lt 2 ]; then
    sed -n '2,11p' "$0" | sed 's/^# \{0,1\}//'
    exit 2
fi
a=$(realpath "$1") b=$(realpath "$2")
shift 2
scenes=("$@")
[ ${#scenes[@]} -gt 0 ] || scenes=(scenes/*.ini)
work=${WORK:-$(mktemp -d)}
methods=(mitchell newton newton-ah mrfro mrfro-newton lipschitz sampling)

# Keys of the stats files that measure the run (or name its files) rather
# than its result, and the leaf-tape keys (written by newer binaries only).
strip_timing() {
    { grep -v -E '"(time_s|build_time_s|render_time_s|peak_bytes|threads|octree_source|leaf_tapes[a-z_]*)"' "$1" || true; } | sed 's/,$//'
}

# An OpenVDB file names itself with a random UUID in its header.
strip_uuid() {
    perl -0777 -pe 's/[0-9a-f]{8}-[0-9a-f]{4}-[0-9a-f]{4}-[0-9a-f]{4}-[0-9a-f]{12}/UUID/' "$1"
}

# Run a command; its exit status and error messages (paths made relative to
# the output folder) become outputs too: NAME.status.
run() { # DIR NAME BIN ARGS...
    local dir=$1 name=$2
    shift 2
    local rc=0
    "$@" 2> "$dir/$name.err" || rc=$?
    { echo "exit $rc"; sed "s|$dir/||g" "$dir/$name.err"; } > "$dir/$name.status"
    rm -f "$dir/$name.err"
}

run_all() { # BIN DIR EXTRA-RENDER-ARGS
    local bin=$1 dir=$2 extra=$3 s n m
    mkdir -p "$dir"
    for s in "${scenes[@]}"; do
        n=$(basename "$s" .ini)
        local build=("$bin" build "$s" --depth 6 --threads 2 --quiet)
        run "$dir" "$n.build" "${build[@]}" --save "$dir/$n.ivo" --cells "$dir/$n.csv" \
            --vtu "$dir/$n.vtu" --htg "$dir/$n.htg" --stats "$dir/$n.build.json"
        run "$dir" "$n.vdb" "${build[@]}" --vdb "$dir/$n.vdb"
        # every test of the chain, and the refinement (slabs, the normal cone)
        run "$dir" "$n.refine" "${build[@]}" --tests interval,lipschitz,ilie --refine 0.01 \
            --save "$dir/$n.refine.ivo" --cells "$dir/$n.refine.csv" \
            --stats "$dir/$n.refine.json"
        for m in "${methods[@]}"; do
            local render=("$bin" render "$s" --method "$m" --threads 2 --quiet $extra)
            run "$dir" "$n.$m" "${render[@]}" --octree "$dir/$n.ivo" --size 96x72 \
                --png "$dir/$n.$m.png" --vti "$dir/$n.$m.vti" --stats "$dir/$n.$m.json"
            run "$dir" "$n.$m.box" "${render[@]}" --no-octree --size 48x36 \
                --png "$dir/$n.$m.box.png" --stats "$dir/$n.$m.box.json"
        done
    done
}

# An .ivo without its checksum, its version as its layout (tests/ivo_payload.py).
ivo_payload() { /usr/bin/python3 tests/ivo_payload.py "$1"; }

run_all "$a" "$work/a" "${RENDER_ARGS_A:-}"
run_all "$b" "$work/b" "${RENDER_ARGS_B:-}"

differ=0 files=0
if ! cmp -s <(ls "$work/a") <(ls "$work/b"); then
    echo "the two runs wrote different sets of files:"
    diff <(ls "$work/a") <(ls "$work/b") || true
    differ=1
fi
for fa in "$work"/a/*; do
    fb="$work/b/$(basename "$fa")"
    files=$((files + 1))
    if [[ $fa == *.json ]]; then
        cmp -s <(strip_timing "$fa") <(strip_timing "$fb") && continue
    elif [[ $fa == *.ivo ]]; then
        cmp -s <(ivo_payload "$fa") <(ivo_payload "$fb") && continue
    elif [[ $fa == *.vdb ]]; then
        cmp -s <(strip_uuid "$fa") <(strip_uuid "$fb") && continue
    else
        cmp -s "$fa" "$fb" && continue
    fi
    echo "differs: $(basename "$fa")"
    differ=$((differ + 1))
done
echo "$files files compared, $differ differ (outputs in $work)"
[ "$differ" -eq 0 ]
