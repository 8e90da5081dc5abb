#!/usr/bin/env bash
# Issue 15: the peers' claim rules, chosen on tuning seeds, then every method scored on held-out
# seeds with them. A cloud peer (PCL GICP, NDT, FPFH + SAC-IA + GICP, Open3D FPFH + RANSAC + ICP,
# ICP-EM from identity) claims an overlap only when it converged and its fit passes its rule.
#   1. peer_bench --pairs-csv on tuning seeds (warehouse and corridor 1..TUNE_SEEDS, disjoint
#      1..20) logs every pair registration with its fit and the truth:
#      docs/bench/peer_tuning_pairs.csv.
#   2. scripts/choose_peer_rules.py picks each method's thresholds there:
#      docs/bench/peer_claim_rules.csv.
#   3. peer_bench --claim-rules on held-out seeds 1001..1000+HELD_OUT_SEEDS (warehouse, corridor,
#      disjoint), every method: docs/bench/peer_heldout.{csv,md}.
#   bash scripts/peer_claim_rules.sh     # TUNE_SEEDS=6 HELD_OUT_SEEDS=4: about 1.5 hours here
#   STEP=heldout bash scripts/peer_claim_rules.sh   # step 3 only, with the committed rules
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_open3d.sh
bash scripts/build.sh >/dev/null
cloud=pcl-gicp,pcl-ndt,pcl-fpfh-sacia-gicp,open3d-fpfh-ransac-icp,mm4mm-icp-identity
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
if [ "${STEP:-all}" = all ]; then
  ./build/bench/peer_bench --seeds "${TUNE_SEEDS:-6}" --first-seed 1 --presets warehouse,corridor \
    --methods "$cloud" --csv "$scratch/a.csv" --pairs-csv "$scratch/pairs_a.csv" >/dev/null
  ./build/bench/peer_bench --seeds 20 --first-seed 1 --presets disjoint \
    --methods "$cloud" --csv "$scratch/b.csv" --pairs-csv "$scratch/pairs_b.csv" >/dev/null
  { cat "$scratch/pairs_a.csv"; tail -n +2 "$scratch/pairs_b.csv"; } >docs/bench/peer_tuning_pairs.csv
  /usr/bin/python3 scripts/choose_peer_rules.py docs/bench/peer_tuning_pairs.csv \
    >docs/bench/peer_claim_rules.csv
  cat docs/bench/peer_claim_rules.csv
fi
./build/bench/peer_bench --seeds "${HELD_OUT_SEEDS:-4}" --first-seed 1001 \
  --presets warehouse,corridor,disjoint --claim-rules docs/bench/peer_claim_rules.csv \
  --csv docs/bench/peer_heldout.csv --pairs-csv docs/bench/peer_heldout_pairs.csv |
  tee docs/bench/peer_heldout.md
