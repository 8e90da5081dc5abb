#include "mm4mm/merge/merge_sessions.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "mm4mm/core/timing.hpp"
#include "mm4mm/merge/all_pairs_matching.hpp"
#include "mm4mm/merge/merge_steps.hpp"
#include "mm4mm/merge/pair_refinement.hpp"

namespace mm4mm {

bool MergeConfig::IsValid(std::string* error) const {
  const auto fail = [&](const char* message) {
    if (error) *error = message;
    return false;
  };
  // Each message starts with the key it is about, as the config file names it.
  std::string inner;
  const auto within = [&](const char* key, bool valid) {
    if (!valid && error) *error = std::string(key) + "." + inner;
    return valid;
  };
  if (!within("matcher", matcher.IsValid(&inner)) ||
      !within("growing_map", growing_map.IsValid(&inner)) ||
      !within("point_map", point_map.IsValid(&inner)) ||
      !within("pair_icp", pair_icp.IsValid(&inner)) || !within("edges", edges.IsValid(&inner)) ||
      !within("structure_map", structure_map.IsValid(&inner)) ||
      !within("geometry_matcher", geometry_matcher.IsValid(&inner)) ||
      !within("joint", joint.IsValid(&inner)) || !within("graph", graph.IsValid(&inner)))
    return false;
  if (std::abs(geometry_matcher.map.cell_size_m - structure_map.cell_size_m) > 1e-9)
    return fail("geometry_matcher.map.cell_size_m must equal structure_map.cell_size_m");
  if (!(overlap_margin_m >= 0.0)) return fail("overlap_margin_m must be >= 0");
  if (!(magnetic_edge_sigma_m > 0.0) || !(magnetic_edge_sigma_deg > 0.0))
    return fail("magnetic_edge_sigma_m and magnetic_edge_sigma_deg must be > 0");
  if (max_modes_verified < 1) return fail("max_modes_verified must be >= 1");
  if (!(min_geometric_inlier_ratio >= 0.0 && min_geometric_inlier_ratio <= 1.0) ||
      !(geometric_inlier_margin >= 0.0))
    return fail("min_geometric_inlier_ratio must be in [0, 1] and geometric_inlier_margin >= 0");
  if (!(consistency_translation_m > 0.0) || !(consistency_rotation_deg > 0.0))
    return fail("consistency_translation_m and consistency_rotation_deg must be > 0");
  if (!(max_height_difference_m >= 0.0))
    return fail("max_height_difference_m must be >= 0 (m; .inf: always compared)");
  return true;
}

MatchObstacle magneticMatchObstacle(const Session& session, const MagneticMap& map,
                                    const MagneticMatcherConfig& config) {
  using Reason = MatchObstacle::Reason;
  MatchObstacle obstacle;
  if (session.keyframes.empty()) return {Reason::kNoKeyframes};
  if (session.magnetometer.empty()) return {Reason::kNoReadings};
  const double first_s = session.keyframes.front().time_s;
  const double last_s = session.keyframes.back().time_s;
  if (std::none_of(
          session.magnetometer.begin(), session.magnetometer.end(),
          [&](const MagnetometerSample& m) { return m.time_s >= first_s && m.time_s <= last_s; }))
    return {Reason::kNoReadingsInSpan};
  const MagneticMatcherConfig applied = config.appliedTo(map, map);
  obstacle.needed_m2 = std::max(applied.search.min_overlap_m2, applied.score.min_overlap_m2);
  obstacle.covered_m2 = map.coveredArea_m2();
  if (obstacle.covered_m2 >= obstacle.needed_m2) return {};
  obstacle.reason = Reason::kTooLittleCoverage;
  for (std::size_t k = 1; k < session.keyframes.size(); ++k)
    obstacle.travelled_m += (session.keyframes[k].T_frame_body.translation() -
                             session.keyframes[k - 1].T_frame_body.translation())
                                .norm();
  return obstacle;
}

namespace {

// Step 2 with the growing map (growing_map_matching.hpp): the placements' candidate pairs, each
// with its magnetic result restating the placement (the session maps' agreement there).
std::vector<PairResult> pairsOfGrowingMap(const std::vector<Session>& sessions,
                                          const std::vector<MagneticMap>& maps,
                                          const MergeConfig& config, MergeResult* result) {
  const GrowingMapMatch growing =
      matchAgainstGrowingMap(sessions, maps, config.matcher, config.growing_map);
  result->magnetic_matches = growing.matches;
  std::vector<PairResult> pairs;
  for (const CandidatePair& c : growing.pairs)
    pairs.push_back(pairAtPlacement(c.a, c.b, c.T_a_b, maps[c.a], maps[c.b], config, c.anchor));
  return pairs;
}

}  // namespace

MergeResult mergeSessions(const std::vector<Session>& sessions, const MergeConfig& config,
                          const ProgressCallback& progress) {
  std::string error;
  if (!config.IsValid(&error)) throw std::invalid_argument("mergeSessions: " + error);
  if (sessions.empty()) throw std::invalid_argument("mergeSessions: no sessions");
  const auto say = [&](const std::string& message) {
    if (progress) progress(message);
  };
  const int n = static_cast<int>(sessions.size());
  std::vector<const Session*> inputs;
  for (const Session& session : sessions) inputs.push_back(&session);
  MergeResult result;
  result.config = config;

  // 1. Each session's magnetic map, in its own frame.
  auto start = SteadyClock::now();
  SessionMaps maps = buildSessionMaps(inputs, config);
  result.seconds_maps = secondsSince(start);
  say("magnetic maps of " + std::to_string(n) + " sessions in " +
      std::to_string(result.seconds_maps) + " s");
  for (int s = 0; s < n; ++s)
    if (maps.obstacles[s].any())
      say("session " + sessions[s].id +
          " cannot be matched magnetically: " + describe(maps.obstacles[s]) +
          (config.geometry_fallback && sessions[s].hasScans() &&
                   config.pair_matching == PairMatching::kAllPairs
               ? "; its pairs fall back to geometry only"
               : "; it stays unconnected"));

  // 2. T_B of the candidate pairs, p(T_B | magnetic maps).
  start = SteadyClock::now();
  if (config.pair_matching == PairMatching::kGrowingMap) {
    result.pairs = pairsOfGrowingMap(sessions, maps.magnetic, config, &result);
  } else {
    AllPairsMatch all = matchAllPairs(inputs, maps, config, progress);
    result.pairs = std::move(all.pairs);
    result.structure_maps = std::move(all.structure_maps);
    result.magnetic_matches = all.magnetic_matches;
    result.geometry_matches = all.geometry_matches;
  }
  result.magnetic_maps = std::move(maps.magnetic);
  result.match_obstacles = std::move(maps.obstacles);
  result.frame_heights = std::move(maps.frame_height);
  result.magnetometer_heights_m = std::move(maps.height_above_floor_m);
  result.seconds_matching = secondsSince(start);
  say(matchingSummary(result));

  // 3–5. T_M by ICP-EM inside each pair's magnetic overlap, p(T_M | T_B, point maps); the
  // sessions placed along the spanning tree; the edges of the pairs used.
  start = SteadyClock::now();
  refineAll(inputs, result.magnetic_maps, result.structure_maps, result.frame_heights, config,
            &result.pairs, progress);
  const Placement placement = placeSessions(n, config, &result.pairs);
  result.frame_session = placement.frame_session;
  if (result.frame_session != 0)
    say("the atlas takes " + sessions[result.frame_session].id +
        "'s frame: it begins the largest group of sessions that overlap, which " + sessions[0].id +
        " is not in");
  const auto& T_tree = placement.T_atlas;
  GraphEdges edges = edgesOfUsedPairs(inputs, T_tree, config, &result.pairs, {}, progress);
  result.seconds_refinement = secondsSince(start);

  // 6. One solve over all sessions.
  start = SteadyClock::now();
  solveGraph(inputs, T_tree, {}, std::move(edges), config, &result);
  result.seconds_solve = secondsSince(start);
  say(solveSummary(result));
  return result;
}

std::string matchingSummary(const MergeResult& result) {
  const int accepted = static_cast<int>(std::count_if(
      result.pairs.begin(), result.pairs.end(), [](const PairResult& p) { return p.accepted; }));
  return "ran " + std::to_string(result.magnetic_matches) + " magnetic matches" +
         (result.geometry_matches > 0
              ? " and " + std::to_string(result.geometry_matches) + " geometry-only ones"
              : std::string()) +
         " (" + std::to_string(result.pairs.size()) + " candidate pairs) in " +
         std::to_string(result.seconds_matching) + " s; " + std::to_string(accepted) + " overlap";
}

std::string solveSummary(const MergeResult& result) {
  const auto& connected = result.solution.connected;
  return "solved the graph in " + std::to_string(result.seconds_solve) +
         " s: " + std::to_string(std::count(connected.begin(), connected.end(), true)) + " of " +
         std::to_string(connected.size()) + " sessions connected, " +
         std::to_string(result.solution.magnetic_residuals) + " magnetic residuals";
}

}  // namespace mm4mm
