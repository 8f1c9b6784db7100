#!/usr/bin/env bash
# Render time against hit error, and the OpenVDB level-set baseline.
#   bash bench/ray_error.sh [--build DIR] [--out NAME] [--quick] [ivoct_ray_error options]
# Runs build/release/bench/ivoct_ray_error (see bench/ray_error.c) over the eight
# comparison surfaces at each scene's camera and size (300x300), every method with
# the octree (all threads and 1 thread) and without it, and the OpenVDB level set
# ray cast with LevelSetRayIntersector (1 thread and all threads); errors against
# the MPFR reference of tests/support/ray_reference.c.  --quick: sphere and
# gumdrop, 100x100, mitchell and lipschitz, one repetition (under a minute).
# Other options go to ivoct_ray_error (--surfaces, --methods, --size, --threads,
# --reps (repetitions of the octree renders and of the OpenVDB casts; the
# no-octree renders run once), --depth, --voxel, --half-width, --dump DIR).
# Writes bench/results/NAME.csv (one row per surface, variant, method, threads),
# NAME.md (the tables of docs/BENCHMARKS.md) and NAME.load; NAME defaults to
# ray_error (ray_error_quick with --quick).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/.." && pwd)
build=${IVOCT_BUILD:-$root/build/release}
name=
quick=
args=()
while [ $# -gt 0 ]; do
    case $1 in
    --build) build=$2; shift 2 ;;
    --out) name=$2; shift 2 ;;
    --quick) quick=1; args+=(--quick); shift ;;
    --quick=*) echo "bench/ray_error.sh: --quick takes no value" >&2; exit 2 ;;
    *) args+=("$1"); shift ;;
    esac
done
[ -n "$name" ] || name=ray_error${quick:+_quick}
bin=$build/bench/ivoct_ray_error
[ -x "$bin" ] || { echo "bench/ray_error.sh: no $bin (build first with export/ and MPFR, or --build DIR)" >&2; exit 2; }
out=$root/bench/results
mkdir -p "$out"
csv=$out/$name.csv

echo "load average at start: $(cut -d' ' -f1-3 /proc/loadavg)" >"$out/$name.load"
start=$(date +%s)
"$bin" --scenes "$root/scenes" --csv "$csv" ${args[@]+"${args[@]}"}
echo "load average at end: $(cut -d' ' -f1-3 /proc/loadavg)" >>"$out/$name.load"
echo "wall clock: $(( $(date +%s) - start )) s" >>"$out/$name.load"

python3 - "$csv" >"$out/$name.md" <<'EOF'
import csv, sys
from collections import OrderedDict
rows = list(csv.DictReader(open(sys.argv[1])))
surfaces = list(OrderedDict.fromkeys(r["surface"] for r in rows))
CERTIFIED = {"mitchell", "newton", "newton-ah", "mrfro", "mrfro-newton", "lipschitz"}
allthr = max(int(r["threads"]) for r in rows)

def g(s, variant, method, thr):
    for r in rows:
        if (r["surface"], r["variant"], r["method"], int(r["threads"])) == (s, variant, method, thr):
            return r
    return None

def e(x):
    return "%.1e" % float(x) if x not in ("", "nan") else "–"

def mx(r):
    a, u = r["max_abs_err"], r["max_abs_err_unambiguous"]
    return e(a) if float(a) == float(u) else "%s (%s)" % (e(a), e(u))

def differ(r):
    return "%s (%s/%s)" % (r["disagree"], r["disagree_ambiguous"], r["disagree_within_voxel"])

print("Per method (times: the render or cast alone; errors |t − t_ref| over the pixels where "
      "both hit, max over all of them and, in brackets, over those the reference does not call "
      "ambiguous; differ: hit/miss disagreements (of which ambiguous at 1e-9 / within a voxel "
      "of tangency)).\n")
