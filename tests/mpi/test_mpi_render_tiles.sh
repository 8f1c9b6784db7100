#!/usr/bin/env bash
# `mpirun -np N ivoct render` with fewer frames than ranks (cmd_render.c, cli/mpi.c,
# docs/cluster.md): each frame cut into parts, one per rank (the 16x16 tiles (tx, ty) with
# (tx + ty) mod N = rank), gathered on rank 0, which writes the files.
#
# For N = 1, 2, 3 (oversubscribed) on the CSG scene (its octree loaded by every rank, from
# one file and from the pieces of a build over 3 ranks (.pivo), which give the same files;
# and with a point light, whose shadow flags travel with the pixels), the
# gumdrop without an octree under several methods, and a sphere whose octree every rank
# builds: the PNG and the .vti are the single-process files (cmp), at a size whose last
# row and column of tiles are partial; the stats' sums are the single render's, the
# ranks' rays add up to the rays, the bytes gathered are the other ranks' pixels (86 a
# pixel with --vti, 3 with --png alone, none with --stats alone).  Two frames over three
# ranks: both split, both the single files.  Failures: a missing folder (every rank),
# --png /dev/full (rank 0 alone fails, after the gather) and a missing --octree on rank 1
# alone: one message, the same status on every rank (each rank's recorded by a wrapper),
# no file left.  The ranks run one thread each (--threads 1; the single render has all
# cores: the files do not depend on it), and under the sanitizers, where each mpirun of 3
# ranks takes ~6 s on the 2-core test machine, fewer methods and ranks.
#
# Needs IVOCT_BIN, IVOCT_SOURCE_DIR and IVOCT_MPIEXEC (mpirun), as set by ctest.
set -u

. "$(dirname "${BASH_SOURCE[0]}")/../support/cli.sh"
cli_setup mpi-render-tiles
. "$(dirname "${BASH_SOURCE[0]}")/../support/mpi.sh"
size=61x47 # 4 x 3 tiles, the last column and row partial
asan=${IVOCT_ASAN:-0}
nps="1 2 3" few=3
[ "$asan" = 1 ] && nps="2 3" few=2
# the sums of the stats (time_s and threads are not sums of work)
totals() { grep -E '"(frames|rays|hits|tangent_hits|tape_evals|segments|leaves_visited|width|height|shadow_[a-z_]+|shadowed|beams|rays_decided_by_beam)"' "$1"; }
json_key() { "$PY" -c "import json,sys; d=json.load(open(sys.argv[1])); print(eval('d'+sys.argv[2]))" "$1" "$2"; }

# mpi_figures TAG NP JSON BYTES_A_PIXEL: the "mpi" object of a split render
mpi_figures() {
    local tag=$1 np=$2 json=$3 bpp=$4 why
    why=$("$PY" - "$json" "$np" "$bpp" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
np_, bpp = int(sys.argv[2]), int(sys.argv[3])
m = d.get("mpi")
if m is None:
    print("no mpi object"); sys.exit()
rays = m["rank_rays"]
checks = [
    (m["ranks"] == np_, "ranks %s" % m["ranks"]),
    (m["split"] == "tiles", "split %s" % m["split"]),
    (len(m["rank_time_s"]) == np_ and len(rays) == np_ and len(m["rank_tape_evals"]) == np_,
     "per-rank lists of %d, %d, %d" % (len(m["rank_time_s"]), len(rays), len(m["rank_tape_evals"]))),
    (sum(rays) == d["rays"] == d["width"] * d["height"] * d["frames"],
     "rank_rays add up to %d, rays %d" % (sum(rays), d["rays"])),
    (sum(m["rank_tape_evals"]) == d["tape_evals"], "rank_tape_evals do not add up"),
    (all(r > 0 for r in rays), "a rank without rays: %s" % rays),
    (m["balance"] >= 1, "balance %s" % m["balance"]),
    (m["gather_bytes"] == (d["rays"] - rays[0]) * bpp,
     "gather_bytes %d, expected %d" % (m["gather_bytes"], (d["rays"] - rays[0]) * bpp)),
]
print("; ".join(w for ok, w in checks if not ok))
PY
)
    [ -z "$why" ] && ok || fail "$tag, $np ranks: mpi figures: $why"
}

