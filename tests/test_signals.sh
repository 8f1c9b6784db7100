# ivoct build and render under SIGINT, SIGTERM and SIGHUP (cli/README.md, "Signals";
# io/README.md, "Commit groups"): whenever the signal comes, afterwards no temporary
# file is left, and either every output of the command exists complete (identical to an
# uninterrupted run's) or none does (or, when older files were there, all of them are
# still the old ones); the exit status is 128 + the signal's number.
#
# The signals come at named steps (IVOCT_TEST_PAUSE_AT=STEP makes the CLI stop there
# and print "ivoct: test pause at STEP": before the build, before each output, before
# the outputs are renamed into place) and at delays spread over an uninterrupted run's
# time, which land in the build and in the middle of each writer.
source "$IVOCT_SOURCE_DIR/tests/support/cli.sh"
cli_setup signals

# A background job of a non-interactive shell starts with SIGINT ignored (and ivoct
# keeps a signal ignored that it was started ignoring, like nohup's SIGHUP): the
# children are started through this, with the three signals at their defaults.
# shellcheck disable=SC2016
RESET='import os, signal, sys
for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP, signal.SIGPIPE):
    signal.signal(s, signal.SIG_DFL)
for s in sys.argv[1].split(","):
    if s: signal.signal(getattr(signal, "SIG" + s), signal.SIG_IGN)
os.execv(sys.argv[2], sys.argv[2:])'

status_of() { case $1 in INT) echo 130 ;; TERM) echo 143 ;; HUP) echo 129 ;; esac; }

# start STEP IGNORED ARGS...: ivoct ARGS in the background (PID), paused at STEP
# ("" for none), with the signals of IGNORED (e.g. "HUP") ignored from the start
start() {
    local step=$1 ignored=$2
    shift 2
    : >"$TMP/err"
    IVOCT_TEST_PAUSE_AT=$step "$PY" -c "$RESET" "$ignored" "$BIN" "$@" >"$TMP/out" 2>"$TMP/err" &
    PID=$!
}

# wait_for TEXT: until TEXT is on the child's stderr (false if it ended first or
# after 300 s)
wait_for() {
    local i
    for ((i = 0; i < 3000; i++)); do
        grep -qF -- "$1" "$TMP/err" && return 0
        kill -0 "$PID" 2>/dev/null || { grep -qF -- "$1" "$TMP/err"; return; }
        sleep 0.1
    done
    return 1
}

# finish: wait for the child; RC its exit status (bash's "Hangup" notice dropped)
finish() {
    { wait "$PID"; } 2>/dev/null
    RC=$?
}

# wait_started: until the child is ivoct with the three signals blocked (its
# signal thread taking them), read from /proc: a signal before that point kills it
# by the default action, which leaves nothing but says nothing either
wait_started() {
    local i mask
    for ((i = 0; i < 3000; i++)); do
        mask=$(awk '/^SigBlk:/ {print $2}' "/proc/$PID/status" 2>/dev/null) || return 1
        [ -n "$mask" ] && [ $((0x$mask & 0x4003)) -eq $((0x4003)) ] && return 0
        sleep 0.01
    done
    return 1
}

now_ms() { date +%s%3N; }

# ---- the outputs of one build, and what complete means ------------------------------------
if [ "${IVOCT_ASAN:-0}" != 0 ]; then DEPTH=5; else DEPTH=6; fi
SCENE=$SCENES/gumdrop.ini
EXTS="csv ivo json vtu htg"
O=$TMP/o/out
mkdir -p "$TMP/o" "$TMP/new" "$TMP/old"
outputs() { # the options writing every output to $1.EXT
    echo --cells "$1.csv" --save "$1.ivo" --stats "$1.json" --vtu "$1.vtu" --htg "$1.htg"
}

# same A B: the output A is the reference B (byte for byte; the stats have times in
# them, so they are compared by their leaves and cells)
same() {
    case $1 in
    *.json)
        "$PY" - "$1" "$2" <<'EOF' 2>/dev/null
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:3])
sys.exit(0 if all(a[k] == b[k] for k in ("leaves", "cells_visited", "leaves_by_depth", "nodes")) else 1)
EOF
        ;;
    *) cmp -s "$1" "$2" ;;
    esac
}

