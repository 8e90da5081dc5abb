#!/usr/bin/env bash
# The test command of README.md: builds and runs the whole GoogleTest suite under CTest.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh
ctest --test-dir build --output-on-failure --parallel "$(nproc)" --timeout 900