W=$TMP/w
mkdir -p "$W"
# compare TAG "NPS" ARGS...: render ARGS once alone and over each N of NPS, with --png,
# --vti and --stats; the files must be the single ones
compare() {
    local tag=$1 nps=$2
    shift 2
    run 0 "$tag: single" -- render "$@" --size $size --png "$W/one.png" --vti "$W/one.vti" \
        --stats "$W/one.json" --quiet || return
    local np
    for np in $nps; do
        rm -f "$W"/m.*
        mpirun_ivoct $np 0 "$tag: $np ranks" -- render "$@" --threads 1 --size $size --png "$W/m.png" \
            --vti "$W/m.vti" --stats "$W/m.json" --quiet || continue
        cmp -s "$W/one.png" "$W/m.png" && ok || fail "$tag, $np ranks: the PNG differs"
        cmp -s "$W/one.vti" "$W/m.vti" && ok || fail "$tag, $np ranks: the .vti differs"
        diff <(totals "$W/one.json") <(totals "$W/m.json") >/dev/null && ok ||
            fail "$tag, $np ranks: the stats' sums differ: $(diff <(totals "$W/one.json") <(totals "$W/m.json") | tr '\n' ' ')"
        [ "$np" -gt 1 ] && mpi_figures "$tag" $np "$W/m.json" 86
    done
}

# the CSG scene, its octree (shallow: the render is what is tested) loaded by every rank
run 0 "csg: octree" -- build "$SCENES/csg-64-spheres.ini" --depth 6 --save "$W/csg.ivo" --quiet
compare "csg" "$nps" "$SCENES/csg-64-spheres.ini" --octree "$W/csg.ivo"
cp "$W/one.png" "$W/csg-ivo.png" && cp "$W/one.vti" "$W/csg-ivo.vti"
# the same octree saved in pieces by a build over 3 ranks (--save F.pivo): every rank reads
# the index and puts the pieces together; the files are those rendered from the one file
mpirun_ivoct 3 0 "csg: octree in pieces" -- build "$SCENES/csg-64-spheres.ini" --depth 6 \
    --threads 1 --save "$W/csgp.pivo" --quiet && {
    compare "csg, octree in pieces" "$few" "$SCENES/csg-64-spheres.ini" --octree "$W/csgp.pivo"
    cmp -s "$W/one.png" "$W/csg-ivo.png" && cmp -s "$W/one.vti" "$W/csg-ivo.vti" && ok ||
        fail "csg: the render from the pieces is not the render from the one file"
}
# with a point light: the shadows travel with the pixels
compare "csg, a light" "$few" "$SCENES/csg-64-spheres.ini" --octree "$W/csg.ivo" --light 3 -4 5
# methods, without an octree
methods=(mitchell newton mrfro-newton lipschitz sampling)
[ "$asan" = 1 ] && methods=(mitchell)
for m in "${methods[@]}"; do
    compare "gumdrop --no-octree --method $m" "3" "$SCENES/gumdrop.ini" --no-octree --method $m
done
# every rank builds the octree (the scene's [octree], made shallow here)
sed 's/^depth *=.*/depth = 5/' "$SCENES/sphere.ini" >"$W/sphere5.ini"
grep -q '^depth = 5' "$W/sphere5.ini" && ok || fail "sphere5.ini has no depth line"
compare "sphere, octree built per rank" "2" "$W/sphere5.ini" --method mrfro

# two frames over three ranks: each frame split
run 0 "2 frames: single" -- render "$SCENES/csg-64-spheres.ini" --octree "$W/csg.ivo" --size $size \
    --frames 2 --png "$W/one.png" --vti "$W/one.vti" --stats "$W/one.json" --quiet
mpirun_ivoct 3 0 "2 frames, 3 ranks" -- render "$SCENES/csg-64-spheres.ini" --octree "$W/csg.ivo" \
    --threads 1 --size $size --frames 2 --png "$W/f.png" --vti "$W/f.vti" --stats "$W/f.json" --quiet && {
    for k in 0 1; do
        cmp -s "$W/one_00$k.png" "$W/f_00$k.png" && cmp -s "$W/one_00$k.vti" "$W/f_00$k.vti" && ok ||
            fail "2 frames, 3 ranks: frame $k differs"
    done
    diff <(totals "$W/one.json") <(totals "$W/f.json") >/dev/null && ok ||
        fail "2 frames, 3 ranks: the stats' sums differ"
    mpi_figures "2 frames" 3 "$W/f.json" 86
}
# what is gathered: the shaded image for a PNG alone, nothing for the stats alone
run 0 "png alone: single" -- render "$SCENES/csg-64-spheres.ini" --octree "$W/csg.ivo" --size $size \
    --png "$W/one.png" --stats "$W/one.json" --quiet
