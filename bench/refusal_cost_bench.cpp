// What a refused pair costs a merge (issue 33): every pair of a simulated 4-session warehouse
// (realistic sensors, calibrated as `mm4mm merge` does), matched by the field as merge matches it
// (the default config: coarse to fine, falling back on the exhaustive sweep where it accepts no
// place) and by the exhaustive sweep alone; then, as merge's joint stage does for a pair the field
// refused, both sessions' structure maps built and matched as the joint stage matches them
// (matchStructureForJoint: the geometry matcher, its modes proposed as JointMatchConfig says;
// before 2026-12-08 the geometry matcher's exhaustive sweep, as the geometry-only fallback). Each
// time is one process on every core, one stage at a time, so the columns add up to what a refused
// pair asks of the machine (a merge runs two pairs at once and shares the cores between them).
// "same" says whether the default and the exhaustive sweep gave the same verdict and, for an
// accepted pair, a pose within 0.1 m and 0.5 deg (issue 33's "same answers").
//
// Usage: refusal_cost_bench [--seeds N] [--first-seed S] [--csv FILE] [--label L]
// Appends one row per seed and pair to FILE; rows with the same label, seed and pair already in
// it are kept and not run again (a cut run resumes).

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <set>
#include <string>

#include "bench_util.hpp"
#include "mm4mm/core/pose.hpp"
#include "mm4mm/magnetic/magnetic_matcher.hpp"
#include "mm4mm/merge/joint_match.hpp"
#include "mm4mm/merge/merge_sessions.hpp"
#include "mm4mm/merge/merge_steps.hpp"
#include "mm4mm/merge/structure_map.hpp"
#include "peer_scenarios.hpp"

namespace {

using Clock = std::chrono::steady_clock;
constexpr const char* kUsage =
    "refusal_cost_bench [--seeds N] [--first-seed S] [--csv FILE] [--label L]";

double since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

bool sameAnswer(const mm4mm::MagneticMatchResult& x, const mm4mm::MagneticMatchResult& y) {
  if (x.verdict != y.verdict) return false;
  if (!x.overlap()) return true;
  return std::hypot(x.T_a_b.x_m - y.T_a_b.x_m, x.T_a_b.y_m - y.T_a_b.y_m) <= 0.1 &&
         std::abs(mm4mm::wrapAngle(x.T_a_b.yaw_rad - y.T_a_b.yaw_rad)) <= 0.5 * M_PI / 180.0;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace mm4mm;
  int seeds = 2, first_seed = 1;
  std::string csv_path = "refusal_cost.csv", label = "current";
  for (const auto& [flag, value] :
       bench::parseFlags(argc, argv, {"--seeds", "--first-seed", "--csv", "--label"}, kUsage)) {
    if (flag == "--seeds") seeds = std::stoi(value);
    if (flag == "--first-seed") first_seed = std::stoi(value);
    if (flag == "--csv") csv_path = value;
    if (flag == "--label") label = value;
  }
  const std::set<std::string> done = bench::casesDone(csv_path);
  const bool fresh = !std::ifstream(csv_path).good();
  std::ofstream csv(csv_path, std::ios::app);
  if (fresh)
    csv << "label,seed,pair,verdict,coarse_to_fine,match_s,match_search_s,match_refine_s,"
           "exhaustive_s,exhaustive_verdict,same,structure_maps_s,structure_match_s,"
           "structure_search_s,structure_refine_s\n"
        << std::flush;
  const MergeConfig config;
  for (int seed = first_seed; seed < first_seed + seeds; ++seed) {
    const peers::Scenario scenario = peers::simulateScenario("warehouse", seed);
    const int n = static_cast<int>(scenario.sessions.size());
    std::vector<const Session*> sessions;
    for (const Session& s : scenario.sessions) sessions.push_back(&s);
    const SessionMaps maps = buildSessionMaps(sessions, config);
    for (int a = 0; a < n; ++a)
      for (int b = a + 1; b < n; ++b) {
        const std::string pair = scenario.sessions[a].id + "+" + scenario.sessions[b].id;
        if (done.count(label + "," + std::to_string(seed) + "," + pair)) continue;
        const MagneticMatchResult m =
            matchMagneticMaps(maps.magnetic[a], maps.magnetic[b], config.matcher);
        MagneticMatcherConfig exhaustive_config = config.matcher;
        exhaustive_config.search.pyramid_factor = 1;
        const MagneticMatchResult exhaustive =
            matchMagneticMaps(maps.magnetic[a], maps.magnetic[b], exhaustive_config);
        auto start = Clock::now();
        const StructureMap structure_a = buildStructureMap(*sessions[a], config.structure_map);
        const StructureMap structure_b = buildStructureMap(*sessions[b], config.structure_map);
        const double structure_maps_s = since(start);
        const MagneticMatchResult structure =
            matchStructureForJoint(structure_a.asMatchGrid(), structure_b.asMatchGrid(),
                                   config.geometry_matcher, config.joint);
        char row[512];
        std::snprintf(
            row, sizeof row, "%s,%d,%s,%s,%s,%.3f,%.3f,%.3f,%.3f,%s,%s,%.3f,%.3f,%.3f,%.3f\n",
            label.c_str(), seed, pair.c_str(), toString(m.verdict).c_str(),
            toString(m.coarse_to_fine).c_str(), m.seconds, m.stage_seconds.search,
            m.stage_seconds.refine, exhaustive.seconds, toString(exhaustive.verdict).c_str(),
            sameAnswer(m, exhaustive) ? "yes" : "no", structure_maps_s, structure.seconds,
            structure.stage_seconds.search, structure.stage_seconds.refine);
        csv << row << std::flush;
        std::fputs(row, stdout);
      }
  }
  return 0;
}
