#!/usr/bin/env bash
# `ivoct render` from the outside: exit codes and one-line messages, outputs
# complete or absent (never partial), byte-identical PNG and .vti for 1 and 2
# threads, the stats JSON, the PNG and .vti contents, turntable frame names;
# the octree: built by default or loaded with --octree (same image either way,
# and the same hits and t as --no-octree), mismatched or bad .ivo files; a
# point light (--light, the scene's [render] light, --no-light): the shadow
# array and the light in the .vti, the shadow counts in the JSON, the shadows
# the same with and without the octree and for 1 and 2 threads.  (Whether the
# shadows are right is tests/test_ray_shadows.c's job, against MPFR.)  Beams:
# --no-beams gives the same PNG and .vti as the default, with and without a
# light and leaf tapes, and the stats count the beams only by default.
#
# Needs IVOCT_BIN (the CLI) and IVOCT_SOURCE_DIR (the source tree), as set by
# ctest; /usr/bin/python3 reads the JSON, PNG and .vti outputs.
set -u

. "$(dirname "${BASH_SOURCE[0]}")/support/cli.sh"
cli_setup render-cli

# no file (and no temporary) left in $TMP/out-dir
no_outputs() {
    local what=$1
    if [ -n "$(ls -A "$TMP/o" 2>/dev/null)" ]; then
        fail "$what: files left behind: $(ls -A "$TMP/o" | tr '\n' ' ')"
    else
        ok
    fi
}

S=$SCENES/sphere.ini
mkdir -p "$TMP/o"

# ---- help and usage errors -------------------------------------------------------------
if run 0 "render --help" -- render --help; then
    for m in mitchell newton newton-ah mrfro mrfro-newton lipschitz sampling --no-octree \
        --octree --method --size --threads --png --vti --frames --stats --quiet --light \
        --no-light --no-beams; do
        grep -q -- "$m" "$TMP/out" && ok || fail "render --help does not mention $m"
    done
fi
grep -q "render" <("$BIN" --help) && ok || fail "ivoct --help does not list render"

run 2 "no scene" -- render && one_line_error "no scene"
run 2 "unknown method" -- render "$S" --method newtonn --png "$TMP/o/x.png" &&
    one_line_error "unknown method" && grep -q "newtonn" "$TMP/err" && ok
for bad in 0x5 5x 5 x5 abc 100000x2 65537x4 4x65537 -3x4 5x5x5 "4x 4"; do
    run 2 "--size $bad" -- render "$S" --size "$bad" --png "$TMP/o/x.png" &&
        one_line_error "--size $bad"
done
run 2 "--threads 0" -- render "$S" --threads 0 && one_line_error "--threads 0"
run 2 "--frames 0" -- render "$S" --frames 0 && one_line_error "--frames 0"
run 2 "--frames x" -- render "$S" --frames x && one_line_error "--frames x"
run 2 "unknown option" -- render "$S" --bogus && one_line_error "unknown option"
run 2 "option without value" -- render "$S" --png && one_line_error "option without value"
run 2 "two scenes" -- render "$S" "$S" && one_line_error "two scenes"
run 2 "--octree missing file" -- render "$S" --octree "$TMP/x.ivo" --png "$TMP/o/x.png" &&
    one_line_error "--octree missing file" && grep -q "x.ivo" "$TMP/err" && ok
run 2 "--octree and --no-octree" -- render "$S" --octree a.ivo --no-octree &&
    one_line_error "--octree and --no-octree"
run 2 "missing scene file" -- render "$TMP/none.ini" --png "$TMP/o/x.png" &&
    one_line_error "missing scene file"
printf '[surface]\nf = x^2 +\nbox = -1 1 -1 1 -1 1\n' >"$TMP/bad.ini"
run 2 "bad scene" -- render "$TMP/bad.ini" --png "$TMP/o/x.png" && one_line_error "bad scene" &&
    grep -q "bad.ini:2:" "$TMP/err" && ok
