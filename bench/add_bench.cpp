// Growing an atlas one session at a time (issue 6): N sessions of the large warehouse
// (configs/warehouse_large.yaml: 170 m x 75 m, random starts) written to disk, the first merged
// alone, then each next one added exactly as `mm4mm add` does: load the atlas (manifest, checksums,
// sessions, trajectories, graph, report, fused map), add the session, rewrite every output but the
// OctoMap, which `mm4mm add` leaves out since 6f8116a (docs/benchmarks.md's rows of 2026-12-01
// rebuilt it within 'rewrite outputs'). Per add: the seconds of each stage (the calibration of
// every session included, as `mm4mm add` runs it), the magnetic matches run, the sessions
// connected, and this
// process's peak RSS during that add. At the end: the accuracy of every session against ground
// truth, and the same N sessions merged at once (growing-map matching) for comparison.
//
// Usage: add_bench [--sessions N] [--seed S] [--preset NAME] [--dir DIR] [--csv FILE]
//                  [--pairs-csv FILE]
// --pairs-csv: one row per session pair that overlaps by ground truth (10 keyframe pairs within
// 2 m, as match_bench), for the grown atlas and for the one merged at once: connected, aligned
// (0.5 m / 2°) and the median overlap error; appended to, with a header when the file is new.
// --preset: a merge benchmark preset (bench/sim_presets.hpp: procedural for the held-out worlds of
// docs/heldout_set.md) instead of the large warehouse.
// Prints markdown tables; writes one CSV row per add.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "bench_util.hpp"
#include "mm4mm/atlas/add_session.hpp"
#include "mm4mm/core/timing.hpp"
#include "mm4mm/eval/accuracy.hpp"
#include "mm4mm/io/atlas_io.hpp"
#include "mm4mm/io/config_io.hpp"
#include "mm4mm/io/session_io.hpp"
#include "mm4mm/magnetic/self_calibration.hpp"
#include "mm4mm/merge/merge_sessions.hpp"
#include "mm4mm/render/magnetic_map_render.hpp"
#include "mm4mm/sim/simulator.hpp"
#include "sim_presets.hpp"

namespace {

using namespace mm4mm;
using bench::parseFlags;
using bench::resetPeakRss;
using bench::residentMb;
namespace fs = std::filesystem;
using Clock = SteadyClock;

std::vector<const Session*> pointersTo(const std::vector<Session>& sessions) {
  std::vector<const Session*> pointers;
  for (const Session& s : sessions) pointers.push_back(&s);
  return pointers;
}

// How far the add moved the sessions that were already placed: the largest keyframe translation
// and rotation change, and how many sessions moved a point 30 m from a keyframe (OctoMap's ray
// length) by more than 5 cm (half its voxel): those whose stored outputs could not be kept.
struct OldSessionMoves {
  double max_translation_m = 0.0;
  double max_rotation_deg = 0.0;
  int moved_beyond_half_voxel = 0;
  std::string farthest;  ///< id of the session with the largest keyframe translation
};

// The pipeline's calibration step as `mm4mm merge` and `mm4mm add` run it before they match:
// every session read from its source is calibrated (deterministic, so the atlas's sessions get
// the calibration they were merged with). Without it realistic sensors match uncalibrated.
std::vector<SessionCalibration> calibrateAsTheCliDoes(std::vector<Session>& sessions,
                                                      Session* added = nullptr) {
  std::vector<Session*> pointers;
  for (Session& s : sessions) pointers.push_back(&s);
  if (added != nullptr) pointers.push_back(added);
  return calibrateSessions(pointers, MergeConfig{}.matcher.calibration);
}

OldSessionMoves oldSessionMoves(const Atlas& before, const MultiSessionSolution& after) {
  OldSessionMoves moves;
  for (std::size_t s = 0; s < before.sessions.size(); ++s) {
    if (!before.connected[s] || !after.connected[s]) continue;
    double worst_at_30m = 0.0;
    for (std::size_t k = 0; k < before.T_atlas_keyframe[s].size(); ++k) {
      const Eigen::Isometry3d delta =
          before.T_atlas_keyframe[s][k].inverse() * after.T_atlas_keyframe[s][k];
      const double t = delta.translation().norm();
      const double angle = Eigen::AngleAxisd(delta.linear()).angle();
      if (t > moves.max_translation_m) moves.farthest = before.sessions[s].id;
      moves.max_translation_m = std::max(moves.max_translation_m, t);
      moves.max_rotation_deg = std::max(moves.max_rotation_deg, angle * 180.0 / M_PI);
      worst_at_30m = std::max(worst_at_30m, t + 30.0 * angle);
    }
    if (worst_at_30m > 0.05) ++moves.moved_beyond_half_voxel;
  }
  return moves;
}

}  // namespace

