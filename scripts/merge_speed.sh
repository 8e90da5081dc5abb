#!/usr/bin/env bash
# A 4-session warehouse merge end to end with every output (issue 33): `mm4mm merge` of warehouse
# seeds 1-2 (tuning seeds; realistic sensors, the default config, every core), its wall-clock time
# and the stages of its timings.json, beside PCL's GICP on the 0.25 m point maps of s0 and s1 of
# the same seed in the same script (bench/match_speed_bench's peer), so the ratio is the figure to
# compare across machines. Appends rows labelled LABEL (default: the checkout's commit, "+" when
# it has uncommitted changes) to docs/bench/merge_speed.csv, skipping a label and seed already
# there; then perf's share of the cycles per library and the hottest symbols of the seed-1 merge
# in docs/bench/merge_speed_perf_LABEL.txt. Assumes scripts/build.sh has run with
# MM4MM_BUILD_BENCHMARKS=ON. About 5 minutes. BIN (default ./build) is where mm4mm and
# bench/match_speed_bench are: a copy of an earlier build measures the code before a change in the
# same session (with LD_LIBRARY_PATH at its libraries). CONFIG (default: none, the code's
# defaults) is a config YAML the merges read (`mm4mm merge --config`): a setting measured beside
# the default under a label of its own.
# Usage: [BIN=DIR] [CONFIG=FILE] scripts/merge_speed.sh [LABEL]
set -euo pipefail
cd "$(dirname "$0")/.."
label=${1:-$(git rev-parse --short HEAD)$(git diff --quiet HEAD -- src include || echo +)}
csv=docs/bench/merge_speed.csv
bin=${BIN:-./build}
config=()
[ -z "${CONFIG:-}" ] || config=(--config "$CONFIG")
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for seed in 1 2; do
  if [ -f "$csv" ] && grep -q "^$label,$seed," "$csv"; then continue; fi
  rm -rf "$tmp/wh" "$tmp/atlas"
  "$bin/mm4mm" simulate --world warehouse --sessions 4 --seed "$seed" --out "$tmp/wh" >/dev/null 2>&1
  start=$(date +%s.%N)
  "$bin/mm4mm" merge "$tmp"/wh/s* --out "$tmp/atlas" "${config[@]}" >/dev/null 2>&1
  end=$(date +%s.%N)
  rm -f "$tmp/peer.csv"
  "$bin/bench/match_speed_bench" --seeds 1 --first-seed "$seed" --csv "$tmp/peer.csv" \
    --label peer >/dev/null 2>&1
  python3 - "$label" "$seed" "$start" "$end" "$tmp/atlas/timings.json" "$tmp/peer.csv" "$csv" <<'PY'
import csv, json, os, sys
label, seed, start, end, timings, peer, out = sys.argv[1:]
stages = json.load(open(timings))["stages_s"]
rows = list(csv.DictReader(open(peer)))
gicp = max(rows, key=lambda r: int(r["threads"]))["gicp_s"]
names = ["magnetic_maps", "matching", "refinement_and_edges", "solve", "merged_cloud",
         "magnetic_map", "octomap"]
fresh = not os.path.exists(out)
with open(out, "a") as f:
    if fresh:
        f.write("label,seed,wall_s," + ",".join(n + "_s" for n in names) + ",gicp_s\n")
    f.write(f"{label},{seed},{float(end) - float(start):.2f}," +
            ",".join(f"{stages[n]:.3f}" for n in names) + f",{float(gicp):.3f}\n")
PY
  echo "$label seed $seed: $(tail -1 "$csv")"
done
rm -rf "$tmp/wh" "$tmp/atlas"
"$bin/mm4mm" simulate --world warehouse --sessions 4 --seed 1 --out "$tmp/wh" >/dev/null 2>&1
perf record -q -o "$tmp/perf.data" "$bin/mm4mm" merge "$tmp"/wh/s* --out "$tmp/atlas" \
  "${config[@]}" >/dev/null 2>&1
scripts/perf_summary.sh "$tmp/perf.data" \
  "perf record of mm4mm merge, warehouse seed 1, 4 sessions, code $label" 10 20 \
  > "docs/bench/merge_speed_perf_$label.txt"
cat "docs/bench/merge_speed_perf_$label.txt"
