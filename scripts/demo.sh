#!/usr/bin/env bash
# The demo that `make demo` runs: the default scene (scenes/gumdrop.ini).
# Usage: scripts/demo.sh [PATH-TO-IVOCT]   (default build/release/cli/ivoct)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

ivoct="${1:-build/release/cli/ivoct}"
mkdir -p out

# ---- demo commands ----------------------------------------------------------
# For now: a rigorous enclosure of f and its gradient over the whole box.
# To be replaced once `ivoct build` exists by:
#   "$ivoct" build scenes/gumdrop.ini --cells out/gumdrop.csv --stats out/gumdrop.json
"$ivoct" eval scenes/gumdrop.ini --box -2 2 -2 2 -2 2 --grad --json > out/gumdrop-eval.json.tmp
mv out/gumdrop-eval.json.tmp out/gumdrop-eval.json
echo "out/gumdrop-eval.json:"
cat out/gumdrop-eval.json
# -----------------------------------------------------------------------------
