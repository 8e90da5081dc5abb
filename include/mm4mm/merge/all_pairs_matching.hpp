#pragma once
// Step 2 of `merge` with every pair matched (PairMatching::kAllPairs; merge_steps.hpp): each pair
// of sessions matched magnetically in parallel (Eq. 2–3); a pair in which a session cannot be
// matched by its field falls back to the two sessions' structure maps where both have scans
// (geometry-only, structure_map.hpp); a pair the field alone refused gets the structure maps'
// credible modes put to the field (joint_match.hpp: geometry proposes, the field decides).

#include <utility>
#include <vector>

#include "mm4mm/merge/merge_sessions.hpp"
#include "mm4mm/merge/merge_steps.hpp"

namespace mm4mm {

struct AllPairsMatch {
  std::vector<PairResult> pairs;  ///< every pair matched, in the order asked
  /// Each session's structure map where a geometry-only or joint match needed it (else empty).
  std::vector<StructureMap> structure_maps;
  int magnetic_matches = 0;  ///< magnetic matches run
  int geometry_matches = 0;  ///< geometry-only matches run
};

/// Every pair (a < b), in order.
AllPairsMatch matchAllPairs(const std::vector<const Session*>& sessions, const SessionMaps& maps,
                            const MergeConfig& config, const ProgressCallback& progress = {});

/// The pairs `which` (indices into `sessions`, each pair's a and b as given) matched as
/// matchAllPairs matches each: the field, the geometry-only fallback, then the joint stage where
/// the field refused. An `add` runs it on the new session's pairs with atlas sessions.
AllPairsMatch matchPairs(const std::vector<const Session*>& sessions, const SessionMaps& maps,
                         const std::vector<std::pair<int, int>>& which, const MergeConfig& config,
                         const ProgressCallback& progress = {});

}  // namespace mm4mm
