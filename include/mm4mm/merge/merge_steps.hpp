#pragma once
// The named steps that `merge` (merge_sessions.hpp) and `add` (atlas/add_session.hpp) are made of,
// in the order of the paper's Eq. 1, p(T_M, T_B | ...) = p(T_B | magnetic maps) ·
// p(T_M | T_B, point maps):
//   1. session maps      each session's magnetic map in its own frame (Eq. 2–3 compare them)
//   2. pair matching     T_B per candidate pair (merge: all_pairs_matching.hpp or the growing map;
//                        add: against the atlas map)
//   3. refinement        T_M by ICP-EM inside the magnetic overlap (Eq. 7–11; pair_refinement.hpp)
//   4. tree, consistency where each session goes (pair_refinement.hpp)
//   5. edges             inter-session edges of the pairs used (inter_session_edges.hpp)
//   6. solve             one multi-session pose graph (graph/multi_session_graph.hpp)
// The outputs (Eq. 12–13) are built from the result by atlas/atlas_outputs.hpp.

#include <Eigen/Geometry>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "mm4mm/merge/merge_sessions.hpp"
#include "mm4mm/merge/structure_map.hpp"

namespace mm4mm {

/// Step 1: each session's fine magnetic map in its own frame, and per session why it cannot be
/// matched magnetically at all (magneticMatchObstacle) and how high its magnetometers are.
struct SessionMaps {
  std::vector<MagneticMap> magnetic;
  std::vector<MatchObstacle> obstacles;
  /// The session frame's height above the floor, stated or from its scans (frameHeightAboveFloor).
  std::vector<std::optional<FrameHeight>> frame_height;
  /// The magnetometers' mean height above the floor (m): the map's height in the session frame
  /// plus the frame's; unset where the frame's is not known or the session has no map.
  std::vector<std::optional<double>> height_above_floor_m;
};
SessionMaps buildSessionMaps(const std::vector<const Session*>& sessions,
                             const MergeConfig& config);

/// How far apart in height (m, a's minus b's) the magnetometers of sessions a and b are, where
/// both heights are known and differ by more than `max_difference_m`: then the two are not
/// compared by their field (MergeConfig::max_height_difference_m); nullopt otherwise.
std::optional<double> heightMismatch(const SessionMaps& maps, int a, int b,
                                     double max_difference_m);

/// Step 3 over a whole list: refinePairs on every pair of `pairs`; an accepted pair it could not
/// refine by geometry (a session without scans) takes its z from the two frames' heights above
/// the floor (`frame_heights`, one per session: SessionMaps::frame_height), where both are known.
void refineAll(const std::vector<const Session*>& sessions, const std::vector<MagneticMap>& maps,
               const std::vector<StructureMap>& structure_maps,
               const std::vector<std::optional<FrameHeight>>& frame_heights,
               const MergeConfig& config, std::vector<PairResult>* pairs,
               const ProgressCallback& progress);

/// Step 4: every pair's role from scratch (the maximum-confidence spanning tree, then the others'
/// consistency with it) and the session frames the tree gives (unset where it does not reach), in
/// the frame of `frame_session`: an atlas's own (`add`), or where none is given the first session
/// of the tree's largest component (largestComponentRoot; a new atlas).
struct Placement {
  std::vector<std::optional<Eigen::Isometry3d>> T_atlas;
  int frame_session = 0;  ///< whose frame the atlas's is: identity in T_atlas
};
Placement placeSessions(int sessions, const MergeConfig& config, std::vector<PairResult>* pairs,
                        std::optional<int> frame_session = std::nullopt);

/// A pair takes part in the graph: in the tree or consistent with it, both sessions placed.
bool usedInGraph(const PairResult& pair,
                 const std::vector<std::optional<Eigen::Isometry3d>>& T_atlas);

/// Step 5: the inter-session edges of every used pair (computed in parallel, gathered in pair
/// order so that the graph does not depend on the thread count), and which pair owns each edge.
/// `stored(p)`, where given and not empty, supplies pair p's edges instead of computing them (an
/// add keeps the edges of pairs the atlas already used). Sets each pair's `edges`, adds the time
/// spent on it to its `seconds`.
struct GraphEdges {
  std::vector<InterSessionEdge> edges;
  std::vector<std::size_t> owner;  ///< index into the pairs
};
using StoredEdges = std::function<std::optional<std::vector<InterSessionEdge>>(std::size_t)>;
GraphEdges edgesOfUsedPairs(const std::vector<const Session*>& sessions,
                            const std::vector<std::optional<Eigen::Isometry3d>>& T_atlas,
                            const MergeConfig& config, std::vector<PairResult>* pairs,
                            const StoredEdges& stored = {}, const ProgressCallback& progress = {});

/// Step 6: one solve over all sessions from the frames `T_start` (unset: unconnected), each warm
/// session (`warm_keyframes[s]` not empty) from those keyframe poses, the first keyframe of
/// `result->frame_session` held where it starts (the gauge); records the solution, the edges and
/// the kept-edge counts in `result` (whose `magnetic_maps` the magnetic residuals use).
void solveGraph(const std::vector<const Session*>& sessions,
                const std::vector<std::optional<Eigen::Isometry3d>>& T_start,
                const std::vector<std::vector<Eigen::Isometry3d>>& warm_keyframes, GraphEdges edges,
                const MergeConfig& config, MergeResult* result);

}  // namespace mm4mm
