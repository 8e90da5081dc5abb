#!/usr/bin/env bash
# The README's main command: installs, builds, simulates the shipped small corridor scenario and
# renders every session. Outputs go to out/demo/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/build.sh
out=out/demo
./build/mm4mm simulate --config configs/corridor_small.yaml --seed 7 --out "$out/sessions"
for session in "$out"/sessions/s*; do
  ./build/mm4mm render "$session" --out "$out/$(basename "$session").png"
done
echo "demo: sessions in $out/sessions, pictures in $out/*.png"
