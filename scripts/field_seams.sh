#!/usr/bin/env bash
# Seams between sessions in the fused magnetic map (issue 32): bench/field_seams_bench on the
# warehouse and corridor presets, one sensor and the 7-sensor array, realistic sensors calibrated
# as merge does. Tuning seeds 1-3 while the work goes on; the held-out figures (seeds 2001 and up,
# docs/heldout_set.md) are run once at the end. Appends to docs/bench/field_seams.csv under LABEL
# (default: the commit, "+" when the tree has changes), one bench run per preset, rig and seed,
# skipping those the CSV already holds under that label (a cut run resumes). About 10 minutes.
# Each case runs twice: with the Earth's vertical field the simulated sessions state (the fused
# map's B_v anchored on it), and under LABEL:sum0 without it (the offsets sum to zero).
# Each session's vertical hard iron as the atlas ends up with it (the calibration's less the fused
# map's B_v offset) against the true one goes to docs/bench/field_seams_hard_iron.csv (issue 32's
# proof: within 1 µT where the anchor is given).
# FIELD_SEAMS_BENCH overrides the program (default ./build/bench/field_seams_bench); RIGS the rigs
# (default "imu array7"; handheld is the rig whose calibration observes its own vertical).
# Usage: scripts/field_seams.sh [LABEL]
set -euo pipefail
cd "$(dirname "$0")/.."
bench=${FIELD_SEAMS_BENCH:-./build/bench/field_seams_bench}
label=${1:-$(git rev-parse --short HEAD)$(git diff --quiet HEAD -- src include || echo +)}
csv=docs/bench/field_seams.csv
for preset in warehouse corridor; do
  for rig in ${RIGS:-imu array7}; do
    for seed in 1 2 3; do
      for earth in stated none; do
        run=$label
        [ "$earth" = stated ] || run=$label:sum0
        if [ -f "$csv" ] && grep -q "^$run,$preset,$rig,$seed,fused," "$csv"; then continue; fi
        "$bench" --presets "$preset" --rigs "$rig" --first-seed "$seed" --seeds 1 --label "$run" \
          --earth-vertical "$earth" --csv "$csv" \
          --hard-iron-csv docs/bench/field_seams_hard_iron.csv 2>/dev/null
        echo "$run $preset $rig seed $seed"
      done
    done
  done
done