# The reference outputs (timed: the delays below are spread over this run), and older
# ones (a lower depth) for the runs over existing files.
# The fastest of three runs: on a shared machine one run can be slowed by a neighbour, and
# delays computed from a slow run would land after the end of the later, faster ones.
mkdir -p "$TMP/again"
T=
for r in 1 2 3; do
    t0=$(now_ms)
    dir=$TMP/new
    [ "$r" -gt 1 ] && dir=$TMP/again
    # shellcheck disable=SC2046
    run 0 "reference build $r" -- build "$SCENE" --depth "$DEPTH" --threads 2 --quiet $(outputs "$dir/out")
    t=$(($(now_ms) - t0))
    [ -z "$T" ] || [ "$t" -lt "$T" ] && T=$t
done
rm -rf "$TMP/again"
# shellcheck disable=SC2046
run 0 "older outputs" -- build "$SCENE" --depth $((DEPTH - 1)) --quiet $(outputs "$TMP/old/out")
for e in $EXTS; do
    same "$TMP/new/out.$e" "$TMP/old/out.$e" && fail "the older .$e is the same as the new one"
done
# the timed runs count from ivoct's start (wait_started: its signal mask is set, the
# shared libraries loaded), so their delays are spread over T less that start-up
t0=$(now_ms)
"$BIN" --version >/dev/null
STARTUP=$(($(now_ms) - t0))
T=$((T > 2 * STARTUP ? T - STARTUP : T / 2))
echo "reference build: ${T} ms at depth $DEPTH after a start-up of ${STARTUP} ms"

