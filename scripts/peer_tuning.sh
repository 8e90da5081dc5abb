#!/usr/bin/env bash
# Fair peers, their rule chosen on tuning worlds (issue 31 slice 6). PCL's GICP and NDT (from the
# identity and from the centroids at 8 headings) and FPFH + SAC-IA + GICP (4 seeds) run on the
# same pairs as mm4mm's matching benchmark (bench/match_bench, procedural seeds 1-20, the imu
# robot: a peer reads no magnetometer), each claiming whatever converged, with its best answer's
# fit and how well its best distinct answer fits: docs/bench/peer_multistart_imu.csv, grown a seed
# at a time (a cut run resumes; scripts/procedural_tuning.sh's loop). Then
# scripts/choose_peer_rules.py --multi-start picks each method's refusal rule as mm4mm's own is
# picked (no wrong claim, with a margin): docs/bench/peer_ambiguity_rules.csv, which the held-out
# run reads (match_bench --peer-rules). MATCH_BENCH overrides the program.
# Usage: scripts/peer_tuning.sh
set -euo pipefail
cd "$(dirname "$0")/.."
NAME=peer_multistart METHODS=pcl-gicp,pcl-ndt,pcl-fpfh-sacia-gicp scripts/procedural_tuning.sh imu
/usr/bin/python3 scripts/choose_peer_rules.py --multi-start docs/bench/peer_multistart_imu.csv \
  >docs/bench/peer_ambiguity_rules.csv
cat docs/bench/peer_ambiguity_rules.csv
