#!/usr/bin/env python3
"""The one-thread render times of bench/ray.sh in the layout of Flórez's table
(Flórez 2008; docs/surfaces.md): rows the methods, columns the surfaces.

    python3 bench/florez_table.py bench/results/ray.csv > table.md

Blocks: render s with the octree (and the octree build s, and build + render
as "total"), render s without it, each method's time over Mitchell's on the
same surface (octree, and no octree), and the published Pentium 4 table with
its own ratios.  When the CSV has baseline columns (bench/ray.sh --baseline),
the baseline's blocks and the speed-up baseline / this build per cell follow.
"""
import csv
import math
import sys

SURFACES = ["sphere", "drop", "chubs", "crosscap", "gumdrop", "horned-cube", "mcmullen-k3",
            "kusner-schmitt"]
HEAD = ["sphere", "drop", "chubs", "crosscap", "gumdrop", "horned cube", "McMullen K3",
        "Kusner–Schmitt"]
METHODS = ["mitchell", "newton", "newton-ah", "mrfro", "mrfro-newton", "lipschitz", "sampling"]
NAMES = {"mitchell": "Mitchell", "newton": "Newton", "newton-ah": "Newton+AH", "mrfro": "MRFro",
         "mrfro-newton": "MRFro+Newton", "lipschitz": "Lipschitz (K–B)",
         "sampling": "sampling (not certified)"}
# Flórez 2008, seconds on a Pentium 4 (docs/surfaces.md)
PUBLISHED = {
    "mitchell": [20, 36, 98, 80, 240, 99, 102, 75],
    "newton": [28, 47, 94, 96, 260, 180, 123, 94],
    "newton-ah": [27, 46, 92, 99, 202, 166, 110, 86],
    "mrfro": [48, 103, 188, 105, 541, 272, 276, 210],
    "mrfro-newton": [55, 96, 174, 151, 380, 283, 221, 173],
}


def num(x):
    try:
        v = float(x)
    except (TypeError, ValueError):
        return math.nan
    return v


def main():
    rows = list(csv.DictReader(open(sys.argv[1])))
    cell = {(r["surface"], r["method"]): r for r in rows}
    surfaces = [s for s in SURFACES if any(k[0] == s for k in cell)]
    methods = [m for m in METHODS if any(k[1] == m for k in cell)]
    head = [HEAD[SURFACES.index(s)] for s in surfaces]
    build = {s: num(next(r for k, r in cell.items() if k[0] == s)["build_s"]) for s in surfaces}

    def get(s, m, col):
        r = cell.get((s, m))
        return num(r[col]) if r and col in r else math.nan

    def fmt(v, spec):
        return "–" if math.isnan(v) else spec % v

    def table(title, value, spec, extra=()):
        print("**%s**\n" % title)
        print("| | " + " | ".join(head) + " |")
        print("|---|" + "---:|" * len(head))
        for m in methods:
            print("| %s | %s |" % (NAMES[m], " | ".join(fmt(value(s, m), spec) for s in surfaces)))
        for name, f, sp in extra:
            print("| %s | %s |" % (name, " | ".join(fmt(f(s), sp) for s in surfaces)))
        print()

    def ratio(col):
        return lambda s, m: get(s, m, col) / get(s, "mitchell", col)

    def best_certified(col):
        return lambda s: min((get(s, m, col) for m in methods if m != "sampling"),
                             default=math.nan)

    def blocks(label, oct_col, none_col):
        table("%s: render s, 1 thread, with the octree" % label,
              lambda s, m: get(s, m, oct_col), "%.3f",
              [("octree build s (2 threads, apart)", lambda s: build[s], "%.3f"),
               ("total: build + best certified render", lambda s: build[s] + best_certified(oct_col)(s),
                "%.3f")])
        table("%s: render s, 1 thread, no octree (--no-octree)" % label,
              lambda s, m: get(s, m, none_col), "%.3f",
              [("best certified", best_certified(none_col), "%.3f")])
        table("%s: time / Mitchell's, with the octree" % label, ratio(oct_col), "%.2f")
        table("%s: time / Mitchell's, no octree" % label, ratio(none_col), "%.2f")

    blocks("This build", "octree_1t_s", "none_1t_s")
    if any(not math.isnan(num(r.get("base_octree_1t_s"))) for r in rows):
        blocks("Baseline", "base_octree_1t_s", "base_none_1t_s")
        table("Speed-up, baseline s / this build's s, with the octree",
              lambda s, m: get(s, m, "base_octree_1t_s") / get(s, m, "octree_1t_s"), "%.2f")
        table("Speed-up, baseline s / this build's s, no octree",
              lambda s, m: get(s, m, "base_none_1t_s") / get(s, m, "none_1t_s"), "%.2f")
    print("**Published (Flórez 2008, Pentium 4, s; no octree)**, and / Mitchell's\n")
    print("| | " + " | ".join(head) + " |")
    print("|---|" + "---:|" * len(head))
    for m in methods:
        if m in PUBLISHED:
            p = PUBLISHED[m]
            print("| %s | %s |" % (NAMES[m], " | ".join(
                "%d (%.2f)" % (p[SURFACES.index(s)], p[SURFACES.index(s)] / PUBLISHED["mitchell"][SURFACES.index(s)])
                for s in surfaces)))
    print()


main()
