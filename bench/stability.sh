#!/usr/bin/env bash
# The numerical stability stress suite as a table: runs the two
# stability test executables (tests/test_stab_octree.c, tests/test_stab_rays.c) with
# IVOCT_STAB_CSV set, so that each case appends one row
#   suite,case,outcome,time_s,error
# outcome: missed cells / missed hits (and what else the case counts); error: for octree
# rows the largest certified leaf error bound of the builds, for ray rows max |t - t_ref|
# against the MPFR oracle (non-ambiguous rays), for grazing rays likewise.
#   bash bench/stability.sh [--build DIR]
# Writes bench/results/stability.csv and stability.md (a Markdown table).  Exit status:
# non-zero when a test fails (its rows are still written).
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/.." && pwd)
build=${IVOCT_BUILD:-$root/build/release}
while [ $# -gt 0 ]; do
    case $1 in
    --build) build=$2; shift 2 ;;
    *) echo "bench/stability.sh: unknown option $1" >&2; exit 2 ;;
    esac
done
out=$root/bench/results
mkdir -p "$out"
csv=$out/stability.csv
echo "suite,case,outcome,time_s,error" >"$csv"
status=0
start=$(date +%s)
for t in test_stab_octree test_stab_rays; do
    bin=$build/tests/$t
    [ -x "$bin" ] || { echo "bench/stability.sh: no $bin (build first, or --build DIR)" >&2; exit 2; }
    (cd "$root" && IVOCT_SOURCE_DIR=$root IVOCT_STAB_CSV=$csv "$bin" >"$out/$t.log" 2>&1) || {
        echo "bench/stability.sh: $t FAILED (see $out/$t.log)" >&2
        status=1
    }
done
python3 - "$csv" >"$out/stability.md" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
print("| suite | case | outcome | time s | error |")
print("|---|---|---|---:|---:|")
for r in rows:
    print("| %s | %s | %s | %s | %s |" % (r["suite"], r["case"], r["outcome"], r["time_s"], r["error"]))
PY
column -s, -t <"$csv" | cut -c1-200
echo "total $(($(date +%s) - start)) s; load average $(cut -d' ' -f1-3 /proc/loadavg)"
echo "wrote $csv and $out/stability.md"
exit $status
