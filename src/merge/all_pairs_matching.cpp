#include "mm4mm/merge/all_pairs_matching.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <mutex>
#include <string>

#include "mm4mm/core/timing.hpp"
#include "mm4mm/merge/joint_match.hpp"
#include "mm4mm/merge/pair_refinement.hpp"
#include "mm4mm/merge/structure_map.hpp"

namespace mm4mm {

AllPairsMatch matchAllPairs(const std::vector<const Session*>& sessions, const SessionMaps& maps,
                            const MergeConfig& config, const ProgressCallback& progress) {
  const int n = static_cast<int>(sessions.size());
  std::vector<std::pair<int, int>> pairs;
  for (int a = 0; a < n; ++a)
    for (int b = a + 1; b < n; ++b) pairs.emplace_back(a, b);
  return matchPairs(sessions, maps, pairs, config, progress);
}

AllPairsMatch matchPairs(const std::vector<const Session*>& sessions, const SessionMaps& maps,
                         const std::vector<std::pair<int, int>>& which, const MergeConfig& config,
                         const ProgressCallback& progress) {
  std::mutex progress_mutex;  // pairs report from worker threads
  const auto say = [&](const std::string& message) {
    const std::lock_guard<std::mutex> lock(progress_mutex);
    if (progress) progress(message);
  };
  const int n = static_cast<int>(sessions.size());
  AllPairsMatch match;
  for (const auto& [a, b] : which) {
    PairResult pair;
    pair.a = a;
    pair.b = b;
    pair.height_difference_m = heightMismatch(maps, a, b, config.max_height_difference_m);
    match.pairs.push_back(pair);
  }
  const auto scans = [&](const PairResult& pair) {
    return sessions[pair.a]->hasScans() && sessions[pair.b]->hasScans();
  };
  const auto magnetic = [&](const PairResult& pair) {
    return !maps.obstacles[pair.a].any() && !maps.obstacles[pair.b].any();
  };
  // Two sessions at heights whose fields differ are not searched by the field alone, which
  // cannot match them (the field's pattern changes with height); where both have scans the joint
  // stage below still puts the structure maps' modes to the field.
  const auto field_alone = [&](const PairResult& pair) {
    return magnetic(pair) && !pair.height_difference_m;
  };
  const auto by_geometry = [&](const PairResult& pair) {
    return !magnetic(pair) && config.geometry_fallback && scans(pair);
  };
  match.magnetic_matches =
      static_cast<int>(std::count_if(match.pairs.begin(), match.pairs.end(), field_alone));
  match.geometry_matches =
      static_cast<int>(std::count_if(match.pairs.begin(), match.pairs.end(), by_geometry));
  match.structure_maps.resize(n);
  const auto buildStructureMaps = [&](const std::vector<bool>& needed) {
    tbb::parallel_for(0, n, [&](int s) {
      if (needed[s])
        match.structure_maps[s] = buildStructureMap(*sessions[s], config.structure_map);
    });
  };
  std::vector<bool> needs_structure(n, false);
  for (const PairResult& pair : match.pairs)
    if (by_geometry(pair)) needs_structure[pair.a] = needs_structure[pair.b] = true;
  buildStructureMaps(needs_structure);

  tbb::parallel_for(std::size_t{0}, match.pairs.size(), [&](std::size_t p) {
    PairResult& pair = match.pairs[p];
    if (!field_alone(pair) && !by_geometry(pair)) return;  // refused as it stands: no overlap
    const auto start = SteadyClock::now();
    if (field_alone(pair)) {
      pair.magnetic =
          matchMagneticMaps(maps.magnetic[pair.a], maps.magnetic[pair.b], config.matcher);
      pair.T_a_b = pair.magnetic.T_a_b.toIsometry();
      pair.accepted = pair.magnetic.overlap();
    } else {
      pair = geometryOnlyPair(pair.a, pair.b, match.structure_maps, config);
      say("pair " + sessions[pair.a]->id + "+" + sessions[pair.b]->id +
          ": geometry-only match (structure maps): " + toString(pair.magnetic.verdict) + ", r " +
          std::to_string(pair.magnetic.r) + " over " + std::to_string(pair.magnetic.overlap_m2) +
          " m², second mode ratio " + std::to_string(pair.magnetic.second_mode_ratio));
    }
    pair.seconds = secondsSince(start);
  });

  // Geometry proposes, the field decides: pairs the field alone refused, of sessions with scans,
  // are put to the field at their structure maps' credible modes. A pair the field places but
  // whose yaw it leaves open, and which the field does not place here, goes on to ICP-EM from its
  // own pose (refinePairs).
  const auto joint = [&](const PairResult& pair) {
    return config.joint.enabled && magnetic(pair) && !pair.accepted && scans(pair);
  };
  std::vector<bool> needs_more(n, false);
  for (const PairResult& pair : match.pairs)
    if (joint(pair))
      for (int s : {pair.a, pair.b}) needs_more[s] = match.structure_maps[s].observedCells() == 0;
  buildStructureMaps(needs_more);
  tbb::parallel_for(std::size_t{0}, match.pairs.size(), [&](std::size_t p) {
    PairResult& pair = match.pairs[p];
    if (!joint(pair)) return;
    const auto start = SteadyClock::now();
    const MagneticMatchResult structure = matchStructureForJoint(
        match.structure_maps[pair.a].asMatchGrid(), match.structure_maps[pair.b].asMatchGrid(),
        config.geometry_matcher, config.joint);
    const MagneticMatchResult chosen =
        matchJointly(maps.magnetic[pair.a], maps.magnetic[pair.b], structure,
                     config.geometry_matcher, config.matcher, config.joint);
    pair.seconds += secondsSince(start);
    say("pair " + sessions[pair.a]->id + "+" + sessions[pair.b]->id + ": the field alone said " +
        toString(pair.magnetic.verdict) + "; at " + std::to_string(chosen.modes.size()) +
        " structure modes it says " + toString(chosen.verdict) + " (z " + std::to_string(chosen.z) +
        ", r " + std::to_string(chosen.r) + ", second mode ratio " +
        std::to_string(chosen.second_mode_ratio) + ")");
    if (!chosen.overlap()) return;
    pair.magnetic = chosen;
    pair.joint = true;
    pair.accepted = true;
    pair.T_a_b = chosen.T_a_b.toIsometry();
  });
  return match;
}

}  // namespace mm4mm
