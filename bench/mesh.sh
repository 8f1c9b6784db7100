#!/usr/bin/env bash
# The certified mesh (`ivoct build --mesh-certified`) against OpenVDB's (`--mesh`).
#
#   bash bench/mesh.sh [--build DIR] [--quick] [--reps N] [--depth N] [--ref-depth N]
#                      [--surfaces "sphere gumdrop ..."] [--out NAME]
#
# Surfaces (default): sphere, gumdrop, chubs and McMullen K3 (f from scenes/*.ini) over
# the box [-2,2]^3 — temporary scene files with that box, the one libfive's published
# times are for — and the bretzel (scenes/bretzel.ini) and the torus of
# tests/test_mesh_certified.c at their own boxes; and three traps of docs/surfaces.md at
# theirs: the offset sphere (a unit sphere at x = 1e6), the thin shell (two spheres 2e-3
# apart), the tiny sphere (radius 1e-6).  Depth --depth (default 8), one thread.
# For each, interleaved run by run so all see the same load, best of --reps (default 3):
#   build     ivoct build SCENE --depth D --threads 1              (the octree alone)
#   vdb       ... --mesh F.ply                                     (OpenVDB volumeToMesh)
#   cert      ... --mesh-certified F.ply                           (default --mesh-min-depth, D-2)
#   cert0     ... --mesh-certified F.ply --mesh-min-depth 0        (the coarsest)
#   certD     ... --mesh-certified F.ply --mesh-min-depth D        (every cell at depth D:
#                                                                   --mesh's resolution)
# wall and CPU (user + sys) of each command; the mesh's time is the command's less
# `build`'s (the mesh, its file, nothing else: the octree is built by every command),
# both for wall and CPU, and its ratio to --mesh's; for the certified mesh also the
# mesher's own time (mesh_certified.time_s of --stats).  The certified mesh refuses a
# singular surface (exit 3, nothing written): the exit status, the cells and regions of
# its message are recorded (and any other failure's message).  Then every mesh goes
# through ivoct_mesh_quality (topology by tests/support/mesh_check.c with the exact
# intersection test; distances proved on the surface, with MPFI where doubles cannot
# decide) against a reference of points on the surface: the OpenVDB mesh at --ref-depth
# (default D+1) with its vertices projected onto the surface (--reference-project: a
# sampling independent of both meshers' vertices), or where OpenVDB fails, the certified
# mesh at --ref-depth (vertices on the surface).
# Writes bench/results/NAME.csv and NAME.md (NAME: mesh, or mesh-quick with --quick:
# depth 7, sphere gumdrop chubs, one run).  `uptime` before and after goes into the .md.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/.." && pwd)
build=$root/build/release
reps=3
depth=8
refdepth=
surfaces="sphere gumdrop chubs mcmullen-k3 bretzel torus offset-sphere thin-shell tiny-sphere"
name=mesh
quick=0
surfaces_given=0
while [ $# -gt 0 ]; do
    case $1 in
    --build) build=$2; shift ;;
    --reps) reps=$2; shift ;;
    --depth) depth=$2; shift ;;
    --ref-depth) refdepth=$2; shift ;;
    --surfaces) surfaces=$2 surfaces_given=1; shift ;;
    --out) name=$2; shift ;;
    --quick) quick=1 ;;
    -h | --help) sed -n '2,33p' "$0"; exit 0 ;;
    *) echo "bench/mesh.sh: unknown option $1" >&2; exit 2 ;;
    esac
    shift
done
if [ "$quick" = 1 ]; then
    depth=7 reps=1
    [ "$surfaces_given" = 1 ] || surfaces="sphere gumdrop chubs"
    [ "$name" = mesh ] && name=mesh-quick
fi
[ -n "$refdepth" ] || refdepth=$((depth + 1))
bin=${IVOCT_BIN:-$build/cli/ivoct}
quality=$build/bench/ivoct_mesh_quality
[ -x "$bin" ] || { echo "bench/mesh.sh: no $bin (build first, or --build DIR)" >&2; exit 2; }
[ -x "$quality" ] || { echo "bench/mesh.sh: no $quality (it is built with the tests)" >&2; exit 2; }
out=$root/bench/results
mkdir -p "$out"
tmp=$(mktemp -d /tmp/ivoct-mesh.XXXXXX)
trap 'rm -rf "$tmp"' EXIT
# copies of the binaries: a rebuild of the build tree during the run changes nothing here
cp "$bin" "$tmp/ivoct" && bin=$tmp/ivoct
cp "$quality" "$tmp/ivoct_mesh_quality" && quality=$tmp/ivoct_mesh_quality
load_before=$(uptime)

