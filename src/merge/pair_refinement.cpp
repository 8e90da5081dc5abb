#include "mm4mm/merge/pair_refinement.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <mutex>
#include <numeric>
#include <queue>
#include <stdexcept>
#include <string>

#include "mm4mm/core/pose.hpp"
#include "mm4mm/core/timing.hpp"
#include "mm4mm/magnetic/match_score.hpp"
#include "mm4mm/magnetic/overlap_region.hpp"

namespace mm4mm {
namespace {

using Clock = SteadyClock;

// Refines an ambiguous pair by ICP-EM from each credible magnetic mode (those whose r is within
// the matcher's credible gap of the best, the ones its rule found too close) and accepts the mode
// the geometry clearly prefers. Records the inlier ratios; returns whether it decided.
template <typename RefineFrom>
bool settleByGeometry(const RefineFrom& refineFrom, const MergeConfig& config, PairResult* pair) {
  const auto& modes = pair->magnetic.modes;
  std::vector<IcpEmResult> refined;
  std::vector<int> verified;
  for (std::size_t m = 0;
       m < modes.size() && static_cast<int>(verified.size()) < config.max_modes_verified; ++m) {
    const MagneticMatcherConfig& matcher =
        pair->geometry_only ? config.geometry_matcher : config.matcher;
    if (m > 0 && modes[m].r < modes[0].r - matcher.credible_r_gap) continue;
    verified.push_back(static_cast<int>(m));
    refined.push_back(refineFrom(*pair, modes[m].T_a_b.toIsometry()));
    pair->mode_inlier_ratios.push_back(refined.back().inlier_ratio);
  }
  // A lone credible mode decides nothing: the rule called the pair ambiguous for a reason.
  if (refined.size() < 2) return false;
  const std::vector<double>& ratios = pair->mode_inlier_ratios;
  const std::size_t best = std::max_element(ratios.begin(), ratios.end()) - ratios.begin();
  if (!refined[best].converged || ratios[best] < config.min_geometric_inlier_ratio) return false;
  for (std::size_t m = 0; m < refined.size(); ++m)
    if (m != best && ratios[m] > ratios[best] - config.geometric_inlier_margin) return false;
  pair->accepted = true;
  pair->refined = true;
  pair->icp = refined[best];
  pair->T_a_b = refined[best].T_a_b;
  pair->geometry_chosen_mode = verified[best];
  return true;
}

// Union-find for Kruskal's spanning tree.
struct DisjointSets {
  std::vector<int> parent;
  explicit DisjointSets(int n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
  int find(int x) { return parent[x] == x ? x : parent[x] = find(parent[x]); }
  bool join(int a, int b) {
    a = find(a), b = find(b);
    if (a == b) return false;
    parent[std::max(a, b)] = std::min(a, b);
    return true;
  }
};

}  // namespace

void markSpanningTree(int sessions, std::vector<PairResult>* pairs) {
  std::vector<std::size_t> order;
  for (std::size_t p = 0; p < pairs->size(); ++p)
    if ((*pairs)[p].accepted) order.push_back(p);
  // Magnetic pairs first: a geometry-only pair's z is a correlation of walls, not of the field,
  // and joins the tree only where no magnetic pair does.
  std::stable_sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) {
    const PairResult &px = (*pairs)[x], &py = (*pairs)[y];
    if (px.geometry_only != py.geometry_only) return !px.geometry_only;
    return px.magnetic.z > py.magnetic.z;
  });
  DisjointSets components(sessions);
  for (std::size_t p : order)
    if (components.join((*pairs)[p].a, (*pairs)[p].b)) (*pairs)[p].role = PairRole::kTree;
}

std::vector<std::optional<Eigen::Isometry3d>> placeByTree(int sessions,
                                                          const std::vector<PairResult>& pairs,
                                                          int root) {
  if (root < 0 || root >= sessions)
    throw std::invalid_argument("placeByTree: root " + std::to_string(root) + " of " +
                                std::to_string(sessions) + " sessions");
  std::vector<std::optional<Eigen::Isometry3d>> T_atlas(sessions);
  T_atlas[root] = Eigen::Isometry3d::Identity();
  std::queue<int> frontier;
  frontier.push(root);
  while (!frontier.empty()) {
    const int s = frontier.front();
    frontier.pop();
    for (const PairResult& pair : pairs) {
      if (pair.role != PairRole::kTree) continue;
      if (pair.a == s && !T_atlas[pair.b]) {
        T_atlas[pair.b] = *T_atlas[s] * pair.T_a_b;
        frontier.push(pair.b);
      } else if (pair.b == s && !T_atlas[pair.a]) {
        T_atlas[pair.a] = *T_atlas[s] * pair.T_a_b.inverse();
        frontier.push(pair.a);
      }
    }
  }
  return T_atlas;
}

