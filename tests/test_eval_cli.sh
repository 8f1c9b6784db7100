#!/usr/bin/env bash
# ivoct eval from the command line: output format and every kind of bad input.
# Bad input must give exit 2 and a one-line message (file:line:col for scene
# files), never a crash; the ASan build runs this too.
set -u
. "$(dirname "${BASH_SOURCE[0]}")/support/cli.sh"
cli_setup eval-cli

# bad_scene NAME EXPECTED_POSITION: the scene $TMP/bad.ini must be refused with
# exit 2 and one line "ivoct: FILE:POSITION: ..."
bad_scene() {
    local name=$1 pos=$2
    run 2 "$name" -- eval "$TMP/bad.ini" && one_line_error "$name" "ivoct: $TMP/bad.ini:$pos: "
}

# ---- good input --------------------------------------------------------------------------
run 0 "json" -- eval -e 'x^2+y^2+z^2-1' --box 0 1 0 1 0 1 --json &&
    "$PY" - "$TMP/out" <<'PYEOF' || fail "json: contents"
import json, sys
d = json.load(open(sys.argv[1]))
# the exact range is [-1, 2]; the enclosure holds it and is tight
assert d["lo"] <= -1 and d["hi"] >= 2 and d["lo"] > -1 - 1e-12 and d["hi"] < 2 + 1e-12, d
assert "grad" not in d
PYEOF
run 0 "json grad" -- eval -e 'x*y - z' --box 1 2 -1 3 0 0.5 --grad --json &&
    "$PY" - "$TMP/out" <<'PYEOF' || fail "json grad: contents"
import json, sys
d = json.load(open(sys.argv[1]))
gx, gy, gz = d["grad"]
# df/dx = y in [-1, 3], df/dy = x in [1, 2], df/dz = -1
assert gx[0] <= -1 and gx[1] >= 3 and gy[0] <= 1 and gy[1] >= 2 and gz[0] <= -1 <= gz[1], d
PYEOF
run 0 "point box" -- eval -e 'x^2 - 2' --box 1.5 1.5 0 0 0 0 --json &&
    "$PY" -c 'import json,sys; d=json.load(open(sys.argv[1])); assert d["lo"] <= 0.25 <= d["hi"] and d["hi"]-d["lo"] < 1e-15, d' "$TMP/out" ||
    fail "point box"
run 0 "empty (undefined everywhere)" -- eval -e 'sqrt(x)' --box -2 -1 0 0 0 0 --json &&
    grep -q '"empty": true' "$TMP/out" || fail "empty result not reported"
run 0 "scene" -- eval "$SCENES/gumdrop.ini" --grad && grep -q "^df/dz" "$TMP/out" || fail "scene text output"
run 0 "--help" -- eval --help

# ---- usage errors --------------------------------------------------------------------------
run 2 "no input" -- eval
run 2 "-e without --box" -- eval -e 'x'
run 2 "--box with 5 numbers" -- eval -e 'x' --box 0 1 0 1 0
run 2 "--box reversed" -- eval -e 'x' --box 1 0 0 1 0 1
run 2 "--box nan" -- eval -e 'x' --box nan 1 0 1 0 1
run 2 "--box inf" -- eval -e 'x' --box 0 inf 0 1 0 1
run 2 "unknown option" -- eval -e 'x' --box 0 1 0 1 0 1 --frobnicate
run 2 "bad expression" -- eval -e 'x +* y' --box 0 1 0 1 0 1 &&
    grep -q "1:4" "$TMP/err" || fail "bad expression: no column in '$(cat "$TMP/err")'"

# ---- bad scene files ------------------------------------------------------------------------
: >"$TMP/bad.ini"
bad_scene "empty file" "1:1"

printf '[octree]\ndepth = 5\n' >"$TMP/bad.ini"
bad_scene "missing [surface]" "1:1"

printf '[surface]\nf = x\nbox = -1 1 -1 1 -1 1\ncolour = red\n' >"$TMP/bad.ini"
bad_scene "unknown key" "4:1"

printf '[surface]\nf = x + sine(y)\nbox = -1 1 -1 1 -1 1\n' >"$TMP/bad.ini"
bad_scene "unknown function" "2:9"

printf '[surface]\nf = (x + (y*z)\nbox = -1 1 -1 1 -1 1\n' >"$TMP/bad.ini"
bad_scene "unbalanced parentheses" "2:15"

printf '[surface]\nf = x + y )\nbox = -1 1 -1 1 -1 1\n' >"$TMP/bad.ini"
bad_scene "trailing garbage" "2:11"

printf '[surface]\nf = x\nbox = 2 1 -1 1 -1 1\n' >"$TMP/bad.ini"
bad_scene "empty box" "3:7"

printf '[surface]\nf = x\nbox = nan 1 -1 1 -1 1\n' >"$TMP/bad.ini"
bad_scene "nan in the box" "3:7"

printf '[surface]\nf = x\nbox = -1 inf -1 1 -1 1\n' >"$TMP/bad.ini"
bad_scene "inf in the box" "3:10"

"$PY" -c '
import sys
n = 100000
open(sys.argv[1], "w").write("[surface]\nbox = -1 1 -1 1 -1 1\nf = " + "(" * n + "x" + ")" * n + "\n")
' "$TMP/bad.ini"
bad_scene "100000 nested parentheses" "3:1005"

"$PY" -c '
import sys
open(sys.argv[1], "w").write("[surface]\nbox = -1 1 -1 1 -1 1\nf = x" + "+x" * (5 * 1024 * 1024) + "\n")
' "$TMP/bad.ini"
bad_scene "a 10 MB line" "3:1"

run 2 "missing file" -- eval "$TMP/none.ini"

cli_summary
