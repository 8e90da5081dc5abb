// How long one warehouse pair takes to match (issue 33), against PCL's GICP on the same pair's
// point maps in the same process, so that a speed-up can be quoted as a ratio that the machine's
// load does not move. Per seed: the simulated warehouse (peers::simulateScenario: four sessions,
// realistic sensors, calibrated as `mm4mm merge` does) and its pair s0 + s1, matched with the
// default config on every core and on one thread; then GICP from the identity on the two 0.25 m
// point maps. The answer (verdict, T_a_b, z, r) is written beside the time, so that runs before
// and after a change of the search can be compared pair by pair ("same answers").
//
// Usage: match_speed_bench [--seeds N] [--first-seed S] [--csv FILE] [--label L]
// Appends one row per seed and thread count to FILE; rows with the same label and seed already in
// it are kept and not run again (a cut run resumes).

#include <tbb/global_control.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <set>
#include <string>
#include <thread>

#include "bench_util.hpp"
#include "mm4mm/magnetic/magnetic_matcher.hpp"
#include "peer_registration.hpp"
#include "peer_scenarios.hpp"

namespace {

using Clock = std::chrono::steady_clock;
constexpr const char* kUsage =
    "match_speed_bench [--seeds N] [--first-seed S] [--csv FILE] [--label L]";

double since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

}  // namespace

int main(int argc, char** argv) {
  using namespace mm4mm;
  int seeds = 5, first_seed = 1;
  std::string csv_path = "match_speed.csv", label = "current";
  for (const auto& [flag, value] :
       bench::parseFlags(argc, argv, {"--seeds", "--first-seed", "--csv", "--label"}, kUsage)) {
    if (flag == "--seeds") seeds = std::stoi(value);
    if (flag == "--first-seed") first_seed = std::stoi(value);
    if (flag == "--csv") csv_path = value;
    if (flag == "--label") label = value;
  }
  const std::set<std::string> done = mm4mm::bench::casesDone(csv_path);
  const bool fresh = !std::ifstream(csv_path).good();
  std::ofstream csv(csv_path, std::ios::app);
  if (fresh)
    csv << "label,seed,threads,match_s,maps_s,search_s,refine_s,yaw_interval_s,gicp_s,verdict,"
           "x_m,y_m,yaw_deg,z,r\n"
        << std::flush;
  const int cores = static_cast<int>(std::thread::hardware_concurrency());
  for (int seed = first_seed; seed < first_seed + seeds; ++seed) {
    const auto key = [&](int threads) {
      return label + "," + std::to_string(seed) + "," + std::to_string(threads);
    };
    if (done.count(key(cores)) && done.count(key(1))) continue;
    const peers::Scenario scenario = peers::simulateScenario("warehouse", seed);
    const Session& a = scenario.sessions[0];
    const Session& b = scenario.sessions[1];
    for (const int threads : {cores, 1}) {
      if (done.count(key(threads))) continue;
      const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
      auto start = Clock::now();
      const MagneticMatchResult m = matchSessions(a, b, MagneticMatcherConfig{});
      const double match_s = since(start);
      start = Clock::now();
      peers::registerGicp(scenario.maps[0], scenario.maps[1], Eigen::Isometry3d::Identity());
      const double gicp_s = since(start);
      const auto& t = m.stage_seconds;
      char row[512];
      std::snprintf(row, sizeof row,
                    "%s,%d,%d,%.3f,%.3f,%.3f,%.3f,%.3f,%.3f,%s,%.4f,%.4f,%.4f,%.3f,%.4f\n",
                    label.c_str(), seed, threads, match_s, t.maps, t.search, t.refine,
                    t.yaw_interval, gicp_s, toString(m.verdict).c_str(), m.T_a_b.x_m, m.T_a_b.y_m,
                    m.T_a_b.yaw_rad * 180.0 / M_PI, m.z, m.r);
      csv << row << std::flush;
      std::fputs(row, stdout);
    }
  }
  return 0;
}
