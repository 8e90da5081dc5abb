#!/usr/bin/env bash
# Matching on the procedural tuning worlds (seeds 1-20; docs/heldout_set.md holds 2001 and up
# out): every pair's best mode with its features (z, r, second-mode ratio, overlap area and
# shape, the field it holds, the sessions' calibration), the confidence rule opened up
# (bench/matcher_features.yaml: the search as the default runs it) so that a rule can be fitted
# offline. One CSV per rig,
# docs/bench/procedural_tuning_<rig>.csv, grown a seed at a time: a cut run resumes at the first
# seed the CSV lacks. Assumes scripts/build.sh has run.
# The run is named NAME (default procedural_tuning: CSVs docs/bench/NAME_<rig>.csv, commits in
# docs/bench/NAME.commits) with match_bench's METHODS (default: default) and MATCHER (default
# bench/matcher_features.yaml); MATCH_BENCH overrides the program (default
# ./build/bench/match_bench) and CODE_LABEL the commit recorded (default: HEAD's).
# Usage: scripts/procedural_tuning.sh [RIG ...]   (default: imu array7)
set -euo pipefail
cd "$(dirname "$0")/.."
name=${NAME:-procedural_tuning}
bench=${MATCH_BENCH:-./build/bench/match_bench}
label=${CODE_LABEL:-$(git rev-parse HEAD)}
rigs=("$@")
[ ${#rigs[@]} -gt 0 ] || rigs=(imu array7)
tmp=$(mktemp)
trap 'rm -f "$tmp"' EXIT
for rig in "${rigs[@]}"; do
  csv=docs/bench/${name}_$rig.csv
  for seed in $(seq 1 20); do
    if [ -f "$csv" ] && cut -d, -f5 "$csv" | grep -qx "$seed"; then continue; fi
    "$bench" --presets procedural --first-seed "$seed" --seeds 1 --rigs "$rig" \
      --sensors realistic --calibrations estimated --methods "${METHODS:-default}" \
      --matcher "${MATCHER:-bench/matcher_features.yaml}" --csv "$tmp" > /dev/null 2>&1
    if [ -f "$csv" ]; then tail -n +2 "$tmp" >> "$csv"; else cp "$tmp" "$csv"; fi
    echo "$rig,$seed,$label" >> "docs/bench/$name.commits"
    echo "$rig seed $seed: $(($(wc -l < "$tmp") - 1)) pairs"
  done
done
