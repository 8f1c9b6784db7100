# The fuzz targets' ctests and `make fuzz` (README.md here).
#
#   run.sh corpus FUZZER NAME           every input of NAME's corpus once
#   run.sh run FUZZER NAME [SECONDS [CORPUS_DIR]]
#                                       fuzz for SECONDS (default $IVOCT_FUZZ_TEST_TIME or 30)
#                                       starting from the corpus; new inputs go to CORPUS_DIR
#                                       (kept: make fuzz), else to a fresh folder (ctest)
#
# NAME's corpus: tests/fuzz/corpus/NAME/ (committed: seeds and every crash found),
# for scene also scenes/*.ini, and for ivo, vtk and vdb small files written here by
# $IVOCT_BIN build (depth 2 and 3 trees of three scenes).  A crash, leak, timeout or
# sanitizer report fails; its input is saved as $IVOCT_FUZZ_WORK/NAME/crash-* etc.
# Needs IVOCT_SOURCE_DIR, IVOCT_BIN and IVOCT_FUZZ_WORK (ctest sets them).
set -u
mode=$1 fuzzer=$2 name=$3
src=${IVOCT_SOURCE_DIR:?IVOCT_SOURCE_DIR must name the source tree}
work=${IVOCT_FUZZ_WORK:?IVOCT_FUZZ_WORK must name a folder for the fuzzers}/$name
here=$src/tests/fuzz
mkdir -p "$work"
# Leaks are errors; a report aborts with a stack trace (make test sets the same).
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}

# The seed folders of NAME, one per line.
seeds() {
    [ -d "$here/corpus/$name" ] && echo "$here/corpus/$name"
    case $name in
    scene) echo "$src/scenes" ;;
    ivo | vtk | vdb)
        local dir=$work/seeds-$mode
        rm -rf "$dir" && mkdir -p "$dir"
        local bin=${IVOCT_BIN:?IVOCT_BIN must name the ivoct binary} spec
        # scene depth tests: a single-use tape, slabs and lets, a let-heavy CSG
        for spec in "sphere 2 interval" "gumdrop 3 interval,ilie" "barth-sextic 2 interval,lipschitz"; do
            set -- $spec
            local o=$dir/$1-$2
            case $name in
            ivo) "$bin" build "$src/scenes/$1.ini" --depth "$2" --tests "$3" --quiet --save "$o.ivo" ;;
            vtk) "$bin" build "$src/scenes/$1.ini" --depth "$2" --tests "$3" --quiet \
                     --vtu "$o.vtu" --htg "$o.htg" --mesh "$o.vtp" ;;
            vdb) "$bin" build "$src/scenes/$1.ini" --depth "$2" --tests "$3" --quiet --vdb "$o.vdb" ;;
            esac || { echo "run.sh: cannot write the seeds with $bin" >&2; exit 1; }
        done
        echo "$dir"
        ;;
    esac
}

mapfile -t dirs < <(seeds)
[ ${#dirs[@]} -gt 0 ] || { echo "run.sh: no corpus for $name" >&2; exit 1; }

case $mode in
corpus)
    mapfile -t files < <(find "${dirs[@]}" -type f ! -name '.*' ! -name README.md | sort)
    echo "fuzz_$name: ${#files[@]} inputs from ${dirs[*]}"
    exec "$fuzzer" -timeout=30 -rss_limit_mb=2048 "${files[@]}"
    ;;
run)
    seconds=${4:-${IVOCT_FUZZ_TEST_TIME:-30}}
    corpus=${5:-}
    if [ -z "$corpus" ]; then
        corpus=$work/ctest-corpus
        rm -rf "$corpus"
    fi
    mkdir -p "$corpus"
    dict=()
    # scene files hold expressions: their dictionary is both
    case $name in
    expr) dict=(-dict="$here/expr.dict") ;;
    scene) cat "$here/expr.dict" "$here/scene.dict" >"$work/scene-all.dict"
           dict=(-dict="$work/scene-all.dict") ;;
    *) [ -f "$here/$name.dict" ] && dict=(-dict="$here/$name.dict") ;;
    esac
    # ivoct info reads VTK and OpenVDB files in a child process, where the libraries'
    # crashes are expected (export/README.md); symbolizing each of their reports takes a
    # second.  A finding of the parent is reproduced symbolized from its saved input.
    case $name in
    vtk | vdb) export ASAN_OPTIONS=$ASAN_OPTIONS:symbolize=0 ;;
    esac
    echo "fuzz_$name: $seconds s from ${dirs[*]}; new inputs in $corpus"
    # Not nice'd: -timeout is wall time, and under ctest -j2 beside a test on both
    # cores a nice'd fuzzer gets a tenth of a core, so that an input of one second
    # would pass for a hang.  (make fuzz runs alone, and nice's the whole script.)
    exec "$fuzzer" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
        -print_final_stats=1 -artifact_prefix="$work/" "${dict[@]}" "$corpus" "${dirs[@]}"
    ;;
*)
    echo "usage: run.sh corpus|run FUZZER NAME [SECONDS [CORPUS_DIR]]" >&2
    exit 2
    ;;
esac
