#!/usr/bin/env bash
# The README's main command: installs, builds, simulates the shipped small corridor scenario,
# maps and draws every session, and matches consecutive sessions magnetically. Outputs go to
# out/demo/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/build.sh
out=out/demo
./build/mm4mm simulate --config configs/corridor_small.yaml --seed 7 --out "$out/sessions"
for session in "$out"/sessions/s*; do
  id=$(basename "$session")
  ./build/mm4mm render "$session" --out "$out/$id.png"
  ./build/mm4mm map "$session" --out "$out/map_$id"
done
# Exit code 3 means "no overlap" or "ambiguous": an answer, not a failure of the demo.
for pair in "s0 s1" "s1 s2"; do
  set -- $pair
  ./build/mm4mm match "$out/sessions/$1" "$out/sessions/$2" || [ $? -eq 3 ]
done
echo "demo: sessions in $out/sessions, pictures in $out/*.png, maps in $out/map_*"