printf '[surface]\nf = x\nbox = -1 1 -1 1 -1 1\n[camera]\neye = 0 0 5\ntarget = 0 0 0\nup = 0 0 1\n' \
    >"$TMP/badcam.ini"
run 2 "up parallel to the view" -- render "$TMP/badcam.ini" --png "$TMP/o/x.png" &&
    one_line_error "bad camera" && grep -q "parallel" "$TMP/err" && ok
# a depth beyond the octree's OCT_MAX_DEPTH (21) in the scene: an input error at its place
sed 's/^depth .*/depth  = 22/' "$S" >"$TMP/deep.ini"
run 2 "depth-22 scene" -- render "$TMP/deep.ini" --size 8x8 --png "$TMP/o/x.png" &&
    one_line_error "depth-22 scene" "deep.ini:9:10: " "from 0 to 21" "'22'"
run 2 "depth-22 scene, --no-octree" -- render "$TMP/deep.ini" --no-octree --size 8x8 \
    --png "$TMP/o/x.png" && one_line_error "depth-22 scene, --no-octree" "deep.ini:9:10: "
no_outputs "usage errors"

# ---- unwritable outputs: exit 1, nothing written ------------------------------------------
: >"$TMP/afile"
run 1 "unwritable --png" -- render "$S" --size 8x8 --png "$TMP/afile/x.png" --vti "$TMP/o/x.vti" &&
    one_line_error "unwritable --png"
run 1 "--png in a missing folder" -- render "$S" --size 8x8 --png "$TMP/nodir/x.png" \
    --stats "$TMP/o/s.json" && one_line_error "missing folder"
run 1 "unwritable --vti" -- render "$S" --size 8x8 --vti "$TMP/afile/x.vti" --png "$TMP/o/x.png" &&
    one_line_error "unwritable --vti"
run 1 "unwritable --stats" -- render "$S" --size 8x8 --stats "$TMP/afile/s.json" \
    --png "$TMP/o/x.png" && one_line_error "unwritable --stats"
no_outputs "unwritable outputs"
if [ -w /dev/full ]; then
    run 1 "--vti to a full device" -- render "$S" --size 8x8 --vti /dev/full --quiet &&
        one_line_error "full device"
fi
# an existing output is replaced only by a complete file
echo "old" >"$TMP/o/keep.png"
run 1 "failure keeps the old file" -- render "$S" --size 8x8 --png "$TMP/o/keep.png" \
    --vti "$TMP/afile/x.vti"
[ "$(cat "$TMP/o/keep.png")" = "old" ] && ok || fail "an existing output was touched"
rm -f "$TMP/o/keep.png"

# ---- 1 and 2 threads: identical files ------------------------------------------------------
for m in newton-ah mrfro; do
    run 0 "render 1 thread $m" -- render "$SCENES/chubs.ini" --no-octree --method $m \
        --size 40x30 --threads 1 --png "$TMP/a.png" --vti "$TMP/a.vti" --stats "$TMP/a.json" --quiet
    run 0 "render 2 threads $m" -- render "$SCENES/chubs.ini" --no-octree --method $m \
        --size 40x30 --threads 2 --png "$TMP/b.png" --vti "$TMP/b.vti" --stats "$TMP/b.json" --quiet
    cmp -s "$TMP/a.png" "$TMP/b.png" && ok || fail "$m: PNG differs between 1 and 2 threads"
    cmp -s "$TMP/a.vti" "$TMP/b.vti" && ok || fail "$m: .vti differs between 1 and 2 threads"
    [ ! -s "$TMP/out" ] && ok || fail "--quiet printed on stdout"
done

# ---- contents -------------------------------------------------------------------------------
if run 0 "render sphere" -- render "$S" --no-octree --method mitchell --size 40x30 \
    --png "$TMP/s.png" --vti "$TMP/s.vti" --stats "$TMP/s.json"; then
    [ "$(wc -l <"$TMP/out")" -eq 1 ] && ok || fail "expected a one-line summary on stdout"
    if "$PY" - "$TMP/s.json" "$TMP/s.png" "$TMP/s.vti" <<'EOF'; then ok; else fail "contents (above)"; fi
