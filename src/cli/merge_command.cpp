// mm4mm merge: all sessions at once into one atlas directory.

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "commands.hpp"
#include "mm4mm/io/atlas_io.hpp"
#include "mm4mm/io/config_io.hpp"
#include "mm4mm/io/input_error.hpp"
#include "mm4mm/merge/merge_sessions.hpp"
#include "mm4mm/merge/pair_refinement.hpp"
#include "mm4mm/render/magnetic_map_render.hpp"

namespace mm4mm::cli {
namespace {

struct MergeOptions {
  std::vector<std::string> sessions;
  std::string out;
  std::string config;  // empty: the defaults
  // Each flag overrides the config only where given.
  std::optional<double> octomap_resolution_m;
  bool no_magnetic_residuals = false;
  bool no_octomap = false;
  std::optional<std::string> pair_matching;
  std::optional<double> memory_limit_gib;
};

void runMerge(const MergeOptions& options) {
  PipelineConfig pipeline =
      options.config.empty() ? PipelineConfig{} : loadPipelineConfig(options.config);
  if (options.no_magnetic_residuals) pipeline.merge.graph.use_magnetic_residuals = false;
  if (options.pair_matching)
    pipeline.merge.pair_matching =
        *options.pair_matching == "growing" ? PairMatching::kGrowingMap : PairMatching::kAllPairs;
  if (options.octomap_resolution_m)
    pipeline.outputs.octomap.resolution_m = *options.octomap_resolution_m;
  std::string problem;
  if (!pipeline.IsValid(&problem)) throw std::invalid_argument(problem);
  const MergeConfig& config = pipeline.merge;
  const AtlasOutputConfig& outputs = pipeline.outputs;

  // Before anything is read whole: inputs too large are refused with the figure, not killed.
  std::vector<std::filesystem::path> dirs(options.sessions.begin(), options.sessions.end());
  checkMemory(dirs, "merging " + std::to_string(dirs.size()) + " sessions",
              options.memory_limit_gib);
  std::vector<Session> sessions;
  std::vector<std::filesystem::path> sources;
  std::set<std::string> ids;
  for (const std::string& path : options.sessions) {
    sessions.push_back(readSessionDir(path));
    sources.emplace_back(path);
    if (!ids.insert(sessions.back().id).second)
      throw InputError(path, 0, "session id '" + sessions.back().id + "' appears twice");
    spdlog::info("read {}: {} keyframes, {} magnetometer samples{}", sessions.back().id,
                 sessions.back().keyframes.size(), sessions.back().magnetometer.size(),
                 sessions.back().hasScans() ? "" : ", no scans");
  }
  // Checked and locked before the work, not at the write: a wrong --out is said at once, and an
  // add into the same atlas meanwhile would be lost.
  checkAtlasTarget(options.out, sources);
  const AtlasWriteLock lock(options.out);
  std::vector<Session*> pointers;
  for (Session& s : sessions) pointers.push_back(&s);
  const std::vector<SessionCalibration> calibrations =
      calibrateAndLog(pointers, config.matcher.calibration);
  MergeResult result =
      mergeSessions(sessions, config, [](const std::string& message) { spdlog::info(message); });
  result.calibrations = calibrations;
  const AtlasOutputs built =
      buildAtlasOutputs(sessions, result, outputs,
                        options.no_octomap ? OctoMapBuild::kLeaveOut : OctoMapBuild::kBuild);
  const AtlasWriteTimings timings =
      writeAtlas(options.out, sessions, sources, result, built, picturesOf(built));
  if (built.octomap)
    spdlog::info("wrote {} in {:.1f} s: {} merged points, octomap of {} nodes ({:.1f} s)",
                 options.out, timings.total_s, timings.merged_points, timings.octomap_nodes,
                 timings.octomap_s);
  else
    spdlog::info("wrote {} in {:.1f} s: {} merged points{}", options.out, timings.total_s,
                 timings.merged_points,
                 built.octomap_left_out ? "; octomap.bt left out (--no-octomap)" : "");
  printConnections(sessions, result, true);
  printLeftOutOfTheFusedMap(sessions, built);
  printChanges(sessions, built);
}

}  // namespace

std::map<std::string, std::string> picturesOf(const AtlasOutputs& outputs) {
  if (!outputs.fused) return {};
  std::map<std::string, std::string> pictures =
      atlasPictures(outputs.fused->map, outputs.placed.size());
  const ChangeMap& change = outputs.fused->change_map;
  if (change.comparedCells() > 0) {
    MapRegionOverlay regions{change.region, {}};
    for (const LayerChange& pair : outputs.fused->changes)
      for (const MagneticChangeRegion& region : pair.regions)
        regions.label_at_m.push_back(region.centroid_m);
    pictures["changes/magnetic_change.png"] =
        encodeChangePicture(change.deltaMap(), regions, outputs.fused->changes.size());
  }
  return pictures;
}

void printLeftOutOfTheFusedMap(const std::vector<Session>& sessions, const AtlasOutputs& outputs) {
  if (!outputs.fused) return;
  const FusedMagneticMap& fused = *outputs.fused;
  for (std::size_t l = 0; l < fused.other_height_m.size() && l < outputs.placed.size(); ++l)
    if (const std::optional<double>& other = fused.other_height_m[l]) {
      const double difference = *other;
      std::printf(
          "%s: left out of the fused magnetic map (its magnetometers are %.2f m %s the others'; "
          "the field there is another)\n",
          sessions[outputs.placed[l]].id.c_str(), std::abs(difference),
          difference > 0 ? "above" : "below");
    }
}

void printChanges(const std::vector<Session>& sessions, const AtlasOutputs& outputs) {
  if (!outputs.fused) return;
  const auto idOf = [&](int layer) { return sessions[outputs.placed[layer]].id; };
  const std::vector<bool>& unchecked = outputs.fused->change_unchecked;
  std::string left_out;
  for (std::size_t l = 0; l < unchecked.size(); ++l)
    if (unchecked[l]) left_out += (left_out.empty() ? "" : ", ") + idOf(static_cast<int>(l));
  if (!left_out.empty())
    std::printf(
        "changes: %s not compared (magnetometer calibration with no place passed twice at "
        "headings apart: a field off by several µT with the heading would read as change)\n",
        left_out.c_str());
  const std::vector<bool>& of = outputs.fused->changes_of;
  if (std::find(of.begin(), of.end(), true) == of.end()) return;  // detect_changes is off
  std::size_t regions = 0;
  double compared = 0.0;
  for (const LayerChange& change : outputs.fused->changes) {
    compared += change.compared_m2;
    for (const MagneticChangeRegion& region : change.regions) {
      ++regions;
      std::printf("%s\n", changeLine(regions, idOf(change.a), idOf(change.b), region).c_str());
    }
  }
  // After an add only the new session's pairs are compared: say which.
  std::string which;
  if (std::count(of.begin(), of.end(), true) < static_cast<std::ptrdiff_t>(of.size()))
    for (std::size_t l = 0; l < of.size(); ++l)
      if (of[l]) which += (which.empty() ? " with " : ", ") + idOf(static_cast<int>(l));
  std::printf(
      "changes: %zu region(s) in %zu pair(s) of sessions%s compared over %.0f m² "
      "(report.json \"changes\"%s)\n",
      regions, outputs.fused->changes.size(), which.c_str(), compared,
      outputs.fused->change_map.comparedCells() > 0 ? "; changes/magnetic_change.pcd and .png"
                                                    : "");
}

// Where the heights of two sessions' frames above the floor came from, where a scan said it: a
// height the user did not state is one to check.
std::string heightsSource(const std::vector<Session>& sessions, const MergeResult& result, int a,
                          int b) {
  std::string ids;
  for (const int s : {a, b})
    if (static_cast<std::size_t>(s) < result.frame_heights.size() && result.frame_heights[s] &&
        result.frame_heights[s]->from_scans)
      ids += (ids.empty() ? "" : " and ") + sessions[s].id;
  return ids.empty() ? std::string() : " (heights above the floor from the scans of " + ids + ")";
}

void printConnections(const std::vector<Session>& sessions, const MergeResult& result,
                      bool merging) {
  const std::string& frame = sessions.at(result.frame_session).id;
  if (merging && result.frame_session != 0)
    std::printf("atlas frame: %s's (%s is not in the largest group of sessions that overlap)\n",
                frame.c_str(), sessions[0].id.c_str());
  for (std::size_t s = 0; s < sessions.size(); ++s) {
    const auto involves = [&](const PairResult& pair) {
      return pair.a == static_cast<int>(s) || pair.b == static_cast<int>(s);
    };
    const bool tried_geometry =
        std::any_of(result.pairs.begin(), result.pairs.end(),
                    [&](const PairResult& pair) { return pair.geometry_only && involves(pair); });
    const bool placed_by_geometry =
        std::any_of(result.pairs.begin(), result.pairs.end(), [&](const PairResult& pair) {
          return pair.geometry_only && pair.role == PairRole::kTree && involves(pair);
        });
    std::string obstacle =
        s < result.match_obstacles.size() ? describe(result.match_obstacles[s]) : std::string();
    if (obstacle.empty())
      for (const PairResult& pair : result.pairs)
        if (pair.height_difference_m && involves(pair)) {
          // The field was not compared with a session at another height: say which and why.
          const bool is_a = pair.a == static_cast<int>(s);
          const int other = is_a ? pair.b : pair.a;
          const double higher = is_a ? *pair.height_difference_m : -*pair.height_difference_m;
          char text[300];
          std::snprintf(text, sizeof text,
                        "its magnetometers are %.2f m %s %s's%s, and the field alone is not "
                        "searched across more than %.2f m of height",
                        std::abs(higher), higher > 0 ? "above" : "below",
                        sessions[other].id.c_str(),
                        heightsSource(sessions, result, static_cast<int>(s), other).c_str(),
                        result.config.max_height_difference_m);
          obstacle = text;
          break;
        }
    if (result.solution.connected[s] && placed_by_geometry && !obstacle.empty())
      std::printf("%s: connected by geometry only (%s)\n", sessions[s].id.c_str(),
                  obstacle.c_str());
    else if (result.solution.connected[s])
      std::printf("%s: connected\n", sessions[s].id.c_str());
    else if (const std::vector<int> component = treeComponent(static_cast<int>(s), result.pairs);
             component.size() > 1) {
      // Matched, but neither it nor its partners connect to the session whose frame the atlas
      // is in: "matches no session" would send the user looking at the wrong problem.
      std::string others;
      for (const int t : component)
        if (t != static_cast<int>(s)) others += (others.empty() ? "" : ", ") + sessions[t].id;
      const std::string advice =
          merging ? "; the atlas holds the largest group of sessions that overlap" : std::string();
      std::printf(
          "%s: not connected (overlaps %s, %s connected to %s, whose frame is the "
          "atlas's%s)\n",
          sessions[s].id.c_str(), others.c_str(),
          component.size() == 2 ? "which is not" : "none of them", frame.c_str(), advice.c_str());
    } else if (!obstacle.empty())
      std::printf("%s: not connected (%s%s)\n", sessions[s].id.c_str(), obstacle.c_str(),
                  tried_geometry ? "; geometry alone did not place it" : "");
    else
      std::printf("%s: not connected (matches no session)\n", sessions[s].id.c_str());
  }
}

void addMergeCommand(CLI::App& app) {
  auto options = std::make_shared<MergeOptions>();
  CLI::App* command =
      app.add_subcommand("merge", "Merge sessions into one atlas: match, refine, solve, write");
  command
      ->add_option("sessions", options->sessions,
                   "session directories (the atlas takes the frame of the first session of the "
                   "largest group that overlaps)")
      ->required()
      ->check(CLI::ExistingDirectory);
  command->add_option("--out", options->out, "atlas directory to write")->required();
  command
      ->add_option("--config", options->config,
                   "config YAML (configs/mm4mm.yaml; `mm4mm config --dump` prints every key)")
      ->check(CLI::ExistingFile);
  command->add_option("--octomap-resolution", options->octomap_resolution_m,
                      "OctoMap leaf size (m; default: the config's outputs.octomap.resolution_m)");
  addMemoryLimitOption(command, &options->memory_limit_gib);
  command->add_flag("--no-octomap", options->no_octomap,
                    "leave octomap.bt out (`mm4mm export octomap ATLAS` builds it later)");
  command->add_flag("--no-magnetic-residuals", options->no_magnetic_residuals,
                    "solve the graph without the magnetic residuals");
  command
      ->add_option("--pair-matching", options->pair_matching,
                   "all: match every session pair (N²/2 matches; best for a few sessions); "
                   "growing: match each session against the fused map of those already placed "
                   "(about N matches; for many sessions); default: the config's "
                   "merge.pair_matching")
      ->check(CLI::IsMember({"all", "growing"}));
  command->callback([options] { runMerge(*options); });
}

}  // namespace mm4mm::cli
