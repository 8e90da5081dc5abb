#include "mm4mm/atlas/add_session.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <map>
#include <optional>
#include <queue>
#include <set>
#include <stdexcept>
#include <utility>

#include "mm4mm/core/pose.hpp"
#include "mm4mm/core/timing.hpp"
#include "mm4mm/merge/fused_magnetic_map.hpp"
#include "mm4mm/merge/pair_refinement.hpp"
#include "mm4mm/merge/structure_map.hpp"

namespace mm4mm {
namespace {

using Clock = SteadyClock;

// The same data, as far as the session files keep it: times to 1 µs, fields to 0.1 nT.
bool sameRecording(const Session& a, const Session& b) {
  constexpr double kTime_s = 2e-6, kField_uT = 2e-4, kPose = 1e-6;
  if (a.keyframes.size() != b.keyframes.size() || a.magnetometer.size() != b.magnetometer.size())
    return false;
  for (std::size_t k = 0; k < a.keyframes.size(); ++k)
    if (std::abs(a.keyframes[k].time_s - b.keyframes[k].time_s) > kTime_s ||
        !a.keyframes[k].T_frame_body.isApprox(b.keyframes[k].T_frame_body, kPose))
      return false;
  for (std::size_t i = 0; i < a.magnetometer.size(); ++i)
    if (std::abs(a.magnetometer[i].time_s - b.magnetometer[i].time_s) > kTime_s ||
        a.magnetometer[i].sensor != b.magnetometer[i].sensor ||
        (a.magnetometer[i].field_body_uT - b.magnetometer[i].field_body_uT).cwiseAbs().maxCoeff() >
            kField_uT)
      return false;
  return true;
}

Eigen::Isometry3d sessionFrame(const Session& session,
                               const std::vector<Eigen::Isometry3d>& T_atlas_keyframe) {
  return T_atlas_keyframe.front() * session.keyframes.front().T_frame_body.inverse();
}

// The 1 m squares of the atlas frame that a session's magnetic map covers once placed by
// `T_atlas_session`: enough to rank which placed sessions a new one overlaps most.
std::set<std::int64_t> coveredSquares(const MagneticMap& map,
                                      const Eigen::Isometry3d& T_atlas_session) {
  constexpr double kSquare_m = 1.0;
  const MagneticMap coarse =
      downsample(map, std::max(1, static_cast<int>(std::round(kSquare_m / map.cell_size_m))));
  std::set<std::int64_t> squares;
  for (int iy = 0; iy < coarse.height; ++iy)
    for (int ix = 0; ix < coarse.width; ++ix) {
      if (!coarse.covered(ix, iy)) continue;
      const Eigen::Vector2d c = coarse.cellCentre(ix, iy);
      const Eigen::Vector3d p = T_atlas_session * Eigen::Vector3d(c.x(), c.y(), 0.0);
      const auto sx = static_cast<std::int64_t>(std::floor(p.x() / kSquare_m));
      const auto sy = static_cast<std::int64_t>(std::floor(p.y() / kSquare_m));
      squares.insert(sx * 4000003 + sy);
    }
  return squares;
}

double commonSquares_m2(const std::set<std::int64_t>& a, const std::set<std::int64_t>& b) {
  std::size_t common = 0;
  for (std::int64_t square : a) common += b.count(square);
  return static_cast<double>(common);
}

// Candidate pairs of session `s`, placed at `T_atlas_s`, with the placed sessions (`T_atlas`,
// `s` itself and `skip` left out): the one it overlaps most (its anchor, unless `anchor_found`
// already) and its next largest overlaps of at least the growing map's minimum, up to its cap.
// Each pair's magnetic result restates the placement; pairs are ordered (a < b).
std::vector<PairResult> candidatePairs(int s, const Eigen::Isometry3d& T_atlas_s,
                                       const std::vector<std::optional<Eigen::Isometry3d>>& T_atlas,
                                       const std::vector<MagneticMap>& maps,
                                       const std::set<std::pair<int, int>>& skip, bool anchor_found,
                                       const MergeConfig& config) {
  const auto squares = coveredSquares(maps[s], T_atlas_s);
  std::vector<std::pair<double, int>> overlaps;
  for (int t = 0; t < static_cast<int>(T_atlas.size()); ++t) {
    if (t == s || !T_atlas[t] || skip.count({std::min(s, t), std::max(s, t)})) continue;
    const double overlap = commonSquares_m2(squares, coveredSquares(maps[t], *T_atlas[t]));
    if (overlap > 0.0) overlaps.emplace_back(overlap, t);
  }
  std::stable_sort(overlaps.begin(), overlaps.end(),
                   [](const auto& x, const auto& y) { return x.first > y.first; });
  std::vector<PairResult> pairs;
  for (std::size_t k = 0; k < overlaps.size(); ++k) {
    const bool anchor = k == 0 && !anchor_found;
    const int rank = static_cast<int>(k) + (anchor_found ? 1 : 0);  // the anchor is rank 0
    if (!anchor && (overlaps[k].first < config.growing_map.min_pair_overlap_m2 ||
                    rank > config.growing_map.max_pairs_per_session))
      break;
    const int t = overlaps[k].second;
    const int a = std::min(s, t), b = std::max(s, t);
    const Eigen::Isometry3d T_atlas_a = a == s ? T_atlas_s : *T_atlas[t];
    const Eigen::Isometry3d T_atlas_b = b == s ? T_atlas_s : *T_atlas[t];
    pairs.push_back(
        pairAtPlacement(a, b, T_atlas_a.inverse() * T_atlas_b, maps[a], maps[b], config, anchor));
  }
  return pairs;
}

// Where each session placed by the tree starts the solve, in the previous solve's frame: down
// the tree from session 0, a session placed before keeps its previous poses (`warm`) where its
// tree parent did too and their link is one the previous solve already held (`used_before`:
// the pair was a tree or consistent pair of the atlas), or agrees with their previous relative
// pose; any other starts where its parent's start frame and the link put it. Rigid tree frames
// alone would carry the drift the previous solve removed along each chain. The agreement test
// compares session frames (first keyframes), which a drifting session's solved trajectory leaves
// metres from a link registered far along it: without `used_before`, such a session restarted
// from the rigid link at every add and the solve left it somewhere else each time.
struct StartFrames {
  std::vector<std::optional<Eigen::Isometry3d>> T_atlas_session;
  std::vector<bool> warm;
};

StartFrames startFrames(const std::vector<PairResult>& pairs, const std::vector<bool>& used_before,
                        const std::vector<std::optional<Eigen::Isometry3d>>& previous,
                        const MergeConfig& config) {
  const int sessions = static_cast<int>(previous.size());
  StartFrames start{std::vector<std::optional<Eigen::Isometry3d>>(sessions),
                    std::vector<bool>(sessions, false)};
  start.T_atlas_session[0] = previous[0].value_or(Eigen::Isometry3d::Identity());
  start.warm[0] = previous[0].has_value();
  std::queue<int> frontier;
  frontier.push(0);
  while (!frontier.empty()) {
    const int parent = frontier.front();
    frontier.pop();
    for (std::size_t p = 0; p < pairs.size(); ++p) {
      const PairResult& pair = pairs[p];
      if (pair.role != PairRole::kTree || (pair.a != parent && pair.b != parent)) continue;
      const int child = pair.a == parent ? pair.b : pair.a;
      if (start.T_atlas_session[child]) continue;
      const Eigen::Isometry3d T_parent_child = pair.a == parent ? pair.T_a_b : pair.T_a_b.inverse();
      bool keep = false;
      if (start.warm[parent] && previous[child]) {
        const Eigen::Isometry3d delta =
            (previous[parent]->inverse() * *previous[child]).inverse() * T_parent_child;
        keep = used_before[p] ||
               (delta.translation().norm() < config.consistency_translation_m &&
                rotationAngle(delta.linear()) * 180.0 / M_PI < config.consistency_rotation_deg);
      }
      start.warm[child] = keep;
      start.T_atlas_session[child] =
          keep ? *previous[child] : *start.T_atlas_session[parent] * T_parent_child;
      frontier.push(child);
    }
  }
  return start;
}

}  // namespace

MergeResult addSessionToAtlas(const Atlas& atlas, const Session& added, const MergeConfig& config,
                              const ProgressCallback& progress) {
  std::string error;
  if (!config.IsValid(&error)) throw std::invalid_argument("addSessionToAtlas: " + error);
  const int n = static_cast<int>(atlas.sessions.size());
  if (atlas.T_atlas_keyframe.size() != atlas.sessions.size() ||
      atlas.connected.size() != atlas.sessions.size())
    throw std::invalid_argument("addSessionToAtlas: the atlas's sessions and poses disagree");
  for (const Session& s : atlas.sessions) {
    if (s.id == added.id)
      throw std::invalid_argument("session '" + added.id + "' is already in the atlas");
    if (sameRecording(s, added))
      throw std::invalid_argument("session '" + added.id + "' is the same recording as '" + s.id +
                                  "', which is already in the atlas");
  }
  const auto say = [&](const std::string& message) {
    if (progress) progress(message);
  };
  const int new_index = n;
  std::vector<const Session*> sessions;
  for (const Session& s : atlas.sessions) sessions.push_back(&s);
  sessions.push_back(&added);

  MergeResult result;
  result.config = config;
  auto start = Clock::now();
  // Every session's own map: the new one to match, the others for the pairs it may form and for
  // the solve's magnetic residuals, which compare each session with every other.
  result.magnetic_maps.resize(n + 1);
  tbb::parallel_for(0, n + 1, [&](int s) {
    result.magnetic_maps[s] =
        buildMagneticMap(placeFingerprints(*sessions[s]), sessions[s]->rig, config.matcher.map);
  });
  result.seconds_maps = secondsSince(start);
  result.match_obstacles.resize(n + 1);
  for (int s = 0; s <= n; ++s)
    result.match_obstacles[s] =
        magneticMatchObstacle(*sessions[s], result.magnetic_maps[s], config.matcher);
  const bool matchable = result.match_obstacles[new_index].empty();
  const bool by_geometry = !matchable && config.geometry_fallback && added.hasScans();
  if (!matchable)
    say("session " + added.id +
        " cannot be matched magnetically: " + result.match_obstacles[new_index] +
        (by_geometry ? "; matching it by geometry only" : "; it stays unconnected"));

  // Where the placed sessions are now: the previous solve's frames.
  std::vector<std::optional<Eigen::Isometry3d>> T_atlas(n + 1);
  for (int s = 0; s < n; ++s)
    if (atlas.connected[s]) T_atlas[s] = sessionFrame(atlas.sessions[s], atlas.T_atlas_keyframe[s]);

  start = Clock::now();
  // The atlas as a whole: its stored fused map, unless that cannot serve this matcher (another
  // cell size, or channels the stored map does not keep), then fused again from the sessions.
  MagneticMap atlas_map = atlas.fused_magnetic_map;
  if (atlas_map.coveredCells() == 0 ||
      std::abs(atlas_map.cell_size_m - config.matcher.map.cell_size_m) > 1e-9 ||
      config.matcher.score.channels == MatchChannels::kRotatedVector) {
    std::vector<Session> placed;
    std::vector<std::vector<Eigen::Isometry3d>> poses;
    for (int s = 0; s < n; ++s)
      if (atlas.connected[s])
        placed.push_back(atlas.sessions[s]), poses.push_back(atlas.T_atlas_keyframe[s]);
    FusedMagneticMapConfig fused;
    fused.map = config.matcher.map;
    atlas_map = placed.empty() ? MagneticMap{} : fuseMagneticMaps(placed, poses, fused).map;
  }
  std::vector<int> unconnected;
  for (int s = 0; s < n; ++s)
    if (!atlas.connected[s]) unconnected.push_back(s);
  // Task 0 matches against the atlas map, task k against unconnected session k - 1.
  std::vector<MagneticMatchResult> matches(unconnected.size() + 1);
  tbb::parallel_for(std::size_t{0}, matches.size(), [&](std::size_t k) {
    if (!matchable || (k > 0 && !result.match_obstacles[unconnected[k - 1]].empty())) return;
    if (k == 0) {
      if (atlas_map.coveredCells() > 0)
        matches[0] = matchMagneticMaps(atlas_map, result.magnetic_maps[new_index], config.matcher);
    } else {
      matches[k] = matchMagneticMaps(result.magnetic_maps[unconnected[k - 1]],
                                     result.magnetic_maps[new_index], config.matcher);
    }
  });
  result.magnetic_matches = 0;
  if (matchable) {
    result.magnetic_matches = atlas_map.coveredCells() > 0 ? 1 : 0;
    for (int s : unconnected) result.magnetic_matches += result.match_obstacles[s].empty() ? 1 : 0;
  }
  if (matchable)
    say("matched " + added.id + " against the atlas map (" + toString(matches[0].verdict) + ", z " +
        std::to_string(matches[0].z) + ") and " + std::to_string(unconnected.size()) +
        " unconnected sessions");

  // Candidate pairs with placed sessions: the one the new session overlaps most (its anchor)
  // and the next largest overlaps of at least the growing map's minimum.
  std::vector<PairResult> new_pairs;
  if (matches[0].overlap())
    new_pairs = candidatePairs(new_index, matches[0].T_a_b.toIsometry(), T_atlas,
                               result.magnetic_maps, {}, false, config);
  for (std::size_t k = 0; k < unconnected.size(); ++k) {
    PairResult pair;
    pair.a = unconnected[k];
    pair.b = new_index;
    pair.magnetic = matches[k + 1];
    pair.T_a_b = pair.magnetic.T_a_b.toIsometry();
    pair.accepted = pair.magnetic.overlap();
    new_pairs.push_back(pair);
  }
  // The geometry-only fallback, as in merge: a pair of the new session with an atlas session in
  // which either cannot be matched magnetically is matched on structure maps where both have
  // scans. The atlas keeps no fused structure map, so a new session without readings costs one
  // match per atlas session with scans, unlike the magnetic add. Its pair replaces the empty
  // placeholder an unconnected session got above.
  std::vector<int> partners;
  if (config.geometry_fallback && added.hasScans())
    for (int s = 0; s < n; ++s) {
      if (!atlas.sessions[s].hasScans() || (matchable && result.match_obstacles[s].empty()))
        continue;
      const auto existing =
          std::find_if(new_pairs.begin(), new_pairs.end(),
                       [&](const PairResult& pair) { return pair.a == s && pair.b == new_index; });
      if (existing != new_pairs.end() && existing->accepted) continue;
      if (existing != new_pairs.end()) new_pairs.erase(existing);
      partners.push_back(s);
    }
  std::vector<PairResult> geometry_pairs;
  if (!partners.empty()) {
    result.structure_maps.resize(n + 1);
    geometry_pairs.resize(partners.size());
    std::vector<int> mapped = partners;
    mapped.push_back(new_index);
    tbb::parallel_for(std::size_t{0}, mapped.size(), [&](std::size_t k) {
      result.structure_maps[mapped[k]] =
          buildStructureMap(*sessions[mapped[k]], config.structure_map);
    });
    tbb::parallel_for(std::size_t{0}, partners.size(), [&](std::size_t k) {
      geometry_pairs[k] = geometryOnlyPair(partners[k], new_index, result.structure_maps, config);
    });
    result.geometry_matches = static_cast<int>(partners.size());
    int accepted = 0;
    for (const PairResult& pair : geometry_pairs) accepted += pair.accepted ? 1 : 0;
    say("matched " + added.id + " by geometry only (structure maps) with " +
        std::to_string(partners.size()) + " atlas sessions: " + std::to_string(accepted) +
        " overlap");
  }
  result.seconds_matching = secondsSince(start);

  start = Clock::now();
  std::vector<const MagneticMap*> map_pointers;
  for (const MagneticMap& map : result.magnetic_maps) map_pointers.push_back(&map);
  const auto refine = [&](std::vector<PairResult>* to_refine) {
    std::vector<PairResult*> pointers;
    for (PairResult& pair : *to_refine) pointers.push_back(&pair);
    refinePairs(sessions, map_pointers, result.structure_maps, config, pointers, progress);
  };
  new_pairs.insert(new_pairs.end(), geometry_pairs.begin(), geometry_pairs.end());
  refine(&new_pairs);
  // Every pair, the atlas's and the new ones, placed as merge places them: the
  // maximum-confidence spanning tree over all accepted pairs, and the other pairs checked against
  // it. A stronger pair the new session brings can so move a session an earlier, weaker pair
  // placed (a bridge over a small overlap), where only keeping the old placements would drop the
  // stronger pair as inconsistent.
  std::vector<PairResult> pairs = atlas.pairs;
  const std::size_t old_pairs = pairs.size();
  std::vector<PairRole> previous_role;
  for (const PairResult& pair : pairs) previous_role.push_back(pair.role);
  pairs.insert(pairs.end(), new_pairs.begin(), new_pairs.end());
  std::vector<std::optional<Eigen::Isometry3d>> T_tree;
  const auto placeAll = [&] {
    for (PairResult& pair : pairs) pair.role = PairRole::kRefused;
    markSpanningTree(n + 1, &pairs);
    T_tree = placeByTree(n + 1, pairs);
    markConsistency(T_tree, config, &pairs);
  };
  placeAll();
  // A session the new one bridged into the atlas is placed by that one pair alone: it gets
  // candidate pairs with the placed sessions it overlaps, as the new session did, and the tree
  // is drawn again with them.
  // A pair the matcher refused before (the sessions had no known relative place then) is tried
  // again at the new placement, in its slot.
  std::set<std::pair<int, int>> existing;
  std::map<std::pair<int, int>, std::size_t> refused_slot;
  for (std::size_t p = 0; p < pairs.size(); ++p) {
    if (pairs[p].accepted)
      existing.insert({pairs[p].a, pairs[p].b});
    else
      refused_slot[{pairs[p].a, pairs[p].b}] = p;
  }
  std::vector<PairResult> bridge_pairs;
  for (int s = 0; s < n; ++s) {
    if (atlas.connected[s] || !T_tree[s]) continue;
    say("session " + atlas.sessions[s].id + " was unconnected; " + added.id +
        " bridges it into the atlas");
    for (PairResult& pair :
         candidatePairs(s, *T_tree[s], T_tree, result.magnetic_maps, existing, true, config)) {
      existing.insert({pair.a, pair.b});
      bridge_pairs.push_back(pair);
    }
  }
  if (!bridge_pairs.empty()) {
    refine(&bridge_pairs);
    for (const PairResult& pair : bridge_pairs) {
      const auto slot = refused_slot.find({pair.a, pair.b});
      if (slot == refused_slot.end()) {
        pairs.push_back(pair);
      } else {
        pairs[slot->second] = pair;
        if (slot->second < old_pairs) previous_role[slot->second] = PairRole::kRefused;
      }
    }
    placeAll();
  }

  // Edges: a pair used before keeps its stored edges; a pair used now for the first time (the
  // new ones, or an old one the new tree agrees with) gets them computed.
  std::map<std::pair<int, int>, std::vector<std::size_t>> stored_edges;  // by session pair
  for (std::size_t e = 0; e < atlas.edges.size(); ++e) {
    const InterSessionEdge& edge = atlas.edges[e];
    stored_edges[{std::min(edge.session_a, edge.session_b),
                  std::max(edge.session_a, edge.session_b)}]
        .push_back(e);
  }
  const auto used = [&](const PairResult& pair) {
    return (pair.role == PairRole::kTree || pair.role == PairRole::kConsistent) && T_tree[pair.a] &&
           T_tree[pair.b];
  };
  const auto usedBefore = [&](std::size_t p) {
    return p < old_pairs &&
           (previous_role[p] == PairRole::kTree || previous_role[p] == PairRole::kConsistent) &&
           stored_edges.count({pairs[p].a, pairs[p].b}) > 0;
  };
  std::vector<std::vector<InterSessionEdge>> pair_edges(pairs.size());
  tbb::parallel_for(std::size_t{0}, pairs.size(), [&](std::size_t p) {
    if (!used(pairs[p]) || usedBefore(p)) return;
    pair_edges[p] = pairEdges(*sessions[pairs[p].a], pairs[p].a, *sessions[pairs[p].b], pairs[p].b,
                              pairs[p].T_a_b, config);
  });
  std::vector<std::size_t> edge_owner;
  for (std::size_t p = 0; p < pairs.size(); ++p) {
    PairResult& pair = pairs[p];
    pair.edges_kept = 0;
    if (!used(pair)) {
      pair.edges = 0;
      continue;
    }
    if (usedBefore(p))
      for (std::size_t e : stored_edges.at({pair.a, pair.b}))
        pair_edges[p].push_back(atlas.edges[e]);
    pair.edges = static_cast<int>(pair_edges[p].size());
    for (const InterSessionEdge& edge : pair_edges[p]) {
      result.edges.push_back(edge);
      edge_owner.push_back(p);
    }
  }
  std::vector<bool> used_before(pairs.size());
  for (std::size_t p = 0; p < pairs.size(); ++p) used_before[p] = usedBefore(p);
  result.pairs = std::move(pairs);
  result.seconds_refinement = secondsSince(start);

  start = Clock::now();
  MultiSessionProblem problem;
  problem.sessions = sessions;
  problem.initial_T_atlas_keyframe.resize(n + 1);
  const StartFrames start_frames = startFrames(result.pairs, used_before, T_atlas, config);
  for (int s = 0; s <= n; ++s) {
    problem.T_atlas_session.push_back(
        start_frames.T_atlas_session[s].value_or(Eigen::Isometry3d::Identity()));
    problem.connected.push_back(start_frames.T_atlas_session[s].has_value());
    problem.magnetic_maps.push_back(&result.magnetic_maps[s]);
    if (start_frames.warm[s]) problem.initial_T_atlas_keyframe[s] = atlas.T_atlas_keyframe[s];
  }
  solveAndRecord(std::move(problem), edge_owner, config, &result);
  result.seconds_solve = secondsSince(start);
  int connected = 0;
  for (bool c : result.solution.connected) connected += c ? 1 : 0;
  say("solved the graph in " + std::to_string(result.seconds_solve) +
      " s: " + std::to_string(connected) + " of " + std::to_string(n + 1) + " sessions connected");
  return result;
}

}  // namespace mm4mm
