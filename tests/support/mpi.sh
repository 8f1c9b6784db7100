# Shared by the MPI tests (tests/mpi/*.sh): source it after cli.sh and cli_setup.
# Needs IVOCT_MPIEXEC (mpirun), as set by ctest in a build with IVOCT_MPI.

MPIEXEC=${IVOCT_MPIEXEC:?IVOCT_MPIEXEC must name mpirun}
# the test machine has 2 cores; CI runs as root
mpi_args=(--oversubscribe)
[ "$(id -u)" -eq 0 ] && mpi_args+=(--allow-run-as-root)
# Open MPI's shared-memory transport copies large messages (the gather) with CMA, which
# a container without ptrace rights refuses: plain copies through the shared segment
export OMPI_MCA_btl_vader_single_copy_mechanism=none
# Open MPI's own allocations that it never frees show as leaks under LeakSanitizer:
# suppressed for its libraries only (tests/mpi/lsan-openmpi.supp), never for ivoct's code;
# full stacks, so that every one reaches the library that made the call
if [ -n "${IVOCT_ASAN:-}" ]; then
    export LSAN_OPTIONS="${LSAN_OPTIONS:+$LSAN_OPTIONS:}suppressions=$SRC/tests/mpi/lsan-openmpi.supp:print_suppressions=0"
    export ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}fast_unwind_on_malloc=0"
fi

# mpirun_ivoct N EXPECTED_EXIT DESCRIPTION -- ARGS...: ivoct over N ranks, out/err in $TMP
mpirun_ivoct() {
    local np=$1 want=$2 what=$3
    shift 4
    "$MPIEXEC" "${mpi_args[@]}" -np "$np" "$BIN" "$@" >"$TMP/out" 2>"$TMP/err"
    local got=$?
    if [ "$got" -ne "$want" ]; then
        fail "$what: exit $got, expected $want (mpirun -np $np ivoct $*)"
        sed 's/^/    stderr: /' "$TMP/err" >&2
        return 1
    fi
    ok
}

# The lines of ivoct's own messages in $TMP/err (mpirun adds lines of its own).
ivoct_lines() { grep -c '^ivoct' "$TMP/err"; }
