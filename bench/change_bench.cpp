// What the magnetic change score (merge/magnetic_change.hpp) finds in merged sessions of a
// building that changed between them (issue 18): configs/warehouse_changed.yaml (the middle rack
// row of the first block gone from s2 on), simulated per seed and rig, calibrated and merged as
// `mm4mm merge` does; then every pair of connected sessions' placed layers, after the field
// offsets, compared with the default settings. A pair on one side of the change (both sessions
// before it, or both after) has nothing to find: every region it reports is a false one. With
// --world unchanged the building is configs/warehouse.yaml, which never changes: every pair is
// on one side. A pair with a session whose calibration had nothing to check itself against
// (calibrationEvidence) is not compared, as in `mm4mm merge`: its row holds zeros.
//
// Scored against the simulator's truth (sim::changeTruth, what `simulate` writes as
// change_truth.pcd), moved into the atlas frame by the rigid fit of the connected sessions'
// keyframes to their true positions. Over the cells both layers cover, a cell is truly changed
// where the true |(ΔB_h, ΔB_v)| reaches change.truth_threshold_uT (1 µT), strongly where it
// reaches 5 µT (fixed before any run: a change the default noise floor can show, chi-square
// 13.8 over a floor of 1 µT on each side needing |ΔB| > 5.3 µT). Recall is the truly changed
// area inside a reported region over the truly changed area compared (true_found_m2 / true_m2,
// strong_found_m2 / strong_m2); precision the region area on truly changed cells over all region
// area (true_found_m2 / region_area_m2).
//
// Usage: change_bench [--seeds N] [--first-seed S] [--rig imu|array7] [--world changed|unchanged]
//                     [--csv FILE] [--label L] [--sweep FILE]
// Appends one row per seed and pair to FILE; rows with the same label, seed and pair already in
// it are kept and not run again (a cut run resumes).
//
// --sweep FILE: instead, the same merges scored at every setting of a grid fixed before any run
// (kSweep*: the noise floor, the chi-square, the least region area, and a scale on each session's
// calibration evidence), one row per seed and setting summed over its pairs, for
// scripts/choose_change_settings.py; resumes per seed (label, seed, rig and world).

#include <tbb/parallel_for.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
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
#include "mm4mm/sim/world_change.hpp"

