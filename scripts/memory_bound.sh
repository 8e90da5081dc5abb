#!/usr/bin/env bash
# The memory bound that merge and add state up front (issue 19; atlas/memory_bound.hpp) against
# their measured peaks. Sessions of the large warehouse (170 m, random starts) with ROUTE metres
# of route each, for each case of: two sessions with one IMU magnetometer at 350 m and 700 m of
# route, two with the 7-sensor array at 350 m (more magnetometer rows over the same scans), and
# one session with the IMU magnetometer logged at 1 kHz and at 4 kHz (0.4 and 1.5 M rows: the
# magnetometer term alone), the 4 kHz log made 7 times as dense (10.6 M rows, the issue's
# largest log; scripts/densify_magnetometer.py), and one session of 2800 m of route (about 50 M
# scan points, the issue's largest session); each merged by the command line under GNU time
# (every output), and the 700 m pair also as an add of s1 to an atlas of s0.
# Appends one row per case labelled LABEL (default: the checkout's commit, "+" when it has
# uncommitted changes) to docs/bench/memory_bound.csv: scan points and magnetometer rows as the
# bound counts them, the estimate the command logged, the peak resident memory. Assumes
# scripts/build.sh has run. About 30 minutes (the 4 kHz session takes 3 to simulate, the
# 2800 m one longer). BIN (default ./build) is where mm4mm is; CASES (default all) names the
# cases to run, e.g. CASES="imu-350-1000hz imu-350-4000hz".
# Usage: [BIN=DIR] [CASES="..."] scripts/memory_bound.sh [LABEL]
set -euo pipefail
cd "$(dirname "$0")/.."
label=${1:-$(git rev-parse --short HEAD)$(git diff --quiet HEAD -- src include || echo +)}
csv=docs/bench/memory_bound.csv
bin=$(realpath "${BIN:-./build}")
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
if [ ! -f "$csv" ]; then
  echo "label,case,command,scan_points,magnetometer_rows,estimate_gib,peak_rss_gib,seconds" >"$csv"
fi
measure() { # case, command label, log, then the command: appends its row
  local name=$1 what=$2 log=$3
  shift 3
  /usr/bin/time -f "%e %M" -o "$tmp/time" "$@" >"$log" 2>&1
  python3 - "$label" "$name" "$what" "$log" "$tmp/time" "$csv" <<'PY'
import re, sys
label, name, what, log, timing, out = sys.argv[1:]
m = re.search(r"needs about ([\d.]+) GiB \((\d+) scan points, (\d+) magnetometer rows\)",
              open(log).read())
if not m:
    sys.exit(f"{log}: no memory estimate logged")
seconds, kib = open(timing).read().split()
row = (f"{label},{name},{what},{m.group(2)},{m.group(3)},{m.group(1)},"
       f"{int(kib) / 1024 / 1024:.2f},{float(seconds):.1f}")
open(out, "a").write(row + "\n")
print(row)
PY
}
for spec in "imu 350" "imu 700" "array7 350" "imu 350 1000 1" "imu 350 4000 1" \
  "imu 350 4000 1 7" "imu 2800 - 1"; do
  read -r rig route rate sessions densify <<<"$spec"
  [ "$rate" != - ] || rate=
  name="$rig-$route${rate:+-${rate}hz}${densify:+-x$densify}"
  if grep -q "^$label,$name," "$csv"; then continue; fi
  if [ -n "${CASES:-}" ] && [[ " $CASES " != *" $name "* ]]; then continue; fi
  d="$tmp/$name"
  mkdir -p "$d"
  cat >"$d/config.yaml" <<YAML
world: warehouse
warehouse:
  size_x_m: 170.0
  shelf_blocks: 4
layout:
  mode: random
  route_length_m: $route
rig:
  preset: $rig
${rate:+  magnetometer_rate_hz: $rate}
YAML
  "$bin/mm4mm" simulate --config "$d/config.yaml" --sessions "${sessions:-2}" --seed 1 \
    --out "$d/s" >/dev/null 2>&1
  if [ -n "$densify" ]; then python3 scripts/densify_magnetometer.py "$d/s/s0" "$densify"; fi
  measure "$name" merge "$d/merge.log" "$bin/mm4mm" merge "$d"/s/s* --out "$d/atlas"
  if [ "$name" = imu-700 ]; then
    "$bin/mm4mm" merge "$d/s/s0" --out "$d/one" >/dev/null 2>&1
    measure "$name" add "$d/add.log" "$bin/mm4mm" add "$d/one" "$d/s/s1"
  fi
  rm -rf "$d"
done
