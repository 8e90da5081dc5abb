#include "mm4mm/atlas/atlas_outputs.hpp"

#include <tbb/task_group.h>

#include <algorithm>
#include <array>
#include <exception>
#include <stdexcept>
#include <string>

#include "mm4mm/core/timing.hpp"

namespace mm4mm {
namespace {

bool allHaveGroundTruth(const std::vector<Session>& sessions, const std::vector<bool>& connected) {
  for (std::size_t s = 0; s < sessions.size(); ++s)
    if (connected[s] && (!sessions[s].ground_truth ||
                         sessions[s].ground_truth->size() != sessions[s].keyframes.size()))
      return false;
  return true;
}

// The connected sessions and their poses. Sessions carry millions of scan points, so they are
// copied only when some must be left out.
class Placed {
 public:
  Placed(const std::vector<Session>& sessions,
         const std::vector<std::vector<Eigen::Isometry3d>>& poses,
         const std::vector<bool>& connected)
      : all_sessions_(sessions), all_poses_(poses) {
    all_connected_ = std::all_of(connected.begin(), connected.end(), [](bool c) { return c; });
    for (std::size_t s = 0; s < sessions.size(); ++s) {
      if (!connected[s]) continue;
      if (!all_connected_) {
        copies_.push_back(sessions[s]);
        pose_copies_.push_back(poses[s]);
      }
      indices.push_back(static_cast<int>(s));
    }
  }
  const std::vector<Session>& sessions() const { return all_connected_ ? all_sessions_ : copies_; }
  const std::vector<std::vector<Eigen::Isometry3d>>& poses() const {
    return all_connected_ ? all_poses_ : pose_copies_;
  }
  bool haveScans() const {
    return std::any_of(sessions().begin(), sessions().end(),
                       [](const Session& s) { return s.hasScans(); });
  }
  std::vector<int> indices;

 private:
  const std::vector<Session>& all_sessions_;
  const std::vector<std::vector<Eigen::Isometry3d>>& all_poses_;
  bool all_connected_ = true;
  std::vector<Session> copies_;
  std::vector<std::vector<Eigen::Isometry3d>> pose_copies_;
};

}  // namespace

bool AtlasOutputConfig::IsValid(std::string* error) const {
  std::string inner;
  const auto within = [&](const char* key, bool valid) {
    if (!valid && error) *error = std::string(key) + "." + inner;
    return valid;
  };
  return within("cloud", cloud.IsValid(&inner)) && within("magnetic", magnetic.IsValid(&inner)) &&
         within("octomap", octomap.IsValid(&inner));
}

AtlasOutputs buildAtlasOutputs(const std::vector<Session>& sessions, const MergeResult& result,
                               const AtlasOutputConfig& config, OctoMapBuild octomap,
                               const std::vector<bool>& changes_of) {
  const auto start = SteadyClock::now();
  const MultiSessionSolution& solution = result.solution;
  if (solution.connected.size() != sessions.size() ||
      solution.T_atlas_keyframe.size() != sessions.size())
    throw std::invalid_argument(
        "buildAtlasOutputs: the sessions and the solution disagree in size");
  if (!changes_of.empty() && changes_of.size() != sessions.size())
    throw std::invalid_argument("buildAtlasOutputs: " + std::to_string(changes_of.size()) +
                                " change flags for " + std::to_string(sessions.size()) +
                                " sessions");
  AtlasOutputs outputs;
  outputs.config = config;

  const Placed placing(sessions, solution.T_atlas_keyframe, solution.connected);
  outputs.placed = placing.indices;
  const std::vector<Session>& placed = placing.sessions();
  const std::vector<std::vector<Eigen::Isometry3d>>& placed_poses = placing.poses();
  const bool have_scans = placing.haveScans();
  outputs.octomap_left_out = have_scans && octomap == OctoMapBuild::kLeaveOut;

  // The outputs are independent: built concurrently, each timed on its own.
  std::array<std::exception_ptr, 4> failures;
  tbb::task_group builds;
  const auto build = [&](std::size_t slot, auto work) {
    builds.run([&failures, slot, work] {
      try {
        work();
      } catch (...) {
        failures[slot] = std::current_exception();
      }
    });
  };
  build(0, [&] {
    std::vector<int> graph_of(sessions.size(), -1);
    for (std::size_t p = 0; p < placed.size(); ++p)
      graph_of[outputs.placed[p]] = static_cast<int>(p);
    for (std::size_t e = 0; e < result.edges.size(); ++e) {
      if (!solution.edge_kept[e]) continue;
      InterSessionEdge edge = result.edges[e];
      edge.session_a = graph_of[edge.session_a];
      edge.session_b = graph_of[edge.session_b];
      if (edge.session_a >= 0 && edge.session_b >= 0) outputs.kept_edges.push_back(edge);
    }
    if (allHaveGroundTruth(sessions, solution.connected)) {
      std::vector<const Session*> pointers;
      for (const Session& s : sessions) pointers.push_back(&s);
      outputs.evaluation = evaluateAtlas(pointers, solution.T_atlas_keyframe, solution.connected,
                                         result.frame_session);
    }
  });
  build(1, [&] {
    const auto step = SteadyClock::now();
    if (have_scans) outputs.cloud = buildMergedCloud(placed, placed_poses, config.cloud);
    outputs.cloud_s = secondsSince(step);
  });
  build(2, [&] {
    const auto step = SteadyClock::now();
    // A session whose every magnetometer's vertical was estimated (a tilting body) anchors B_v.
    // Heights above the floor, where the merge knew them, decide which layers read one field.
    // What each calibration could check of itself weighs its differences in the change score.
    std::vector<SessionFacts> facts(placed.size());
    for (std::size_t p = 0; p < placed.size(); ++p) {
      const auto s = static_cast<std::size_t>(outputs.placed[p]);
      if (!changes_of.empty()) facts[p].compare_changes = changes_of[s];
      if (s < result.magnetometer_heights_m.size())
        facts[p].height_above_floor_m = result.magnetometer_heights_m[s];
      if (s >= result.calibrations.size()) continue;
      facts[p].vertical_observed = result.calibrations[s].verticalObserved();
      facts[p].calibration = calibrationEvidence(result.calibrations[s]);
    }
    if (!placed.empty())
      outputs.fused = fuseMagneticMaps(placed, placed_poses, config.magnetic, facts);
    outputs.magnetic_s = secondsSince(step);
  });
  build(3, [&] {
    const auto step = SteadyClock::now();
    if (have_scans && !outputs.octomap_left_out)
      outputs.octomap = buildOctoMap(placed, placed_poses, config.octomap);
    outputs.octomap_s = secondsSince(step);
  });
  builds.wait();
  for (const std::exception_ptr& failure : failures)
    if (failure) std::rethrow_exception(failure);
  outputs.total_s = secondsSince(start);
  return outputs;
}

std::optional<OctoMapTree> buildAtlasOctoMap(
    const std::vector<Session>& sessions,
    const std::vector<std::vector<Eigen::Isometry3d>>& T_atlas_keyframe,
    const std::vector<bool>& connected, const OctoMapConfig& config) {
  if (connected.size() != sessions.size() || T_atlas_keyframe.size() != sessions.size())
    throw std::invalid_argument("buildAtlasOctoMap: sessions, poses and connected differ in size");
  const Placed placing(sessions, T_atlas_keyframe, connected);
  if (!placing.haveScans()) return std::nullopt;
  return buildOctoMap(placing.sessions(), placing.poses(), config);
}

}  // namespace mm4mm