# check WHAT SIG EXPECT [OLD]: after a run sent SIG, with RC its exit status.
# EXPECT: "none" (interrupted before the outputs were renamed: none of them, or all
# the old ones with OLD), "any" (a signal at a delay: none/old, or all new).
INTERRUPTED=0 FINISHED=0
check() {
    local what=$1 sig=$2 expect=$3 old=${4:-} e left n_new=0 n_old=0 n_none=0 state
    left=$(find "$TMP/o" -name '*.tmp.*' | head -5)
    [ -z "$left" ] && ok || fail "$what: temporary files left behind: $left"
    for e in $EXTS; do
        if [ ! -e "$O.$e" ]; then
            n_none=$((n_none + 1))
        elif same "$O.$e" "$TMP/new/out.$e"; then
            n_new=$((n_new + 1))
        elif [ -n "$old" ] && same "$O.$e" "$TMP/old/out.$e"; then
            n_old=$((n_old + 1))
        else
            fail "$what: out.$e is neither complete nor absent ($(wc -c <"$O.$e") bytes)"
        fi
    done
    local all=$(($(echo $EXTS | wc -w)))
    if [ $n_new -eq $all ]; then state=new
    elif [ -z "$old" ] && [ $n_none -eq $all ]; then state=none
    elif [ -n "$old" ] && [ $n_old -eq $all ]; then state=old
    else state=mixed; fi
    case $state in
    mixed) fail "$what: a partial set of outputs: $n_new new, $n_old old, $n_none absent" ;;
    new) [ "$expect" = any ] && ok || fail "$what: the outputs were renamed into place" ;;
    *) ok ;;
    esac
    local want
    want=$(status_of "$sig")
    if [ "$RC" -eq "$want" ]; then
        ok
        INTERRUPTED=$((INTERRUPTED + 1))
        grep -qF "ivoct build: interrupted by SIG$sig" "$TMP/err" && ok ||
            fail "$what: no 'interrupted by SIG$sig' line: $(cat "$TMP/err")"
    elif [ "$RC" -eq 0 ] && [ "$expect" = any ] && [ "$state" = new ]; then
        FINISHED=$((FINISHED + 1)) # the signal came after the end
        ok
    else
        fail "$what: exit $RC, expected $want ($state outputs)"
        sed 's/^/    stderr: /' "$TMP/err" >&2
    fi
    rm -f "$TMP/o"/*
}

# ---- a signal at each step of the build --------------------------------------------------------
sigs=(INT TERM HUP)
k=0
for step in build cells save stats vtu htg commit stats+old htg+old commit+old; do
    old=${step#*+}
    [ "$old" = "$step" ] && old=
    step=${step%+old}
    {
        sig=${sigs[k % 3]}
        k=$((k + 1))
        [ -n "$old" ] && cp "$TMP/old"/out.* "$TMP/o/"
        # shellcheck disable=SC2046
        start "$step" "" build "$SCENE" --depth "$DEPTH" --quiet $(outputs "$O")
        if wait_for "ivoct: test pause at $step"; then
            ok
            kill -"$sig" "$PID"
        else
            fail "step $step: the run did not pause there: $(cat "$TMP/err")"
            kill -KILL "$PID"
        fi
        finish
        check "SIG$sig at $step${old:+ over older files}" "$sig" none "$old"
    }
done

# ---- signals at delays spread over the run: in the build and in each writer ------------------
N=10
for ((i = 0; i < N; i++)); do
    sig=${sigs[i % 3]}
    old=
    [ $((i % 4)) -eq 3 ] && old=old
    delay_ms=$((9 * T * (2 * i + 1) / (20 * N))) # over the first 90% of the run
    # a run that ended before its signal is tried again with half the delay (twice at most)
    for attempt in 1 2 3; do
        [ -n "$old" ] && cp "$TMP/old"/out.* "$TMP/o/"
        finished=$FINISHED
        # shellcheck disable=SC2046
        start "" "" build "$SCENE" --depth "$DEPTH" --quiet $(outputs "$O")
        wait_started || fail "timed run $i: ivoct did not start"
        sleep "$(printf '%d.%03d' $((delay_ms / 1000)) $((delay_ms % 1000)))"
        kill -"$sig" "$PID" 2>/dev/null
        finish
        check "SIG$sig after ${delay_ms} ms${old:+ over older files}" "$sig" any "$old"
        [ "$FINISHED" -eq "$finished" ] || [ "$attempt" -eq 3 ] && break
        FINISHED=$finished
        delay_ms=$((delay_ms / 2))
    done
done
echo "timed signals: $INTERRUPTED interrupted runs in all, $FINISHED timed runs had ended"
# most timed signals must land in the run, or they test nothing (a few may come after
# the end when the machine is faster than during the reference run)
[ "$FINISHED" -le $((N / 2)) ] && ok || fail "$FINISHED of $N timed signals came after the end"

# ---- a second signal stops at once -------------------------------------------------------------
# The first SIGINT comes at the pause before the .ivo (the CSV is written under its
# temporary name by then); IVOCT_TEST_PAUSE_AT's "interrupted" then holds that signal's
# handling before it removes anything (as a slow cleanup would): the second SIGINT must
# end the process at once.
# shellcheck disable=SC2046
start save,interrupted "" build "$SCENE" --depth "$DEPTH" --quiet $(outputs "$O")
if wait_for "ivoct: test pause at save"; then
    [ -n "$(find "$TMP/o" -name 'out.csv.tmp.*')" ] && ok ||
        fail "second SIGINT: no temporary CSV at the pause before the .ivo"
    kill -INT "$PID"
fi
if wait_for "ivoct: test pause at interrupted"; then
    ok
    t0=$(now_ms)
    kill -INT "$PID"
    finish
    took=$(($(now_ms) - t0))
    [ "$RC" -eq 130 ] && ok || fail "second SIGINT: exit $RC, expected 130"
    [ "$took" -lt 5000 ] && ok || fail "second SIGINT: the process took $took ms to end"
    grep -qF "interrupted by" "$TMP/err" && fail "second SIGINT: the first one's handling went on"
else
    fail "second SIGINT: the signal thread did not pause: $(cat "$TMP/err")"
    kill -KILL "$PID"
    finish
fi
rm -f "$TMP/o"/*

# ---- a signal ignored from the start stays ignored (nohup) ---------------------------------
# shellcheck disable=SC2046
start commit HUP build "$SCENES/sphere.ini" --depth 4 --quiet $(outputs "$O")
if wait_for "ivoct: test pause at commit"; then
    kill -HUP "$PID"
    sleep 0.5
    kill -0 "$PID" 2>/dev/null && ok || fail "an ignored SIGHUP ended the process"
    kill -TERM "$PID"
else
    fail "nohup: the run did not pause: $(cat "$TMP/err")"
    kill -KILL "$PID"
fi
finish
[ "$RC" -eq 143 ] && ok || fail "nohup then SIGTERM: exit $RC, expected 143"
left=$(find "$TMP/o" -name '*.tmp.*')
[ -z "$left" ] && ok || fail "nohup then SIGTERM: temporaries left: $left"
rm -f "$TMP/o"/*

# ---- the progress bar leaves the terminal clean ---------------------------------------------
# On a terminal (script's pseudo-terminal) the bar shows once the build has lasted a
# second; SIGTERM then: the message starts a line of its own, the bar's line is ended.
# The build must last well over a second on a fast machine (depth 10 on one thread: a
# few seconds; it is ended as soon as the bar shows).
if command -v script >/dev/null && command -v pgrep >/dev/null; then
    script -qfc "exec '$BIN' build '$SCENE' --depth 10 --threads 1 --cells '$O.csv'" \
        "$TMP/tty.log" >/dev/null 2>&1 &
    SPID=$!
    for ((i = 0; i < 3000; i++)); do
        grep -qF "building [" "$TMP/tty.log" 2>/dev/null && break
        kill -0 "$SPID" 2>/dev/null || break
        sleep 0.1
    done
    kill -TERM "$(pgrep -P "$SPID")"
    { wait "$SPID"; } 2>/dev/null
    tr -d '\r' <"$TMP/tty.log" | grep -q '^ivoct build: interrupted by SIGTERM$' && ok ||
        fail "progress bar: the message is not on a line of its own: $(tail -c 300 "$TMP/tty.log")"
    grep -qF 'COMMAND_EXIT_CODE="143"' "$TMP/tty.log" && ok || fail "progress bar: exit not 143"
    left=$(find "$TMP/o" -mindepth 1 | head -5)
    [ -z "$left" ] && ok || fail "progress bar run: files left: $left"
else
    fail "script (util-linux) and pgrep are needed for the terminal test"
fi

# ---- the OpenVDB exports, the certified mesh, and render ------------------------------------
for step in vdb mesh commit; do
    start "$step" "" build "$SCENES/sphere.ini" --depth 5 --quiet --cells "$O.csv" --vdb "$O.vdb" \
        --mesh "$O.ply"
    wait_for "ivoct: test pause at $step" && ok || fail "exports: no pause at $step"
    kill -TERM "$PID"
    finish
    [ "$RC" -eq 143 ] && ok || fail "SIGTERM at $step of the OpenVDB exports: exit $RC"
    left=$(find "$TMP/o" -mindepth 1 | head -5)
    [ -z "$left" ] && ok || fail "SIGTERM at $step of the OpenVDB exports: files left: $left"
    rm -f "$TMP/o"/*
done
# the certified mesh: before it is computed (its figures go into the stats, so it
# comes before every output) and before its file is written
for step in mesh-certified mesh-certified-write commit; do
    start "$step" "" build "$SCENES/sphere.ini" --depth 5 --quiet --cells "$O.csv" \
        --stats "$O.json" --mesh-certified "$O.ply"
    wait_for "ivoct: test pause at $step" && ok || fail "certified mesh: no pause at $step"
    kill -HUP "$PID"
    finish
    [ "$RC" -eq 129 ] && ok || fail "SIGHUP at $step of the certified mesh: exit $RC"
    left=$(find "$TMP/o" -mindepth 1 | head -5)
    [ -z "$left" ] && ok || fail "SIGHUP at $step of the certified mesh: files left: $left"
    rm -f "$TMP/o"/*
done
R=$TMP/o/r
for step in render frame commit; do
    start "$step" "" render "$SCENES/sphere.ini" --size 64x64 --frames 3 --quiet --png "$R.png" \
        --vti "$R.vti" --stats "$R.json"
    wait_for "ivoct: test pause at $step" && ok || fail "render: no pause at $step"
    kill -INT "$PID"
    finish
    [ "$RC" -eq 130 ] && ok || fail "SIGINT at $step of render: exit $RC"
    grep -qF "ivoct render: interrupted by SIGINT" "$TMP/err" && ok ||
        fail "render: no 'interrupted' line: $(cat "$TMP/err")"
    left=$(find "$TMP/o" -mindepth 1 | head -5)
    [ -z "$left" ] && ok || fail "SIGINT at $step of render: files left: $left"
    rm -f "$TMP/o"/*
done
# the same render uninterrupted writes all seven files
run 0 "render uninterrupted" -- render "$SCENES/sphere.ini" --size 64x64 --frames 3 --quiet \
    --png "$R.png" --vti "$R.vti" --stats "$R.json"
[ "$(find "$TMP/o" -mindepth 1 | wc -l)" -eq 7 ] && ok || fail "render: $(ls "$TMP/o")"

cli_summary
