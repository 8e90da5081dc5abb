// Multi-session merge benchmark (issue 4): over seeds of the paper's set-ups, simulate the
// sessions with LiDAR, merge them, and report how many overlapping session pairs the atlas aligns,
// the median overlap error after the solve, the paper's e_t / e_r, ATE against the odometry's,
// and the time of the merge and of writing the atlas (OctoMap export alone beside it).
// Prints markdown rows for docs/benchmarks.md.
//
// Usage: merge_bench [--seeds N] [--first-seed S] [--presets a,b,...] [--variants a,b,...]
//                    [--rigs a,b,...] [--sensors clean,realistic] [--calibrations none,estimated]
//                    [--write-atlas 0|1] [--csv FILE]
// Presets: warehouse (configs/warehouse.yaml, 4 sessions), corridor (3), featureless
// (corridor_featureless.yaml, 3). Variants: magnetic (magnetic residuals on, the default),
// geometric (off). Rigs: the preset's (array7) unless given (imu, husky3, array7, handheld).
// Calibrations: estimated runs the pipeline's calibration step first, as the CLI does; clean
// sensors are run uncalibrated only.

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "bench_util.hpp"
#include "mm4mm/eval/accuracy.hpp"
#include "mm4mm/io/atlas_io.hpp"
#include "mm4mm/io/config_io.hpp"
#include "mm4mm/magnetic/self_calibration.hpp"
#include "mm4mm/merge/merge_sessions.hpp"
#include "mm4mm/render/magnetic_map_render.hpp"
#include "mm4mm/sim/simulator.hpp"
#include "sim_presets.hpp"

namespace {

using namespace mm4mm;
using bench::median;
using bench::parseFlags;
using bench::Preset;
using bench::presetFor;
using bench::splitList;
namespace fs = std::filesystem;

// Keyframe pairs within 2 m by ground truth: the pair overlaps when there are at least 10.
bool overlapsByTruth(const Session& a, const Session& b) {
  int close = 0;
  for (const StampedPose& kb : *b.ground_truth)
    for (const StampedPose& ka : *a.ground_truth)
      if ((ka.T_frame_body.translation() - kb.T_frame_body.translation()).norm() <= 2.0) {
        ++close;
        break;
      }
  return close >= 10;
}

}  // namespace

