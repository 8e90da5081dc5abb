#include "mm4mm/merge/merge_sessions.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <numeric>
#include <optional>
#include <queue>
#include <stdexcept>
#include <utility>

#include "mm4mm/core/pose.hpp"
#include "mm4mm/core/timing.hpp"
#include "mm4mm/merge/pair_refinement.hpp"
#include "mm4mm/merge/structure_map.hpp"

namespace mm4mm {
namespace {

using Clock = SteadyClock;

}  // namespace

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
  return true;
}

std::string magneticMatchObstacle(const Session& session, const MagneticMap& map,
                                  const MagneticMatcherConfig& config) {
  if (session.keyframes.empty()) return "no keyframes";
  if (session.magnetometer.empty()) return "no magnetometer readings, so nothing to match it by";
  const double first_s = session.keyframes.front().time_s;
  const double last_s = session.keyframes.back().time_s;
  if (std::none_of(
          session.magnetometer.begin(), session.magnetometer.end(),
          [&](const MagnetometerSample& m) { return m.time_s >= first_s && m.time_s <= last_s; }))
    return "no magnetometer reading falls within its keyframes' time span";
  const MagneticMatcherConfig applied = config.appliedTo(map, map);
  const double needed_m2 = std::max(applied.search.min_overlap_m2, applied.score.min_overlap_m2);
  if (map.coveredArea_m2() >= needed_m2) return {};
  double travelled_m = 0.0;
  for (std::size_t k = 1; k < session.keyframes.size(); ++k)
    travelled_m += (session.keyframes[k].T_frame_body.translation() -
                    session.keyframes[k - 1].T_frame_body.translation())
                       .norm();
  char text[200];
  std::snprintf(text, sizeof text,
                "its magnetic map covers %.1f m² after %.1f m of travel, less than the %.0f m² any "
                "match needs",
                map.coveredArea_m2(), travelled_m, needed_m2);
  return text;
}

