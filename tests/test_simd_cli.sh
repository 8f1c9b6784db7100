#!/usr/bin/env bash
# IVOCT_SIMD from the command line: a path forced by the environment is the
# one that runs (--version and the stats say so), an unknown or unavailable one
# is refused (exit 2, one line), and every path the CPU runs builds the same
# .ivo and renders the same image, with 1 and 2 threads.
set -u
. "$(dirname "${BASH_SOURCE[0]}")/support/cli.sh"
cli_setup simd-cli

run 0 "--version" -- --version && grep -q "^SIMD path: " "$TMP/out" && ok ||
    fail "--version: no 'SIMD path:' line: $(cat "$TMP/out")"
default=$(sed -n 's/^SIMD path: \([a-z0-9]*\).*/\1/p' "$TMP/out")
paths=$(sed -n 's/.*this build has: \(.*\))$/\1/p' "$TMP/out")
[ -n "$default" ] && [ -n "$paths" ] && ok || fail "--version: cannot read the paths"

# unknown names are refused before anything runs
IVOCT_SIMD=sse9 "$BIN" build "$SCENES/sphere.ini" --depth 3 --quiet >"$TMP/out" 2>"$TMP/err"
[ $? -eq 2 ] && ok || fail "IVOCT_SIMD=sse9: exit status not 2"
one_line_error "IVOCT_SIMD=sse9" "IVOCT_SIMD" "sse9" "portable"

available=()
for p in $paths; do
    if IVOCT_SIMD=$p "$BIN" --version >"$TMP/out" 2>"$TMP/err"; then
        grep -q "^SIMD path: $p " "$TMP/out" && ok || fail "IVOCT_SIMD=$p: --version says $(cat "$TMP/out")"
        available+=("$p")
    else
        # refused: must be a clean one-line error naming the path
        one_line_error "IVOCT_SIMD=$p (not on this CPU)" "$p"
    fi
done
echo "paths of this build: $paths; this CPU runs: ${available[*]}; default: $default"
[ "${available[0]:-}" = portable ] && ok || fail "the portable path must always run"

# same tree and image on every path and thread count; stats name the path
for scene in gumdrop csg-64-spheres thin-shell; do
    first=
    for p in "${available[@]}"; do
        for threads in 1 2; do
            out=$TMP/$scene-$p-$threads
            if ! IVOCT_SIMD=$p "$BIN" build "$SCENES/$scene.ini" --depth 6 --threads $threads --quiet \
                --save "$out.ivo" --stats "$out.json" 2>"$TMP/err"; then
                fail "$scene $p $threads: build failed: $(cat "$TMP/err")"
                continue
            fi
            grep -q "\"simd\": \"$p\"" "$out.json" && ok || fail "$scene $p: stats do not say simd $p"
            if ! IVOCT_SIMD=$p "$BIN" render "$SCENES/$scene.ini" --octree "$out.ivo" --size 64x48 \
                --threads $threads --quiet --png "$out.png" 2>"$TMP/err"; then
                fail "$scene $p $threads: render failed: $(cat "$TMP/err")"
                continue
            fi
            if [ -z "$first" ]; then
                first=$out
                continue
            fi
            cmp -s "$first.ivo" "$out.ivo" && ok || fail "$scene: .ivo of $p, $threads threads differs"
            cmp -s "$first.png" "$out.png" && ok || fail "$scene: image of $p, $threads threads differs"
        done
    done
done
cli_summary
