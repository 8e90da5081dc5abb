#pragma once
// The outputs of an atlas, built from a solved merge (or add) before io/atlas_io.hpp writes them
// (docs/design.md "Atlas directory"): the edges the solve kept between the connected sessions
// (the writer adds each session's graph at its optimised poses), the merged point cloud
// (Eq. 13), the fused magnetic map (Eq. 12), the OctoMap, and the evaluation where every
// connected session carries ground truth.

#include <optional>
#include <string>
#include <vector>

#include "mm4mm/eval/accuracy.hpp"
#include "mm4mm/merge/fused_magnetic_map.hpp"
#include "mm4mm/merge/inter_session_edges.hpp"
#include "mm4mm/merge/merge_sessions.hpp"
#include "mm4mm/merge/merged_cloud.hpp"
#include "mm4mm/merge/octomap_tree.hpp"
#include "mm4mm/session/session.hpp"

namespace mm4mm {

struct AtlasOutputConfig {
  MergedCloudConfig cloud;
  FusedMagneticMapConfig magnetic;
  OctoMapConfig octomap;

  /// False, with the offending key (e.g. `octomap.resolution_m`) first in `error`.
  bool IsValid(std::string* error) const;
};

/// Whether buildAtlasOutputs casts the OctoMap, which re-casts every scan of every placed session
/// (the largest output cost of `add`; `mm4mm export octomap` builds it on request).
enum class OctoMapBuild { kBuild, kLeaveOut };

struct AtlasOutputs {
  AtlasOutputConfig config;  ///< the settings they were built with (stated in atlas.yaml)
  /// Indices of the connected sessions, the only ones with a place in the atlas frame.
  std::vector<int> placed;
  /// The inter-session edges the solve kept, their session indices into `placed`. (The placed
  /// sessions' graphs, at the solved poses, are built as graph.g2o is written: one at a time.)
  std::vector<InterSessionEdge> kept_edges;
  std::optional<MergedCloud> cloud;           ///< where a placed session has scans
  std::optional<FusedMagneticMap> fused;      ///< where any session is placed
  std::optional<OctoMapTree> octomap;         ///< where a placed session has scans, if built
  bool octomap_left_out = false;              ///< scans to cast, but OctoMapBuild::kLeaveOut
  std::optional<AtlasEvaluation> evaluation;  ///< where every connected session has ground truth
  double cloud_s = 0.0;                       ///< wall-clock seconds of each build
  double magnetic_s = 0.0;
  double octomap_s = 0.0;
  double total_s = 0.0;
};

/// Builds every output of `result` over `sessions` (the merge's inputs, in its order), the
/// independent ones concurrently. Throws std::invalid_argument when the sessions and the solution
/// disagree in size or a config is invalid; when several builds fail, the first in the order
/// graph, cloud, magnetic map, OctoMap is the one reported, however the tasks ran.
/// `changes_of` (empty: every session; else one flag per session) names the sessions whose pairs
/// the fused map compares for change: an add, the new session's.
AtlasOutputs buildAtlasOutputs(const std::vector<Session>& sessions, const MergeResult& result,
                               const AtlasOutputConfig& config,
                               OctoMapBuild octomap = OctoMapBuild::kBuild,
                               const std::vector<bool>& changes_of = {});

/// The OctoMap of an atlas's placed sessions at their keyframe poses in the atlas frame (the
/// connected ones of `connected`): what buildAtlasOutputs builds, for `mm4mm export octomap`.
/// std::nullopt when no placed session has scans.
std::optional<OctoMapTree> buildAtlasOctoMap(
    const std::vector<Session>& sessions,
    const std::vector<std::vector<Eigen::Isometry3d>>& T_atlas_keyframe,
    const std::vector<bool>& connected, const OctoMapConfig& config);

}  // namespace mm4mm
