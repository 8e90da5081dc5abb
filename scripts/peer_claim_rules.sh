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
#      disjoint), every method: docs/bench/peer_heldout.csv (the cloud methods' rows, then
#      mm4mm's), peer_heldout_{cloud,mm4mm}.{csv,md}, and the cloud methods' pair registrations
#      in peer_heldout_pairs.csv.
#   bash scripts/peer_claim_rules.sh     # TUNE_SEEDS=6 HELD_OUT_SEEDS=4: about 1.5 hours here
#   STEP=heldout bash scripts/peer_claim_rules.sh        # step 3 only, with the committed rules
#   STEP=heldout-mm4mm bash scripts/peer_claim_rules.sh  # step 3, mm4mm's methods only
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
# Held out: the cloud methods and mm4mm's in two runs (STEP=heldout-mm4mm reruns mm4mm's only,
# keeping the cloud rows), concatenated into one CSV.
heldout() {  # methods, name
  ./build/bench/peer_bench --seeds "${HELD_OUT_SEEDS:-4}" --first-seed 1001 \
    --presets warehouse,corridor,disjoint --methods "$1" \
    --claim-rules docs/bench/peer_claim_rules.csv --csv "docs/bench/peer_heldout_$2.csv" \
    --pairs-csv "$scratch/pairs_$2.csv" | tee "docs/bench/peer_heldout_$2.md"
}
if [ "${STEP:-all}" != heldout-mm4mm ]; then
  heldout "$cloud" cloud
  cp "$scratch/pairs_cloud.csv" docs/bench/peer_heldout_pairs.csv
fi
heldout mm4mm,mm4mm-magnetic-only,mm4mm-paper,mm4mm-no-magnetic-residuals mm4mm
{ cat docs/bench/peer_heldout_cloud.csv; tail -n +2 docs/bench/peer_heldout_mm4mm.csv; } \
  >docs/bench/peer_heldout.csv
