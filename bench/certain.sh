#!/usr/bin/env bash
# Certain leaves: point witnesses against modal intervals, by depth.
#
#   bash bench/certain.sh [--build DIR] [--quick] [--reps N] [--cap S]
#                         [--surfaces "sphere ..."] [--depths "6 7 8 9 10"]
#                         [--default-depths "6 7 8"] [--out NAME]
#
# For each comparison surface (tests/support/testutil.c: tu_comparison_surfaces) and
# depth, ivoct_bench_certain (bench/certain.c) builds the octree on one thread and
# runs the two passes over its surface leaves, each timed alone: the witnesses of
# oct_certify and the modal inner estimate of mod_inner_range; it counts the leaves
# each proves, both, neither, and those only their hull proves.  Chains:
# `interval, ilie` at --depths (default 6-10) and the default `interval, lipschitz`
# at --default-depths (default 6-8).  At each depth the two chains run alternately,
# --reps times (default 2; the counts do not change, each time is the best of the
# runs).  A configuration whose run (one of the --reps) is predicted over --cap seconds
# (default 60; the same surface and chain one depth up costs 4.5x the one below: leaves
# grow ~4x a level) is skipped and marked so, and so are the deeper ones.  Writes
# bench/results/NAME.csv and NAME.md (NAME: certain, or certain-quick with --quick:
# sphere and gumdrop at depths 6-7, one run), with `uptime` before and after.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/.." && pwd)
build=$root/build/release
reps=2
cap=60
surfaces="sphere drop chubs crosscap gumdrop horned-cube mcmullen-k3 kusner-schmitt"
depths="6 7 8 9 10"
ddepths="6 7 8"
name=certain
quick=0
surfaces_given=0
while [ $# -gt 0 ]; do
    case $1 in
    --build) build=$2; shift ;;
    --reps) reps=$2; shift ;;
    --cap) cap=$2; shift ;;
    --surfaces) surfaces=$2 surfaces_given=1; shift ;;
    --depths) depths=$2; shift ;;
    --default-depths) ddepths=$2; shift ;;
    --out) name=$2; shift ;;
    --quick) quick=1 ;;
    -h | --help) sed -n '2,20p' "$0"; exit 0 ;;
    *) echo "bench/certain.sh: unknown option $1" >&2; exit 2 ;;
    esac
    shift
done
if [ "$quick" = 1 ]; then
    depths="6 7" ddepths="6 7" reps=1
    [ "$surfaces_given" = 1 ] || surfaces="sphere gumdrop"
    [ "$name" = certain ] && name=certain-quick
fi
tool=$build/bench/ivoct_bench_certain
[ -x "$tool" ] || { echo "bench/certain.sh: no $tool (build first, or --build DIR)" >&2; exit 2; }
out=$root/bench/results
mkdir -p "$out"
tmp=$(mktemp -d /tmp/ivoct-certain.XXXXXX)
trap 'rm -rf "$tmp"' EXIT
# a copy: a rebuild of the build tree during the run changes nothing here
cp "$tool" "$tmp/tool" && tool=$tmp/tool
load_before=$(uptime)

csv=$out/$name.csv
echo "surface,chain,depth,leaves,witness,modal,witness_only,modal_only,both,neither,hull_only,build_s,witness_s,modal_s,wall_s,modal_no_inner,modal_one_sign,skipped" >"$csv"

# one run: the JSON line into $tmp/KEY.json (kept: the best times), wall seconds printed
one() {
    local key=$1 s=$2 d=$3 chain=$4
    local t0 t1
    t0=$(date +%s.%N)
    "$tool" "$root/scenes/$s.ini" "$d" --tests "$chain" >"$tmp/run.json"
    t1=$(date +%s.%N)
    /usr/bin/python3 - "$tmp/run.json" "$tmp/$key.json" "$t0" "$t1" <<'EOF'
import json, os, sys
new = json.load(open(sys.argv[1]))
new["wall_s"] = float(sys.argv[4]) - float(sys.argv[3])
if os.path.exists(sys.argv[2]):
    old = json.load(open(sys.argv[2]))
    for k in ("build_s", "witness_s", "modal_s", "wall_s"):
        new[k] = min(new[k], old[k])
json.dump(new, open(sys.argv[2], "w"))
print(f"{new['wall_s']:.3f}")
EOF
}

