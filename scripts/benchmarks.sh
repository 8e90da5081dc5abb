#!/usr/bin/env bash
# Regenerates the figures of docs/benchmarks.md. Run on a quiet machine; timings are wall-clock.
#   bash scripts/benchmarks.sh            # simulator, matching over 20 seeds, real data,
#                                         # ICP-EM vs GICP, atlas export, merges over 10 seeds
#   SEEDS=5 bash scripts/benchmarks.sh    # a reduced run
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh
mkdir -p docs/bench
seeds=${SEEDS:-20}

echo "## simulator"
./build/bench/sim_bench 7 | tee docs/bench/sim_bench.md

echo "## magnetic matching, $seeds seeds per preset"
./build/bench/match_bench --seeds "$seeds" --methods default \
  --csv docs/bench/match_bench_default.csv | tee docs/bench/match_bench_default.md
./build/bench/match_bench --seeds "$seeds" --methods paper \
  --csv docs/bench/match_bench_paper.csv | tee docs/bench/match_bench_paper.md
./build/bench/match_bench --seeds 5 --presets warehouse --methods default,grid,none,compass,concordance \
  --csv docs/bench/match_refinement.csv | tee docs/bench/match_refinement.md

data=../shared/data/aalto-magnetic-data
if [ -d "$data" ]; then
  echo "## real data (Aalto magnetic data, invensense)"
  tmp=$(mktemp -d)
  /usr/bin/python3 scripts/convert_aalto.py --data "$data" --all "$tmp/aalto" >/dev/null
  /usr/bin/python3 scripts/eval_aalto.py "$tmp/aalto" | tee docs/bench/aalto_invensense.md
  rm -rf "$tmp"
else
  echo "skipping real data: $data not found"
fi

echo "## ICP-EM against PCL GICP"
./build/bench/icp_bench --seeds 5 | tee docs/bench/icp_bench.md

echo "## atlas export (OctoMap, merged cloud, fused magnetic map), 4 warehouse sessions"
./build/bench/octomap_bench | tee docs/bench/octomap_bench.md

echo "## multi-session merge, 10 seeds per preset"
./build/bench/merge_bench --seeds 10 --presets warehouse,corridor | tee docs/bench/merge_bench.md
./build/bench/merge_bench --seeds 5 --presets featureless --variants magnetic,geometric \
  --write-atlas 0 | tee docs/bench/merge_featureless.md

echo "## growing an atlas one session at a time (mm4mm add), 16 large-warehouse sessions"
./build/bench/add_bench --sessions 16 --csv docs/bench/add_bench.csv | tee docs/bench/add_bench.md
/usr/bin/python3 scripts/plot_add_bench.py docs/bench/add_bench.csv docs/images/add_bench.png

echo "## against the peers (PCL GICP, NDT, FPFH + SAC-IA; Open3D FPFH + RANSAC)"
SEEDS=${PEER_SEEDS:-10} bash scripts/peer_benchmark.sh
