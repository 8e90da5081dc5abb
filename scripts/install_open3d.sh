#!/usr/bin/env bash
# Open3D is a benchmark-only dependency (the peer benchmarks' Open3D pipeline,
# scripts/open3d_peer.py): Debian's python3-open3d, installed when missing.
set -euo pipefail
if ! /usr/bin/python3 -c "import open3d" 2>/dev/null; then
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  $SUDO apt-get update
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends python3-open3d
fi