all_depths=$(printf '%s\n' $depths $ddepths | sort -n | uniq)
for s in $surfaces; do
    declare -A last=()
    for d in $all_depths; do
        chains=()
        for x in $depths; do [ "$x" = "$d" ] && chains+=("interval, ilie"); done
        for x in $ddepths; do [ "$x" = "$d" ] && chains+=("interval, lipschitz"); done
        run=()
        for c in "${chains[@]}"; do
            pred=$(awk -v w="${last[$c]:-0}" 'BEGIN { printf "%.1f", 4.5 * w }')
            if awk -v p="$pred" -v c="$cap" 'BEGIN { exit !(p > c) }'; then
                echo "$s,$c,$d,,,,,,,,,,,,,,,skipped (predicted ${pred} s)" | sed 's/interval, /interval; /' >>"$csv"
                last[$c]=1e9
            else
                run+=("$c")
            fi
        done
        [ ${#run[@]} -gt 0 ] || continue
        for ((r = 0; r < reps; r++)); do
            for c in "${run[@]}"; do
                w=$(one "$s-$d-${c//[ ,]/}" "$s" "$d" "$c")
                [ "$r" -gt 0 ] || last[$c]=$w
            done
        done
        for c in "${run[@]}"; do
            /usr/bin/python3 - "$tmp/$s-$d-${c//[ ,]/}.json" "$s" >>"$csv" <<'EOF'
import json, sys
j = json.load(open(sys.argv[1]))
st = j["modal_status"]
row = [sys.argv[2], j["tests"].replace(", ", "; "), j["depth"], j["leaves"], j["witness"], j["modal"],
       j["witness_only"], j["modal_only"], j["both"], j["neither"], j["hull_only"],
       f"{j['build_s']:.4f}", f"{j['witness_s']:.4f}", f"{j['modal_s']:.4f}", f"{j['wall_s']:.3f}",
       st.get("no inner estimate (improper result)", 0), st.get("ok_one_sign", 0), ""]
print(",".join(str(x) for x in row))
EOF
        done
    done
    unset last
done
load_after=$(uptime)

/usr/bin/python3 - "$csv" "$load_before" "$load_after" "$reps" >"$out/$name.md" <<'EOF'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
names = {"sphere": "sphere", "drop": "drop", "chubs": "chubs", "crosscap": "crosscap",
         "gumdrop": "gumdrop", "horned-cube": "horned cube", "mcmullen-k3": "McMullen K3",
         "kusner-schmitt": "Kusner–Schmitt"}
print(f"One thread, best of {sys.argv[4]} runs (the chains alternating).  Load before: "
      f"`{sys.argv[2].strip()}`; after: `{sys.argv[3].strip()}`.\n")
# two summaries, one row per surface and chain, one column per depth: the shares of
# leaves proved (witnesses / modal), and the passes' times over the build's
depths = sorted({int(r["depth"]) for r in rows})
groups = []
for r in rows:
    if (r["surface"], r["chain"]) not in groups:
        groups.append((r["surface"], r["chain"]))
def summary(title, cell):
    print(f"{title}\n")
    print("| surface | chain | " + " | ".join(f"depth {d}" for d in depths) + " |")
    print("|---|---|" + "---:|" * len(depths))
    for s, c in groups:
        by = {int(r["depth"]): r for r in rows if (r["surface"], r["chain"]) == (s, c)}
        out = []
        for d in depths:
            r = by.get(d)
            out.append("" if r is None else "skipped" if r["skipped"] else cell(r))
        print(f"| {names.get(s, s)} | {c.replace('; ', ', ')} | " + " | ".join(out) + " |")
    print()
share = lambda r, k: 100 * int(r[k]) / int(r["leaves"]) if int(r["leaves"]) else 0
summary("Surface leaves proved to hold surface: by witnesses / by the modal estimate "
        "(modal only and hull only: 0 unless marked)",
        lambda r: f"{share(r, 'witness'):.1f} / {share(r, 'modal'):.1f} %"
        + (f" (+{r['modal_only']} modal only)" if r["modal_only"] != "0" else "")
        + (f" (+{r['hull_only']} hull only)" if r["hull_only"] != "0" else ""))
summary("The passes' time over the build's: witnesses / modal (build seconds in brackets)",
        lambda r: f"{float(r['witness_s']) / float(r['build_s']):.2f} / "
        f"{float(r['modal_s']) / float(r['build_s']):.2f} ({float(r['build_s']):.3f})")
print("All configurations:\n")
print("| surface | chain | depth | leaves | witnesses | modal | both | witnesses only | modal only "
      "| neither | hull only | build s | witness pass s (× build) | modal pass s (× build) |")
print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
pct = lambda a, n: f"{100 * int(a) / int(n):.1f} %" if int(n) else "–"
for r in rows:
    chain = r["chain"].replace("; ", ", ")
    head = [names.get(r["surface"], r["surface"]), chain, r["depth"]]
    if r["skipped"]:
        print("| " + " | ".join(head + [r["skipped"]] + [""] * 10) + " |")
        continue
    n, b = r["leaves"], float(r["build_s"])
    x = lambda t: f"{float(t):.3f} ({float(t) / b:.2f}×)" if b > 0 else f"{float(t):.3f}"
    print("| " + " | ".join(head + [f"{int(n):,}".replace(",", " "), pct(r["witness"], n), pct(r["modal"], n),
          pct(r["both"], n), pct(r["witness_only"], n), r["modal_only"], pct(r["neither"], n),
          r["hull_only"], f"{b:.3f}", x(r["witness_s"]), x(r["modal_s"])]) + " |")
EOF
cat "$out/$name.md"
