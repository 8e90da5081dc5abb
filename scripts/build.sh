#!/usr/bin/env bash
# Configures and builds mm4mm (Release) into build/. Assumes scripts/setup.sh has run.
set -euo pipefail
cd "$(dirname "$0")/.."
# Paths under the checkout are hashed relative to it, so a clone elsewhere reuses ccache's results.
export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$PWD}"
# MM4MM_BUILD_BENCHMARKS=OFF leaves out the benchmark programs (CI builds no benchmarks).
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DMM4MM_BUILD_BENCHMARKS="${MM4MM_BUILD_BENCHMARKS:-ON}" >/dev/null
cmake --build build --parallel "$(nproc)"
