// How the merge grows with the number of sessions (issue 5): N = 2, 4, 8, 16, 32 simulated
// sessions of a larger warehouse (configs/warehouse_large.yaml: 170 m x 75 m, random starts),
// merged with each session matched against the growing map, and with every pair matched (up to
// --all-pairs-max sessions: that strategy grows with N²). Per run: merge seconds, magnetic matches
// run, candidate pairs refined, sessions connected, overlapping pairs aligned, and peak RSS (this
// process's high-water mark during the merge, the N sessions already in memory included).
//
// Usage: scale_bench [--sizes 2,4,...] [--strategies growing,all] [--seed S] [--all-pairs-max N]
//                    [--csv FILE]
// Memory freed by one run may stay with the process (the allocator keeps it), so a later run's
// "RSS before" includes it: run the strategies in separate processes to compare their peaks.
// The sessions are calibrated once first, as `mm4mm merge` does before it matches (the committed
// rows are from 2026-12-01, clean sensors; a run between 2026-12-02, when the simulator's sensors
// became realistic, and 2026-12-06 matched them uncalibrated); the merge seconds leave that step
// out (printed apart).
// Prints a markdown table; writes one CSV row per run.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <tuple>
#include <vector>

#include "bench_util.hpp"
#include "mm4mm/eval/accuracy.hpp"
#include "mm4mm/io/config_io.hpp"
#include "mm4mm/magnetic/self_calibration.hpp"
#include "mm4mm/merge/merge_sessions.hpp"
#include "mm4mm/sim/simulator.hpp"

namespace {

using namespace mm4mm;
using bench::parseFlags;
using bench::resetPeakRss;
using bench::residentMb;
using bench::splitList;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct Run {
  double seconds = 0, rss_before_mb = 0, peak_mb = 0;
  int matches = 0, pairs = 0, connected = 0, overlapping = 0, aligned = 0;
};

Run mergeFirst(const std::vector<Session>& all, int n, PairMatching strategy) {
  const std::vector<Session> sessions(all.begin(), all.begin() + n);
  MergeConfig config;
  config.pair_matching = strategy;
  Run run;
  resetPeakRss();
  run.rss_before_mb = residentMb("VmRSS:");
  const auto start = Clock::now();
  const MergeResult result = mergeSessions(sessions, config);
  run.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  run.peak_mb = residentMb("VmHWM:");
  run.matches = result.magnetic_matches;
  run.pairs = static_cast<int>(result.pairs.size());
  for (bool c : result.solution.connected) run.connected += c ? 1 : 0;
  for (int a = 0; a < n; ++a)
    for (int b = a + 1; b < n; ++b) {
      if (overlapError(sessions[a], sessions[b], trueRelativeTransform(sessions[a], sessions[b]))
              .pairs < 10)
        continue;
      ++run.overlapping;
      if (!result.solution.connected[a] || !result.solution.connected[b]) continue;
      run.aligned += overlapError(sessions[a], sessions[b], result.solution.T_atlas_keyframe[a],
                                  result.solution.T_atlas_keyframe[b])
                         .aligned();
    }
  return run;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<int> sizes{2, 4, 8, 16, 32};
  int seed = 1, all_pairs_max = 8;
  std::vector<std::string> strategies{"growing", "all"};
  std::string csv_path = "scale_bench.csv";
  for (const auto& [flag, value] :
       parseFlags(argc, argv, {"--sizes", "--strategies", "--seed", "--all-pairs-max", "--csv"},
                  "scale_bench [--sizes 2,4,...] [--strategies growing,all] [--seed S] "
                  "[--all-pairs-max N] [--csv FILE]")) {
    if (flag == "--sizes") {
      sizes.clear();
      for (const std::string& s : splitList(value)) sizes.push_back(std::stoi(s));
    }
    if (flag == "--strategies") strategies = splitList(value);
    if (flag == "--seed") seed = std::stoi(value);
    if (flag == "--all-pairs-max") all_pairs_max = std::stoi(value);
    if (flag == "--csv") csv_path = value;
  }
  int largest = 0;
  for (int n : sizes) largest = std::max(largest, n);
  const sim::SimulationConfig config =
      loadSimulationConfig(fs::path(MM4MM_SOURCE_DIR) / "configs" / "warehouse_large.yaml");
  const auto sim_start = Clock::now();
  std::vector<Session> sessions = sim::simulateSessions(config, largest, seed);
  std::fprintf(stderr, "simulated %d sessions in %.1f s\n", largest,
               std::chrono::duration<double>(Clock::now() - sim_start).count());
  {
    const auto calibration_start = Clock::now();
    std::vector<Session*> pointers;
    for (Session& s : sessions) pointers.push_back(&s);
    calibrateSessions(pointers, MergeConfig{}.matcher.calibration);
    std::fprintf(stderr, "calibrated %d sessions in %.1f s\n", largest,
                 std::chrono::duration<double>(Clock::now() - calibration_start).count());
  }

  std::ofstream csv(csv_path);
  csv << "strategy,sessions,seconds,magnetic_matches,candidate_pairs,connected,overlapping_pairs,"
         "aligned_pairs,rss_before_mb,peak_rss_mb\n";
  std::printf(
      "| strategy | sessions | merge s | magnetic matches | candidate pairs | connected | "
      "overlapping pairs aligned | RSS before / peak (MB) |\n|---|---|---|---|---|---|---|---|\n");
  for (const auto& [key, name, strategy] :
       {std::tuple{"growing", "growing map", PairMatching::kGrowingMap},
        std::tuple{"all", "all pairs", PairMatching::kAllPairs}})
    for (int n : sizes) {
      if (std::find(strategies.begin(), strategies.end(), key) == strategies.end()) continue;
      if (strategy == PairMatching::kAllPairs && n > all_pairs_max) continue;
      const Run r = mergeFirst(sessions, n, strategy);
      std::printf("| %s | %d | %.1f | %d | %d | %d/%d | %d/%d | %.0f / %.0f |\n", name, n,
                  r.seconds, r.matches, r.pairs, r.connected, n, r.aligned, r.overlapping,
                  r.rss_before_mb, r.peak_mb);
      std::fflush(stdout);
      csv << name << ',' << n << ',' << r.seconds << ',' << r.matches << ',' << r.pairs << ','
          << r.connected << ',' << r.overlapping << ',' << r.aligned << ',' << r.rss_before_mb
          << ',' << r.peak_mb << '\n'
          << std::flush;
    }
  return 0;
}
