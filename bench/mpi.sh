#!/usr/bin/env bash
# Strong scaling of the build and the render over MPI (cli/mpi.c, docs/cluster.md).  Not a
# timed test.
#
#   bash bench/mpi.sh [--build DIR] [--scenes "gumdrop mcmullen-k3"] [--depth 11]
#                     [--ranks "1 2 4"] [--threads N] [--outputs "none save pieces"]
#                     [--render-scene gumdrop] [--render-size 600x600] [--render-ranks "1 2"]
#                     [--no-build] [--no-render]
#
# For each scene and rank count R: mpirun -np R ivoct build SCENE --depth D --threads N
# --stats (--oversubscribe when R x N exceeds the cores), once for each of --outputs: none
# (the stats alone), save (--save F.ivo: the subtrees gathered on rank 0) and pieces
# (--save F.pivo: each rank saves its part, nothing gathered).  Per run, from the stats' "mpi" object: the wall
# time (the slowest rank's build), the balance (max / mean rank time), the cells visited
# per rank (the work, which oversubscription does not distort), the subtrees each rank
# built and took from another's range, the bytes gathered on rank 0 and the requests to
# rank 0's dispenser.  Writes bench/results/mpi-STAMP.csv.
#
# The render: the scene's octree (its [octree] settings) saved once, then for each rank
# count R one frame of --render-size, mpirun -np R ivoct render SCENE --octree F.ivo
# --threads N --png --vti --stats: each frame cut into parts, one per rank, gathered on rank
# 0.  Per run, from the stats: the render time (the slowest rank's), the balance (max /
# mean rank time), every rank's rays and tape evaluations (the work, which
# oversubscription does not distort), the bytes gathered and rank 0's time in the gather.
# Writes bench/results/mpi-render-STAMP.csv.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/.." && pwd)
build=$root/build/release
scenes="gumdrop mcmullen-k3"
depth=11
ranks="1 2 4"
threads=1
render_scene=gumdrop
render_size=600x600
render_ranks="1 2"
outputs="none save pieces"
do_build=1
do_render=1
while [ $# -gt 0 ]; do
    case $1 in
    --build) build=$2; shift 2 ;;
    --scenes) scenes=$2; shift 2 ;;
    --depth) depth=$2; shift 2 ;;
    --ranks) ranks=$2; shift 2 ;;
    --threads) threads=$2; shift 2 ;;
    --outputs) outputs=$2; shift 2 ;;
    --render-scene) render_scene=$2; shift 2 ;;
    --render-size) render_size=$2; shift 2 ;;
    --render-ranks) render_ranks=$2; shift 2 ;;
    --no-build) do_build=0; shift ;;
    --no-render) do_render=0; shift ;;
    *) echo "bench/mpi.sh: unknown option $1" >&2; exit 2 ;;
    esac
done
bin=$build/cli/ivoct
command -v mpirun >/dev/null || { echo "bench/mpi.sh: no mpirun (scripts/deps.txt: openmpi-bin)" >&2; exit 1; }
mkdir -p "$root/bench/results"
stamp=$(date -u +%Y%m%dT%H%M%SZ)
out=$root/bench/results/mpi-$stamp.csv
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
args=(--oversubscribe)
[ "$(id -u)" -eq 0 ] && args+=(--allow-run-as-root)
# Open MPI binds a rank to one core (N <= 2) or a socket: a rank's threads need the node
[ "$threads" -gt 1 ] && args+=(--bind-to none)
# the gather of large messages: plain copies where CMA is refused (containers), as tests/mpi/
export OMPI_MCA_btl_vader_single_copy_mechanism=none
if [ $do_build = 1 ]; then
echo "scene,depth,ranks,threads,outputs,leaves,time_s,balance,rank_cells_visited,rank_subtrees,rank_shared_subtrees,gather_bytes,requests,subtrees,wall_s" >"$out"
for sc in $scenes; do
    for r in $ranks; do
        for gather in $outputs; do
            save=()
            [ $gather = save ] && save=(--save "$work/t.ivo")
            [ $gather = pieces ] && save=(--save "$work/t.pivo")
            # wall_s: the whole command (scene, build, outputs), where time_s is the build
            t0=$(date +%s.%N)
            mpirun "${args[@]}" -np "$r" "$bin" build "$root/scenes/$sc.ini" --depth "$depth" \
                --threads "$threads" --stats "$work/s.json" "${save[@]}" --quiet
            t1=$(date +%s.%N)
            rm -f "$work"/t*
            /usr/bin/python3 - "$work/s.json" "$t0" "$t1" "$sc" "$depth" "$r" "$threads" "$gather" >>"$out" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
m = d["mpi"]
j = lambda v: " ".join(str(x) for x in v)
print(",".join([*sys.argv[4:], str(d["leaves"]), "%.3f" % d["time_s"], "%.3f" % m["balance"],
                j(m["rank_cells_visited"]), j(m["rank_subtrees"]), j(m["rank_shared_subtrees"]),
                str(m["gather_bytes"]), str(m["requests"]), str(m["subtrees"]),
                "%.2f" % (float(sys.argv[3]) - float(sys.argv[2]))]))
PY
            tail -1 "$out"
        done
    done
done
echo "wrote $out"
fi

[ $do_render = 1 ] || exit 0
rout=$root/bench/results/mpi-render-$stamp.csv
"$bin" build "$root/scenes/$render_scene.ini" --save "$work/r.ivo" --quiet
echo "scene,size,ranks,threads,rays,hits,time_s,balance,rank_time_s,rank_rays,rank_tape_evals,gather_bytes,gather_time_s" >"$rout"
for r in $render_ranks; do
    mpirun "${args[@]}" -np "$r" "$bin" render "$root/scenes/$render_scene.ini" --octree "$work/r.ivo" \
        --size "$render_size" --threads "$threads" --png "$work/r.png" --vti "$work/r.vti" \
        --stats "$work/r.json" --quiet
    /usr/bin/python3 - "$work/r.json" "$render_scene" "$render_size" "$r" "$threads" >>"$rout" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
# one rank: no "mpi" object; its figures are the render's
m = d.get("mpi", {"rank_time_s": [d["time_s"]], "rank_rays": [d["rays"]],
                  "rank_tape_evals": [d["tape_evals"]], "balance": 1.0, "gather_bytes": 0,
                  "gather_time_s": 0.0})
j = lambda v, f="%s": " ".join(f % x for x in v)
print(",".join([*sys.argv[2:], str(d["rays"]), str(d["hits"]), "%.3f" % d["time_s"],
                "%.3f" % m["balance"], j(m["rank_time_s"], "%.3f"), j(m["rank_rays"]),
                j(m["rank_tape_evals"]), str(m["gather_bytes"]), "%.4f" % m["gather_time_s"]]))
PY
    tail -1 "$rout"
done
echo "wrote $rout"
