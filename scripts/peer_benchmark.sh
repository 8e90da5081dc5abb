#!/usr/bin/env bash
# Issue 5: mm4mm against PCL's GICP, NDT and FPFH + SAC-IA and Open3D's FPFH + RANSAC, on the
# same simulated sessions in one run, then the merge's growth with the number of sessions.
# Writes docs/bench/peer_bench.md (the table), docs/bench/peer_bench.csv (one row per method,
# comparison and seed), docs/images/peer_bench.png (success rates and error distributions),
# docs/bench/scale_bench.{md,csv} and docs/images/scale_bench.png.
#   bash scripts/peer_benchmark.sh    # 10 seeds per preset, N up to 32 (about 2.5 hours here)
#   SEEDS=1 PRESETS=warehouse,corridor,disjoint SIZES=2,4,8 bash scripts/peer_benchmark.sh
# ALL_PAIRS_SIZES (default 2,4,8) bounds the all-pairs strategy, which grows with N².
#                                     # the reduced run (its parts took 3.5 + 1 + 1 + 3.5 min)
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_open3d.sh
bash scripts/build.sh
mkdir -p docs/bench docs/images
./build/bench/peer_bench --seeds "${SEEDS:-10}" \
  --presets "${PRESETS:-warehouse,corridor,random,disjoint}" --csv docs/bench/peer_bench.csv |
  tee docs/bench/peer_bench.md
/usr/bin/python3 scripts/plot_peer_bench.py docs/bench/peer_bench.csv docs/images/peer_bench.png
# The strategies in separate processes: memory one run frees may stay with the process.
sizes=${SIZES:-2,4,8,16,32}
./build/bench/scale_bench --sizes "$sizes" --strategies growing --csv docs/bench/scale_growing.csv |
  tee docs/bench/scale_bench.md
./build/bench/scale_bench --sizes "${ALL_PAIRS_SIZES:-2,4,8}" --strategies all \
  --csv docs/bench/scale_all.csv |
  tail -n +3 | tee -a docs/bench/scale_bench.md
{ cat docs/bench/scale_growing.csv; tail -n +2 docs/bench/scale_all.csv; } > docs/bench/scale_bench.csv
rm docs/bench/scale_growing.csv docs/bench/scale_all.csv
/usr/bin/python3 scripts/plot_scale_bench.py docs/bench/scale_bench.csv docs/images/scale_bench.png
