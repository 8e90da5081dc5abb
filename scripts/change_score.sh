#!/usr/bin/env bash
# Issue 18: the magnetic change score against the simulator's truth (bench/change_bench, its
# header says how recall and precision are counted). Tuning seeds only, fixed before any run:
# the changed warehouse (configs/warehouse_changed.yaml) at seeds 1-10, and the warehouse that
# never changes (configs/warehouse.yaml) at seeds 1-5 (20 sessions), each with the seven-sensor
# array and one IMU magnetometer; realistic sensors, the default merge and change settings.
# Appends to docs/bench/change_score.csv, one row per seed and session pair, labelled LABEL
# (default: the checkout's commit, "+" when it has uncommitted changes); cases already there are
# skipped, so a cut run resumes. About a minute per seed and rig.
# BIN (default ./build) holds bench/change_bench: run from a copy to keep building meanwhile.
# Usage: [BIN=DIR] scripts/change_score.sh [LABEL]
set -euo pipefail
cd "$(dirname "$0")/.."
label=${1:-$(git rev-parse --short HEAD)$(git diff --quiet HEAD -- src include bench || echo +)}
bin=${BIN:-./build}
csv=docs/bench/change_score.csv
for rig in array7 imu; do
  for seed in $(seq 1 10); do
    "$bin/bench/change_bench" --world changed --rig "$rig" --first-seed "$seed" --seeds 1 \
      --csv "$csv" --label "$label"
  done
  for seed in $(seq 1 5); do
    "$bin/bench/change_bench" --world unchanged --rig "$rig" --first-seed "$seed" --seeds 1 \
      --csv "$csv" --label "$label"
  done
done