int main(int argc, char** argv) {
  int n = 16, seed = 1;
  fs::path dir = fs::temp_directory_path() / "mm4mm_add_bench";
  std::string csv_path = "add_bench.csv", preset, pairs_path;
  for (const auto& [flag, value] :
       parseFlags(argc, argv, {"--sessions", "--seed", "--preset", "--dir", "--csv", "--pairs-csv"},
                  "add_bench [--sessions N] [--seed S] [--preset NAME] [--dir DIR] [--csv FILE] "
                  "[--pairs-csv FILE]")) {
    if (flag == "--sessions") n = std::stoi(value);
    if (flag == "--seed") seed = std::stoi(value);
    if (flag == "--dir") dir = value;
    if (flag == "--csv") csv_path = value;
    if (flag == "--preset") preset = value;
    if (flag == "--pairs-csv") pairs_path = value;
  }
  const sim::SimulationConfig world =
      preset.empty()
          ? loadSimulationConfig(fs::path(MM4MM_SOURCE_DIR) / "configs" / "warehouse_large.yaml")
          : bench::presetFor(preset).config;
  fs::remove_all(dir);
  std::vector<fs::path> sources;
  {
    const std::vector<Session> sessions = sim::simulateSessions(world, n, seed);
    for (const Session& s : sessions) {
      sources.push_back(dir / "sessions" / s.id);
      writeSession(s, sources.back());
    }
  }
  const fs::path atlas_dir = dir / "atlas";
  const MergeConfig config;
  const AtlasOutputConfig outputs;

  std::ofstream csv(csv_path);
  csv << "sessions_before,load_s,maps_s,matching_s,refinement_s,solve_s,write_s,total_s,"
         "magnetic_matches,connected_after,peak_rss_mb,old_max_move_m,old_max_turn_deg,"
         "old_moved_beyond_5cm_at_30m,calibration_s\n";
  std::printf(
      "| sessions before | load (s) | maps (s) | matching (s) | refinement + edges (s) | solve "
      "(s) | write (s) | total (s) | magnetic matches | connected after | peak RSS (MB) | placed "
      "sessions moved: max m / ° / number > 5 cm at 30 m |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  {
    std::vector<Session> first{readSession(sources[0])};
    const std::vector<SessionCalibration> calibrations = calibrateAsTheCliDoes(first);
    MergeResult merged = mergeSessions(first, config);
    merged.calibrations = calibrations;
    writeAtlas(atlas_dir, first, {sources[0]}, merged, buildAtlasOutputs(first, merged, outputs));
  }
  double adds_s = 0.0;
  for (int s = 1; s < n; ++s) {
    resetPeakRss();
    const auto start = Clock::now();
    Atlas atlas = loadAtlas(atlas_dir);
    Session added = readSession(sources[s]);
    const double load_s = secondsSince(start);
    // `mm4mm add` calibrates every atlas session again (the atlas does not keep calibrations to
    // reuse): a cost that grows with the atlas (issue 35).
    const auto calibration_start = Clock::now();
    const std::vector<SessionCalibration> calibrations =
        calibrateAsTheCliDoes(atlas.sessions, &added);
    const double calibration_s = secondsSince(calibration_start);
    MergeResult result = addSessionToAtlas(atlas, added, config);
    result.calibrations = calibrations;
    const OldSessionMoves moves = oldSessionMoves(atlas, result.solution);
    std::vector<fs::path> atlas_sources;
    for (const AtlasSessionEntry& entry : atlas.manifest.sessions)
      atlas_sources.push_back(entry.source);
    atlas_sources.push_back(sources[s]);
    atlas.sessions.push_back(std::move(added));
    const AtlasOutputs built =
        buildAtlasOutputs(atlas.sessions, result, outputs, OctoMapBuild::kLeaveOut);
    const AtlasWriteTimings written =
        writeAtlas(atlas_dir, atlas.sessions, atlas_sources, result, built,
                   atlasPictures(built.fused->map, built.placed.size()));
    const double total_s = secondsSince(start);
    adds_s += total_s;
    int connected = 0;
    for (bool c : result.solution.connected) connected += c ? 1 : 0;
    const double peak_mb = residentMb("VmHWM:");
    char row[512];
    std::snprintf(row, sizeof row,
                  "%d,%.2f,%.2f,%.2f,%.2f,%.2f,%.2f,%.2f,%d,%d,%.0f,%.4f,%.4f,%d,%.2f\n", s, load_s,
                  result.seconds_maps, result.seconds_matching, result.seconds_refinement,
                  result.seconds_solve, written.total_s, total_s, result.magnetic_matches,
                  connected, peak_mb, moves.max_translation_m, moves.max_rotation_deg,
                  moves.moved_beyond_half_voxel, calibration_s);
    csv << row << std::flush;
    std::printf(
        "| %d | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f | %d | %d | %.0f | %.3f / %.3f / %d "
        "|\n",
        s, load_s, result.seconds_maps, result.seconds_matching, result.seconds_refinement,
        result.seconds_solve, written.total_s, total_s, result.magnetic_matches, connected, peak_mb,
        moves.max_translation_m, moves.max_rotation_deg, moves.moved_beyond_half_voxel);
    if (!moves.farthest.empty())
      std::fprintf(stderr, "add %d: %s moved farthest (%.3f m)\n", s, moves.farthest.c_str(),
                   moves.max_translation_m);
    std::fflush(stdout);
  }

  // Accuracy of the grown atlas, and of the same sessions merged at once.
  const Atlas grown = loadAtlas(atlas_dir);
  std::vector<Session> sessions;
  for (const fs::path& source : sources) sessions.push_back(readSession(source));
  MergeConfig at_once_config;
  at_once_config.pair_matching = PairMatching::kGrowingMap;
  const auto start = Clock::now();
  calibrateAsTheCliDoes(sessions);
  const MergeResult at_once = mergeSessions(sessions, at_once_config);
  const double at_once_s = secondsSince(start);
  // The grown atlas lists sessions in the order they were added, which is the simulation's.
  const AtlasEvaluation grown_eval = evaluateAtlas(
      pointersTo(grown.sessions), grown.T_atlas_keyframe, grown.connected, grown.frame_session);
  const AtlasEvaluation at_once_eval =
      evaluateAtlas(pointersTo(sessions), at_once.solution.T_atlas_keyframe,
                    at_once.solution.connected, at_once.frame_session);
  const auto summary = [&](const char* name, const AtlasEvaluation& e,
                           const std::vector<bool>& connected, double seconds) {
    int placed = 0, aligned = 0;
    for (bool c : connected) placed += c ? 1 : 0;
    std::vector<double> t, r, e_t, e_r;
    for (const auto& pair : e.pairs) {
      aligned += pair.overlap.aligned();
      t.push_back(pair.overlap.median_translation_m);
      r.push_back(pair.overlap.median_rotation_deg);
    }
    for (const auto& frame : e.frames) {
      e_t.push_back(frame.error.translation_m);
      e_r.push_back(frame.error.rotation_deg);
    }
    std::printf(
        "| %s | %d / %d | %d / %zu | %.3f / %.3f | %.3f / %.3f | %.3f (odometry %.3f) | %.1f |\n",
        name, placed, n, aligned, e.pairs.size(), bench::median(t), bench::median(r),
        bench::median(e_t), bench::median(e_r), e.ate_m, e.odometry_ate_m, seconds);
  };
  if (!pairs_path.empty()) {
    const bool fresh = !fs::exists(pairs_path);
    std::ofstream pairs(pairs_path, std::ios::app);
    if (fresh)
      pairs << "preset,seed,sessions,atlas,pair,connected,aligned,overlap_error_m,"
               "overlap_error_deg\n";
    const auto write = [&](const char* atlas, const std::vector<std::vector<Eigen::Isometry3d>>& T,
                           const std::vector<bool>& connected) {
      for (int a = 0; a < n; ++a)
        for (int b = a + 1; b < n; ++b) {
          const Session& A = sessions[a];
          const Session& B = sessions[b];
          if (overlapError(A, B, trueRelativeTransform(A, B)).pairs < 10) continue;
          const bool placed = connected[a] && connected[b];
          const OverlapError e = placed ? overlapError(A, B, T[a], T[b]) : OverlapError{};
          char row[256];
          std::snprintf(row, sizeof row, "%s,%d,%d,%s,%s-%s,%d,%d,%.4f,%.4f\n",
                        preset.empty() ? "warehouse_large" : preset.c_str(), seed, n, atlas,
                        A.id.c_str(), B.id.c_str(), placed, placed && e.aligned(),
                        e.median_translation_m, e.median_rotation_deg);
          pairs << row;
        }
    };
    write("grown", grown.T_atlas_keyframe, grown.connected);
    write("at_once", at_once.solution.T_atlas_keyframe, at_once.solution.connected);
  }
  std::printf(
      "\n| atlas | sessions connected | overlapping pairs aligned | median overlap error (m / °) "
      "| median e_t (m) / e_r (°) | ATE (m) | s |\n|---|---|---|---|---|---|---|\n");
  summary("grown by add (all adds)", grown_eval, grown.connected, adds_s);
  summary("merged at once (growing map)", at_once_eval, at_once.solution.connected, at_once_s);
  std::vector<int> frames_apart;
  double worst_t = 0, worst_deg = 0;
  for (int s = 0; s < n; ++s) {
    if (!grown.connected[s] || !at_once.solution.connected[s]) continue;
    const Eigen::Isometry3d T_grown = grown.T_atlas_keyframe[s].front() *
                                      grown.sessions[s].keyframes.front().T_frame_body.inverse();
    const Eigen::Isometry3d delta = at_once.solution.T_atlas_session[s].inverse() * T_grown;
    worst_t = std::max(worst_t, delta.translation().norm());
    worst_deg = std::max(worst_deg, Eigen::AngleAxisd(delta.linear()).angle() * 180.0 / M_PI);
  }
  std::printf("\nLargest difference between the two atlases' session frames: %.3f m, %.3f°\n",
              worst_t, worst_deg);
  return 0;
}
