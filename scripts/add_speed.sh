#!/usr/bin/env bash
# What the OctoMap costs an add (issue 35, slice 3). Warehouse tuning seeds 1-2, six sessions
# simulated (realistic sensors, the default config, every core); s0-s2 merged, then s3, s4 and s5
# added one at a time. Each add runs twice on the same atlas: `mm4mm add` as it is now (the OctoMap
# left out) and `mm4mm add --octomap` (rebuilt from every session's scans, as every add did
# before), on a copy; the add without continues. Then `mm4mm export octomap` builds it for the
# final atlas. "same poses" says the two adds wrote the same trajectories byte for byte. The add
# without the OctoMap is broken down by the stages its timings.json times (matching the new
# session against the atlas, ICP-EM refinement and the inter-session edges, the solve, and the
# outputs rebuilt from every session: the merged cloud, the fused magnetic map; columns empty in
# rows from before they were recorded). Appends
# rows labelled LABEL (default: the checkout's commit, "+" when it has uncommitted changes) to
# docs/bench/add_speed.csv, skipping a label and seed already there. Assumes scripts/build.sh
# has run. About 5 minutes a seed. BIN (default ./build) is where mm4mm is.
# Usage: [BIN=DIR] [SEEDS="1 2"] scripts/add_speed.sh [LABEL]
set -euo pipefail
cd "$(dirname "$0")/.."
label=${1:-$(git rev-parse --short HEAD)$(git diff --quiet HEAD -- src include || echo +)}
csv=docs/bench/add_speed.csv
bin=${BIN:-./build}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
seconds() { # wall-clock seconds of a command, its output to $tmp/log
  local start end
  start=$(date +%s.%N)
  "$@" >"$tmp/log" 2>&1 || { cat "$tmp/log" >&2; return 1; }
  end=$(date +%s.%N)
  python3 -c "print(f'{$end - $start:.2f}')"
}
stage() { # timings.json, stage names: their seconds, comma-separated
  python3 -c "import json,sys; t=json.load(open(sys.argv[1]))['stages_s']; print(','.join(f'{t[n]:.2f}' for n in sys.argv[2:]))" "$@"
}
stages="matching refinement_and_edges solve merged_cloud magnetic_map"
if [ ! -f "$csv" ]; then
  echo "label,seed,sessions_before,add_s,add_octomap_s,octomap_stage_s,same_poses,export_s,${stages// /_s,}_s" >"$csv"
fi
for seed in ${SEEDS:-1 2}; do
  if grep -q "^$label,$seed," "$csv"; then continue; fi
  rm -rf "$tmp"/*
  "$bin/mm4mm" simulate --world warehouse --sessions 6 --seed "$seed" --out "$tmp/wh" >/dev/null 2>&1
  "$bin/mm4mm" merge "$tmp"/wh/s0 "$tmp"/wh/s1 "$tmp"/wh/s2 --out "$tmp/atlas" >/dev/null 2>&1
  rows=()
  add_stages=()
  for s in 3 4 5; do
    rm -rf "$tmp/with"
    cp -a "$tmp/atlas" "$tmp/with"
    with_s=$(seconds "$bin/mm4mm" add "$tmp/with" "$tmp/wh/s$s" --octomap)
    built_s=$(stage "$tmp/with/timings.json" octomap)
    add_s=$(seconds "$bin/mm4mm" add "$tmp/atlas" "$tmp/wh/s$s")
    # shellcheck disable=SC2086 # the stage names are words
    add_stages[s]=$(stage "$tmp/atlas/timings.json" $stages)
    same=yes
    diff -rq "$tmp/atlas/trajectories" "$tmp/with/trajectories" >/dev/null || same=no
    rows+=("$label,$seed,$s,$add_s,$with_s,$built_s,$same")
  done
  export_s=$(seconds "$bin/mm4mm" export octomap "$tmp/atlas")
  for i in "${!rows[@]}"; do echo "${rows[i]},$export_s,${add_stages[i + 3]}" | tee -a "$csv"; done
done
