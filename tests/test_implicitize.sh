#!/usr/bin/env bash
# Parametric scenes from the outside: `ivoct implicitize` on every scenes/param-*.ini
# with both methods (the degree each scene documents, the same f), then build, info,
# render and the exports on them as on an implicit scene; the errors (a transcendental
# coordinate at its file:line:column, a curve, a budget exceeded, an implicit scene)
# with their exit codes and no output file left behind.
#
# Needs IVOCT_BIN (the CLI) and IVOCT_SOURCE_DIR (the source tree), as set by ctest.
set -u

. "$(dirname "${BASH_SOURCE[0]}")/support/cli.sh"
cli_setup implicitize

json_field() { "$PY" -c 'import json,sys; print(json.load(open(sys.argv[1]))[sys.argv[2]])' "$@"; }

# ---- usage ----------------------------------------------------------------------------------
run 0 "--help" -- implicitize --help && grep -q '^usage: ivoct implicitize SCENE' "$TMP/out" \
    || fail "--help: no usage"
run 2 "no scene" -- implicitize && one_line_error "no scene" "missing the scene file"
run 2 "unknown method" -- implicitize "$SCENES/param-sphere.ini" --method wu-ritt \
    && one_line_error "unknown method" "wu-ritt" "resultant or groebner"
run 2 "--time-limit 0" -- implicitize "$SCENES/param-sphere.ini" --time-limit 0
run 2 "an implicit scene" -- implicitize "$SCENES/sphere.ini" \
    && one_line_error "an implicit scene" "not a parametric surface"

# ---- every parametric scene, both methods: the documented degree, one f -----------------------
# the degree of f each scene's comment gives ("degree N")
for scene in "$SCENES"/param-*.ini; do
    name=$(basename "$scene" .ini)
    want=$(grep -o -m1 'degree [0-9]*' "$scene" | cut -d' ' -f2)
    [ -n "$want" ] && ok || fail "$name: no 'degree N' in the scene's comments"
    f_first=
    for method in resultant groebner; do
        if run 0 "$name $method" -- implicitize "$scene" --method "$method" --json; then
            cp "$TMP/out" "$TMP/$name.$method.json"
            got=$(json_field "$TMP/$name.$method.json" degree)
            [ "$got" = "$want" ] && ok || fail "$name $method: degree $got, the scene says $want"
            [ "$(json_field "$TMP/$name.$method.json" method)" = "$method" ] && ok \
                || fail "$name $method: another method ran"
            f=$(json_field "$TMP/$name.$method.json" f)
            if [ -z "$f_first" ]; then
                f_first=$f
            else
                [ "$f" = "$f_first" ] && ok || fail "$name: the methods give different f: $f_first / $f"
            fi
        fi
    done
    # the text form names the same things
    run 0 "$name text" -- implicitize "$scene" &&
        grep -q "^degree: *$want$" "$TMP/out" && grep -q "^method: *resultant$" "$TMP/out" &&
        grep -q "^f: " "$TMP/out" && ok || fail "$name: text output: $(cat "$TMP/out")"
done

# ---- build, info, render, exports on a parametric scene ---------------------------------------
P=$TMP/roman
if run 0 "build param-roman" -- build "$SCENES/param-roman.ini" --depth 5 --quiet \
    --save "$P.ivo" --stats "$P.json" --cells "$P.csv" --vtu "$P.vtu"; then
    [ "$("$PY" -c 'import json,sys; print(json.load(open(sys.argv[1]))["implicitize"]["degree"])' "$P.json")" = 4 ] \
        && ok || fail "build stats: no implicitize degree 4"
    [ "$(json_field "$P.json" leaves)" -gt 0 ] && ok || fail "build param-roman: no leaves"
    if run 0 "info .ivo" -- info "$P.ivo"; then
        grep -q '^param.x: *2\*v\*(u^2 + v^2 - 1) / (1 + u^2 + v^2)^2$' "$TMP/out" &&
            grep -q '^u: *\[-4, 4\]$' "$TMP/out" && ok \
            || fail "info .ivo: no parametrization in: $(cat "$TMP/out")"
    fi
    run 0 "info .vtu" -- info "$P.vtu"
    # the saved octree is the scene's: render uses it
    run 0 "render --octree" -- render "$SCENES/param-roman.ini" --octree "$P.ivo" --size 40x30 \
        --quiet --png "$P.png" --stats "$P.render.json" && [ -s "$P.png" ] && ok \
        || fail "render param-roman: no image"
fi
# no box in the scene: the patch bounds it, and the build is the same on every run
run 0 "build param-enneper (box from the patch)" -- build "$SCENES/param-enneper.ini" --depth 4 \
    --quiet --cells "$TMP/enneper.csv" --threads 1
run 0 "build param-enneper, 2 threads" -- build "$SCENES/param-enneper.ini" --depth 4 \
    --quiet --cells "$TMP/enneper2.csv" --threads 2
cmp -s "$TMP/enneper.csv" "$TMP/enneper2.csv" && ok || fail "param-enneper: 1 and 2 threads differ"

# ---- errors ---------------------------------------------------------------------------------
cat >"$TMP/sin.ini" <<'EOF'
[surface]
param.x = u
param.y = v * (1 +
           sin(u))
param.z = u*v
box = -1 1 -1 1 -1 1
EOF
for cmd in implicitize build render; do
    run 2 "$cmd: a transcendental coordinate" -- "$cmd" "$TMP/sin.ini" \
        && one_line_error "$cmd: a transcendental coordinate" "sin.ini:4:12:" "sin"
done
cat >"$TMP/curve.ini" <<'EOF'
[surface]
param.x = u + v
param.y = (u + v)^2
param.z = (u + v)^3
box = -1 1 -1 1 -1 1
EOF
run 2 "a curve" -- implicitize "$TMP/curve.ini" && one_line_error "a curve" "curve.ini:2:11:"
run 2 "a curve, build" -- build "$TMP/curve.ini" --save "$TMP/curve.ivo" --cells "$TMP/curve.csv"
# a budget exceeded is a runtime failure: exit 1, and no output
run 1 "past the time budget" -- implicitize "$SCENES/param-enneper.ini" --time-limit 1e-9 \
    && one_line_error "past the time budget" "budget"
run 1 "past the memory budget" -- implicitize "$SCENES/param-enneper.ini" --max-memory 1k \
    && one_line_error "past the memory budget" "budget"
for f in "$TMP/curve.ivo" "$TMP/curve.csv"; do
    [ -e "$f" ] && fail "$f was written" || ok
done

cli_summary
