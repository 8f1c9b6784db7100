#!/usr/bin/env bash
# One ivoct command, two ways, alternating run by run: whole-command wall time,
# user and system CPU and peak RSS (GNU time), medians and the least wall time.
#
#   bash bench/ab.sh [--build DIR] [--base BIN] [--env "VAR=VALUE ..."]
#                    [--reps N] [--pause S] -- IVOCT-ARGUMENTS...
#
# A: --base BIN (an earlier ivoct) when given, with the VTK and OpenVDB modules of
#    its own build (BIN/../lib/ivoct/, where they are: a binary run from outside
#    its build tree would otherwise open this build's), else this build's ivoct.
# B: this build's ivoct, under the --env assignments when given (an allocator's
#    settings, LD_PRELOAD, IVOCT_OPENVDB_MODULE ...).
# Each runs --reps times (default 6), in a scratch directory emptied after every
# run (outputs named relatively land there, and no run overwrites a file from the
# one before), --pause seconds before each run (default 1; a second or more lets
# this VM's guest give freed memory back to the host, so each run starts as a
# user's command would, on fresh pages; 0 measures back-to-back runs, which
# reuse the pages the run before gave back).  Scene paths are taken as given:
# pass them absolute or relative to the source tree's root.  For example:
#   bash bench/ab.sh --base /tmp/base/ivoct -- build scenes/gumdrop.ini --depth 9 --vdb g.vdb --quiet
#   bash bench/ab.sh --env "MALLOC_CONF=narenas:2" -- build scenes/gumdrop.ini --depth 9 --vdb g.vdb --quiet
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/.." && pwd)
build=$root/build/release
base=""
envb=""
reps=6
pause=1
while [ $# -gt 0 ]; do
    case $1 in
    --build) build=$2; shift ;;
    --base) base=$(realpath "$2"); shift ;;
    --env) envb=$2; shift ;;
    --reps) reps=$2; shift ;;
    --pause) pause=$2; shift ;;
    --) shift; break ;;
    -h | --help) sed -n '2,21p' "$0"; exit 0 ;;
    *) echo "bench/ab.sh: unknown option $1 (the command goes after --)" >&2; exit 2 ;;
    esac
    shift
done
[ $# -gt 0 ] || { echo "bench/ab.sh: no command (give it after --)" >&2; exit 2; }
new=$(realpath "${IVOCT_BIN:-$build/cli/ivoct}")
a_bin=${base:-$new}
a_env=()
if [ -n "$base" ]; then
    lib=$(dirname "$base")/../lib/ivoct
    [ -e "$lib/libivoct_vtk.so" ] && a_env+=("IVOCT_VTK_MODULE=$(realpath "$lib/libivoct_vtk.so")")
    [ -e "$lib/libivoct_openvdb.so" ] && a_env+=("IVOCT_OPENVDB_MODULE=$(realpath "$lib/libivoct_openvdb.so")")
fi
[ -x /usr/bin/time ] || { echo "bench/ab.sh: needs GNU time (/usr/bin/time)" >&2; exit 2; }
work=$(mktemp -d /tmp/ivoct-ab.XXXXXX)
trap 'rm -rf "$work"' EXIT
# files relative to the source tree (the scenes) work from the scratch directory too
args=()
for a in "$@"; do
    if [ -f "$root/$a" ] && [[ $a != /* ]]; then args+=("$root/$a"); else args+=("$a"); fi
done
echo "load before: $(uptime)"
for ((i = 0; i < reps; i++)); do
    for side in A B; do
        sleep "$pause"
        if [ $side = A ]; then
            (cd "$work/" && env "${a_env[@]}" /usr/bin/time -f "A %e %U %S %M" -a -o "$work.times" \
                "$a_bin" "${args[@]}" >/dev/null)
        else
            # shellcheck disable=SC2086  # the assignments split on spaces
            (cd "$work/" && env $envb /usr/bin/time -f "B %e %U %S %M" -a -o "$work.times" \
                "$new" "${args[@]}" >/dev/null)
        fi
        find "$work" -mindepth 1 -delete
    done
done
echo "load after:  $(uptime)"
echo "A: ${base:-this build}"
echo "B: this build${envb:+ with $envb}"
awk '
    $1 == "A" || $1 == "B" { n[$1]++; w[$1, n[$1]] = $2; u[$1, n[$1]] = $3; s[$1, n[$1]] = $4; r[$1, n[$1]] = $5 }
    function med(a, k, m,    i, j, t, v) {
        for (i = 1; i <= m; i++) v[i] = a[k, i]
        for (i = 1; i <= m; i++) for (j = i + 1; j <= m; j++) if (v[j] < v[i]) { t = v[i]; v[i] = v[j]; v[j] = t }
        return m % 2 ? v[(m + 1) / 2] : (v[m / 2] + v[m / 2 + 1]) / 2
    }
    function least(a, k, m,    i, x) { x = a[k, 1]; for (i = 2; i <= m; i++) if (a[k, i] < x) x = a[k, i]; return x }
    END {
        printf "%-4s %4s %10s %10s %8s %8s %8s\n", "side", "runs", "wall_min", "wall_med", "user", "sys", "rss_mb"
        for (k = 0; k < 2; k++) {
            c = k ? "B" : "A"; m = n[c]
            printf "%-4s %4d %10.3f %10.3f %8.2f %8.2f %8.0f\n", c, m, least(w, c, m), med(w, c, m),
                med(u, c, m), med(s, c, m), med(r, c, m) / 1024
        }
    }' "$work.times"
rm -f "$work.times"
