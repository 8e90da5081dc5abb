#!/usr/bin/env bash
# The frame's height above the floor from the scans (geometry/floor_height, issue 32):
# bench/floor_height_bench on the tuning worlds (warehouse, corridor and procedural seeds 1-5,
# every rig, frames at 0, 0.6 and 1.5 m) and the real scan pair in ../shared/data (no truth: found
# or not, and the floor rule's contrast), rows appended to docs/bench/floor_height.csv; a case
# already there is skipped, so a cut run resumes. About 30 minutes on 2 cores. Then
# `python3 scripts/bench_tables.py` tables it in docs/benchmarks.md.
# FLOOR_HEIGHT_BENCH overrides the program (default ./build/bench/floor_height_bench).
set -euo pipefail
cd "$(dirname "$0")/.."
bench=${FLOOR_HEIGHT_BENCH:-./build/bench/floor_height_bench}
"$bench" --seeds 5 --presets warehouse,corridor,procedural --rigs imu,husky3,array7,handheld \
  --raised 0,0.6,1.5 --real-scan-pair ../shared/data/koide-gicp-lidar-scan-pair/small_gicp \
  --csv docs/bench/floor_height.csv