import base64, json, math, struct, sys, zlib
import xml.etree.ElementTree as ET

st = json.load(open(sys.argv[1]))
want = {"method": "mitchell", "octree": False, "width": 40, "height": 30, "rays": 1200,
        "leaves_visited": 0, "frames": 1}
for k, v in want.items():
    assert st[k] == v, (k, st[k], v)
for k in ("hits", "time_s", "tape_evals"):
    assert k in st, k
assert 0 < st["hits"] < 1200 and st["tape_evals"] > 0 and st["time_s"] >= 0

# PNG: 40x30 RGB; the centre is the lit sphere, a corner the background
b = open(sys.argv[2], "rb").read()
assert b[:8] == b"\x89PNG\r\n\x1a\n"
pos, idat, w, h = 8, b"", None, None
while pos < len(b):
    n, = struct.unpack(">I", b[pos:pos + 4]); typ = b[pos + 4:pos + 8]
    data = b[pos + 8:pos + 8 + n]; pos += 12 + n
    if typ == b"IHDR":
        w, h, depth, ctype = struct.unpack(">IIBB", data[:10])
        assert (w, h, depth, ctype) == (40, 30, 8, 2), (w, h, depth, ctype)
    elif typ == b"IDAT":
        idat += data
raw = zlib.decompress(idat)
stride = 1 + 3 * w
rows, prev = [], bytearray(3 * w)
for r in range(h):
    f, line = raw[r * stride], bytearray(raw[r * stride + 1:(r + 1) * stride])
    for i in range(len(line)):
        a = line[i - 3] if i >= 3 else 0
        up = prev[i]; c = prev[i - 3] if i >= 3 else 0
        if f == 1: line[i] = (line[i] + a) & 255
        elif f == 2: line[i] = (line[i] + up) & 255
        elif f == 3: line[i] = (line[i] + (a + up) // 2) & 255
        elif f == 4:
            p = a + up - c; pa, pb, pc = abs(p - a), abs(p - up), abs(p - c)
            line[i] = (line[i] + (a if pa <= pb and pa <= pc else up if pb <= pc else c)) & 255
    rows.append(line); prev = line
centre = rows[15][3 * 20:3 * 20 + 3]; corner = rows[0][0:3]
assert sum(centre) > 2 * sum(corner), (centre, corner)

# .vti: parses, the arrays decode to 1200 tuples, t is NaN exactly where hit is 0
root = ET.parse(sys.argv[3]).getroot()
assert root.get("type") == "ImageData" and root.get("header_type") == "UInt64"
img = root.find("ImageData")
assert img.get("WholeExtent") == "0 39 0 29 0 0"
fd = {a.get("Name"): a for a in img.find("FieldData")}
assert set(fd) == {"eye", "target", "up", "fov", "method"}, set(fd)
assert "".join(chr(int(x)) for x in fd["method"].text.split()[:-1]) == "mitchell"
arrays = {}
for a in img.find("Piece").find("PointData"):
    raw = base64.b64decode("".join(a.text.split()))
    n, = struct.unpack("<Q", raw[:8])
    comps = int(a.get("NumberOfComponents"))
    assert a.get("type") == "Float64" and n == 1200 * comps * 8 == len(raw) - 8, a.get("Name")
    arrays[a.get("Name")] = struct.unpack("<%dd" % (1200 * comps), raw[8:])
assert set(arrays) == {"t", "hit", "point", "normal", "dir"}
hits = 0
for i in range(1200):
    hit, t = arrays["hit"][i], arrays["t"][i]
    assert hit in (0.0, 1.0) and (hit == 0) == math.isnan(t)
    d = arrays["dir"][3 * i:3 * i + 3]
    assert abs(sum(x * x for x in d) - 1) < 1e-12
    if hit:
        hits += 1
        p = arrays["point"][3 * i:3 * i + 3]
        assert abs(sum(x * x for x in p) - 1) < 1e-12    # on the unit sphere
        nrm = arrays["normal"][3 * i:3 * i + 3]
        assert all(abs(nrm[k] - p[k]) < 1e-9 for k in range(3))
assert hits == st["hits"]
EOF
fi

# ---- every method, the scene's method, --size overriding the scene ------------------------
for m in mitchell newton newton-ah mrfro mrfro-newton lipschitz sampling; do
    run 0 "method $m" -- render "$SCENES/drop.ini" --no-octree --method $m --size 12x10 \
        --stats "$TMP/m.json" --quiet &&
        "$PY" -c 'import json,sys; s=json.load(open(sys.argv[1])); assert s["method"]==sys.argv[2] and s["width"]==12 and s["height"]==10 and s["certified"]==(sys.argv[2]!="sampling")' \
            "$TMP/m.json" $m && ok || fail "stats of --method $m"
done
run 0 "the scene's method" -- render "$S" --size 8x8 --stats "$TMP/m.json" --quiet &&
    "$PY" -c 'import json,sys; assert json.load(open(sys.argv[1]))["method"]=="newton-ah"' \
        "$TMP/m.json" && ok || fail "the scene's method is not used"

# ---- turntable frames ------------------------------------------------------------------------
if run 0 "--frames 3" -- render "$S" --size 16x12 --frames 3 --png "$TMP/o/f.png" \
    --vti "$TMP/o/v" --stats "$TMP/o/f.json" --quiet; then
    for k in 000 001 002; do
        [ -s "$TMP/o/f_$k.png" ] && ok || fail "missing frame f_$k.png"
        [ -s "$TMP/o/v_$k" ] && ok || fail "missing frame v_$k"
    done
    [ ! -e "$TMP/o/f.png" ] && ok || fail "--frames also wrote f.png"
    "$PY" -c 'import json,sys; s=json.load(open(sys.argv[1])); assert s["frames"]==3 and s["rays"]==3*16*12' \
        "$TMP/o/f.json" && ok || fail "stats of --frames"
    # the sphere looks the same from every side of a turntable; the directions do not
    cmp -s "$TMP/o/v_000" "$TMP/o/v_001" && fail "frames 0 and 1 are identical" || ok
    [ "$(ls "$TMP/o" | wc -l)" -eq 7 ] && ok || fail "unexpected files: $(ls "$TMP/o" | tr '\n' ' ')"
fi

# ---- the octree: built in-process (the default), or loaded with --octree ---------------------
vti_t() { # print t of a .vti, one value per line (nan on a miss)
    "$PY" - "$1" <<'EOF'
import base64, struct, sys
import xml.etree.ElementTree as ET
img = ET.parse(sys.argv[1]).getroot().find("ImageData")
for a in img.find("Piece").find("PointData"):
    if a.get("Name") == "t":
        raw = base64.b64decode("".join(a.text.split()))
        n, = struct.unpack("<Q", raw[:8])
        for v in struct.unpack("<%dd" % (n // 8), raw[8:]):
            print(repr(v))
EOF
}
# the gumdrop at depth 6: the behaviour is the same as at the scene's 8, the sanitizer
# build much faster
G=$TMP/gumdrop.ini
sed 's/^depth .*/depth  = 6/' "$SCENES/gumdrop.ini" >"$G"
rm -rf "$TMP/o" && mkdir -p "$TMP/o"
if run 0 "build --save" -- build "$G" --save "$TMP/g.ivo" --quiet; then
    for m in newton-ah lipschitz; do
        run 0 "render default octree $m" -- render "$G" --method $m --size 48x40 --threads 1 \
            --png "$TMP/d.png" --vti "$TMP/d.vti" --stats "$TMP/d.json"
        grep -q "octree depth 6" "$TMP/out" && grep -q "built in" "$TMP/out" && ok ||
            fail "summary of the built octree: $(cat "$TMP/out")"
        run 0 "render --octree $m" -- render "$G" --octree "$TMP/g.ivo" --method $m --size 48x40 \
            --threads 2 --png "$TMP/f.png" --vti "$TMP/f.vti" --stats "$TMP/f.json" --quiet
        cmp -s "$TMP/d.png" "$TMP/f.png" && ok || fail "$m: PNG of the built and the loaded octree differ"
        cmp -s "$TMP/d.vti" "$TMP/f.vti" && ok || fail "$m: .vti of the built and the loaded octree differ"
        run 0 "render --no-octree $m" -- render "$G" --no-octree --method $m --size 48x40 \
            --vti "$TMP/n.vti" --stats "$TMP/n.json" --quiet
        # same hits, t to 1e-12 relative
        paste <(vti_t "$TMP/d.vti") <(vti_t "$TMP/n.vti") | "$PY" -c '
import math, sys
bad = 0
for line in sys.stdin:
    a, b = map(float, line.split())
    if math.isnan(a) != math.isnan(b) or (not math.isnan(a) and abs(a - b) > 1e-12 * max(1, abs(a))):
        bad += 1
sys.exit(bad != 0)' && ok || fail "$m: octree and --no-octree images differ"
        "$PY" - "$TMP/d.json" "$TMP/f.json" "$TMP/n.json" "$TMP/g.ivo" <<'EOF' && ok || fail "$m: octree stats (above)"
import json, sys
d, f, n = (json.load(open(p)) for p in sys.argv[1:4])
assert d["octree"] is True and f["octree"] is True and n["octree"] is False
for s in (d, f):
    assert 0 < s["leaves_visited"] <= s["segments"] + 4 * s["hits"], s
    assert s["octree_depth"] == 6 and s["octree_leaves"] > 0
    # 48 x 40 rays are far too few for slabs to pay (ray_octree_params)
    assert s["octree_slabs"] is False, s
assert d["octree_source"] == "built" and d["build_time_s"] > 0 and d["time_s"] > 0
assert f["octree_source"] == sys.argv[4] and "build_time_s" not in f
assert n["leaves_visited"] == 0 and "build_time_s" not in n and "octree_source" not in n
assert d["hits"] == f["hits"] == n["hits"] and d["rays"] == 48 * 40
assert d["tape_evals"] < n["tape_evals"]
EOF
    done
    # from 2^19 rays on the render's own octree has slabs (ray_octree_params), the octree
    # ivoct build makes with ilie among its tests: the same image from either
    if run 0 "build --save with slabs" -- build "$G" --tests interval,lipschitz,ilie \
        --save "$TMP/gs.ivo" --quiet; then
        run 0 "render 2^19 rays" -- render "$G" --method lipschitz --size 1024x512 \
            --png "$TMP/ds.png" --stats "$TMP/ds.json" --quiet
        run 0 "render 2^19 rays, --octree" -- render "$G" --octree "$TMP/gs.ivo" \
            --method lipschitz --size 1024x512 --png "$TMP/fs.png" --stats "$TMP/fs.json" --quiet
        cmp -s "$TMP/ds.png" "$TMP/fs.png" && ok || fail "slabs: PNG of the built and the loaded octree differ"
        "$PY" - "$TMP/ds.json" "$TMP/fs.json" <<'EOF' && ok || fail "slabs: octree stats (above)"
import json, sys
d, f = (json.load(open(p)) for p in sys.argv[1:3])
assert d["octree_slabs"] is True and f["octree_slabs"] is True, (d, f)
assert d["octree_leaves"] == f["octree_leaves"] and d["hits"] == f["hits"], (d, f)
EOF
    fi
    # 1 and 2 threads with the octree: identical files
    for src in default file; do
        extra=()
        [ $src = file ] && extra=(--octree "$TMP/g.ivo")
        run 0 "octree ($src) 1 thread" -- render "$G" "${extra[@]}" --method mitchell --size 40x30 \
            --threads 1 --png "$TMP/a.png" --vti "$TMP/a.vti" --quiet
        run 0 "octree ($src) 2 threads" -- render "$G" "${extra[@]}" --method mitchell --size 40x30 \
            --threads 2 --png "$TMP/b.png" --vti "$TMP/b.vti" --quiet
        cmp -s "$TMP/a.png" "$TMP/b.png" && ok || fail "octree ($src): PNG differs between 1 and 2 threads"
        cmp -s "$TMP/a.vti" "$TMP/b.vti" && ok || fail "octree ($src): .vti differs between 1 and 2 threads"
    done
    # a turntable from one octree
    if run 0 "--octree --frames 3" -- render "$G" --octree "$TMP/g.ivo" --size 16x12 --frames 3 \
        --png "$TMP/o/g.png" --stats "$TMP/o/g.json" --quiet; then
        for k in 000 001 002; do
            [ -s "$TMP/o/g_$k.png" ] && ok || fail "missing frame g_$k.png"
        done
        "$PY" -c 'import json,sys; s=json.load(open(sys.argv[1])); assert s["frames"]==3 and s["octree"] and s["rays"]==3*16*12' \
            "$TMP/o/g.json" && ok || fail "stats of --octree --frames"
        rm -f "$TMP"/o/g_*.png "$TMP/o/g.json"
    fi
    # a saved octree from another scene, another box, or not an octree: exit 2, one line
    run 2 "--octree of another scene" -- render "$S" --octree "$TMP/g.ivo" --png "$TMP/o/x.png" &&
        one_line_error "--octree of another scene" && grep -q "was not built from" "$TMP/err" &&
        grep -q "its box" "$TMP/err" && ok
    sed 's/^f *=.*/f = 4*(x^4 + (y^2+z^2)^2) + 17*x^2*(y^2+z^2) - 20*(x^2+y^2+z^2) + 16/' "$G" >"$TMP/g2.ini"
    run 2 "--octree of another f" -- render "$TMP/g2.ini" --octree "$TMP/g.ivo" --png "$TMP/o/x.png" &&
        one_line_error "--octree of another f" && grep -q "its f" "$TMP/err" && ok
    printf 'not an octree\n' >"$TMP/bad.ivo"
    run 2 "--octree of a bad file" -- render "$G" --octree "$TMP/bad.ivo" --png "$TMP/o/x.png" &&
        one_line_error "--octree of a bad file"
    no_outputs "--octree errors"
fi

# ---- leaf tapes: a scene with min (the 64-sphere union) and one without ------------------
C=$TMP/csg.ini
sed 's/^depth .*/depth  = 6/' "$SCENES/csg-64-spheres.ini" >"$C"
for m in newton-ah mrfro; do
    run 0 "leaf tapes $m" -- render "$C" --method $m --size 48x40 --png "$TMP/lt.png" \
        --vti "$TMP/lt.vti" --stats "$TMP/lt.json" --quiet &&
        run 0 "--no-leaf-tapes $m" -- render "$C" --method $m --size 48x40 --no-leaf-tapes \
            --png "$TMP/rt.png" --vti "$TMP/rt.vti" --stats "$TMP/rt.json" --quiet || continue
    cmp -s "$TMP/lt.png" "$TMP/rt.png" && ok || fail "$m: PNG differs with and without leaf tapes"
    # same hits, t to 2^-42 relative (both certified to 2^-44)
    paste <(vti_t "$TMP/lt.vti") <(vti_t "$TMP/rt.vti") | "$PY" -c '
import math, sys
bad = 0
for line in sys.stdin:
    a, b = map(float, line.split())
    if math.isnan(a) != math.isnan(b) or (not math.isnan(a) and abs(a - b) > 2**-42 * abs(a)):
        bad += 1
sys.exit(bad != 0)' && ok || fail "$m: hits differ with and without leaf tapes"
    "$PY" - "$TMP/lt.json" "$TMP/rt.json" <<'EOF' && ok || fail "$m: leaf tape stats (above)"
import json, sys
lt, rt = (json.load(open(p)) for p in sys.argv[1:3])
assert lt["leaf_tapes"] is True and rt["leaf_tapes"] is False, (lt, rt)
assert lt["leaf_tapes_stored"] > 0 and lt["leaf_tapes_clauses"] > 0 and lt["leaf_tapes_time_s"] >= 0
assert "leaf_tapes_stored" not in rt
assert lt["hits"] == rt["hits"] > 0
EOF
done
run 0 "no choices: no leaf tapes" -- render "$S" --size 16x12 --stats "$TMP/s.json" --quiet &&
    "$PY" -c 'import json,sys; s=json.load(open(sys.argv[1])); assert s["leaf_tapes"] is False' \
        "$TMP/s.json" && ok || fail "a tape without choices got leaf tapes"
run 0 "render --help: --no-leaf-tapes" -- render --help &&
    grep -q -- "--no-leaf-tapes" "$TMP/out" && ok || fail "render --help does not mention --no-leaf-tapes"

# ---- a point light: shadows -------------------------------------------------------------
G=$SCENES/gumdrop.ini
run 2 "--light with two values" -- render "$G" --light 1 2 && one_line_error "--light 1 2"
run 2 "--light nan" -- render "$G" --light 1 2 nan --png "$TMP/o/x.png" &&
    one_line_error "--light nan"
run 2 "--light and --no-light" -- render "$G" --light 1 2 3 --no-light &&
    one_line_error "--light and --no-light"
printf '[surface]\nf = x^2 + y^2 + z^2 - 1\nbox = -2 2 -2 2 -2 2\n[render]\nlight = 5 1\n' \
    >"$TMP/badlight.ini"
run 2 "scene light with two values" -- render "$TMP/badlight.ini" --png "$TMP/o/x.png" &&
    one_line_error "scene light" "badlight.ini:5:12: "
no_outputs "light errors"
# the gumdrop at depth 6; the light up and to the right of the eye
sed 's/^depth .*/depth  = 6/' "$G" >"$TMP/g6.ini"
printf 'light = 12 -4 14\n' >>"$TMP/g6.ini"
for t in 1 2; do
    run 0 "light, octree, $t threads" -- render "$TMP/g6.ini" --size 40x36 --threads $t \
        --png "$TMP/l$t.png" --vti "$TMP/l$t.vti" --stats "$TMP/l$t.json" --quiet
done
cmp -s "$TMP/l1.png" "$TMP/l2.png" && ok || fail "light: PNG differs between 1 and 2 threads"
cmp -s "$TMP/l1.vti" "$TMP/l2.vti" && ok || fail "light: .vti differs between 1 and 2 threads"
run 0 "light, --no-octree" -- render "$TMP/g6.ini" --size 40x36 --no-octree \
    --vti "$TMP/ln.vti" --stats "$TMP/ln.json" --quiet
run 0 "--light overrides the scene's" -- render "$TMP/g6.ini" --size 40x36 --light 12 -4 14 \
    --png "$TMP/lo.png" --quiet && cmp -s "$TMP/l1.png" "$TMP/lo.png" && ok ||
    fail "--light with the scene's own light gives another image"
run 0 "--no-light" -- render "$TMP/g6.ini" --size 40x36 --no-light --png "$TMP/nl.png" \
    --vti "$TMP/nl.vti" --stats "$TMP/nl.json" --quiet
"$PY" - "$TMP/l1.json" "$TMP/l1.vti" "$TMP/ln.json" "$TMP/ln.vti" "$TMP/nl.json" "$TMP/nl.vti" \
    <<'EOF' && ok || fail "light: contents (above)"
import base64, json, math, struct, sys
import xml.etree.ElementTree as ET

def vti(path):
    img = ET.parse(path).getroot().find("ImageData")
    fd = {a.get("Name"): a.text for a in img.find("FieldData")}
    arrays = {}
    for a in img.find("Piece").find("PointData"):
        raw = base64.b64decode("".join(a.text.split()))
        n, = struct.unpack("<Q", raw[:8])
        arrays[a.get("Name")] = struct.unpack("<%dd" % (n // 8), raw[8:])
    return fd, arrays

st, (fd, ar) = json.load(open(sys.argv[1])), vti(sys.argv[2])
assert st["light"] == [12, -4, 14], st["light"]
assert [float(x) for x in fd["light"].split()] == [12, -4, 14]
assert set(ar) == {"t", "hit", "point", "normal", "dir", "shadow"}, set(ar)
sh, hit = ar["shadow"], ar["hit"]
assert all(s in (0.0, 1.0) for s in sh) and all(s == 0 for s, h in zip(sh, hit) if not h)
n_sh = int(sum(sh))
assert st["shadow_rays"] == st["hits"] == int(sum(hit)) > 0
assert n_sh == st["shadowed"] + st["shadow_undecided"] and 0 < n_sh < st["hits"], (n_sh, st)
assert 0 < st["shadow_tape_evals"] < st["tape_evals"]
# the octree and the box source: the same hits and the same shadows
stn, (_, arn) = json.load(open(sys.argv[3])), vti(sys.argv[4])
assert arn["hit"] == hit and arn["shadow"] == sh and stn["shadowed"] == st["shadowed"]
# --no-light: no shadow array, no light
stl, (fdl, arl) = json.load(open(sys.argv[5])), vti(sys.argv[6])
assert stl["light"] is None and "shadow_rays" not in stl and "light" not in fdl
assert "shadow" not in arl and arl["hit"] == hit
EOF
cmp -s "$TMP/l1.png" "$TMP/nl.png" && fail "the light does not change the image" || ok

# ---- beams: --no-beams walks ray by ray, the files are the same -------------------------
# the gumdrop with its light (g6.ini, above), every method, and the 64-sphere
# union with leaf tapes (csg.ini, above), two methods; 2 threads against 1
for m in mitchell newton newton-ah mrfro mrfro-newton lipschitz sampling; do
    for sc in g6 csg; do
        [ $sc = csg ] && [ $m != newton-ah ] && [ $m != mrfro ] && continue
        f=$TMP/$sc.ini
        run 0 "beams $sc $m" -- render "$f" --method $m --size 40x36 --threads 2 \
            --png "$TMP/bm.png" --vti "$TMP/bm.vti" --stats "$TMP/bm.json" --quiet &&
            run 0 "--no-beams $sc $m" -- render "$f" --method $m --size 40x36 --no-beams \
                --threads 1 --png "$TMP/nb.png" --vti "$TMP/nb.vti" --stats "$TMP/nb.json" \
                --quiet || continue
        cmp -s "$TMP/bm.png" "$TMP/nb.png" && ok || fail "$sc $m: PNG differs with --no-beams"
        cmp -s "$TMP/bm.vti" "$TMP/nb.vti" && ok || fail "$sc $m: .vti differs with --no-beams"
        "$PY" - "$TMP/bm.json" "$TMP/nb.json" <<'EOF' && ok || fail "$sc $m: beam stats (above)"
import json, sys
bm, nb = (json.load(open(p)) for p in sys.argv[1:3])
assert bm["beams"] > 0 and 0 < bm["rays_decided_by_beam"] <= bm["rays"] - bm["hits"], bm
assert nb["beams"] == nb["rays_decided_by_beam"] == 0, nb
for k in ("hits", "tangent_hits", "tape_evals", "segments", "leaves_visited"):
    assert bm[k] == nb[k], k
EOF
    done
done
run 0 "--no-octree: no beams" -- render "$S" --no-octree --size 16x12 --stats "$TMP/s.json" \
    --quiet && "$PY" -c 'import json,sys; s=json.load(open(sys.argv[1])); assert s["beams"] == 0' \
    "$TMP/s.json" && ok || fail "--no-octree has beams"

cli_summary
