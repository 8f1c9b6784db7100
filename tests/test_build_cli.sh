#!/usr/bin/env bash
# `ivoct build` and `ivoct info` from the outside: exit codes, messages,
# output files (complete or absent, never partial), CSV and JSON contents,
# thread-count independence of the saved tree, corrupt-file handling.
#
# Needs IVOCT_BIN (the CLI) and IVOCT_SOURCE_DIR (the source tree), as set by
# ctest; /usr/bin/python3 reads the CSV and JSON outputs.
set -u

. "$(dirname "${BASH_SOURCE[0]}")/support/cli.sh"
cli_setup build-cli

# no file matching the glob pattern(s) exists
no_files() {
    local what=$1
    shift
    local f
    for f in "$@"; do
        if [ -e "$f" ]; then
            fail "$what: $f exists"
        else
            ok
        fi
    done
}

no_temporaries() {
    local what=$1 left
    left=$(find "$TMP" -name '*.tmp.*' | head -5)
    if [ -n "$left" ]; then
        fail "$what: temporary files left behind: $left"
    else
        ok
    fi
}

# ---- usage errors: exit 2 with a message ---------------------------------------------
run 0 "--help" -- build --help && grep -q '^usage: ivoct build SCENE' "$TMP/out" \
    || fail "--help: no usage on stdout"
run 0 "-h" -- build -h
run 2 "no scene" -- build && one_line_error "no scene"
run 2 "unknown option" -- build "$SCENES/sphere.ini" --no-such-option && one_line_error "unknown option"
grep -q -- "--no-such-option" "$TMP/err" || fail "unknown option: the message does not name it"
run 2 "depth 22" -- build "$SCENES/sphere.ini" --depth 22 && one_line_error "depth 22" "0 to 21"
run 2 "depth -1" -- build "$SCENES/sphere.ini" --depth -1
run 2 "depth abc" -- build "$SCENES/sphere.ini" --depth abc
run 2 "depth 5x" -- build "$SCENES/sphere.ini" --depth 5x
run 2 "depth without value" -- build "$SCENES/sphere.ini" --depth
run 2 "threads 0" -- build "$SCENES/sphere.ini" --threads 0
run 2 "bad --tests" -- build "$SCENES/sphere.ini" --tests interval,bogus && one_line_error "bad --tests"
run 2 "empty --tests" -- build "$SCENES/sphere.ini" --tests ""
run 2 "bad --max-memory" -- build "$SCENES/sphere.ini" --max-memory lots
run 2 "two scenes" -- build "$SCENES/sphere.ini" "$SCENES/drop.ini"
run 2 "missing scene file" -- build "$TMP/no-such-scene.ini" && one_line_error "missing scene file"
grep -q "no-such-scene.ini" "$TMP/err" || fail "missing scene file: the message does not name it"

# ---- a scene error: exit 2, file:line:col -------------------------------------------
cat >"$TMP/bad.ini" <<'EOF'
[surface]
name = broken
f    = x^2 + * y
box  = -1 1  -1 1  -1 1
EOF
if run 2 "scene error" -- build "$TMP/bad.ini" --depth 3; then
    one_line_error "scene error"
    grep -Eq "bad\.ini:3:[0-9]+: " "$TMP/err" \
        || { fail "scene error: no file:line:col in '$(cat "$TMP/err")'"; }
fi
no_files "scene error" "$TMP"/*.csv

# a depth beyond the octree's OCT_MAX_DEPTH (21) in the scene: an input error at its place
sed 's/^depth .*/depth  = 22/' "$SCENES/sphere.ini" >"$TMP/deep.ini"
if run 2 "depth-22 scene" -- build "$TMP/deep.ini" --cells "$TMP/deep.csv"; then
    one_line_error "depth-22 scene" "deep.ini:9:10: " "from 0 to 21" "'22'"
fi
run 2 "depth-22 scene, --depth 3" -- build "$TMP/deep.ini" --depth 3 --quiet &&
    one_line_error "depth-22 scene, --depth 3" "deep.ini:9:10: "
