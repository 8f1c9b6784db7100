#!/usr/bin/env bash
# The program's malloc (cli/allocator.c): a release build links jemalloc and
# runs on the settings compiled into it (huge pages, one arena), and says so
# in --version; a build without it (the sanitizers') says it runs on the C
# library's malloc.  The library, libivoct, never links an allocator: its
# users choose theirs.
set -u
. "$(dirname "${BASH_SOURCE[0]}")/support/cli.sh"
cli_setup allocator

needed() { readelf -d "$1" 2>/dev/null | grep -c "NEEDED.*libjemalloc"; }

run 0 "--version" -- --version
line=$(grep "^malloc: " "$TMP/out")
[ -n "$line" ] && ok || fail "--version: no 'malloc:' line: $(cat "$TMP/out")"
if [ "$(needed "$BIN")" -gt 0 ]; then
    # the compiled-in settings took effect (jemalloc read them at its first allocation)
    [[ $line =~ ^malloc:\ jemalloc\ [0-9]+\.[0-9]+\.[0-9]+\ \(thp:\ always,\ arenas:\ 1\)$ ]] && ok ||
        fail "--version: expected jemalloc on huge pages with one arena, got '$line'"
    # MALLOC_CONF still adds to them, for experiments
    MALLOC_CONF=narenas:2 "$BIN" --version >"$TMP/out" 2>"$TMP/err"
    grep -q "^malloc: jemalloc .*(thp: always, arenas: 2)$" "$TMP/out" && ok ||
        fail "MALLOC_CONF=narenas:2: --version says $(grep malloc: "$TMP/out")"
    # and a build with every output runs on it
    run 0 "build with every output" -- build "$SCENES/gumdrop.ini" --depth 5 --quiet \
        --cells "$TMP/g.csv" --save "$TMP/g.ivo" --vtu "$TMP/g.vtu" --htg "$TMP/g.htg" \
        --vdb "$TMP/g.vdb" --mesh "$TMP/g.vtp"
    for f in g.csv g.ivo g.vtu g.htg g.vdb g.vtp; do
        [ -s "$TMP/$f" ] && ok || fail "build with every output: $f missing"
    done
else
    [ "$line" = "malloc: the C library's malloc" ] && ok ||
        fail "--version: a build without jemalloc says '$line'"
fi

lib=$(dirname "$BIN")/../libivoct.so
if [ -e "$lib" ]; then
    [ "$(needed "$lib")" -eq 0 ] && ok || fail "libivoct.so links jemalloc"
fi
cli_summary
