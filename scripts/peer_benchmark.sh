#!/usr/bin/env bash
# Issue 5: mm4mm against PCL's GICP, NDT and FPFH + SAC-IA and Open3D's FPFH + RANSAC, on the
# same simulated sessions in one run. Writes docs/bench/peer_bench.md (the table),
# docs/bench/peer_bench.csv (one row per method, comparison and seed) and
# docs/images/peer_bench.png (success rates and error distributions).
#   bash scripts/peer_benchmark.sh           # 10 seeds per preset (about 2 hours here)
#   SEEDS=1 bash scripts/peer_benchmark.sh   # the reduced run (under 10 minutes)
# Open3D is a benchmark-only dependency: Debian's python3-open3d is installed here if missing.
set -euo pipefail
cd "$(dirname "$0")/.."
if ! /usr/bin/python3 -c "import open3d" 2>/dev/null; then
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  $SUDO apt-get update
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y --no-install-recommends python3-open3d
fi
bash scripts/build.sh
mkdir -p docs/bench docs/images
./build/bench/peer_bench --seeds "${SEEDS:-10}" --csv docs/bench/peer_bench.csv |
  tee docs/bench/peer_bench.md
/usr/bin/python3 scripts/plot_peer_bench.py docs/bench/peer_bench.csv docs/images/peer_bench.png
