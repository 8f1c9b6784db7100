#!/usr/bin/env bash
# The demo that `make demo` runs: the default scene (scenes/gumdrop.ini).
# Usage: scripts/demo.sh [PATH-TO-IVOCT]   (default build/release/cli/ivoct)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

ivoct="${1:-build/release/cli/ivoct}"
mkdir -p out

# ---- demo commands ----------------------------------------------------------
scene=scenes/gumdrop.ini
"$ivoct" build "$scene" --depth 7 --cells out/gumdrop.csv --stats out/gumdrop.json \
    --save out/gumdrop.ivo --vtu out/gumdrop.vtu --htg out/gumdrop.htg --vdb out/gumdrop.vdb \
    --mesh-certified out/gumdrop.vtp
"$ivoct" render "$scene" --octree out/gumdrop.ivo --png out/gumdrop.png --stats out/gumdrop-render.json
"$ivoct" info out/gumdrop.ivo
echo
echo "outputs in out/: gumdrop.csv (surface cells), gumdrop.json (build stats),"
echo "gumdrop.ivo (octree), gumdrop.vtu / .htg (ParaView), gumdrop.vdb (OpenVDB),"
echo "gumdrop.vtp (a mesh with certified topology: two spheres and a torus),"
echo "gumdrop.png and gumdrop-render.json (ray cast with the octree)"
# -----------------------------------------------------------------------------
