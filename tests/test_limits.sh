# Resource limits on every output (cli/README.md, "Memory budget"; io/README.md):
# --max-memory covers the exports and the render as well as the build, a full device or a
# file-size limit met by any output of a command; each fails with exit 1, one line on
# stderr, and leaves no output of the command and no temporary file.
source "$IVOCT_SOURCE_DIR/tests/support/cli.sh"
cli_setup limits

no_outputs() { # WHAT: nothing at all in $TMP/o (no output, no temporary)
    local left
    left=$(find "$TMP/o" -mindepth 1 | head -5)
    [ -z "$left" ] && ok || fail "$1: files left: $left"
    rm -rf "${TMP:?}/o" && mkdir "$TMP/o"
}
mkdir "$TMP/o"
O=$TMP/o/out
G=$SCENES/gumdrop.ini

# ---- --max-memory on the exports ---------------------------------------------------------------
# At depth 6 the build needs a few MB (peak_bytes); 3 times that holds the build and the
# CSV, and none of the exports.
run 0 "depth 6, no budget" -- build "$G" --depth 6 --quiet --stats "$TMP/s.json"
peak=$("$PY" -c 'import json,sys; print(json.load(open(sys.argv[1]))["peak_bytes"])' "$TMP/s.json")
budget=$((3 * peak))
run 0 "depth 6 within $budget bytes: the build and the CSV" -- build "$G" --depth 6 --quiet \
    --max-memory "$budget" --cells "$O.csv" --stats "$O.json"
[ -s "$O.csv" ] && [ -s "$O.json" ] && ok || fail "the CSV and stats within the budget"
rm -f "$TMP/o"/*
for opt in vtu htg vdb mesh; do
    case $opt in mesh) ext=ply ;; *) ext=$opt ;; esac
    run 1 "--$opt past --max-memory $budget" -- build "$G" --depth 6 --quiet --max-memory "$budget" \
        --cells "$O.csv" --save "$O.ivo" --stats "$O.json" "--$opt" "$O.$ext" &&
        one_line_error "--$opt past the budget" "--$opt needs about" "raise --max-memory"
    no_outputs "--$opt past the budget"
done
# every export within a budget that holds them
run 0 "every export within 1G" -- build "$G" --depth 6 --quiet --max-memory 1G --cells "$O.csv" \
    --save "$O.ivo" --stats "$O.json" --vtu "$O.vtu" --htg "$O.htg" --vdb "$O.vdb" --mesh "$O.ply"
[ "$(find "$TMP/o" -mindepth 1 -size +0 | wc -l)" -eq 7 ] && ok || fail "1G: $(ls "$TMP/o")"
rm -f "$TMP/o"/*
# the issue's case: a 10 MB budget on a depth-10 export (the build itself is past it)
run 1 "10M at depth 10" -- build "$G" --depth 10 --quiet --max-memory 10M --cells "$O.csv" \
    --vtu "$O.vtu" --htg "$O.htg" && one_line_error "10M at depth 10" "memory budget" "--max-memory"
no_outputs "10M at depth 10"

# ---- --max-memory on render ----------------------------------------------------------------
S=$SCENES/sphere.ini
run 2 "render --max-memory 12Q" -- render "$S" --max-memory 12Q --png "$O.png" &&
    one_line_error "render --max-memory 12Q" "--max-memory"
# 1000x1000 pixels of buffers are ~81 MB
run 1 "render: image past the budget" -- render "$S" --size 1000x1000 --max-memory 10M --quiet \
    --png "$O.png" --stats "$O.json" && one_line_error "render: image past the budget" "image buffers" \
    "raise --max-memory"
no_outputs "render: image past the budget"
# the octree built for the render is past 1M, the image alone is not
run 1 "render: octree past the budget" -- render "$S" --size 64x64 --max-memory 1M --quiet \
    --png "$O.png" --stats "$O.json" && one_line_error "render: octree past the budget" "memory budget"
no_outputs "render: octree past the budget"
run 0 "render --no-octree within 1M" -- render "$S" --no-octree --size 64x64 --max-memory 1M \
    --quiet --png "$O.png"
[ -s "$O.png" ] && ok || fail "render --no-octree within 1M: no image"
run 0 "render --no-octree, no budget" -- render "$S" --no-octree --size 64x64 --quiet --png "$TMP/ref.png"
cmp -s "$O.png" "$TMP/ref.png" && ok || fail "the budget changed the image"
rm -f "$TMP/o"/*

# ---- a full device among several outputs -----------------------------------------------------
if [ -w /dev/full ]; then
    for opt in stats vtu htg; do
        run 1 "--$opt /dev/full beside --cells" -- build "$SCENES/sphere.ini" --depth 5 --quiet \
            --cells "$O.csv" --save "$O.ivo" "--$opt" /dev/full &&
            one_line_error "--$opt /dev/full beside --cells" "/dev/full" "No space left on device"
        no_outputs "--$opt /dev/full beside --cells"
    done
    run 1 "render --png /dev/full beside --stats" -- render "$S" --size 16x16 --quiet \
        --stats "$O.json" --vti "$O.vti" --png /dev/full &&
        one_line_error "render --png /dev/full" "/dev/full" "No space left on device"
    no_outputs "render --png /dev/full"
else
    fail "/dev/full is not writable here"
fi

# ---- a file-size limit met midway (stands for a full disk) ---------------------------------
# SIGXFSZ is left at its default: ivoct ignores it itself, so the write fails with EFBIG
# (a kill by SIGXFSZ would be exit 153 and leave the temporaries).
limited() { # KIB ARGS...: ivoct ARGS under ulimit -f KIB; RC, and $TMP/err
    local kib=$1
    shift
    (
        ulimit -f "$kib"
        exec "$BIN" "$@"
    ) >"$TMP/out" 2>"$TMP/err"
    RC=$?
}
for big in cells vtu htg save; do
    case $big in cells) ext=csv ;; save) ext=ivo ;; *) ext=$big ;; esac
    limited 64 build "$SCENES/sphere.ini" --depth 6 --quiet --stats "$O.json" "--$big" "$O.$ext"
    [ "$RC" -eq 1 ] && ok || fail "--$big past ulimit -f 64: exit $RC, expected 1"
    one_line_error "--$big past ulimit -f 64" "out.$ext" "too large"
    no_outputs "--$big past ulimit -f 64"
done
# a render whose .vti is past the limit and whose PNGs are not
limited 64 render "$S" --size 64x64 --frames 2 --quiet --png "$O.png" --vti "$O.vti" --stats "$O.json"
[ "$RC" -eq 1 ] && ok || fail "render .vti past ulimit -f 64: exit $RC, expected 1"
one_line_error "render .vti past ulimit -f 64" "out_000.vti" "too large"
no_outputs "render .vti past ulimit -f 64"

cli_summary
