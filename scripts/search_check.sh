#!/usr/bin/env bash
# Does a faster search give the exhaustive search's answers (issue 33, "same answers")?
# METHOD compass: the compass window (slice 2); pyramid: coarse to fine over x, y (slice 3);
# refine_all: every mode of the sweep refined (refine_modes = max_modes), not the best three;
# joint_pyramid: the joint stage with its structure modes proposed by coarse to fine (slice 4),
# compared with the joint stage as merge runs it (method joint) instead of the exhaustive sweep.
# bench/match_bench with methods METHOD and exhaustive (every yaw and shift on the search's
# cells; joint for joint_pyramid) on tuning worlds: procedural seeds 1-10 with every rig, warehouse seeds 1-5 with one
# sensor and the array; realistic sensors, calibration estimated. Appends to
# docs/bench/METHOD_check.csv, one match_bench run per world, rig and seed, skipping those
# already there (a cut run resumes). Tuning seeds only: the held-out check is run once at the
# end with the held-out set (docs/heldout_set.md). About 45 minutes.
# MATCH_BENCH overrides the program (default ./build/bench/match_bench); NAME the CSV's name
# (default METHOD_check: a changed search gets a CSV of its own beside the old one's).
# Usage: scripts/search_check.sh compass|pyramid|refine_all|joint_pyramid
set -euo pipefail
cd "$(dirname "$0")/.."
method=${1:?usage: scripts/search_check.sh compass|pyramid|refine_all|joint_pyramid}
case "$method" in compass | pyramid | refine_all) baseline=exhaustive ;; joint_pyramid) baseline=joint ;; *) echo "search_check: unknown method $method" >&2; exit 2 ;; esac
bench=${MATCH_BENCH:-./build/bench/match_bench}
name=${NAME:-${method}_check}
csv=docs/bench/$name.csv
tmp=$(mktemp)
trap 'rm -f "$tmp"' EXIT
run() {  # preset rig seed
  local key="$1,$2,$3"
  if [ -f "$csv" ] && grep -qx "$key" <(cut -d, -f1,2,5 "$csv" | sed 's/^procedural:[a-z]*/procedural/'); then
    return
  fi
  "$bench" --presets "$1" --first-seed "$3" --seeds 1 --rigs "$2" --sensors realistic \
    --calibrations estimated --methods "$method","$baseline" --csv "$tmp" > /dev/null 2>&1
  if [ -f "$csv" ]; then tail -n +2 "$tmp" >> "$csv"; else cp "$tmp" "$csv"; fi
  echo "$key,$(git rev-parse --short HEAD)$(git diff --quiet HEAD -- src include || echo +)" >> "docs/bench/$name.commits"
  echo "$key: $(($(wc -l < "$tmp") - 1)) rows"
}
if [ "$method" = joint_pyramid ]; then
  # The joint stage runs where the field refused, most often in the procedural worlds; with scans
  # simulated a world, rig and seed takes about 3 minutes, so a smaller set: procedural seeds 1-5
  # with every rig, then warehouse seeds 1-3 with one sensor and the array.
  for seed in $(seq 1 5); do
    for rig in imu array7 husky3 handheld; do run procedural "$rig" "$seed"; done
  done
  for seed in $(seq 1 3); do
    for rig in imu array7; do run warehouse "$rig" "$seed"; done
  done
  exit 0
fi
for seed in $(seq 1 5); do
  for rig in imu array7; do run warehouse "$rig" "$seed"; done
done
for seed in $(seq 1 10); do
  for rig in imu array7 husky3 handheld; do run procedural "$rig" "$seed"; done
done