no_files "depth-22 scene" "$TMP"/*.csv

# ---- the memory budget: exit 1, a clear message, no output at all ----------------------
if run 1 "--max-memory 1K" -- build "$SCENES/gumdrop.ini" --depth 6 --max-memory 1K \
    --cells "$TMP/mem.csv" --save "$TMP/mem.ivo" --stats "$TMP/mem.json"; then
    one_line_error "--max-memory 1K"
    grep -qi "memory" "$TMP/err" || fail "--max-memory 1K: the message does not say memory"
fi
no_files "--max-memory 1K" "$TMP/mem.csv" "$TMP/mem.ivo" "$TMP/mem.json"
no_temporaries "--max-memory 1K"
# a budget large enough succeeds
run 0 "--max-memory 512M" -- build "$SCENES/gumdrop.ini" --depth 5 --max-memory 512M --quiet

# ---- a full build: CSV, JSON, .ivo, info --------------------------------------------------
if run 0 "build crosscap" -- build "$SCENES/crosscap.ini" --depth 5 --threads 2 \
    --cells "$TMP/c.csv" --save "$TMP/c.ivo" --stats "$TMP/c.json"; then
    grep -q "surface leaves" "$TMP/out" || fail "build: no summary line on stdout"
    no_temporaries "build crosscap"
    if "$PY" - "$TMP/c.csv" "$TMP/c.json" "$SCENES/crosscap.ini" <<'EOF'; then ok; else fail "CSV/JSON checks (above)"; fi
import csv, json, sys
cells, stats, scene = sys.argv[1:4]
errors = []
with open(stats) as f:
    st = json.load(f)
for key in ["depth", "leaves", "leaves_by_depth", "cells_visited", "decided_by",
            "max_error_bound", "tape_clauses_evaluated", "time_s", "peak_bytes", "threads",
            "simd"]:
    if key not in st:
        errors.append("stats: no key %r" % key)
for key in ["interval", "lipschitz", "ilie", "refine"]:
    if key not in st.get("decided_by", {}):
        errors.append("stats: no decided_by.%s" % key)
if not errors:
    if st["depth"] != 5: errors.append("stats: depth %r" % st["depth"])
    if st["threads"] != 2: errors.append("stats: threads %r" % st["threads"])
    if sum(st["leaves_by_depth"]) != st["leaves"]:
        errors.append("stats: leaves_by_depth does not sum to leaves")
    d = st["decided_by"]
    decided = d["interval"] + d["lipschitz"] + d["ilie"] + d["refine"] + d.get("max_depth", st["leaves"])
    if "split" in st:
        if decided != st["cells_visited"] - st["split"]:
            errors.append("stats: decided %d != cells_visited - split %d" % (decided, st["cells_visited"] - st["split"]))
        if st["cells_visited"] != 1 + 8 * st["split"]:
            errors.append("stats: cells_visited != 1 + 8 split")
    if not (st["time_s"] >= 0 and st["peak_bytes"] > 0 and st["tape_clauses_evaluated"] > 0):
        errors.append("stats: time/peak/clauses implausible")
    if not st["max_error_bound"] > 0:
        errors.append("stats: max_error_bound %r" % st["max_error_bound"])

box = None
for line in open(scene):
    line = line.split(";")[0].strip()
    if line.startswith("box"):
        box = [float(v) for v in line.split("=")[1].split()]
with open(cells, newline="") as f:
    rows = list(csv.reader(f))
HEADER = ["x0", "x1", "y0", "y1", "z0", "z1", "depth", "f_lo", "f_hi",
          "nx", "ny", "nz", "d_lo", "d_hi", "error_bound"]
if rows[0] != HEADER:
    errors.append("csv header %r" % rows[0])
body = rows[1:]
if len(body) != st.get("leaves"):
    errors.append("csv: %d rows, stats say %r leaves" % (len(body), st.get("leaves")))
seen = set()
for r in body:
    if len(r) != len(HEADER):
        errors.append("csv: row %r" % r); break
    # without the ilie test no leaf has a slab; the error bound is the diagonal
    diag = ((float(r[1]) - float(r[0]))**2 + (float(r[3]) - float(r[2]))**2 + (float(r[5]) - float(r[4]))**2)**0.5
    if any(r[9:14]) or not (diag <= float(r[14]) <= diag * (1 + 1e-12)):
        errors.append("csv: slab/error bound %r" % r); break
    x0, x1, y0, y1, z0, z1 = map(float, r[:6]); dep = int(r[6]); flo, fhi = float(r[7]), float(r[8])
    if not (box[0] <= x0 < x1 <= box[1] and box[2] <= y0 < y1 <= box[3] and box[4] <= z0 < z1 <= box[5]):
        errors.append("csv: cell outside the box %r" % r); break
    if dep != 5 or not (flo <= 0 <= fhi):
        errors.append("csv: row %r" % r); break
    if (x0, y0, z0) in seen:
        errors.append("csv: cell twice %r" % r); break
    seen.add((x0, y0, z0))
for e in errors:
    print("  " + e, file=sys.stderr)
sys.exit(1 if errors else 0)
EOF
    leaves=$("$PY" -c 'import json,sys; print(json.load(open(sys.argv[1]))["leaves"])' "$TMP/c.json")
    if run 0 "info" -- info "$TMP/c.ivo"; then
        grep -q "^scene: *Crosscap$" "$TMP/out" || fail "info: no scene name in: $(head -3 "$TMP/out")"
        grep -q "^leaves: *$leaves$" "$TMP/out" || fail "info: no 'leaves: $leaves'"
        grep -q "^depth: *5$" "$TMP/out" || fail "info: no depth"
    fi
fi
# ---- the whole chain: ILIE slabs in the CSV, early leaves -----------------------------------
run 2 "--refine without ilie" -- build "$SCENES/gumdrop.ini" --depth 4 --refine 0.1 \
    && one_line_error "--refine without ilie"
if run 0 "build with ilie" -- build "$SCENES/gumdrop.ini" --depth 5 --threads 2 --quiet \
    --tests interval,lipschitz,ilie --refine 0.1 --cells "$TMP/i.csv" --stats "$TMP/i.json"; then
    if "$PY" - "$TMP/i.csv" "$TMP/i.json" <<'EOF'; then ok; else fail "ilie CSV checks (above)"; fi
import csv, json, sys
rows = list(csv.reader(open(sys.argv[1], newline="")))
st = json.load(open(sys.argv[2]))
errors = []
body = rows[1:]
if len(body) != st["leaves"]:
    errors.append("csv: %d rows, stats say %d leaves" % (len(body), st["leaves"]))
slabs = 0
for r in body:
    dep = int(r[6])
    diag = ((float(r[1]) - float(r[0]))**2 + (float(r[3]) - float(r[2]))**2 + (float(r[5]) - float(r[4]))**2)**0.5
    if not 0 <= dep <= 5:
        errors.append("csv: depth %r" % r); break
    if any(r[9:14]):
        slabs += 1
        n = [float(v) for v in r[9:12]]
        lo, hi, eb = float(r[12]), float(r[13]), float(r[14])
        if abs(sum(v * v for v in n) - 1) > 1e-9 or not lo <= hi or not eb >= 0:
            errors.append("csv: slab %r" % r); break
    elif not diag <= float(r[14]) <= diag * (1 + 1e-12):
        errors.append("csv: error bound of a leaf without slab %r" % r); break
    if dep < 5 and not any(r[9:14]):
        errors.append("csv: an early leaf without a slab %r" % r); break
if slabs == 0:
    errors.append("csv: no leaf has a slab")
if sum(st["leaves_by_depth"][:5]) != st["decided_by"]["refine"]:
    errors.append("stats: early leaves %r != decided_by.refine %r" % (st["leaves_by_depth"], st["decided_by"]["refine"]))
for e in errors:
    print("  " + e, file=sys.stderr)
sys.exit(1 if errors else 0)
EOF
fi

run 0 "info --help" -- info --help
run 2 "info without file" -- info
run 2 "info on a missing file" -- info "$TMP/none.ivo" && one_line_error "info on a missing file"

# ---- --quiet: nothing on stdout ------------------------------------------------------------
run 0 "--quiet" -- build "$SCENES/sphere.ini" --depth 4 --quiet
[ -s "$TMP/out" ] && fail "--quiet: output on stdout"

# ---- unwritable outputs: exit 1 --------------------------------------------------------------
run 1 "--cells /dev/full" -- build "$SCENES/sphere.ini" --depth 4 --quiet --cells /dev/full \
    && one_line_error "--cells /dev/full"
run 1 "--stats /dev/full" -- build "$SCENES/sphere.ini" --depth 4 --quiet --stats /dev/full
run 1 "--save /dev/full" -- build "$SCENES/sphere.ini" --depth 4 --quiet --save /dev/full
for opt in --cells --save --stats; do
    run 1 "$opt in a missing folder" -- build "$SCENES/sphere.ini" --depth 4 --quiet \
        "$opt" "$TMP/no-such-dir/out" && one_line_error "$opt in a missing folder"
done
no_files "missing folder" "$TMP/no-such-dir"
no_temporaries "unwritable outputs"

# ---- a symbolic link is followed: the file it names is replaced, the link stays --------------
# (renamed over, the link itself became the file: /dev/stdout, when stdout is a file)
for ext in csv vtu; do
    opt=--cells
    [ $ext = vtu ] && opt=--vtu
    run 0 "$opt plain" -- build "$SCENES/sphere.ini" --depth 4 --quiet "$opt" "$TMP/plain.$ext"
    echo old >"$TMP/target.$ext"
    ln -s "target.$ext" "$TMP/link.$ext"
    run 0 "$opt to a symbolic link" -- build "$SCENES/sphere.ini" --depth 4 --quiet "$opt" "$TMP/link.$ext"
    [ -L "$TMP/link.$ext" ] && ok || fail "$opt to a symbolic link: the link was replaced"
    cmp -s "$TMP/plain.$ext" "$TMP/target.$ext" && ok || fail "$opt to a symbolic link: its file differs"
done
# a link to the standard output, which is a file ($TMP/out): as /dev/stdout is
ln -s /proc/self/fd/1 "$TMP/stdout"
run 0 "--cells to a link to stdout" -- build "$SCENES/sphere.ini" --depth 4 --quiet --cells "$TMP/stdout"
[ -L "$TMP/stdout" ] && ok || fail "--cells to a link to stdout: the link was replaced"
cmp -s "$TMP/plain.csv" "$TMP/out" && ok || fail "--cells to a link to stdout: stdout's file differs"
no_temporaries "symbolic links"

# ---- the same tree for any thread count ----------------------------------------------------
for s in sphere csg-64-spheres thin-shell horned-cube; do
    run 0 "$s threads 1" -- build "$SCENES/$s.ini" --depth 6 --threads 1 --quiet --save "$TMP/t1.ivo" &&
    run 0 "$s threads 2" -- build "$SCENES/$s.ini" --depth 6 --threads 2 --quiet --save "$TMP/t2.ivo" &&
    { cmp -s "$TMP/t1.ivo" "$TMP/t2.ivo" && ok || fail "$s: --threads 1 and 2 give different .ivo files"; }
done
for s in csg-64-spheres gumdrop; do
    all=(--tests interval,lipschitz,ilie --refine 0.05)
    run 0 "$s ilie threads 1" -- build "$SCENES/$s.ini" --depth 6 "${all[@]}" --threads 1 --quiet --save "$TMP/t1.ivo" &&
    run 0 "$s ilie threads 2" -- build "$SCENES/$s.ini" --depth 6 "${all[@]}" --threads 2 --quiet --save "$TMP/t2.ivo" &&
    { cmp -s "$TMP/t1.ivo" "$TMP/t2.ivo" && ok || fail "$s (ilie, refine): --threads 1 and 2 give different .ivo files"; }
done

# ---- corrupt files: info exits 2 with one line ----------------------------------------------
if [ -f "$TMP/c.ivo" ]; then
    size=$(stat -c %s "$TMP/c.ivo")
    head -c $((size / 2)) "$TMP/c.ivo" >"$TMP/trunc.ivo"
    run 2 "info on a truncated file" -- info "$TMP/trunc.ivo" && one_line_error "info truncated"
    cp "$TMP/c.ivo" "$TMP/flip.ivo"
    # flip one byte in the middle of the nodes
    "$PY" -c '
import sys
p = sys.argv[1]; b = bytearray(open(p, "rb").read()); b[len(b) // 3] ^= 0x10
open(p, "wb").write(b)' "$TMP/flip.ivo"
    run 2 "info on a corrupt file" -- info "$TMP/flip.ivo" && one_line_error "info corrupt"
    : >"$TMP/empty.ivo"
    run 2 "info on an empty file" -- info "$TMP/empty.ivo" && one_line_error "info empty"
    run 2 "info on a scene file" -- info "$SCENES/sphere.ini" && one_line_error "info scene"
fi

cli_summary
