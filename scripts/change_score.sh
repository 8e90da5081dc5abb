#!/usr/bin/env bash
# Issue 18: the magnetic change score against the simulator's truth (bench/change_bench, its
# header says how recall and precision are counted). Tuning seeds only, fixed before any run:
# the changed warehouse (configs/warehouse_changed.yaml) at seeds 1-10, and the warehouse that
# never changes (configs/warehouse.yaml) at seeds 1-5 (20 sessions), each with the seven-sensor
# array and one IMU magnetometer; realistic sensors, the default merge and change settings.
# Appends to docs/bench/change_score.csv, one row per seed and session pair, labelled LABEL
# (default: the checkout's commit, "+" when it has uncommitted changes); cases already there are
# skipped, so a cut run resumes. About a minute per seed and rig.
# SEEDS=heldout runs the held-out set of docs/heldout_set.md instead (fixed there before any run):
# the changed warehouse at seeds 14001-14010 and the unchanged one at 14001-14005, both rigs, into
# docs/bench/heldout_change.csv; run once, with the settings scripts/choose_change_settings.py chose.
# BIN (default ./build) holds bench/change_bench: run from a copy to keep building meanwhile.
# Usage: [BIN=DIR] [SEEDS=tuning|heldout] scripts/change_score.sh [LABEL]
set -euo pipefail
cd "$(dirname "$0")/.."
label=${1:-$(git rev-parse --short HEAD)$(git diff --quiet HEAD -- src include bench || echo +)}
bin=${BIN:-./build}
case "${SEEDS:-tuning}" in
  tuning) first=1 csv=docs/bench/change_score.csv ;;
  heldout) first=14001 csv=docs/bench/heldout_change.csv ;;
  *) echo "change_score: SEEDS is tuning or heldout, not $SEEDS" >&2; exit 2 ;;
esac
for rig in array7 imu; do
  for seed in $(seq "$first" $((first + 9))); do
    "$bin/bench/change_bench" --world changed --rig "$rig" --first-seed "$seed" --seeds 1 \
      --csv "$csv" --label "$label"
  done
  for seed in $(seq "$first" $((first + 4))); do
    "$bin/bench/change_bench" --world unchanged --rig "$rig" --first-seed "$seed" --seeds 1 \
      --csv "$csv" --label "$label"
  done
done
