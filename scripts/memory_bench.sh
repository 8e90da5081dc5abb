#!/usr/bin/env bash
# Peak memory of merging large sessions (issue 7): two sessions of the large warehouse with
# ROUTE_M (default 700) metres of route each, about ten million scan points per session at the
# simulator's LiDAR, simulated, then merged by the command line under GNU time. Prints one
# markdown row per stage: points, seconds, peak resident memory. Run on a quiet machine.
set -euo pipefail
cd "$(dirname "$0")/.."
route_m="${ROUTE_M:-700}"
work="${WORK:-$(mktemp -d)}"
mkdir -p "$work"
cat >"$work/large.yaml" <<YAML
world: warehouse
warehouse:
  size_x_m: 170.0
  shelf_blocks: 4
layout:
  mode: random
  route_length_m: $route_m
YAML
measure() {  # label, command...: runs it under GNU time and prints "seconds peak_MB"
  local label=$1
  shift
  /usr/bin/time -f "%e %M" -o "$work/$label.time" "$@" >"$work/$label.log" 2>&1
  awk '{printf "%.1f %.0f", $1, $2 / 1024}' "$work/$label.time"
}
points_of() {  # sum of POINTS over a session's scans
  for f in "$1"/scans/*.pcd; do head -c 400 "$f" | grep -a -m1 '^POINTS' | cut -d' ' -f2; done |
    awk '{s += $1} END {print s}'
}
read -r sim_s sim_mb <<<"$(measure simulate ./build/mm4mm simulate --config "$work/large.yaml" \
  --sessions 2 --seed 1 --out "$work/sessions")"
p0=$(points_of "$work/sessions/s0")
p1=$(points_of "$work/sessions/s1")
read -r merge_s merge_mb <<<"$(measure merge ./build/mm4mm merge "$work/sessions/s0" \
  "$work/sessions/s1" --out "$work/atlas")"
echo "| stage | scan points | seconds | peak RSS (MB) |"
echo "|---|---|---|---|"
echo "| simulate 2 sessions of ${route_m} m | $p0 + $p1 | $sim_s | $sim_mb |"
echo "| merge them (all outputs) | $((p0 + p1)) | $merge_s | $merge_mb |"
grep -a "connected" "$work/merge.log" | sed 's/^/    /' || true
[ -z "${WORK:-}" ] && rm -rf "$work"
true
