#!/usr/bin/env bash
# Which sessions an atlas places (issue 32): bench/field_seams_bench's --placement-csv on the
# tuning worlds (procedural seeds 1-5, warehouse and corridor seeds 1-3), the mixed set (the first
# session carried by hand, the others by the imu robot) and the imu robot alone, realistic
# sensors calibrated as merge does. Per merge: sessions placed, the frame session, how many the
# first session's group of the spanning tree held (what the atlas placed while it always took the
# first session's frame), and the placed pairs that overlap by the truth, aligned or not. Appends
# to docs/bench/field_seams_placement.csv under LABEL (default: the commit, "+" when the tree has
# changes), skipping the cases the CSV already holds under that label (a cut run resumes). The
# seams and vertical biases of these merges are not kept (scripts/field_seams.sh keeps its own).
# FIELD_SEAMS_BENCH overrides the program (default ./build/bench/field_seams_bench).
# Usage: scripts/placement_check.sh [LABEL]
set -euo pipefail
cd "$(dirname "$0")/.."
bench=${FIELD_SEAMS_BENCH:-./build/bench/field_seams_bench}
label=${1:-$(git rev-parse --short HEAD)$(git diff --quiet HEAD -- src include || echo +)}
csv=docs/bench/field_seams_placement.csv
scratch=$(mktemp)
trap 'rm -f "$scratch" "$scratch.hard_iron"' EXIT
for preset in procedural warehouse corridor; do
  seeds="1 2 3"
  [ "$preset" = procedural ] && seeds="1 2 3 4 5"
  for rig in handheld+imu imu; do
    for seed in $seeds; do
      if [ -f "$csv" ] && grep -q "^$label,$preset,$rig,$seed," "$csv"; then continue; fi
      "$bench" --presets "$preset" --rigs "$rig" --first-seed "$seed" --seeds 1 --label "$label" \
        --earth-vertical stated --csv "$scratch" --placement-csv "$csv" 2>/dev/null
      echo "$label $preset $rig seed $seed"
    done
  done
done
