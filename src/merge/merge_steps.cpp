#include "mm4mm/merge/merge_steps.hpp"

#include <tbb/parallel_for.h>

#include <cmath>
#include <mutex>
#include <stdexcept>
#include <utility>

#include "mm4mm/core/timing.hpp"
#include "mm4mm/merge/pair_refinement.hpp"

namespace mm4mm {

SessionMaps buildSessionMaps(const std::vector<const Session*>& sessions,
                             const MergeConfig& config) {
  const int n = static_cast<int>(sessions.size());
  SessionMaps maps;
  maps.magnetic.resize(n);
  maps.obstacles.resize(n);
  maps.frame_height.resize(n);
  maps.height_above_floor_m.resize(n);
  tbb::parallel_for(0, n, [&](int s) {
    maps.magnetic[s] =
        buildMagneticMap(placeFingerprints(*sessions[s]), sessions[s]->rig, config.matcher.map);
    maps.obstacles[s] = magneticMatchObstacle(*sessions[s], maps.magnetic[s], config.matcher);
    maps.frame_height[s] = frameHeightAboveFloor(*sessions[s]);
    if (maps.frame_height[s] && maps.magnetic[s].coveredCells() > 0)
      maps.height_above_floor_m[s] = maps.frame_height[s]->height_m + maps.magnetic[s].height_m;
  });
  return maps;
}

std::optional<double> heightMismatch(const SessionMaps& maps, int a, int b,
                                     double max_difference_m) {
  const auto& heights = maps.height_above_floor_m;
  if (heights.empty() || !heights.at(a) || !heights.at(b)) return std::nullopt;
  const double difference = *heights[a] - *heights[b];
  if (std::abs(difference) <= max_difference_m) return std::nullopt;
  return difference;
}

void refineAll(const std::vector<const Session*>& sessions, const std::vector<MagneticMap>& maps,
               const std::vector<StructureMap>& structure_maps,
               const std::vector<std::optional<FrameHeight>>& frame_heights,
               const MergeConfig& config, std::vector<PairResult>* pairs,
               const ProgressCallback& progress) {
  std::vector<const MagneticMap*> map_pointers;
  for (const MagneticMap& map : maps) map_pointers.push_back(&map);
  std::vector<PairResult*> pair_pointers;
  for (PairResult& pair : *pairs) pair_pointers.push_back(&pair);
  refinePairs(sessions, map_pointers, structure_maps, config, pair_pointers, progress);
  // A pair ICP-EM did not refine (a session without scans) keeps the field's planar transform,
  // whose z says nothing; where both frames' heights above the floor are known, the floor they
  // share does. Without it a frame 0.5 m up would put its magnetometers 0.5 m off the others'.
  for (PairResult& pair : *pairs) {
    if (pair.refined || !pair.accepted) continue;
    const std::optional<FrameHeight>& a = frame_heights.at(pair.a);
    const std::optional<FrameHeight>& b = frame_heights.at(pair.b);
    if (a && b) pair.T_a_b.translation().z() = b->height_m - a->height_m;
  }
}

Placement placeSessions(int sessions, const MergeConfig& config, std::vector<PairResult>* pairs,
                        std::optional<int> frame_session) {
  for (PairResult& pair : *pairs) pair.role = PairRole::kRefused;
  markSpanningTree(sessions, pairs);
  Placement placement;
  // Only a new atlas chooses its frame; an add keeps the one given.
  placement.frame_session = frame_session ? *frame_session : largestComponentRoot(sessions, *pairs);
  placement.T_atlas = placeByTree(sessions, *pairs, placement.frame_session);
  markConsistency(placement.T_atlas, config, pairs);
  return placement;
}

bool usedInGraph(const PairResult& pair,
                 const std::vector<std::optional<Eigen::Isometry3d>>& T_atlas) {
  return (pair.role == PairRole::kTree || pair.role == PairRole::kConsistent) && T_atlas[pair.a] &&
         T_atlas[pair.b];
}

GraphEdges edgesOfUsedPairs(const std::vector<const Session*>& sessions,
                            const std::vector<std::optional<Eigen::Isometry3d>>& T_atlas,
                            const MergeConfig& config, std::vector<PairResult>* pairs,
                            const StoredEdges& stored, const ProgressCallback& progress) {
  std::mutex progress_mutex;  // pairs report from worker threads
  std::vector<std::vector<InterSessionEdge>> pair_edges(pairs->size());
  tbb::parallel_for(std::size_t{0}, pairs->size(), [&](std::size_t p) {
    PairResult& pair = (*pairs)[p];
    pair.edges = pair.edges_kept = 0;
    if (!usedInGraph(pair, T_atlas)) return;
    if (stored)
      if (std::optional<std::vector<InterSessionEdge>> kept = stored(p)) {
        pair_edges[p] = std::move(*kept);
        pair.edges = static_cast<int>(pair_edges[p].size());
        return;
      }
    const auto start = SteadyClock::now();
    const Session& a = *sessions[pair.a];
    const Session& b = *sessions[pair.b];
    pair_edges[p] = pairEdges(a, pair.a, b, pair.b, pair.T_a_b, config);
    pair.edges = static_cast<int>(pair_edges[p].size());
    pair.seconds += secondsSince(start);
    const std::lock_guard<std::mutex> lock(progress_mutex);
    if (progress)
      progress("pair " + a.id + "+" + b.id + ": " + std::to_string(pair.edges) +
               " inter-session edges");
  });
  GraphEdges graph;
  for (std::size_t p = 0; p < pair_edges.size(); ++p)
    for (InterSessionEdge& edge : pair_edges[p]) {
      graph.edges.push_back(std::move(edge));
      graph.owner.push_back(p);
    }
  return graph;
}

void solveGraph(const std::vector<const Session*>& sessions,
                const std::vector<std::optional<Eigen::Isometry3d>>& T_start,
                const std::vector<std::vector<Eigen::Isometry3d>>& warm_keyframes, GraphEdges edges,
                const MergeConfig& config, MergeResult* result) {
  const std::size_t n = sessions.size();
  if (T_start.size() != n || result->magnetic_maps.size() != n ||
      (!warm_keyframes.empty() && warm_keyframes.size() != n))
    throw std::invalid_argument("solveGraph: one start frame and magnetic map per session needed");
  MultiSessionProblem problem;
  problem.sessions = sessions;
  problem.gauge_session = result->frame_session;
  problem.max_height_difference_m = config.max_height_difference_m;
  problem.heights_above_floor_m = result->magnetometer_heights_m;
  problem.initial_T_atlas_keyframe = warm_keyframes;
  for (std::size_t s = 0; s < n; ++s) {
    problem.T_atlas_session.push_back(T_start[s].value_or(Eigen::Isometry3d::Identity()));
    problem.connected.push_back(T_start[s].has_value());
    problem.magnetic_maps.push_back(&result->magnetic_maps[s]);
  }
  problem.edges = edges.edges;
  result->tree_T_atlas_session = problem.T_atlas_session;
  result->solution = solveMultiSessionGraph(problem, config.graph);
  result->edges = std::move(edges.edges);
  for (std::size_t e = 0; e < result->edges.size(); ++e)
    if (result->solution.edge_kept[e]) ++result->pairs[edges.owner[e]].edges_kept;
}

}  // namespace mm4mm
