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
# Left out unless FUZZ_SKIP says otherwise (FUZZ_SKIP= runs every target): fuzz_rosbag, whose
# readers are ROS's own. It finds within a few hundred inputs a heap read past a bag record's
# header inside Debian's cpp_common (ros::Header::parse bounds a field's length by 1 MB, not by the
# header's; fuzz/corpus/known_crashes/fuzz_rosbag-*), which mm4mm cannot prevent short of
# parsing bags itself (docs/benchmarks.md, "Sanitizers and fuzzing").
skip=" ${FUZZ_SKIP-fuzz_rosbag} "
targets=$(for t in $targets; do [[ "$skip" == *" $t "* ]] || echo "$t"; done)

run_one() {
  local target=$1 build=$2 seconds=$3
  mkdir -p "$build/fuzz-corpus/$target"
  local memory=(-rss_limit_mb=2048)
  if [ "$target" = fuzz_rosbag ]; then
    # rosbag_storage and roscpp allocate what a bag's lengths claim before reading that far (up
    # to 4 GB, more for a vector of messages); mm4mm then refuses the bag, a failed allocation
    # included (std::bad_alloc). Bound what is used, not what is asked for.
    memory=(-rss_limit_mb=6144 -malloc_limit_mb=1073741824)
    export ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}allocator_may_return_null=1"
  fi
  # A fixed seed: CI explores the same inputs each run (time still bounds how many).
  if "$build/fuzz/$target" -seed=1 -max_total_time="$seconds" -timeout=10 "${memory[@]}" \
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
