#!/usr/bin/env bash
# The README's main command: installs, builds, simulates the shipped small corridor scenario,
# merges its sessions into one atlas, prints the evaluation against ground truth and draws the
# atlas. Outputs go to out/demo/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/build.sh
out=out/demo
rm -rf "$out"
./build/mm4mm simulate --config configs/corridor_small.yaml --seed 7 --out "$out/sessions"
./build/mm4mm merge "$out"/sessions/s* --out "$out/atlas"
./build/mm4mm eval "$out/atlas"
./build/mm4mm render "$out/atlas" --out "$out/atlas.png"
echo "demo: atlas in $out/atlas (merged.pcd/.ply, magnetic_map.pcd/.png, octomap.bt, report.json)," \
  "pictures $out/atlas.png, $out/atlas_magnetic.png and $out/atlas_seams_{before,after}.png"