namespace {

constexpr const char* kUsage =
    "change_bench [--seeds N] [--first-seed S] [--rig imu|array7] [--world changed|unchanged] "
    "[--csv FILE] [--label L]";
constexpr double kStrongChange_uT = 5.0;
// The sweep's grid (issue 18, slice 1), fixed before any run: the default (1 µT, 13.8, 1 m², 1)
// and looser and stricter steps of each. Chi-square of two degrees of freedom at p = 0.01, 0.001,
// 1e-4 and 1e-5.
constexpr double kSweepFloor_uT[] = {0.5, 0.75, 1.0};
constexpr double kSweepChi2[] = {9.21, 13.8, 18.4, 23.0};
constexpr double kSweepArea_m2[] = {0.5, 1.0, 2.0, 4.0};
constexpr double kSweepCalibrationScale[] = {0.5, 0.75, 1.0};

// The true |(ΔB_h, ΔB_v)| at a world point; 0 off the truth's grid (nothing changed there).
double trueChange(const mm4mm::sim::ChangeTruth& truth, const Eigen::Vector2d& p_world) {
  if (truth.width == 0) return 0.0;
  const Eigen::Vector2d c = (p_world - truth.origin_m) / truth.cell_m;
  const int ix = static_cast<int>(std::floor(c.x())), iy = static_cast<int>(std::floor(c.y()));
  if (ix < 0 || iy < 0 || ix >= truth.width || iy >= truth.height) return 0.0;
  const std::size_t i = static_cast<std::size_t>(iy) * truth.width + ix;
  return std::hypot(truth.delta_h_uT[i], truth.delta_v_uT[i]);
}

// The rigid transform from the atlas frame to the world, fitted to the connected sessions'
// keyframes (atlas pose against true pose), in the plane.
Eigen::Isometry2d worldFromAtlas(const std::vector<mm4mm::Session>& sessions,
                                 const mm4mm::MultiSessionSolution& solution) {
  std::vector<Eigen::Vector2d> atlas, world;
  for (std::size_t s = 0; s < sessions.size(); ++s) {
    if (!solution.connected[s]) continue;
    const auto& truth = *sessions[s].ground_truth;
    for (std::size_t k = 0; k < truth.size(); ++k) {
      atlas.push_back(solution.T_atlas_keyframe[s][k].translation().head<2>());
      world.push_back(truth[k].T_frame_body.translation().head<2>());
    }
  }
  Eigen::MatrixXd from(2, atlas.size()), to(2, world.size());
  for (std::size_t k = 0; k < atlas.size(); ++k) {
    from.col(k) = atlas[k];
    to.col(k) = world[k];
  }
  return Eigen::Isometry2d(Eigen::Matrix3d(Eigen::umeyama(from, to, false)));
}

// One pair's comparison scored against the truth (areas in m²).
struct PairScore {
  double region_area = 0.0, largest_area = 0.0, largest_delta = 0.0;
  double true_m2 = 0.0, true_found_m2 = 0.0, strong_m2 = 0.0, strong_found_m2 = 0.0;
};

// Per cell of a pair's comparison (a's grid): 0 where nothing truly changed (or the cell was not
// compared), 1 where the truth reaches `threshold_uT`, 2 where it reaches kStrongChange_uT.
// Between two sessions on one side of the change nothing changed.
std::vector<std::uint8_t> truthClasses(const mm4mm::MagneticChange& change,
                                       const mm4mm::sim::ChangeTruth& truth,
                                       const Eigen::Isometry2d& T_world_atlas, bool across,
                                       double threshold_uT) {
  std::vector<std::uint8_t> classes(change.delta_uT.size(), 0);
  if (!across) return classes;
  for (int iy = 0; iy < change.height; ++iy)
    for (int ix = 0; ix < change.width; ++ix) {
      const std::size_t i = static_cast<std::size_t>(iy) * change.width + ix;
      if (std::isnan(change.delta_uT[i])) continue;
      const Eigen::Vector2d centre =
          change.origin_m + change.cell_size_m * Eigen::Vector2d(ix + 0.5, iy + 0.5);
      const double delta = trueChange(truth, T_world_atlas * centre);
      classes[i] = delta >= kStrongChange_uT ? 2 : delta >= threshold_uT ? 1 : 0;
    }
  return classes;
}

PairScore scorePair(const mm4mm::MagneticChange& change, const std::vector<std::uint8_t>& classes) {
  PairScore score;
  const double cell_area = change.cell_size_m * change.cell_size_m;
  for (const mm4mm::MagneticChangeRegion& region : change.regions) {
    score.region_area += region.area_m2;
    score.largest_area = std::max(score.largest_area, region.area_m2);
    score.largest_delta = std::max(score.largest_delta, region.max_delta_uT);
  }
  for (std::size_t i = 0; i < classes.size(); ++i) {
    if (classes[i] == 0) continue;
    const bool found = change.region[i] >= 0;
    score.true_m2 += cell_area;
    score.true_found_m2 += found ? cell_area : 0.0;
    score.strong_m2 += classes[i] == 2 ? cell_area : 0.0;
    score.strong_found_m2 += classes[i] == 2 && found ? cell_area : 0.0;
  }
  return score;
}

// The seeds (label, seed, rig/world) a sweep file holds already.
std::set<std::string> sweptSeeds(const std::string& path) {
  std::set<std::string> done;
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    const std::vector<std::string> fields = mm4mm::bench::splitList(line);
    if (fields.size() > 3)
      done.insert(fields[0] + "," + fields[1] + "," + fields[2] + "/" + fields[3]);
  }
  return done;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace mm4mm;
  int seeds = 3, first_seed = 1;
  std::string csv_path = "change_bench.csv", label = "current", rig = "array7", world = "changed";
  std::string sweep_path;
  for (const auto& [flag, value] : bench::parseFlags(
           argc, argv,
           {"--seeds", "--first-seed", "--rig", "--world", "--csv", "--label", "--sweep"},
           kUsage)) {
    if (flag == "--sweep") sweep_path = value;
    if (flag == "--seeds") seeds = std::stoi(value);
    if (flag == "--first-seed") first_seed = std::stoi(value);
    if (flag == "--rig") rig = value;
    if (flag == "--world") world = value;
    if (flag == "--csv") csv_path = value;
    if (flag == "--label") label = value;
  }
  if (world != "changed" && world != "unchanged") {
    std::fprintf(stderr, "change_bench: --world is changed or unchanged, not %s\nusage: %s\n",
                 world.c_str(), kUsage);
    return 2;
  }
  sim::SimulationConfig config =
      loadSimulationConfig(std::filesystem::path(MM4MM_SOURCE_DIR) / "configs" /
                           (world == "changed" ? "warehouse_changed.yaml" : "warehouse.yaml"));
  sim::applyRigPreset(rig, &config);
  // Without a change every session is on the same side.
  const int first_after = config.change.first_session > 0 ? config.change.first_session : 4;
  const bool sweeping = !sweep_path.empty();
  const std::string out_path = sweeping ? sweep_path : csv_path;
  const std::set<std::string> done = bench::casesDone(csv_path);
  const std::set<std::string> swept = sweeping ? sweptSeeds(sweep_path) : std::set<std::string>{};
  const bool fresh = !std::ifstream(out_path).good();
  std::ofstream csv(out_path, std::ios::app);
  if (fresh && !sweeping)
    csv << "label,seed,pair,rig,world,across_change,compared_m2,changed_m2,regions,region_area_m2,"
           "largest_region_m2,largest_delta_uT,true_m2,true_found_m2,strong_m2,strong_found_m2\n"
        << std::flush;
  if (fresh && sweeping)
    csv << "label,seed,rig,world,noise_floor_uT,min_chi2,min_region_area_m2,calibration_scale,"
           "pairs_compared,pairs_across,false_regions,false_region_m2,regions_across,"
           "region_area_m2,true_m2,true_found_m2,strong_m2,strong_found_m2\n"
        << std::flush;
  const MergeConfig merge_config;
  const FusedMagneticMapConfig fused_config;
  const MagneticChangeConfig change_config;
  for (int seed = first_seed; seed < first_seed + seeds; ++seed) {
    const auto key = [&](int a, int b) {
      return label + "," + std::to_string(seed) + ",s" + std::to_string(a) + "+s" +
             std::to_string(b) + "/" + rig + "/" + world;
    };
    std::vector<Session> sessions = sim::simulateSessions(config, 4, seed);
    const int n = static_cast<int>(sessions.size());
    bool all_done = true;
    for (int a = 0; a < n; ++a)
      for (int b = a + 1; b < n; ++b) all_done = all_done && done.count(key(a, b));
    if (sweeping)
      all_done = swept.count(label + "," + std::to_string(seed) + "," + rig + "/" + world);
    if (all_done) continue;
    std::vector<Session*> pointers;
    for (Session& s : sessions) pointers.push_back(&s);
    const std::vector<SessionCalibration> calibrations =
        calibrateSessions(pointers, merge_config.matcher.calibration);
    const MergeResult result = mergeSessions(sessions, merge_config);
    const MultiSessionSolution& solution = result.solution;
    const sim::ChangingWorld worlds(config, static_cast<std::uint64_t>(seed));
    const sim::ChangeTruth truth =
        worlds.changes() ? sim::changeTruth(worlds.before().field, worlds.after().field,
                                            config.change, config.rig.magnetometer_height_m)
                         : sim::ChangeTruth{};
    const Eigen::Isometry2d T_world_atlas = worldFromAtlas(sessions, solution);
    std::vector<MagneticLayer> layers(n);
    for (int s = 0; s < n; ++s)
      if (solution.connected[s]) {
        layers[s] = buildMagneticLayer(sessions[s], solution.T_atlas_keyframe[s], fused_config);
        const CalibrationEvidence evidence = calibrationEvidence(calibrations[s]);
        layers[s].calibration_uT = evidence.residual_uT;
        layers[s].calibration_checked = evidence.checked;
      }
    applyFieldOffsets(layers, fused_config.offsets);
    if (sweeping) {
      // The pairs compared, and each one's truth on its cells (a's grid, whatever the setting),
      // so that each setting costs its comparison and a count.
      struct Compared {
        int a, b;
        bool across;
        std::vector<std::uint8_t> truth;  // truthClasses
      };
      std::vector<Compared> compared_pairs;
      for (int a = 0; a < n; ++a)
        for (int b = a + 1; b < n; ++b) {
          if (!solution.connected[a] || !solution.connected[b] || !layers[a].calibration_checked ||
              !layers[b].calibration_checked)
            continue;
          const MagneticChange change = magneticChange(layers[a], layers[b], change_config);
          if (change.compared_cells == 0) continue;
          const bool across = (a < first_after) != (b < first_after);
          Compared pair{
              a, b, across,
              truthClasses(change, truth, T_world_atlas, across, config.change.truth_threshold_uT)};
          compared_pairs.push_back(std::move(pair));
        }
      std::vector<MagneticChangeConfig> settings;
      for (const double floor_uT : kSweepFloor_uT)
        for (const double chi2 : kSweepChi2)
          for (const double area_m2 : kSweepArea_m2)
            for (const double scale : kSweepCalibrationScale) {
              MagneticChangeConfig setting;
              setting.noise_floor_uT = floor_uT;
              setting.min_chi2 = chi2;
              setting.min_region_area_m2 = area_m2;
              setting.calibration_scale = scale;
              settings.push_back(setting);
            }
      std::vector<std::string> rows(settings.size());
      tbb::parallel_for(std::size_t{0}, settings.size(), [&](std::size_t k) {
        const MagneticChangeConfig& setting = settings[k];
        int across_pairs = 0, false_regions = 0, regions_across = 0;
        double false_m2 = 0.0;
        PairScore sum;
        for (const Compared& pair : compared_pairs) {
          const MagneticChange change = magneticChange(layers[pair.a], layers[pair.b], setting);
          const PairScore score = scorePair(change, pair.truth);
          if (!pair.across) {
            false_regions += static_cast<int>(change.regions.size());
            false_m2 += score.region_area;
            continue;
          }
          ++across_pairs;
          regions_across += static_cast<int>(change.regions.size());
          sum.region_area += score.region_area;
          sum.true_m2 += score.true_m2;
          sum.true_found_m2 += score.true_found_m2;
          sum.strong_m2 += score.strong_m2;
          sum.strong_found_m2 += score.strong_found_m2;
        }
        char row[512];
        std::snprintf(
            row, sizeof row, "%s,%d,%s,%s,%g,%g,%g,%g,%zu,%d,%d,%.2f,%d,%.2f,%.2f,%.2f,%.2f,%.2f\n",
            label.c_str(), seed, rig.c_str(), world.c_str(), setting.noise_floor_uT,
            setting.min_chi2, setting.min_region_area_m2, setting.calibration_scale,
            compared_pairs.size(), across_pairs, false_regions, false_m2, regions_across,
            sum.region_area, sum.true_m2, sum.true_found_m2, sum.strong_m2, sum.strong_found_m2);
        rows[k] = row;
      });
      for (const std::string& row : rows) csv << row;
      csv << std::flush;
      std::printf("%s seed %d %s/%s: swept\n", label.c_str(), seed, rig.c_str(), world.c_str());
      continue;
    }
    for (int a = 0; a < n; ++a)
      for (int b = a + 1; b < n; ++b) {
        if (done.count(key(a, b)) || !solution.connected[a] || !solution.connected[b]) continue;
        // As layerChanges: a session whose calibration could not check itself is compared with
        // none (a row of zeros: nothing compared).
        const MagneticChange change = layers[a].calibration_checked && layers[b].calibration_checked
                                          ? magneticChange(layers[a], layers[b], change_config)
                                          : MagneticChange{};
        const double cell_area = change.cell_size_m * change.cell_size_m;
        const bool across = (a < first_after) != (b < first_after);
        const PairScore score = scorePair(change, truthClasses(change, truth, T_world_atlas, across,
                                                               config.change.truth_threshold_uT));
        char row[640];
        std::snprintf(row, sizeof row,
                      "%s,%d,s%d+s%d/%s/%s,%s,%s,%d,%.2f,%.2f,%zu,%.2f,%.2f,%.2f,%.2f,%.2f,%.2f,"
                      "%.2f\n",
                      label.c_str(), seed, a, b, rig.c_str(), world.c_str(), rig.c_str(),
                      world.c_str(), across ? 1 : 0, change.compared_cells * cell_area,
                      change.changed_cells * cell_area, change.regions.size(), score.region_area,
                      score.largest_area, score.largest_delta, score.true_m2, score.true_found_m2,
                      score.strong_m2, score.strong_found_m2);
        csv << row << std::flush;
        std::fputs(row, stdout);
      }
  }
  return 0;
}
