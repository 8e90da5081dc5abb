#!/usr/bin/env bash
# scripts/demo.sh after the build (issue 33: under 20 s): its four steps (simulate the small
# corridor, merge, eval, render) timed as demo.sh runs them, RUNS times (default 3), every core.
# Appends one row per run labelled LABEL (default: the checkout's commit, "+" when it has
# uncommitted changes) to docs/bench/demo_speed.csv, skipping a label already there. Assumes
# scripts/build.sh has run. BIN (default ./build) is where mm4mm is.
# Usage: [BIN=DIR] [RUNS=3] scripts/demo_speed.sh [LABEL]
set -euo pipefail
cd "$(dirname "$0")/.."
label=${1:-$(git rev-parse --short HEAD)$(git diff --quiet HEAD -- src include || echo +)}
csv=docs/bench/demo_speed.csv
bin=${BIN:-./build}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
if [ ! -f "$csv" ]; then echo "label,run,simulate_s,merge_s,eval_s,render_s,total_s" >"$csv"; fi
if grep -q "^$label," "$csv"; then exit 0; fi
step() { # wall-clock seconds of a command
  local start end
  start=$(date +%s.%N)
  "$@" >"$tmp/log" 2>&1 || { cat "$tmp/log" >&2; return 1; }
  end=$(date +%s.%N)
  python3 -c "print(f'{$end - $start:.2f}')"
}
for run in $(seq 1 "${RUNS:-3}"); do
  out="$tmp/demo"
  rm -rf "$out"
  sim=$(step "$bin/mm4mm" simulate --config configs/corridor_small.yaml --seed 7 --out "$out/sessions")
  merge=$(step "$bin/mm4mm" merge "$out"/sessions/s0 "$out"/sessions/s1 "$out"/sessions/s2 \
    --out "$out/atlas")
  eval=$(step "$bin/mm4mm" eval "$out/atlas")
  render=$(step "$bin/mm4mm" render "$out/atlas" --out "$out/atlas.png")
  total=$(python3 -c "print(f'{$sim + $merge + $eval + $render:.2f}')")
  echo "$label,$run,$sim,$merge,$eval,$render,$total" | tee -a "$csv"
done
