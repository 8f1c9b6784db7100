# Shared by the CLI tests (tests/*.sh): source it, then call cli_setup NAME.
# Needs IVOCT_BIN (the CLI) and IVOCT_SOURCE_DIR (the source tree), as set by ctest.

# Sets BIN, SRC, PY, SCENES, and TMP (a fresh directory removed on exit).
cli_setup() {
    BIN=${IVOCT_BIN:?IVOCT_BIN must name the ivoct binary}
    SRC=${IVOCT_SOURCE_DIR:-.}
    PY=/usr/bin/python3
    SCENES=$SRC/scenes
    TMP=$(mktemp -d "/tmp/ivoct-$1.XXXXXX")
    trap 'rm -rf "$TMP"' EXIT
    failures=0
    checks=0
}

fail() {
    echo "FAIL: $*" >&2
    failures=$((failures + 1))
}
ok() { checks=$((checks + 1)); }

# run EXPECTED_EXIT DESCRIPTION -- ARGS...: runs $BIN ARGS, stdout/stderr in $TMP/out, $TMP/err
run() {
    local want=$1 what=$2
    shift 3
    "$BIN" "$@" >"$TMP/out" 2>"$TMP/err"
    local got=$?
    if [ "$got" -ne "$want" ]; then
        fail "$what: exit $got, expected $want (ivoct $*)"
        sed 's/^/    stderr: /' "$TMP/err" >&2
        return 1
    fi
    ok
    return 0
}

# one_line_error DESCRIPTION [WORD...]: the error output is exactly one
# non-empty line, containing each WORD
one_line_error() {
    local what=$1 lines
    shift
    lines=$(wc -l <"$TMP/err")
    if [ "$lines" -ne 1 ] || [ ! -s "$TMP/err" ]; then
        fail "$what: expected a one-line message on stderr, got $lines lines"
        sed 's/^/    stderr: /' "$TMP/err" >&2
        return
    fi
    ok
    local word
    for word in "$@"; do
        grep -qF -- "$word" "$TMP/err" && ok || fail "$what: '$word' not in: $(cat "$TMP/err")"
    done
}

# The closing line, and the exit status.
cli_summary() {
    echo "$checks checks passed, $failures failed"
    [ "$failures" -eq 0 ]
}
