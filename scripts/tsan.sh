#!/usr/bin/env bash
# ThreadSanitizer over the parallel paths (issue 19), a stage of .ci/run. A clang build with
# -fsanitize=thread (build-tsan/) of the command line and two test programs, run on every core:
#  - the tests that run a parallel stage and check its answer: the correlation search in arenas of
#    one and four threads, one whole magnetic match, the merged cloud, and the OctoMap against
#    OctoMap's own insertion;
#  - the command line on the small corridor: simulate three sessions; merge two with every output
#    (matching, refinement, inter-session edges, the solve, merged cloud, fused map, OctoMap);
#    add the third (the atlas map's matching, refinement, the outputs again); merge all three with
#    the growing-map matching.
# Any report (data race, lock-order inversion, misuse of a mutex, thread leak) fails the run.
#
# TBB is rebuilt with -fsanitize=thread first: Debian's libtbb is not instrumented, so TSan cannot
# see the synchronisation inside it (a worker's writes, then parallel_for returning) and reports
# races on every parallel loop's results. The source is the one Debian built its libtbb12 from,
# from Debian's own archive (the version installed, checked against Debian's checksum), built
# with oneTBB's TBB_SANITIZE option and put first on the library path; the headers stay
# Debian's (the same version). Assumes scripts/setup.sh has run. About 5 minutes on 2 cores with
# ccache warm (the first build of build-tsan/ takes about 12 more).
# Usage: scripts/tsan.sh
set -euo pipefail
cd "$(dirname "$0")/.."
# As scripts/sanitize.sh: a clone elsewhere reuses ccache's results.
export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$PWD}"
export CCACHE_NOHASHDIR="${CCACHE_NOHASHDIR:-true}"
build=build-tsan
mkdir -p "$build"

# oneTBB as Debian 12 ships it (libtbb-dev 2021.8.0-2+deb12u1; Sources of bookworm/main).
tbb_version=2021.8.0
tbb_sha256=7e9111b8bb59c8800bf6d0b06afe7b0891937443d2dae1ee1101c8e2ede6a7ef
installed=$(dpkg-query -W -f='${Version}' libtbb-dev)
if [ "${installed%%-*}" != "$tbb_version" ]; then
  echo "tsan: libtbb-dev is $installed, this script builds oneTBB $tbb_version: update both" >&2
  exit 1
fi
tbb=$(realpath "$build")/onetbb-$tbb_version
if [ ! -f "$tbb/lib/libtbb.so.12" ]; then
  tarball=$build/onetbb_$tbb_version.orig.tar.xz
  if [ ! -f "$tarball" ]; then
    curl -fsSL -o "$tarball.part" \
      "http://deb.debian.org/debian/pool/main/o/onetbb/onetbb_$tbb_version.orig.tar.xz"
    mv "$tarball.part" "$tarball"
  fi
  echo "$tbb_sha256  $tarball" | sha256sum -c --quiet
  rm -rf "$build/onetbb-src" "$build/onetbb-build"
  mkdir -p "$build/onetbb-src"
  tar -xJf "$tarball" -C "$build/onetbb-src" --strip-components=1
  CC=clang CXX=clang++ cmake -S "$build/onetbb-src" -B "$build/onetbb-build" -G Ninja \
    -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER_LAUNCHER=ccache \
    -DTBB_SANITIZE=thread -DTBB_TEST=OFF -DTBB_EXAMPLES=OFF -DTBB_STRICT=OFF \
    -DTBBMALLOC_BUILD=OFF -DCMAKE_INSTALL_PREFIX="$tbb" >/dev/null
  cmake --build "$build/onetbb-build" --parallel "$(nproc)" >/dev/null
  cmake --install "$build/onetbb-build" >/dev/null
fi
export LD_LIBRARY_PATH="$tbb/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"

# Set before the build too: the build lists each test program's tests by running it.
export TSAN_OPTIONS="${TSAN_OPTIONS:-suppressions=$PWD/scripts/tsan.supp:halt_on_error=1:second_deadlock_stack=1}"
export TSAN_SYMBOLIZER_PATH=/usr/lib/llvm-14/bin/llvm-symbolizer
CC=clang CXX=clang++ cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DMM4MM_SANITIZE=thread -DMM4MM_BUILD_BENCHMARKS=OFF >/dev/null
cmake --build "$build" --parallel "$(nproc)" --target mm4mm_cli magnetic_match_test \
  merge_outputs_test

"$build/tests/magnetic_match_test" \
  --gtest_filter='CorrelationSearch.SameModesWithOneThreadOrMany:MagneticMatcher.FindsTheTrueOverlapOfASimulatedPair'
"$build/tests/merge_outputs_test" --gtest_filter='MergedCloud.*:OutputFiles.OctoMap*'

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
run() {
  echo "tsan: mm4mm $*"
  "$build/mm4mm" "$@" >"$tmp/cli.log" 2>&1 || {
    tail -80 "$tmp/cli.log"
    echo "tsan: mm4mm $1 failed" >&2
    exit 1
  }
}
s=$tmp/sessions
run simulate --config configs/corridor_small.yaml --seed 7 --out "$s"
run merge "$s/s0" "$s/s1" --out "$tmp/atlas" --octomap-resolution 0.3
run add "$tmp/atlas" "$s/s2"
run merge "$s"/s* --out "$tmp/growing" --pair-matching growing --no-octomap
echo "tsan: no report"
