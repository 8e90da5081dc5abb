#!/usr/bin/env bash
# One warehouse pair's match time (issue 33): bench/match_speed_bench on warehouse seeds 1-5
# (s0 + s1 of each, realistic sensors calibrated as merge does), on every core and on one thread,
# beside PCL's GICP on the same pair's 0.25 m point maps in the same process. Appends rows labelled
# LABEL (default: the checkout's commit, "+" when it has uncommitted changes) to
# docs/bench/match_speed.csv; a label already there is not run again. Then perf's share of the
# cycles per library for `mm4mm match` of one simulated warehouse pair (seed 3, every core) in
# docs/bench/match_speed_perf_LABEL.txt. Assumes scripts/build.sh has run with
# MM4MM_BUILD_BENCHMARKS=ON. About 2 minutes.
# Usage: scripts/match_speed.sh [LABEL]
set -euo pipefail
cd "$(dirname "$0")/.."
label=${1:-$(git rev-parse --short HEAD)$(git diff --quiet HEAD -- src include || echo +)}
./build/bench/match_speed_bench --seeds 5 --first-seed 1 --csv docs/bench/match_speed.csv \
  --label "$label"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
./build/mm4mm simulate --world warehouse --sessions 2 --seed 3 --out "$tmp/wh" >/dev/null 2>&1
perf record -q -o "$tmp/perf.data" ./build/mm4mm match "$tmp/wh/s0" "$tmp/wh/s1" >/dev/null 2>&1
scripts/perf_summary.sh "$tmp/perf.data" \
  "perf record of mm4mm match, warehouse seed 3 s0 + s1, code $label" 8 12 \
  > "docs/bench/match_speed_perf_$label.txt"
cat "docs/bench/match_speed_perf_$label.txt"
