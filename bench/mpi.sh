#!/usr/bin/env bash
# Strong scaling of the build over MPI (cli/mpi.c, docs/cluster.md).  Not a timed test.
#
#   bash bench/mpi.sh [--build DIR] [--scenes "gumdrop mcmullen-k3"] [--depth 11]
#                     [--ranks "1 2 4"] [--threads N]
#
# For each scene and rank count R: mpirun -np R ivoct build SCENE --depth D --threads N
# --stats (--oversubscribe when R x N exceeds the cores), once with --save (the subtrees
# gathered on rank 0) and once without.  Per run, from the stats' "mpi" object: the wall
# time (the slowest rank's build), the balance (max / mean rank time), the cells visited
# per rank (the work, which oversubscription does not distort), the subtrees each rank
# built and took from another's range, the bytes gathered on rank 0 and the requests to
# rank 0's dispenser.  Writes bench/results/mpi-STAMP.csv.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/.." && pwd)
build=$root/build/release
scenes="gumdrop mcmullen-k3"
depth=11
ranks="1 2 4"
threads=1
while [ $# -gt 0 ]; do
    case $1 in
    --build) build=$2; shift 2 ;;
    --scenes) scenes=$2; shift 2 ;;
    --depth) depth=$2; shift 2 ;;
    --ranks) ranks=$2; shift 2 ;;
    --threads) threads=$2; shift 2 ;;
    *) echo "bench/mpi.sh: unknown option $1" >&2; exit 2 ;;
    esac
done
bin=$build/cli/ivoct
command -v mpirun >/dev/null || { echo "bench/mpi.sh: no mpirun (scripts/deps.txt: openmpi-bin)" >&2; exit 1; }
mkdir -p "$root/bench/results"
out=$root/bench/results/mpi-$(date -u +%Y%m%dT%H%M%SZ).csv
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
args=(--oversubscribe)
[ "$(id -u)" -eq 0 ] && args+=(--allow-run-as-root)
echo "scene,depth,ranks,threads,gather,leaves,time_s,balance,rank_cells_visited,rank_subtrees,rank_shared_subtrees,gather_bytes,requests,subtrees" >"$out"
for sc in $scenes; do
    for r in $ranks; do
        for gather in 0 1; do
            save=()
            [ $gather = 1 ] && save=(--save "$work/t.ivo")
            mpirun "${args[@]}" -np "$r" "$bin" build "$root/scenes/$sc.ini" --depth "$depth" \
                --threads "$threads" --stats "$work/s.json" "${save[@]}" --quiet
            /usr/bin/python3 - "$work/s.json" "$sc" "$depth" "$r" "$threads" "$gather" >>"$out" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
m = d["mpi"]
j = lambda v: " ".join(str(x) for x in v)
print(",".join([*sys.argv[2:], str(d["leaves"]), "%.3f" % d["time_s"], "%.3f" % m["balance"],
                j(m["rank_cells_visited"]), j(m["rank_subtrees"]), j(m["rank_shared_subtrees"]),
                str(m["gather_bytes"]), str(m["requests"]), str(m["subtrees"])]))
PY
            tail -1 "$out"
        done
    done
done
echo "wrote $out"