print("| surface | method | octree %dt s | octree 1t s | no octree %dt s | octree max err | octree mean err | octree differ | no-octree max err | no-octree mean err | no-octree differ |" % (allthr, allthr))
print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
for s in surfaces:
    first = True
    methods = list(OrderedDict.fromkeys(r["method"] for r in rows if r["surface"] == s and r["variant"] != "openvdb"))
    for m in methods:
        o = g(s, "octree", m, allthr); o1 = g(s, "octree", m, 1) if allthr > 1 else o
        n = g(s, "no-octree", m, allthr)
        print("| %s | %s | %.3f | %.3f | %.3f | %s | %s | %s | %s | %s | %s |" % (
            s if first else "", m + ("" if m in CERTIFIED else " (not certified)"),
            float(o["time_s"]), float(o1["time_s"]), float(n["time_s"]),
            mx(o), e(o["mean_abs_err"]), differ(o),
            mx(n), e(n["mean_abs_err"]), differ(n)))
        first = False
    v = g(s, "openvdb", "level-set", allthr); v1 = g(s, "openvdb", "level-set", 1)
    if v:
        print("| | **OpenVDB level set** (grid %.3f s) | cast %.3f | cast 1t %.3f | | %s | %s | %s | | | |" % (
            float(v["build_s"]), float(v["time_s"]), float(v1["time_s"]),
            mx(v), e(v["mean_abs_err"]), differ(v)))

print("\nAgainst the goal (ivoct's fastest certified method with the octree, %d threads, against the "
      "OpenVDB cast, %d threads; 'with builds': octree build + render against octree build + grid "
      "build + cast, the grid's band coming from the octree).\n" % (allthr, allthr))
print("| surface | best certified | ivoct s | OpenVDB s | time ratio | ivoct+build s | OpenVDB+builds s | ratio with builds | ivoct 1t s | OpenVDB 1t s | ratio 1t | ivoct 1t CPU s | OpenVDB 1t CPU s | ratio 1t CPU | mean err ivoct | mean err OpenVDB | mean err ratio | max err ivoct (unamb.) | max err OpenVDB (unamb.) | max err ratio |")
print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
for s in surfaces:
    cands = [r for r in rows if r["surface"] == s and r["variant"] == "octree" and int(r["threads"]) == allthr and r["method"] in CERTIFIED]
    v = g(s, "openvdb", "level-set", allthr); v1 = g(s, "openvdb", "level-set", 1)
    if not cands or not v:
        continue
    b = min(cands, key=lambda r: float(r["time_s"]))
    b1 = g(s, "octree", b["method"], 1) or b
    ob = float(b["build_s"]); gb = float(v["build_s"])
    ti, tv = float(b["time_s"]), float(v["time_s"])
    mi, mv = float(b["mean_abs_err"]), float(v["mean_abs_err"])
    xi, xv = float(b["max_abs_err_unambiguous"]), float(v["max_abs_err_unambiguous"])
    # the CPU columns: the certified method with the least thread CPU time on 1 thread
    c1 = [r for r in rows if r["surface"] == s and r["variant"] == "octree" and int(r["threads"]) == 1 and r["method"] in CERTIFIED]
    bc = min(c1, key=lambda r: float(r["cpu_1t_s"])) if c1 else b1
    ci, cv = float(bc["cpu_1t_s"]), float(v1["cpu_1t_s"])
    print("| %s | %s | %.3f | %.3f | %.1f× | %.3f | %.3f | %.2f× | %.3f | %.3f | %.1f× | %s | %.3f | %.1f× | %.1e | %.1e | %.0e | %.1e | %.1e | %.0e |" % (
        s, b["method"], ti, tv, ti / tv, ob + ti, ob + gb + tv, (ob + ti) / (ob + gb + tv),
        float(b1["time_s"]), float(v1["time_s"]), float(b1["time_s"]) / float(v1["time_s"]),
        "%.3f%s" % (ci, "" if bc["method"] == b["method"] else " (" + bc["method"] + ")"), cv, ci / cv,
        mi, mv, mv / mi if mi > 0 else float("inf"), xi, xv, xv / xi if xi > 0 else float("inf")))
EOF
cat "$out/$name.load"
echo "wrote $csv and $out/$name.md"