std::vector<int> treeComponent(int session, const std::vector<PairResult>& pairs) {
  std::vector<int> component{session};
  for (std::size_t next = 0; next < component.size(); ++next)
    for (const PairResult& pair : pairs) {
      if (pair.role != PairRole::kTree) continue;
      const int s = component[next];
      const int other = pair.a == s ? pair.b : pair.b == s ? pair.a : -1;
      if (other >= 0 && std::find(component.begin(), component.end(), other) == component.end())
        component.push_back(other);
    }
  std::sort(component.begin(), component.end());
  return component;
}

int largestComponentRoot(int sessions, const std::vector<PairResult>& pairs) {
  int root = 0;
  std::size_t largest = 0;
  std::vector<bool> seen(sessions, false);
  for (int s = 0; s < sessions; ++s) {
    if (seen[s]) continue;
    const std::vector<int> component = treeComponent(s, pairs);
    for (int member : component) seen[member] = true;
    // Sessions in index order, so a component is first met at its earliest session.
    if (component.size() > largest) {
      largest = component.size();
      root = s;
    }
  }
  return root;
}

void markConsistency(const std::vector<std::optional<Eigen::Isometry3d>>& T_atlas,
                     const MergeConfig& config, std::vector<PairResult>* pairs) {
  for (PairResult& pair : *pairs) {
    if (!pair.accepted || pair.role == PairRole::kTree) continue;
    if (!T_atlas[pair.a] || !T_atlas[pair.b]) {
      pair.role = PairRole::kInconsistent;
      continue;
    }
    const Eigen::Isometry3d delta =
        (T_atlas[pair.a]->inverse() * *T_atlas[pair.b]) * pair.T_a_b.inverse();
    const bool agrees =
        delta.translation().norm() < config.consistency_translation_m &&
        rotationAngle(delta.linear()) * 180.0 / M_PI < config.consistency_rotation_deg;
    pair.role = agrees ? PairRole::kConsistent : PairRole::kInconsistent;
  }
}

PairResult pairAtPlacement(int a, int b, const Eigen::Isometry3d& T_a_b, const MagneticMap& map_a,
                           const MagneticMap& map_b, const MergeConfig& config, bool anchor) {
  PairResult pair;
  pair.a = a;
  pair.b = b;
  const PlanarTransform T = PlanarTransform::fromIsometry(T_a_b);
  const MatchScore score = MatchScorer(map_a, map_b, config.matcher.score).evaluate(T);
  pair.accepted = anchor || score.r >= config.matcher.appliedTo(map_a, map_b).min_r;
  pair.magnetic.verdict = pair.accepted ? MatchVerdict::kMatch : MatchVerdict::kNoOverlap;
  pair.magnetic.T_a_b = T;
  pair.magnetic.z = score.z;
  pair.magnetic.r = score.r;
  pair.magnetic.overlap_m2 = score.overlap_m2;
  pair.magnetic.fitness = score.value;
  pair.magnetic.modes = {{T, score.z, score.r, score.overlap_m2}};
  pair.T_a_b = T_a_b;
  return pair;
}

PairResult geometryOnlyPair(int a, int b, const std::vector<StructureMap>& structure_maps,
                            const MergeConfig& config) {
  PairResult pair;
  pair.a = a;
  pair.b = b;
  pair.geometry_only = true;
  pair.magnetic = matchMagneticMaps(structure_maps[a].asMatchGrid(),
                                    structure_maps[b].asMatchGrid(), config.geometry_matcher);
  pair.T_a_b = pair.magnetic.T_a_b.toIsometry();
  pair.accepted = pair.magnetic.overlap();
  return pair;
}