MergeResult mergeSessions(const std::vector<Session>& sessions, const MergeConfig& config,
                          const ProgressCallback& progress) {
  std::string error;
  if (!config.IsValid(&error)) throw std::invalid_argument("mergeSessions: " + error);
  if (sessions.empty()) throw std::invalid_argument("mergeSessions: no sessions");
  std::mutex progress_mutex;  // pairs report from worker threads
  const auto say = [&](const std::string& message) {
    const std::lock_guard<std::mutex> lock(progress_mutex);
    if (progress) progress(message);
  };
  const int n = static_cast<int>(sessions.size());
  MergeResult result;
  result.config = config;

  auto start = Clock::now();
  result.magnetic_maps.resize(n);
  tbb::parallel_for(0, n, [&](int s) {
    result.magnetic_maps[s] =
        buildMagneticMap(placeFingerprints(sessions[s]), sessions[s].rig, config.matcher.map);
  });
  result.seconds_maps = secondsSince(start);
  say("magnetic maps of " + std::to_string(n) + " sessions in " +
      std::to_string(result.seconds_maps) + " s");
  result.match_obstacles.resize(n);
  for (int s = 0; s < n; ++s) {
    result.match_obstacles[s] =
        magneticMatchObstacle(sessions[s], result.magnetic_maps[s], config.matcher);
    if (!result.match_obstacles[s].empty())
      say("session " + sessions[s].id +
          " cannot be matched magnetically: " + result.match_obstacles[s] +
          (config.geometry_fallback && sessions[s].hasScans() &&
                   config.pair_matching == PairMatching::kAllPairs
               ? "; its pairs fall back to geometry only"
               : "; it stays unconnected"));
  }

  start = Clock::now();
  if (config.pair_matching == PairMatching::kGrowingMap) {
    const GrowingMapMatch growing =
        matchAgainstGrowingMap(sessions, result.magnetic_maps, config.matcher, config.growing_map);
    result.magnetic_matches = growing.matches;
    // The candidates' magnetic results restate the placements; their score is the session
    // maps' agreement at the placed transform.
    for (const CandidatePair& candidate : growing.pairs)
      result.pairs.push_back(pairAtPlacement(
          candidate.a, candidate.b, candidate.T_a_b, result.magnetic_maps[candidate.a],
          result.magnetic_maps[candidate.b], config, candidate.anchor));
  } else {
    for (int a = 0; a < n; ++a)
      for (int b = a + 1; b < n; ++b) {
        PairResult pair;
        pair.a = a;
        pair.b = b;
        result.pairs.push_back(pair);
      }
    const auto magnetic = [&](const PairResult& pair) {
      return result.match_obstacles[pair.a].empty() && result.match_obstacles[pair.b].empty();
    };
    const auto by_geometry = [&](const PairResult& pair) {
      return !magnetic(pair) && config.geometry_fallback && sessions[pair.a].hasScans() &&
             sessions[pair.b].hasScans();
    };
    result.magnetic_matches =
        static_cast<int>(std::count_if(result.pairs.begin(), result.pairs.end(), magnetic));
    result.geometry_matches =
        static_cast<int>(std::count_if(result.pairs.begin(), result.pairs.end(), by_geometry));
    std::vector<bool> needs_structure(n, false);
    for (const PairResult& pair : result.pairs)
      if (by_geometry(pair)) needs_structure[pair.a] = needs_structure[pair.b] = true;
    result.structure_maps.resize(n);
    tbb::parallel_for(0, n, [&](int s) {
      if (needs_structure[s])
        result.structure_maps[s] = buildStructureMap(sessions[s], config.structure_map);
    });
    tbb::parallel_for(std::size_t{0}, result.pairs.size(), [&](std::size_t p) {
      PairResult& pair = result.pairs[p];
      const bool by_field = magnetic(pair);
      if (!by_field && !by_geometry(pair)) return;  // refused as it stands: no overlap
      const auto pair_start = Clock::now();
      if (by_field) {
        pair.magnetic = matchMagneticMaps(result.magnetic_maps[pair.a],
                                          result.magnetic_maps[pair.b], config.matcher);
        pair.T_a_b = pair.magnetic.T_a_b.toIsometry();
        pair.accepted = pair.magnetic.overlap();
      } else {
        pair = geometryOnlyPair(pair.a, pair.b, result.structure_maps, config);
      }
      pair.seconds = secondsSince(pair_start);
      if (pair.geometry_only)
        say("pair " + sessions[pair.a].id + "+" + sessions[pair.b].id +
            ": geometry-only match (structure maps): " + toString(pair.magnetic.verdict) + ", r " +
            std::to_string(pair.magnetic.r) + " over " + std::to_string(pair.magnetic.overlap_m2) +
            " m², second mode ratio " + std::to_string(pair.magnetic.second_mode_ratio));
    });
    // Geometry proposes, the field decides: pairs the field alone refused, of sessions with
    // scans, are put to the field at their structure maps' credible modes. A pair the field
    // places but whose yaw it leaves open, and which the field does not place here, goes on to
    // ICP-EM from its own pose (refinePairs).
    const auto joint = [&](const PairResult& pair) {
      return config.joint.enabled && magnetic(pair) && !pair.accepted &&
             sessions[pair.a].hasScans() && sessions[pair.b].hasScans();
    };
    std::vector<bool> needs_more(n, false);
    for (const PairResult& pair : result.pairs)
      if (joint(pair))
        for (int s : {pair.a, pair.b}) needs_more[s] = result.structure_maps[s].coveredCells() == 0;
    tbb::parallel_for(0, n, [&](int s) {
      if (needs_more[s])
        result.structure_maps[s] = buildStructureMap(sessions[s], config.structure_map);
    });
    tbb::parallel_for(std::size_t{0}, result.pairs.size(), [&](std::size_t p) {
      PairResult& pair = result.pairs[p];
      if (!joint(pair)) return;
      const auto pair_start = Clock::now();
      const MagneticMatchResult structure = matchMagneticMaps(
          result.structure_maps[pair.a], result.structure_maps[pair.b], config.geometry_matcher);
      const MagneticMatchResult chosen =
          matchJointly(result.magnetic_maps[pair.a], result.magnetic_maps[pair.b], structure,
                       config.geometry_matcher, config.matcher, config.joint);
      pair.seconds += secondsSince(pair_start);
      say("pair " + sessions[pair.a].id + "+" + sessions[pair.b].id + ": the field alone said " +
          toString(pair.magnetic.verdict) + "; at " + std::to_string(chosen.modes.size()) +
          " structure modes it says " + toString(chosen.verdict) + " (z " +
          std::to_string(chosen.z) + ", r " + std::to_string(chosen.r) + ", second mode ratio " +
          std::to_string(chosen.second_mode_ratio) + ")");
      if (!chosen.overlap()) return;
      pair.magnetic = chosen;
      pair.joint = true;
      pair.accepted = true;
      pair.T_a_b = chosen.T_a_b.toIsometry();
    });
  }
  result.seconds_matching = secondsSince(start);
  int accepted = 0;
  for (const PairResult& pair : result.pairs) accepted += pair.accepted ? 1 : 0;
  say("ran " + std::to_string(result.magnetic_matches) + " magnetic matches" +
      (result.geometry_matches > 0
           ? " and " + std::to_string(result.geometry_matches) + " geometry-only ones"
           : std::string()) +
      " (" + std::to_string(result.pairs.size()) + " candidate pairs) in " +
      std::to_string(result.seconds_matching) + " s; " + std::to_string(accepted) + " overlap");

  // Pair refinement by ICP-EM over the whole point maps, restricted to the overlap of the maps
  // each pair was matched on.
  start = Clock::now();
  {
    std::vector<const Session*> session_pointers;
    std::vector<const MagneticMap*> map_pointers;
    for (int s = 0; s < n; ++s) {
      session_pointers.push_back(&sessions[s]);
      map_pointers.push_back(&result.magnetic_maps[s]);
    }
    std::vector<PairResult*> pair_pointers;
    for (PairResult& pair : result.pairs) pair_pointers.push_back(&pair);
    refinePairs(session_pointers, map_pointers, result.structure_maps, config, pair_pointers, say);
  }

  markSpanningTree(n, &result.pairs);
  const auto T_atlas = placeByTree(n, result.pairs);
  markConsistency(T_atlas, config, &result.pairs);

  // Inter-session edges of every used pair, in parallel; gathered in pair order so the graph
  // is the same whatever the thread count.
  std::vector<std::vector<InterSessionEdge>> pair_edges(result.pairs.size());
  tbb::parallel_for(std::size_t{0}, result.pairs.size(), [&](std::size_t p) {
    PairResult& pair = result.pairs[p];
    if (pair.role != PairRole::kTree && pair.role != PairRole::kConsistent) return;
    if (!T_atlas[pair.a] || !T_atlas[pair.b]) return;
    const auto pair_start = Clock::now();
    const Session& a = sessions[pair.a];
    const Session& b = sessions[pair.b];
    pair_edges[p] = pairEdges(a, pair.a, b, pair.b, pair.T_a_b, config);
    pair.edges = static_cast<int>(pair_edges[p].size());
    pair.seconds += secondsSince(pair_start);
    say("pair " + a.id + "+" + b.id + ": " + std::to_string(pair.edges) + " inter-session edges");
  });
  std::vector<std::size_t> edge_owner;
  for (std::size_t p = 0; p < result.pairs.size(); ++p)
    for (const InterSessionEdge& edge : pair_edges[p]) {
      result.edges.push_back(edge);
      edge_owner.push_back(p);
    }
  result.seconds_refinement = secondsSince(start);

  start = Clock::now();
  MultiSessionProblem problem;
  for (int s = 0; s < n; ++s) {
    problem.sessions.push_back(&sessions[s]);
    problem.T_atlas_session.push_back(T_atlas[s].value_or(Eigen::Isometry3d::Identity()));
    problem.connected.push_back(T_atlas[s].has_value());
    problem.magnetic_maps.push_back(&result.magnetic_maps[s]);
  }
  solveAndRecord(std::move(problem), edge_owner, config, &result);
  result.seconds_solve = secondsSince(start);
  int connected = 0;
  for (bool c : result.solution.connected) connected += c ? 1 : 0;
  say("solved the graph in " + std::to_string(result.seconds_solve) +
      " s: " + std::to_string(connected) + " of " + std::to_string(n) + " sessions connected, " +
      std::to_string(result.solution.magnetic_residuals) + " magnetic residuals");
  return result;
}

}  // namespace mm4mm
