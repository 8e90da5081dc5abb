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

echo "## realistic magnetometers (issue 14)"
# Thresholds are chosen on tuning seeds (1-6 here, within 1-20) with the confidence rule opened
# up; every figure is then measured on held-out seeds from 1001 with the default config.
for rig in imu array7; do  # one run per rig: each rig's thresholds are chosen on its own
  [ "$rig" = imu ] && suffix="" || suffix="_array"
  ./build/bench/match_bench --first-seed 1 --seeds 6 --rigs "$rig" --sensors realistic \
    --calibrations estimated --matcher bench/matcher_permissive.yaml \
    --csv "docs/bench/match_tuning$suffix.csv" > "docs/bench/match_tuning$suffix.md"
  /usr/bin/python3 scripts/choose_thresholds.py "docs/bench/match_tuning$suffix.csv" \
    | tee "docs/bench/match_tuning${suffix}_thresholds.md"
  # The yaw uncertainty of right and wrong best modes, single sensor (the 2 deg rule is the
  # issue's, not tuned; this run checks it costs no right mode on tuning seeds).
  [ "$rig" = imu ] && ./build/bench/match_bench --first-seed 1 --seeds 4 --rigs imu \
    --sensors realistic --calibrations estimated --matcher bench/matcher_permissive.yaml \
    --csv docs/bench/match_tuning_yaw.csv > docs/bench/match_tuning_yaw.md
  # Held-out seeds: 20 for the single sensor (60 disjoint pairs), 5 for the array.
  [ "$rig" = imu ] && heldout=${HELDOUT_SEEDS:-20} || heldout=${HELDOUT_SEEDS:-5}
  ./build/bench/match_bench --first-seed 1001 --seeds "$heldout" --rigs "$rig" \
    --sensors realistic --calibrations estimated \
    --csv "docs/bench/match_heldout_$rig.csv" | tee "docs/bench/match_heldout_$rig.md"
  ./build/bench/match_bench --first-seed 1001 --seeds 3 --presets warehouse --rigs "$rig" \
    --sensors clean,realistic --calibrations none,true \
    --csv "docs/bench/match_heldout_sensors_$rig.csv" | tee "docs/bench/match_heldout_sensors_$rig.md"
done
# Geometry proposes, the field decides: one magnetometer with scans, the field alone against
# joint matching against the walls alone. The joint rule's thresholds are chosen on tuning
# seeds 1-4 from the candidates this run lists (every candidate's field z, r and true error).
MATCH_BENCH_MODES=1 ./build/bench/match_bench --first-seed 1 --seeds 4 --presets warehouse,corridor \
  --rigs imu --methods joint --csv docs/bench/match_tuning_joint.csv 2>&1 >/dev/null \
  | grep -E '^(warehouse|corridor),|joint candidate' > docs/bench/match_tuning_joint_candidates.txt
./build/bench/match_bench --first-seed 1001 --seeds 5 --presets warehouse,corridor --rigs imu \
  --methods default,joint,geometry --csv docs/bench/match_heldout_joint.csv \
  | tee docs/bench/match_heldout_joint.md
./build/bench/merge_bench --first-seed 1001 --seeds 3 --presets warehouse,corridor --rigs array7 \
  --sensors clean,realistic --calibrations estimated,none --write-atlas 0 \
  --csv docs/bench/merge_heldout.csv | tee docs/bench/merge_heldout.md

data=../shared/data/aalto-magnetic-data
if [ -d "$data" ]; then
  echo "## real data (Aalto magnetic data, invensense), default config"
  tmp=$(mktemp -d)
  /usr/bin/python3 scripts/convert_aalto.py --data "$data" --all "$tmp/aalto" >/dev/null
  /usr/bin/python3 scripts/eval_aalto.py "$tmp/aalto" --csv docs/bench/aalto_invensense.csv \
    | tee docs/bench/aalto_invensense.md
  echo "## the field's spatial statistics: simulated (clean sensors) against Aalto"
  printf 'lidar: {enabled: false}\nmagnetometer_errors: {model: clean}\n' > "$tmp/clean.yaml"
  ./build/mm4mm simulate --config "$tmp/clean.yaml" --world warehouse --sessions 1 --seed 1001 \
    --out "$tmp/warehouse" >/dev/null
  ./build/mm4mm simulate --config "$tmp/clean.yaml" --world corridor --sessions 1 --seed 1001 \
    --out "$tmp/corridor" >/dev/null
  /usr/bin/python3 scripts/field_statistics.py --csv docs/bench/field_statistics.csv \
    sim-warehouse="$tmp/warehouse/s0" sim-corridor="$tmp/corridor/s0" \
    aalto-1="$tmp/aalto/seq1" aalto-3="$tmp/aalto/seq3" aalto-5="$tmp/aalto/seq5" \
    aalto-7="$tmp/aalto/seq7" | tee docs/bench/field_statistics.md
  rm -rf "$tmp"
else
  echo "skipping real data: $data not found"
fi

echo "## ICP-EM against PCL GICP"
./build/bench/icp_bench --seeds 5 --csv docs/bench/icp_bench.csv | tee docs/bench/icp_bench.md

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

echo "## peers that may refuse: claim rules on tuning seeds, every method on held-out seeds"
bash scripts/peer_claim_rules.sh