# the scene of a surface: the box [-2,2]^3 for the four of libfive's table
scene_of() {
    case $1 in
    sphere | gumdrop | chubs | mcmullen-k3)
        sed 's/^box .*/box = -2 2  -2 2  -2 2/' "$root/scenes/$1.ini" >"$tmp/$1.ini" ;;
    torus)
        printf '[surface]\nname = Torus\nf = (x^2 + y^2 + z^2 + 1 - 0.16)^2 - 4*(x^2 + y^2)\nbox = -1.6 1.6  -1.6 1.6  -0.6 0.6\n' \
            >"$tmp/$1.ini" ;;
    *) cp "$root/scenes/$1.ini" "$tmp/$1.ini" ;;
    esac
    echo "$tmp/$1.ini"
}

# run VARIANT SCENE ARGS...: one timed command; leaves "wall cpu rc" in $tmp/VARIANT.t.
# Timed from Python (perf_counter, and the child's rusage for user + sys): /usr/bin/time
# counts in hundredths, and a small mesh takes a few of them.
run() {
    local v=$1 sc=$2
    shift 2
    /usr/bin/python3 - "$tmp/$v.t" "$tmp/$v.err" "$bin" build "$sc" --depth "$depth" --threads 1 \
        --stats "$tmp/$v.json" --quiet "$@" <<'EOF'
import resource, subprocess, sys, time
t0 = time.perf_counter()
with open(sys.argv[2], "w") as err:
    rc = subprocess.call(sys.argv[3:], stderr=err)
wall = time.perf_counter() - t0
u = resource.getrusage(resource.RUSAGE_CHILDREN)
open(sys.argv[1], "w").write(f"{wall:.4f} {u.ru_utime + u.ru_stime:.4f} {rc}\n")
EOF
}
smaller() { awk -v a="$1" -v b="$2" 'BEGIN { print (b == "" || a + 0 < b + 0) ? a : b }'; }
json() { /usr/bin/python3 -c 'import json, sys
d = json.load(open(sys.argv[1]))
for k in sys.argv[2].split("."): d = d.get(k, "") if isinstance(d, dict) else ""
print(d)' "$1" "$2" 2>/dev/null || echo ""; }

csv=$out/$name.csv
echo "surface,box,depth,variant,exit,wall_s,cpu_s,mesh_wall_s,mesh_cpu_s,mesher_s,ratio_wall,ratio_cpu,failed_cells,failed_regions,message,triangles,vertices,closed_embedded,boundary_edges,nonmanifold_edges,nonmanifold_vertices,misoriented_edges,intersecting_pairs,euler,components,to_surface_max,to_surface_mean,to_surface_unconverged,reference,to_mesh_max,to_mesh_mean,hausdorff" >"$csv"

for s in $surfaces; do
    sc=$(scene_of "$s")
    box=$(sed -n 's/^box *= *\([^;]*\).*/\1/p' "$sc" | tr -s ' ' | sed 's/ *$//')
    declare -A wall=() cpu=() rc=() mesher=()
    for ((r = 0; r < reps; r++)); do
        run build "$sc"
        run vdb "$sc" --mesh "$tmp/$s-vdb.ply"
        run cert "$sc" --mesh-certified "$tmp/$s-cert.ply"
        run cert0 "$sc" --mesh-certified "$tmp/$s-cert0.ply" --mesh-min-depth 0
        run certD "$sc" --mesh-certified "$tmp/$s-certD.ply" --mesh-min-depth "$depth"
        for v in build vdb cert cert0 certD; do
            read -r w c e <"$tmp/$v.t"
            wall[$v]=$(smaller "$w" "${wall[$v]:-}")
            cpu[$v]=$(smaller "$c" "${cpu[$v]:-}")
            rc[$v]=$e
            if [ "$e" = 0 ] && [ "$v" != build ] && [ "$v" != vdb ]; then
                t=$(json "$tmp/$v.json" mesh_certified.time_s)
                mesher[$v]=$(smaller "$(awk -v t="$t" 'BEGIN { printf "%.4f", t }')" "${mesher[$v]:-}")
            fi
        done
    done
    # the reference: points on the surface
    ref="$tmp/$s-ref.ply" refargs=(--reference "$ref" --reference-project)
    refname="OpenVDB depth $refdepth projected"
    if ! "$bin" build "$sc" --depth "$refdepth" --threads 2 --mesh "$ref" --quiet 2>/dev/null; then
        refargs=(--reference "$ref") refname="certified depth $refdepth"
        "$bin" build "$sc" --depth "$refdepth" --threads 2 --mesh-certified "$ref" --quiet \
            2>/dev/null || refargs=() refname=""
    fi
    for v in build vdb cert cert0 certD; do
        mw= mc= rw= rcp= cells= regions= msg= q=
        if [ "$v" != build ]; then
            mw=$(awk -v a="${wall[$v]}" -v b="${wall[build]}" 'BEGIN { printf "%.4f", a - b }')
            mc=$(awk -v a="${cpu[$v]}" -v b="${cpu[build]}" 'BEGIN { printf "%.4f", a - b }')
        fi
        if [ "${v#cert}" != "$v" ] && [ "${rc[vdb]}" = 0 ]; then
            vw=$(awk -v a="${wall[vdb]}" -v b="${wall[build]}" 'BEGIN { printf "%.6f", a - b }')
            vc=$(awk -v a="${cpu[vdb]}" -v b="${cpu[build]}" 'BEGIN { printf "%.6f", a - b }')
            # (no ratio to a --mesh time lost in the noise)
            rw=$(awk -v a="$mw" -v b="$vw" 'BEGIN { if (b > 0) printf "%.2f", a / b }')
            rcp=$(awk -v a="$mc" -v b="$vc" 'BEGIN { if (b > 0) printf "%.2f", a / b }')
        fi
        if [ "${rc[$v]}" != 0 ]; then
            msg=$(grep -v '^ ' "$tmp/$v.err" | head -n 1 | tr ',' ';')
        fi
        if [ "${rc[$v]}" = 3 ]; then
            # "the topology is not certified in N cells (max depth D), in R regions:"
            cells=$(sed -n 's/.*not certified in \([0-9]*\) cells.*/\1/p' "$tmp/$v.err" | head -n 1)
            regions=$(sed -n 's/.*, in \([0-9]*\) regions\{0,1\}:.*/\1/p' "$tmp/$v.err" | head -n 1)
        fi
        if [ "$v" != build ] && [ "${rc[$v]}" = 0 ]; then
            q=$("$quality" "$sc" "$tmp/$s-$v.ply" ${refargs[@]+"${refargs[@]}"})
        fi
        /usr/bin/python3 - "$s" "$box" "$depth" "$v" "${rc[$v]}" "${wall[$v]}" "${cpu[$v]}" "$mw" "$mc" \
            "${mesher[$v]:-}" "$rw" "$rcp" "$cells" "$regions" "$msg" "$refname" "$q" >>"$csv" <<'EOF'
import json, sys
a = sys.argv[1:]
q = json.loads(a[16]) if a[16] else {}
keys = ["triangles", "vertices", "closed_embedded", "boundary_edges", "nonmanifold_edges",
        "nonmanifold_vertices", "misoriented_edges", "intersecting_pairs", "euler", "components",
        "to_surface_max", "to_surface_mean", "to_surface_unconverged"]
row = a[:15] + [q.get(k, "") for k in keys] + [a[15] if q else ""]
row += [q.get(k, "") for k in ["to_mesh_max", "to_mesh_mean", "hausdorff"]]
print(",".join("" if x is None else str(x) for x in row))
EOF
    done
    unset wall cpu rc mesher
done
load_after=$(uptime)

# the table: one row per surface and variant, libfive's published times beside
/usr/bin/python3 - "$csv" "$load_before" "$load_after" "$depth" "$reps" >"$out/$name.md" <<'EOF'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
libfive = {"sphere": "0.32", "gumdrop": "3.7", "chubs": "1.2", "mcmullen-k3": "2.3"}
names = {"sphere": "sphere", "gumdrop": "gumdrop", "chubs": "chubs", "mcmullen-k3": "McMullen K3",
         "bretzel": "bretzel", "torus": "torus", "offset-sphere": "offset sphere",
         "thin-shell": "thin shell", "tiny-sphere": "tiny sphere"}
# the surface's Euler characteristic and components (in its box): from the equation
# (tests/test_mesh_certified.c; McMullen K3's from that test's dense sampling); chubs
# is singular (12 double points): no mesh is isotopic to it
truth = {"sphere": (2, 1), "gumdrop": (4, 3), "mcmullen-k3": (2, 1), "bretzel": (-2, 1),
         "torus": (0, 1), "offset-sphere": (2, 1), "thin-shell": (4, 2), "tiny-sphere": (2, 1)}
label = {"vdb": "`--mesh` (OpenVDB)", "cert": "`--mesh-certified`",
         "cert0": "`--mesh-certified --mesh-min-depth 0`",
         "certD": f"`--mesh-certified --mesh-min-depth {sys.argv[4]}`"}
print(f"Depth {sys.argv[4]}, one thread, best of {sys.argv[5]} interleaved runs.  Load before: "
      f"`{sys.argv[2].strip()}`; after: `{sys.argv[3].strip()}`.\n")
print("| surface (box) | libfive DC, published (s) | build alone (s) | mesh | mesh s (wall) | mesh s (CPU) "
      "| mesher s (own clock) | × `--mesh` (wall, CPU) | triangles | manifold check "
      "| χ, components (surface's) | mesh→surface max / mean | surface→mesh max / mean | Hausdorff |")
print("|---|---:|---:|---|---:|---:|---:|---:|---:|---|---:|---:|---:|---:|")
e = lambda x: f"{float(x):.1e}" if x not in ("", None) else ""
build = {}
for r in rows:
    s = r["surface"]
    if r["variant"] == "build":
        build[s] = r
        continue
    b = build[s]
    box = "[-2,2]³" if r["box"] == "-2 2 -2 2 -2 2" else f"[{r['box']}]"
    first = r["variant"] == "vdb"
    cells = [f"{names.get(s, s)} ({box})" if first else "", libfive.get(s, "–") if first else "",
             f"{float(b['wall_s']):.2f}" if first else "", label[r["variant"]]]
    ratio = f"{r['ratio_wall']}, {r['ratio_cpu']}" if r["ratio_wall"] else ""
    t = truth.get(s)
    if r["exit"] == "3":
        cells += [r["mesh_wall_s"], r["mesh_cpu_s"], "", ratio, "–",
                  f"refused (exit 3): {r['failed_cells']} cells, {r['failed_regions']} regions",
                  f"({t[0]}, {t[1]})" if t else "(singular)", "", "", ""]
    elif r["exit"] != "0":
        cells += ["", "", "", "", "–", f"**failed** (exit {r['exit']}): {r['message']}",
                  f"({t[0]}, {t[1]})" if t else "(singular)", "", "", ""]
    else:
        if r["closed_embedded"] == "1":
            topo = "closed, embedded"
        else:
            bad = [f"{r[k]} {k.replace('_', ' ')}" for k in ["boundary_edges", "nonmanifold_edges",
                   "nonmanifold_vertices", "misoriented_edges", "intersecting_pairs"] if r[k] not in ("", "0")]
            topo = "**fails**: " + ", ".join(bad)
        chi = f"{r['euler']}, {r['components']}"
        if t and (int(r["euler"]), int(r["components"])) != t:
            chi = f"**{chi}**"
        chi += f" ({t[0]}, {t[1]})" if t else " (singular)"
        cells += [r["mesh_wall_s"], r["mesh_cpu_s"], r["mesher_s"], ratio,
                  f"{int(r['triangles']):,}".replace(",", " "), topo, chi,
                  f"{e(r['to_surface_max'])} / {e(r['to_surface_mean'])}",
                  f"{e(r['to_mesh_max'])} / {e(r['to_mesh_mean'])}", e(r["hausdorff"])]
    print("| " + " | ".join(cells) + " |")
refs = sorted({(r["surface"], r["reference"]) for r in rows if r["reference"]})
print("\nReferences (surface→mesh): " + "; ".join(f"{names.get(s, s)}: {ref}" for s, ref in refs) + ".")
EOF
cat "$out/$name.md"