mpirun_ivoct 2 0 "png alone, 2 ranks" -- render "$SCENES/csg-64-spheres.ini" --octree "$W/csg.ivo" \
    --threads 1 --size $size --png "$W/p.png" --stats "$W/p.json" --quiet && {
    cmp -s "$W/one.png" "$W/p.png" && ok || fail "png alone, 2 ranks: the PNG differs"
    mpi_figures "png alone" 2 "$W/p.json" 3
    [ "$(json_key "$W/p.json" "['mpi']['gathered']")" = rgb ] && ok || fail "png alone: not gathered as rgb"
}
mpirun_ivoct $few 0 "stats alone, $few ranks" -- render "$SCENES/csg-64-spheres.ini" --octree "$W/csg.ivo" \
    --threads 1 --size $size --stats "$W/s.json" && {
    diff <(totals "$W/one.json") <(totals "$W/s.json") >/dev/null && ok || fail "stats alone: the sums differ"
    mpi_figures "stats alone" $few "$W/s.json" 0
    grep -q "$few ranks (each frame in tiles), balance" "$TMP/out" && ok ||
        fail "stats alone: summary line: $(cat "$TMP/out")"
}

# ---- failures: one message, the same status on every rank, nothing left --------------------
F=$TMP/f
mkdir -p "$F"
# statuses NP WANT DESCRIPTION -- ARGS: ivoct over NP ranks, each rank's exit status written
# by a wrapper that itself exits 0 (so that mpirun ends no rank early); on rank 1 the
# argument "$F/rank1-only" is replaced by "$F/missing.ivo"
statuses() {
    local np=$1 want=$2 what=$3
    shift 4
    rm -f "$TMP/status"
    "$MPIEXEC" "${mpi_args[@]}" -np "$np" bash -c '
        bin=$1 status=$2; shift 2
        if [ "$OMPI_COMM_WORLD_RANK" = 1 ]; then
            for a; do shift; [ "$a" = "'"$F"'/rank1-only" ] && a="'"$F"'/missing.ivo"; set -- "$@" "$a"; done
        fi
        "$bin" "$@"; echo "$OMPI_COMM_WORLD_RANK $?" >>"$status"; exit 0' \
        wrapper "$BIN" "$TMP/status" "$@" >"$TMP/out" 2>"$TMP/err"
    local got
    got=$(sort "$TMP/status" 2>/dev/null | tr '\n' ' ')
    local expect="" r
    for ((r = 0; r < np; r++)); do expect+="$r $want "; done
    [ "$got" = "$expect" ] && ok || { fail "$what: statuses '$got', expected '$expect'"; sed 's/^/    stderr: /' "$TMP/err" >&2; }
    local n
    n=$(ivoct_lines)
    [ "$n" -eq 1 ] && ok || { fail "$what: $n messages from ivoct, expected 1"; sed 's/^/    stderr: /' "$TMP/err" >&2; }
    left=$(ls -A "$F" | grep -v -x -e rank1-only)
    [ -z "$left" ] && ok || fail "$what: left behind: $left"
}
cp "$W/csg.ivo" "$F/rank1-only"
csg=("$SCENES/csg-64-spheres.ini" --threads 1 --size $size --quiet)
statuses $few 1 "missing folder" -- render "${csg[@]}" --octree "$W/csg.ivo" --png "$F/none/x.png" \
    --stats "$F/s.json"
grep '^ivoct' "$TMP/err" | grep -qF "none/x.png" && ok || fail "missing folder: the message does not name it"
if [ -w /dev/full ]; then
    statuses $few 1 "--png /dev/full" -- render "${csg[@]}" --octree "$W/csg.ivo" --png /dev/full \
        --vti "$F/x.vti" --stats "$F/s.json"
    grep '^ivoct' "$TMP/err" | grep -qF "No space left on device" && ok ||
        fail "--png /dev/full: the message: $(grep '^ivoct' "$TMP/err")"
else
    fail "/dev/full is not writable here"
fi
statuses $few 2 "rank 1's --octree missing" -- render "${csg[@]}" --octree "$F/rank1-only" \
    --png "$F/x.png" --vti "$F/x.vti" --stats "$F/s.json"
grep '^ivoct' "$TMP/err" | grep -qF "missing.ivo" && ok ||
    fail "rank 1's --octree missing: the message is not rank 1's: $(grep '^ivoct' "$TMP/err")"

cli_summary