void refinePairs(const std::vector<const Session*>& sessions,
                 const std::vector<const MagneticMap*>& maps,
                 const std::vector<StructureMap>& structure_maps, const MergeConfig& config,
                 const std::vector<PairResult*>& pairs, const ProgressCallback& progress) {
  if (maps.size() != sessions.size())
    throw std::invalid_argument("refinePairs: one magnetic map per session needed");
  if (std::any_of(pairs.begin(), pairs.end(),
                  [](const PairResult* p) { return p->geometry_only; }) &&
      structure_maps.size() != sessions.size())
    throw std::invalid_argument(
        "refinePairs: geometry-only pairs need one structure map per session");
  std::mutex progress_mutex;  // pairs report from worker threads
  const auto say = [&](const std::string& message) {
    const std::lock_guard<std::mutex> lock(progress_mutex);
    if (progress) progress(message);
  };
  const int n = static_cast<int>(sessions.size());
  std::vector<bool> needs_point_map(n, false);
  const auto ambiguous = [&](const PairResult& pair) {
    return config.verify_ambiguous_with_geometry &&
           pair.magnetic.verdict == MatchVerdict::kAmbiguous && !pair.magnetic.modes.empty();
  };
  // One place whose yaw the field leaves open: the geometry fixes the yaw where both sessions
  // have scans (ICP-EM from the magnetic pose, kept when it converges with enough inliers).
  const auto yaw_uncertain = [&](const PairResult& pair) {
    return pair.magnetic.verdict == MatchVerdict::kYawUncertain;
  };
  for (const PairResult* pair : pairs) {
    if (!pair->accepted && !ambiguous(*pair) && !yaw_uncertain(*pair)) continue;
    const bool scans = sessions[pair->a]->hasScans() && sessions[pair->b]->hasScans();
    needs_point_map[pair->a] = needs_point_map[pair->a] || scans;
    needs_point_map[pair->b] = needs_point_map[pair->b] || scans;
  }
  // Points only: ICP-EM computes covariances on the overlap it crops them to.
  std::vector<PointCloud> points(n);
  tbb::parallel_for(0, n, [&](int s) {
    if (needs_point_map[s]) points[s] = buildVoxelisedPoints(*sessions[s], config.point_map);
  });
  const auto refineFrom = [&](const PairResult& pair, const Eigen::Isometry3d& seed) {
    // A geometry-only pair's overlap is where its structure maps, which it was matched on, meet.
    const PlanarRegion region =
        pair.geometry_only
            ? overlapRegion(structure_maps[pair.a].asMatchGrid(),
                            structure_maps[pair.b].asMatchGrid(), seed, config.overlap_margin_m)
            : overlapRegion(*maps[pair.a], *maps[pair.b], seed, config.overlap_margin_m);
    return refineIcpEm(points[pair.a], points[pair.b], seed, config.pair_icp, &region);
  };
  tbb::parallel_for(std::size_t{0}, pairs.size(), [&](std::size_t p) {
    PairResult& pair = *pairs[p];
    // A point map is built only for sessions with scans.
    if (!needs_point_map[pair.a] || !needs_point_map[pair.b]) return;
    const std::string name = sessions[pair.a]->id + "+" + sessions[pair.b]->id;
    const auto pair_start = Clock::now();
    if (pair.accepted) {
      pair.icp = refineFrom(pair, pair.T_a_b);
      pair.refined = true;
      if (pair.icp.converged) pair.T_a_b = pair.icp.T_a_b;
      if (pair.icp.inlier_ratio < config.min_geometric_inlier_ratio) pair.accepted = false;
      say("pair " + name + ": ICP-EM " + (pair.icp.converged ? "converged" : "did not converge") +
          ", inlier ratio " + std::to_string(pair.icp.inlier_ratio) +
          (pair.icp.degenerate ? ", degenerate" : "") +
          (pair.accepted ? "" : "; the geometry contradicts the magnetic match, pair dropped"));
    } else if (yaw_uncertain(pair)) {
      pair.icp = refineFrom(pair, pair.T_a_b);
      pair.refined = true;
      pair.accepted = pair.icp.converged && !pair.icp.degenerate &&
                      pair.icp.inlier_ratio >= config.min_geometric_inlier_ratio;
      if (pair.accepted) pair.T_a_b = pair.icp.T_a_b;
      say("pair " + name + ": the field places it but knows its yaw only to ±" +
          std::to_string(pair.magnetic.yaw_uncertainty_deg) + " deg; ICP-EM " +
          (pair.icp.converged ? "converged" : "did not converge") + ", inlier ratio " +
          std::to_string(pair.icp.inlier_ratio) + (pair.icp.degenerate ? ", degenerate" : "") +
          (pair.accepted ? ", the geometry fixes the yaw" : ", refused"));
    } else if (ambiguous(pair)) {
      const bool decided = settleByGeometry(refineFrom, config, &pair);
      std::string ratios;
      for (double ratio : pair.mode_inlier_ratios) ratios += " " + std::to_string(ratio);
      say("pair " + name +
          (pair.geometry_only ? ": ambiguous by its structure maps" : ": magnetically ambiguous") +
          "; ICP-EM inlier ratios of its modes" + ratios +
          (decided ? ", the geometry decides" : ", still ambiguous, refused"));
    }
    pair.seconds += secondsSince(pair_start);
  });
}

std::vector<InterSessionEdge> pairEdges(const Session& a, int index_a, const Session& b,
                                        int index_b, const Eigen::Isometry3d& T_a_b,
                                        const MergeConfig& config) {
  return a.hasScans() && b.hasScans()
             ? interSessionEdges(a, index_a, b, index_b, T_a_b, config.edges)
             : magneticOnlyEdges(a, index_a, b, index_b, T_a_b, config.edges,
                                 config.magnetic_edge_sigma_m, config.magnetic_edge_sigma_deg);
}

}  // namespace mm4mm
