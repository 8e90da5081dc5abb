// What the magnetic change score (merge/magnetic_change.hpp) finds in merged sessions of a
// building that changed between them (issue 18): configs/warehouse_changed.yaml (the middle rack
// row of the first block gone from s2 on), simulated per seed and rig, calibrated and merged as
// `mm4mm merge` does; then every pair of connected sessions' placed layers, after the field
// offsets, compared with the default settings. A pair on one side of the change (both sessions
// before it, or both after) has nothing to find: every region it reports is a false one. A pair
// across the change should report the changed area and nothing else (scored against the
// simulator's truth in a later slice).
//
// Usage: change_bench [--seeds N] [--first-seed S] [--rig imu|array7] [--csv FILE] [--label L]
// Appends one row per seed and pair to FILE; rows with the same label, seed and pair already in
// it are kept and not run again (a cut run resumes).

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>

#include "bench_util.hpp"
#include "mm4mm/io/config_io.hpp"
#include "mm4mm/magnetic/self_calibration.hpp"
#include "mm4mm/merge/field_offsets.hpp"
#include "mm4mm/merge/fused_magnetic_map.hpp"
#include "mm4mm/merge/magnetic_change.hpp"
#include "mm4mm/merge/merge_sessions.hpp"
#include "mm4mm/sim/simulator.hpp"

namespace {

constexpr const char* kUsage =
    "change_bench [--seeds N] [--first-seed S] [--rig imu|array7] [--csv FILE] [--label L]";

}  // namespace

int main(int argc, char** argv) {
  using namespace mm4mm;
  int seeds = 3, first_seed = 1;
  std::string csv_path = "change_bench.csv", label = "current", rig = "array7";
  for (const auto& [flag, value] : bench::parseFlags(
           argc, argv, {"--seeds", "--first-seed", "--rig", "--csv", "--label"}, kUsage)) {
    if (flag == "--seeds") seeds = std::stoi(value);
    if (flag == "--first-seed") first_seed = std::stoi(value);
    if (flag == "--rig") rig = value;
    if (flag == "--csv") csv_path = value;
    if (flag == "--label") label = value;
  }
  sim::SimulationConfig config = loadSimulationConfig(std::filesystem::path(MM4MM_SOURCE_DIR) /
                                                      "configs" / "warehouse_changed.yaml");
  sim::applyRigPreset(rig, &config);
  const int first_after = config.change.first_session;
  const std::set<std::string> done = bench::casesDone(csv_path);
  const bool fresh = !std::ifstream(csv_path).good();
  std::ofstream csv(csv_path, std::ios::app);
  if (fresh)
    csv << "label,seed,pair,rig,across_change,compared_m2,changed_m2,regions,region_area_m2,"
           "largest_region_m2,largest_delta_uT\n"
        << std::flush;
  const MergeConfig merge_config;
  const FusedMagneticMapConfig fused_config;
  const MagneticChangeConfig change_config;
  for (int seed = first_seed; seed < first_seed + seeds; ++seed) {
    const auto key = [&](int a, int b) {
      return label + "," + std::to_string(seed) + ",s" + std::to_string(a) + "+s" +
             std::to_string(b) + "/" + rig;
    };
    std::vector<Session> sessions = sim::simulateSessions(config, 4, seed);
    const int n = static_cast<int>(sessions.size());
    bool all_done = true;
    for (int a = 0; a < n; ++a)
      for (int b = a + 1; b < n; ++b) all_done = all_done && done.count(key(a, b));
    if (all_done) continue;
    std::vector<Session*> pointers;
    for (Session& s : sessions) pointers.push_back(&s);
    calibrateSessions(pointers, merge_config.matcher.calibration);
    const MergeResult result = mergeSessions(sessions, merge_config);
    const MultiSessionSolution& solution = result.solution;
    std::vector<MagneticLayer> layers(n);
    for (int s = 0; s < n; ++s)
      if (solution.connected[s])
        layers[s] = buildMagneticLayer(sessions[s], solution.T_atlas_keyframe[s], fused_config);
    applyFieldOffsets(layers, fused_config.offsets);
    for (int a = 0; a < n; ++a)
      for (int b = a + 1; b < n; ++b) {
        if (done.count(key(a, b)) || !solution.connected[a] || !solution.connected[b]) continue;
        const MagneticChange change = magneticChange(layers[a], layers[b], change_config);
        const double cell_area = change.cell_size_m * change.cell_size_m;
        double region_area = 0.0, largest_area = 0.0, largest_delta = 0.0;
        for (const MagneticChangeRegion& region : change.regions) {
          region_area += region.area_m2;
          largest_area = std::max(largest_area, region.area_m2);
          largest_delta = std::max(largest_delta, region.max_delta_uT);
        }
        const bool across = (a < first_after) != (b < first_after);
        char row[512];
        std::snprintf(row, sizeof row, "%s,%d,s%d+s%d/%s,%s,%d,%.2f,%.2f,%zu,%.2f,%.2f,%.2f\n",
                      label.c_str(), seed, a, b, rig.c_str(), rig.c_str(), across ? 1 : 0,
                      change.compared_cells * cell_area, change.changed_cells * cell_area,
                      change.regions.size(), region_area, largest_area, largest_delta);
        csv << row << std::flush;
        std::fputs(row, stdout);
      }
  }
  return 0;
}
