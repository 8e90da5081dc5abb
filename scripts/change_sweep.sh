#!/usr/bin/env bash
# Issue 18, slice 1: the magnetic change score at every setting of bench/change_bench's sweep grid
# (noise floor, chi-square, least region area, scale on each session's calibration evidence), for
# scripts/choose_change_settings.py. Tuning seeds only, the cases of scripts/change_score.sh fixed
# before any run: the changed warehouse (configs/warehouse_changed.yaml) at seeds 1-10 and the
# warehouse that never changes at seeds 1-5 (20 sessions), each with the seven-sensor array and
# one IMU magnetometer; realistic sensors, the default merge. Appends one row per seed and setting
# to docs/bench/change_sweep.csv, labelled LABEL (default: the checkout's commit, "+" when it has
# uncommitted changes); seeds already there are skipped, so a cut run resumes. About a minute
# and a half per seed and rig.
# BIN (default ./build) holds bench/change_bench: run from a copy to keep building meanwhile.
# Usage: [BIN=DIR] scripts/change_sweep.sh [LABEL]
set -euo pipefail
cd "$(dirname "$0")/.."
label=${1:-$(git rev-parse --short HEAD)$(git diff --quiet HEAD -- src include bench || echo +)}
bin=${BIN:-./build}
csv=docs/bench/change_sweep.csv
for seed in $(seq 1 10); do
  for rig in array7 imu; do
    "$bin/bench/change_bench" --world changed --rig "$rig" --first-seed "$seed" --seeds 1 \
      --label "$label" --sweep "$csv"
    if [ "$seed" -le 5 ]; then
      "$bin/bench/change_bench" --world unchanged --rig "$rig" --first-seed "$seed" --seeds 1 \
        --label "$label" --sweep "$csv"
    fi
  done
done
