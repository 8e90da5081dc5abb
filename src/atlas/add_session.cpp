#include "mm4mm/atlas/add_session.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <queue>
#include <set>
#include <stdexcept>
#include <utility>

#include "mm4mm/core/pose.hpp"
#include "mm4mm/core/timing.hpp"
#include "mm4mm/merge/all_pairs_matching.hpp"
#include "mm4mm/merge/candidate_pairs.hpp"
#include "mm4mm/merge/fused_magnetic_map.hpp"
#include "mm4mm/merge/merge_steps.hpp"
#include "mm4mm/merge/pair_refinement.hpp"
#include "mm4mm/merge/structure_map.hpp"

namespace mm4mm {
namespace {

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

// Candidate pairs of session `s`, placed at `T_atlas_s`, with the placed sessions (`T_atlas`,
// pairs in `skip` left out), by the growing map's rule (candidate_pairs.hpp): the placed sessions
// came before `s`; a session bridged in (`anchor_found`) already has its anchor, the pair with the
// new session, so it is given the earliest place in that order. Each pair's magnetic result
// restates the placement.
std::vector<PairResult> candidatePairs(int s, const Eigen::Isometry3d& T_atlas_s,
                                       std::vector<std::optional<Eigen::Isometry3d>> T_atlas,
                                       const std::vector<MagneticMap>& maps,
                                       const std::set<std::pair<int, int>>& skip, bool anchor_found,
                                       const MergeConfig& config) {
  const int n = static_cast<int>(T_atlas.size());
  T_atlas[s] = T_atlas_s;
  std::vector<PlacedCoverage> coverage(n);
  tbb::parallel_for(0, n, [&](int t) {
    if (T_atlas[t]) coverage[t] = placedCoverage(maps[t], *T_atlas[t]);
  });
  std::vector<int> order(n, 0);
  order[s] = anchor_found ? -1 : 1;
  std::vector<bool> ranks(n, false);
  ranks[s] = true;
  std::vector<PairResult> pairs;
  for (const CandidatePair& candidate :
       selectCandidatePairs(T_atlas, coverage, order, ranks, {skip.begin(), skip.end()},
                            config.growing_map.candidateRule()))
    pairs.push_back(pairAtPlacement(candidate.a, candidate.b, candidate.T_a_b, maps[candidate.a],
                                    maps[candidate.b], config, candidate.anchor));
  return pairs;
}

// Where each session placed by the tree starts the solve, in the previous solve's frame: down
// the tree from the atlas's frame session (`root`), a session placed before keeps its previous
// poses (`warm`) where its tree parent did too and their link is one the previous solve already
// held (`used_before`: the pair was a tree or consistent pair of the atlas), or agrees with their
// previous relative pose; any other starts where its parent's start frame and the link put it.
// Rigid tree frames alone would carry the drift the previous solve removed along each chain. The
// agreement test compares session frames (first keyframes), which a drifting session's solved
// trajectory leaves metres from a link registered far along it: without `used_before`, such a
// session restarted from the rigid link at every add and the solve left it somewhere else each
// time.
struct StartFrames {
  std::vector<std::optional<Eigen::Isometry3d>> T_atlas_session;
  std::vector<bool> warm;
};

StartFrames startFrames(const std::vector<PairResult>& pairs, const std::vector<bool>& used_before,
                        const std::vector<std::optional<Eigen::Isometry3d>>& previous, int root,
                        const MergeConfig& config) {
  const int sessions = static_cast<int>(previous.size());
  StartFrames start{std::vector<std::optional<Eigen::Isometry3d>>(sessions),
                    std::vector<bool>(sessions, false)};
  start.T_atlas_session[root] = previous[root].value_or(Eigen::Isometry3d::Identity());
  start.warm[root] = previous[root].has_value();
  std::queue<int> frontier;
  frontier.push(root);
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

void checkAddable(const Atlas& atlas, const Session& added, const MergeConfig& config) {
  std::string error;
  if (!config.IsValid(&error)) throw std::invalid_argument("addSessionToAtlas: " + error);
  if (atlas.T_atlas_keyframe.size() != atlas.sessions.size() ||
      atlas.connected.size() != atlas.sessions.size())
    throw std::invalid_argument("addSessionToAtlas: the atlas's sessions and poses disagree");
  if (atlas.frame_session < 0 || atlas.frame_session >= static_cast<int>(atlas.sessions.size()) ||
      !atlas.connected[atlas.frame_session])
    throw std::invalid_argument("addSessionToAtlas: the atlas's frame session " +
                                std::to_string(atlas.frame_session) +
                                " is not one of its connected sessions");
  for (const Session& s : atlas.sessions) {
    if (s.id == added.id)
      throw std::invalid_argument("session '" + added.id + "' is already in the atlas");
    if (sameRecording(s, added))
      throw std::invalid_argument("session '" + added.id + "' is the same recording as '" + s.id +
                                  "', which is already in the atlas");
  }
}

// The atlas as a whole, to match a new session against: its stored fused map, unless that cannot
// serve this matcher (another cell size, or channels the stored map does not keep), then fused
// again from the placed sessions, at the heights above the floor `maps` knows.
MagneticMap atlasMap(const Atlas& atlas, const SessionMaps& maps,
                     const MagneticMatcherConfig& matcher) {
  const MagneticMap& stored = atlas.fused_magnetic_map;
  if (stored.coveredCells() > 0 && std::abs(stored.cell_size_m - matcher.map.cell_size_m) < 1e-9 &&
      matcher.score.channels != MatchChannels::kRotatedVector)
    return stored;
  std::vector<Session> placed;
  std::vector<std::vector<Eigen::Isometry3d>> poses;
  std::vector<SessionFacts> facts;
  for (std::size_t s = 0; s < atlas.sessions.size(); ++s)
    if (atlas.connected[s]) {
      placed.push_back(atlas.sessions[s]), poses.push_back(atlas.T_atlas_keyframe[s]);
      facts.emplace_back();
      facts.back().height_above_floor_m = maps.height_above_floor_m[s];
    }
  FusedMagneticMapConfig fused;
  fused.map = matcher.map;
  fused.detect_changes = false;  // only the map is wanted here
  return placed.empty() ? MagneticMap{} : fuseMagneticMaps(placed, poses, fused, facts).map;
}

// How high above the floor the atlas map reads the field (m): at the height most placed sessions
// share, as the fused map keeps them (atOneHeight), where every placed session's height is known.
// Else the frame session's frame height plus the map's z in the atlas frame, which an odometry's
// tilt moves along a chain of sessions; nullopt where neither is known.
std::optional<double> atlasMapHeight(const Atlas& atlas, const SessionMaps& maps,
                                     const MagneticMap& whole, double max_difference_m) {
  std::vector<std::optional<double>> placed;
  bool every_known = true;
  for (std::size_t s = 0; s < atlas.sessions.size(); ++s)
    if (atlas.connected[s] && maps.magnetic[s].coveredCells() > 0) {
      placed.push_back(maps.height_above_floor_m[s]);
      every_known = every_known && placed.back().has_value();
    }
  if (every_known && !placed.empty()) {
    const std::vector<bool> kept = atOneHeight(placed, max_difference_m);
    double sum = 0.0;
    int count = 0;
    for (std::size_t i = 0; i < placed.size(); ++i)
      if (kept[i]) sum += *placed[i], ++count;
    if (count > 0) return sum / count;
  }
  const std::optional<FrameHeight>& frame = maps.frame_height[atlas.frame_session];
  if (!frame || whole.coveredCells() == 0) return std::nullopt;
  return frame->height_m + whole.height_m;
}

// Step 2 of an add: the new session (the last of `sessions`) matched against the atlas map, and
// its candidate pairs with the placed sessions it then overlaps. Its pairs with single atlas
// sessions are matched as merge matches a pair (matchPairs: the field, the geometry-only fallback,
// the joint stage where the field refused): with each unconnected session (the atlas map does not
// hold it); with each session that cannot be matched magnetically where both have scans (the atlas
// keeps no fused structure map); and, where the atlas map did not place the new session and it has
// scans, with every placed session that has scans, so that geometry may propose where the field
// alone refused, as it does in a merge. Fills the result's match counts and structure maps.
std::vector<PairResult> matchIntoAtlas(const Atlas& atlas,
                                       const std::vector<const Session*>& sessions,
                                       const SessionMaps& maps,
                                       const std::vector<std::optional<Eigen::Isometry3d>>& T_atlas,
                                       const MergeConfig& config, const ProgressCallback& say,
                                       MergeResult* result) {
  const int n = static_cast<int>(atlas.sessions.size());
  const Session& added = *sessions[n];
  const bool matchable = !maps.obstacles[n].any();
  const MagneticMap whole = matchable ? atlasMap(atlas, maps, config.matcher) : MagneticMap{};
  // A new session whose magnetometers are at another height than the atlas map's reads another
  // field, and is matched pair by pair.
  const std::optional<double> atlas_height =
      whole.coveredCells() > 0 ? atlasMapHeight(atlas, maps, whole, config.max_height_difference_m)
                               : std::nullopt;
  const std::optional<double>& added_height = maps.height_above_floor_m[n];
  const bool atlas_height_differs =
      atlas_height && added_height &&
      std::abs(*atlas_height - *added_height) > config.max_height_difference_m;
  if (atlas_height_differs) {
    char difference[32];
    std::snprintf(difference, sizeof difference, "%+.2f", *added_height - *atlas_height);
    say(added.id + "'s magnetometers are " + difference +
        " m above the atlas map's height: not matched against it, only pair by pair");
  }
  MagneticMatchResult against_atlas;
  if (whole.coveredCells() > 0 && !atlas_height_differs) {
    against_atlas = matchMagneticMaps(whole, maps.magnetic[n], config.matcher);
    result->magnetic_matches = 1;
    say("matched " + added.id + " against the atlas map (" + toString(against_atlas.verdict) +
        ", z " + std::to_string(against_atlas.z) + ")");
  }
  std::vector<PairResult> pairs;
  if (against_atlas.overlap())
    pairs = candidatePairs(n, against_atlas.T_a_b.toIsometry(), T_atlas, maps.magnetic, {}, false,
                           config);
  const auto paired = [&](int s) {
    return std::any_of(pairs.begin(), pairs.end(),
                       [&](const PairResult& pair) { return pair.a == s && pair.accepted; });
  };
  const bool joint_fallback =
      matchable && !against_atlas.overlap() && config.joint.enabled && added.hasScans();
  std::vector<std::pair<int, int>> which;
  for (int s = 0; s < n; ++s) {
    const bool magnetic = matchable && !maps.obstacles[s].any();
    const bool scans = added.hasScans() && atlas.sessions[s].hasScans();
    const bool geometry = !magnetic && config.geometry_fallback && scans;
    if (paired(s)) continue;
    if (((!atlas.connected[s] || atlas_height_differs) && magnetic) || geometry ||
        (joint_fallback && magnetic && scans))
      which.emplace_back(s, n);
  }
  if (which.empty()) return pairs;
  AllPairsMatch matched = matchPairs(sessions, maps, which, config, say);
  result->magnetic_matches += matched.magnetic_matches;
  result->geometry_matches = matched.geometry_matches;
  result->structure_maps = std::move(matched.structure_maps);
  const auto accepted = std::count_if(matched.pairs.begin(), matched.pairs.end(),
                                      [](const PairResult& pair) { return pair.accepted; });
  say("matched " + added.id + " pair by pair with " + std::to_string(which.size()) +
      (which.size() == 1 ? " atlas session: " : " atlas sessions: ") + std::to_string(accepted) +
      " overlap");
  pairs.insert(pairs.end(), matched.pairs.begin(), matched.pairs.end());
  return pairs;
}

// A session the new one bridged into the atlas is placed by that one pair alone: it gets
// candidate pairs with the placed sessions it overlaps, as the new session did. A pair the
// matcher refused before (the sessions had no known relative place then) is tried again at the
// new placement, in its slot, and no longer counts as the atlas's (`previous_role`). Returns
// whether any pair was added, so that the tree is drawn again.
bool bridgeUnconnected(const Atlas& atlas, const std::vector<const Session*>& sessions,
                       const std::vector<MagneticMap>& maps,
                       const std::vector<StructureMap>& structure_maps,
                       const std::vector<std::optional<FrameHeight>>& frame_heights,
                       const std::vector<std::optional<Eigen::Isometry3d>>& T_tree,
                       const MergeConfig& config, const ProgressCallback& say,
                       std::vector<PairResult>* pairs, std::vector<PairRole>* previous_role) {
  std::set<std::pair<int, int>> existing;
  std::map<std::pair<int, int>, std::size_t> refused_slot;
  for (std::size_t p = 0; p < pairs->size(); ++p) {
    if ((*pairs)[p].accepted)
      existing.insert({(*pairs)[p].a, (*pairs)[p].b});
    else
      refused_slot[{(*pairs)[p].a, (*pairs)[p].b}] = p;
  }
  std::vector<PairResult> bridge_pairs;
  for (int s = 0; s < static_cast<int>(atlas.sessions.size()); ++s) {
    if (atlas.connected[s] || !T_tree[s]) continue;
    say("session " + atlas.sessions[s].id + " was unconnected; " + sessions.back()->id +
        " bridges it into the atlas");
    for (PairResult& pair : candidatePairs(s, *T_tree[s], T_tree, maps, existing, true, config)) {
      existing.insert({pair.a, pair.b});
      bridge_pairs.push_back(pair);
    }
  }
  if (bridge_pairs.empty()) return false;
  refineAll(sessions, maps, structure_maps, frame_heights, config, &bridge_pairs, say);
  for (const PairResult& pair : bridge_pairs) {
    const auto slot = refused_slot.find({pair.a, pair.b});
    if (slot == refused_slot.end()) {
      pairs->push_back(pair);
    } else {
      (*pairs)[slot->second] = pair;
      if (slot->second < previous_role->size()) (*previous_role)[slot->second] = PairRole::kRefused;
    }
  }
  return true;
}

// Step 5 of an add: a pair the atlas used (tree or consistent, with stored edges) keeps its stored
// edges (`used_before`, per pair); a pair used for the first time gets them computed.
GraphEdges edgesKeepingStored(const std::vector<InterSessionEdge>& atlas_edges,
                              const std::vector<PairRole>& previous_role,
                              const std::vector<const Session*>& sessions,
                              const std::vector<std::optional<Eigen::Isometry3d>>& T_tree,
                              const MergeConfig& config, std::vector<PairResult>* pairs,
                              std::vector<bool>* used_before) {
  std::map<std::pair<int, int>, std::vector<InterSessionEdge>> stored;  // by session pair
  for (const InterSessionEdge& edge : atlas_edges)
    stored[{std::min(edge.session_a, edge.session_b), std::max(edge.session_a, edge.session_b)}]
        .push_back(edge);
  used_before->assign(pairs->size(), false);
  for (std::size_t p = 0; p < previous_role.size(); ++p)
    (*used_before)[p] =
        (previous_role[p] == PairRole::kTree || previous_role[p] == PairRole::kConsistent) &&
        stored.count({(*pairs)[p].a, (*pairs)[p].b}) > 0;
  return edgesOfUsedPairs(sessions, T_tree, config, pairs,
                          [&](std::size_t p) -> std::optional<std::vector<InterSessionEdge>> {
                            if (!(*used_before)[p]) return std::nullopt;
                            return stored.at({(*pairs)[p].a, (*pairs)[p].b});
                          });
}

}  // namespace

MergeResult addSessionToAtlas(const Atlas& atlas, const Session& added, const MergeConfig& config,
                              const ProgressCallback& progress) {
  checkAddable(atlas, added, config);
  // The steps below call it unchecked.
  const ProgressCallback say = [&](const std::string& message) {
    if (progress) progress(message);
  };
  const int n = static_cast<int>(atlas.sessions.size());
  std::vector<const Session*> sessions;
  for (const Session& s : atlas.sessions) sessions.push_back(&s);
  sessions.push_back(&added);
  MergeResult result;
  result.config = config;

  // 1. Every session's own map: the new one to match, the others for the pairs it may form and
  // for the solve's magnetic residuals, which compare each session with every other.
  auto start = SteadyClock::now();
  SessionMaps maps = buildSessionMaps(sessions, config);
  result.seconds_maps = secondsSince(start);
  if (maps.obstacles[n].any())
    say("session " + added.id + " cannot be matched magnetically: " + describe(maps.obstacles[n]) +
        (config.geometry_fallback && added.hasScans() ? "; matching it by geometry only"
                                                      : "; it stays unconnected"));

  // 2. The new session's pairs, from where the placed sessions are now (the previous solve).
  start = SteadyClock::now();
  std::vector<std::optional<Eigen::Isometry3d>> T_atlas(n + 1);
  for (int s = 0; s < n; ++s)
    if (atlas.connected[s]) T_atlas[s] = sessionFrame(atlas.sessions[s], atlas.T_atlas_keyframe[s]);
  std::vector<PairResult> new_pairs =
      matchIntoAtlas(atlas, sessions, maps, T_atlas, config, say, &result);
  result.magnetic_maps = std::move(maps.magnetic);
  result.match_obstacles = std::move(maps.obstacles);
  result.frame_heights = std::move(maps.frame_height);
  result.magnetometer_heights_m = std::move(maps.height_above_floor_m);
  result.seconds_matching = secondsSince(start);

  // 3. Refinement of the new pairs; 4. every pair, the atlas's and the new ones, placed as merge
  // places them, so that a stronger pair the new session brings can move a session an earlier,
  // weaker pair placed (a bridge over a small overlap) instead of being dropped as inconsistent.
  start = SteadyClock::now();
  refineAll(sessions, result.magnetic_maps, result.structure_maps, result.frame_heights, config,
            &new_pairs, progress);
  result.pairs = atlas.pairs;
  std::vector<PairRole> previous_role;
  for (const PairResult& pair : atlas.pairs) previous_role.push_back(pair.role);
  result.pairs.insert(result.pairs.end(), new_pairs.begin(), new_pairs.end());
  // The atlas keeps its frame: the tree is placed from its frame session, whatever else joins.
  result.frame_session = atlas.frame_session;
  auto T_tree = placeSessions(n + 1, config, &result.pairs, atlas.frame_session).T_atlas;
  if (bridgeUnconnected(atlas, sessions, result.magnetic_maps, result.structure_maps,
                        result.frame_heights, T_tree, config, say, &result.pairs, &previous_role))
    T_tree = placeSessions(n + 1, config, &result.pairs, atlas.frame_session).T_atlas;

  // 5. Edges: a pair used before keeps its stored edges, one used for the first time gets them.
  std::vector<bool> used_before;
  GraphEdges edges = edgesKeepingStored(atlas.edges, previous_role, sessions, T_tree, config,
                                        &result.pairs, &used_before);
  result.seconds_refinement = secondsSince(start);

  // 6. The solve, warm where the previous solve already placed a session the same way.
  start = SteadyClock::now();
  const StartFrames frames =
      startFrames(result.pairs, used_before, T_atlas, atlas.frame_session, config);
  std::vector<std::vector<Eigen::Isometry3d>> warm(n + 1);
  for (int s = 0; s < n; ++s)
    if (frames.warm[s]) warm[s] = atlas.T_atlas_keyframe[s];
  solveGraph(sessions, frames.T_atlas_session, warm, std::move(edges), config, &result);
  result.seconds_solve = secondsSince(start);
  say(solveSummary(result));
  return result;
}

}  // namespace mm4mm
