#!/usr/bin/env bash
# Runs every fuzz target of BUILD_DIR (default build-sanitize, see scripts/sanitize.sh) for
# FUZZ_SECONDS (default 60), as many at once as there are cores, starting from the seed inputs in
# fuzz/corpus/<target>. New inputs go to BUILD_DIR/fuzz-corpus, crashes to BUILD_DIR/fuzz-crashes
# (turn each into a regression test). Exits non-zero when any target finds a crash.
set -euo pipefail
cd "$(dirname "$0")/.."
build="${1:-build-sanitize}"
seconds="${FUZZ_SECONDS:-60}"
mkdir -p "$build/fuzz-crashes"
targets=$(cd fuzz && ls fuzz_*.cpp | sed 's/\.cpp$//')

run_one() {
  local target=$1 build=$2 seconds=$3
  mkdir -p "$build/fuzz-corpus/$target"
  # A fixed seed: CI explores the same inputs each run (time still bounds how many).
  if "$build/fuzz/$target" -seed=1 -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
    -print_final_stats=1 -artifact_prefix="$build/fuzz-crashes/$target-" \
    "$build/fuzz-corpus/$target" "fuzz/corpus/$target" >"$build/fuzz-$target.log" 2>&1; then
    echo "fuzz: $target: no crash in ${seconds} s ($(grep -m1 -o 'stat::number_of_executed_units: *[0-9]*' "$build/fuzz-$target.log" | grep -o '[0-9]*$') inputs)"
  else
    echo "fuzz: $target: FAILED, see $build/fuzz-$target.log"
    tail -40 "$build/fuzz-$target.log"
    return 1
  fi
}
export -f run_one
status=0
echo "$targets" | xargs -P "$(nproc)" -I{} bash -c 'run_one "$@"' _ {} "$build" "$seconds" || status=$?
rm -rf /tmp/mm4mm_fuzz_*  # the targets' scratch files (fuzz/fuzz_input.hpp)
exit "$status"
