#!/usr/bin/env bash
# The joint rule's tuning run (issue 31 slice 4): bench/match_bench --methods joint on the
# procedural tuning worlds (seeds 1-20; docs/heldout_set.md holds 2001 and up out) with the
# joint rule opened up (bench/joint_features.yaml) and the field's match as the default runs it,
# realistic sensors calibrated as merge does. Rows whose stage is "joint" are the pairs the field
# refused, with the best structure candidate the field chose and its features; the rule is then
# chosen by scripts/choose_thresholds.py --stage joint. One CSV per rig,
# docs/bench/joint_tuning_<rig>.csv, grown a seed at a time: a cut run resumes at the first seed
# the CSV lacks. MATCH_BENCH overrides the program (default ./build/bench/match_bench) and
# CODE_LABEL the commit recorded in docs/bench/joint_tuning.commits (default: HEAD's).
# Usage: scripts/joint_tuning.sh [RIG ...]   (default: imu handheld)
set -euo pipefail
cd "$(dirname "$0")/.."
bench=${MATCH_BENCH:-./build/bench/match_bench}
label=${CODE_LABEL:-$(git rev-parse --short HEAD)}
rigs=("$@")
[ ${#rigs[@]} -gt 0 ] || rigs=(imu handheld)
tmp=$(mktemp)
trap 'rm -f "$tmp"' EXIT
for rig in "${rigs[@]}"; do
  csv=docs/bench/joint_tuning_$rig.csv
  for seed in $(seq 1 20); do
    if [ -f "$csv" ] && cut -d, -f5 "$csv" | grep -qx "$seed"; then continue; fi
    "$bench" --presets procedural --first-seed "$seed" --seeds 1 --rigs "$rig" \
      --sensors realistic --calibrations estimated --methods joint \
      --matcher bench/joint_features.yaml --csv "$tmp" > /dev/null 2>&1
    if [ -f "$csv" ]; then tail -n +2 "$tmp" >> "$csv"; else cp "$tmp" "$csv"; fi
    echo "$rig,$seed,$label" >> docs/bench/joint_tuning.commits
    echo "$rig seed $seed: $(($(wc -l < "$tmp") - 1)) pairs"
  done
done