int main(int argc, char** argv) {
  int seeds = 10, first_seed = 1;
  bool write_atlas = true;
  std::vector<std::string> presets{"warehouse", "corridor"}, variants{"magnetic"}, rigs{""},
      sensor_models{"realistic"}, calibrations{"estimated"};
  std::string csv_path;
  for (const auto& [flag, value] :
       parseFlags(argc, argv,
                  {"--seeds", "--first-seed", "--presets", "--variants", "--rigs", "--sensors",
                   "--calibrations", "--write-atlas", "--csv"},
                  "merge_bench [--seeds N] [--first-seed S] [--presets a,b,...] "
                  "[--variants a,b,...] [--rigs a,b,...] [--sensors clean,realistic] "
                  "[--calibrations none,estimated] [--write-atlas 0|1] [--csv FILE]")) {
    if (flag == "--seeds") seeds = std::stoi(value);
    if (flag == "--first-seed") first_seed = std::stoi(value);
    if (flag == "--presets") presets = splitList(value);
    if (flag == "--variants") variants = splitList(value);
    if (flag == "--rigs") rigs = splitList(value);
    if (flag == "--sensors") sensor_models = splitList(value);
    if (flag == "--calibrations") calibrations = splitList(value);
    if (flag == "--write-atlas") write_atlas = value == "1";
    if (flag == "--csv") csv_path = value;
  }
  std::FILE* csv = csv_path.empty() ? nullptr : std::fopen(csv_path.c_str(), "w");
  if (csv)
    std::fprintf(csv,
                 "preset,rig,sensors,calibration,variant,seed,pair,overlapping,connected,aligned,"
                 "overlap_error_m,overlap_error_deg,ate_m,odometry_ate_m,merge_s\n");
  std::printf(
      "| preset | rig | sensors | calibration | variant | seeds | overlapping pairs aligned | "
      "median overlap error after solve (m / °) | median e_t (m) / e_r (°) | ATE after solve / "
      "odometry at true frames / rigid tree placement | merge s (median) | atlas write s / of "
      "which OctoMap s (median) |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const std::string& preset_name : presets)
    for (const std::string& rig : rigs)
      for (const std::string& sensors : sensor_models)
        for (const std::string& calibration : calibrations)
          for (const std::string& variant : variants) {
            if (sensors == "clean" && calibration != calibrations.front()) continue;
            Preset preset = presetFor(preset_name);
            if (!rig.empty()) sim::applyRigPreset(rig, &preset.config);
            preset.config.magnetometer_errors.model = sensors;
            const std::string calibrated = sensors == "clean" ? "none" : calibration;
            MergeConfig config;
            config.graph.use_magnetic_residuals = variant != "geometric";
            int pairs = 0, aligned = 0;
            std::vector<double> overlap_t, overlap_r, frame_t, frame_r, ate, tree_ate, odometry_ate,
                merge_s, write_s, octomap_s;
            for (int seed = first_seed; seed < first_seed + seeds; ++seed) {
              std::vector<Session> sessions =
                  sim::simulateSessions(preset.config, preset.sessions, seed);
              const auto start = std::chrono::steady_clock::now();
              if (calibrated == "estimated") {
                std::vector<Session*> pointers;
                for (Session& s : sessions) pointers.push_back(&s);
                calibrateSessions(pointers, config.matcher.calibration);
              }
              const MergeResult result = mergeSessions(sessions, config);
              merge_s.push_back(
                  std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
              const MultiSessionSolution& solution = result.solution;
              std::vector<const Session*> pointers;
              for (const Session& s : sessions) pointers.push_back(&s);
              for (std::size_t a = 0; a < sessions.size(); ++a)
                for (std::size_t b = a + 1; b < sessions.size(); ++b) {
                  if (!overlapsByTruth(sessions[a], sessions[b])) continue;
                  ++pairs;
                  const bool connected = solution.connected[a] && solution.connected[b];
                  OverlapError error;
                  if (connected) {
                    error = overlapError(sessions[a], sessions[b], solution.T_atlas_keyframe[a],
                                         solution.T_atlas_keyframe[b]);
                    overlap_t.push_back(error.median_translation_m);
                    overlap_r.push_back(error.median_rotation_deg);
                    aligned += error.aligned() ? 1 : 0;
                  }
                  if (csv)
                    std::fprintf(csv, "%s,%s,%s,%s,%s,%d,%s-%s,1,%d,%d,%.4f,%.4f,,,\n",
                                 preset_name.c_str(), preset.config.rig.preset.c_str(),
                                 sensors.c_str(), calibrated.c_str(), variant.c_str(), seed,
                                 sessions[a].id.c_str(), sessions[b].id.c_str(), connected,
                                 connected && error.aligned(), error.median_translation_m,
                                 error.median_rotation_deg);
                }
              const AtlasEvaluation evaluation = evaluateAtlas(
                  pointers, solution.T_atlas_keyframe, solution.connected, result.frame_session);
              for (const auto& frame : evaluation.frames) {
                frame_t.push_back(frame.error.translation_m);
                frame_r.push_back(frame.error.rotation_deg);
              }
              ate.push_back(evaluation.ate_m);
              tree_ate.push_back(atlasTrajectoryError(
                  pointers, placeOdometry(pointers, result.tree_T_atlas_session),
                  solution.connected, result.frame_session));
              odometry_ate.push_back(evaluation.odometry_ate_m);
              if (write_atlas) {
                const fs::path dir =
                    fs::temp_directory_path() / ("mm4mm_merge_bench_" + std::to_string(::getpid()));
                // Sources are recorded in atlas.yaml only; they must lie outside the atlas.
                std::vector<fs::path> sources(sessions.size(),
                                              dir.parent_path() / "sources-not-written");
                const AtlasOutputs built = buildAtlasOutputs(sessions, result, AtlasOutputConfig{});
                const AtlasWriteTimings timings =
                    writeAtlas(dir, sessions, sources, result, built,
                               atlasPictures(built.fused->map, built.placed.size()));
                write_s.push_back(timings.total_s);
                octomap_s.push_back(timings.octomap_s);
                fs::remove_all(dir);
              }
              if (csv) {
                std::fprintf(csv, "%s,%s,%s,%s,%s,%d,all,,,,,,%.4f,%.4f,%.2f\n",
                             preset_name.c_str(), preset.config.rig.preset.c_str(), sensors.c_str(),
                             calibrated.c_str(), variant.c_str(), seed, evaluation.ate_m,
                             evaluation.odometry_ate_m, merge_s.back());
                std::fflush(csv);
              }
              std::fprintf(stderr,
                           "%s %s seed %d: merge %.1f s, ATE %.3f (odometry %.3f, tree %.3f)\n",
                           preset_name.c_str(), variant.c_str(), seed, merge_s.back(), ate.back(),
                           odometry_ate.back(), tree_ate.back());
            }
            std::printf(
                "| %s | %s | %s | %s | %s | %d | %d/%d (%.0f %%) | %.3f / %.3f | %.3f / %.3f | "
                "%.3f / "
                "%.3f / %.3f | %.1f | %.1f / %.1f |\n",
                preset_name.c_str(), preset.config.rig.preset.c_str(), sensors.c_str(),
                calibrated.c_str(), variant.c_str(), seeds, aligned, pairs,
                pairs ? 100.0 * aligned / pairs : 0.0, median(overlap_t), median(overlap_r),
                median(frame_t), median(frame_r), median(ate), median(odometry_ate),
                median(tree_ate), median(merge_s), median(write_s), median(octomap_s));
            std::fflush(stdout);
          }
  if (csv) std::fclose(csv);
  return 0;
}
