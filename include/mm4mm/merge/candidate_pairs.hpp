#pragma once
// Which pairs of placed sessions are refined and linked by edges, once their relative places are
// known from matches against a fused map (the growing-map merge, and add): the pairs whose placed
// magnetic maps overlap, each session's anchor (its largest overlap with a session placed before
// it, which keeps it connected to the first) and each session's `max_pairs_per_session` next
// largest overlaps of at least `min_pair_overlap_m2`, so that refinement stays linear in the
// sessions where many crowd one place. One rule and one overlap measure for both callers.

#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

#include "mm4mm/magnetic/magnetic_map.hpp"

namespace mm4mm {

/// A pair of placed sessions whose magnetic maps overlap: `a < b`, T_a_b from the placements.
struct CandidatePair {
  int a = 0;
  int b = 0;
  double overlap_m2 = 0.0;
  Eigen::Isometry3d T_a_b = Eigen::Isometry3d::Identity();
  bool anchor = false;  ///< the pair that placed its later session
};

/// The cells of an atlas-frame grid (origin at zero, the map's own cell size) that a session's
/// magnetic map covers once placed: a cell counts when its centre, carried back into the session
/// frame, falls in a covered cell of the map. Sorted, so two coverages intersect in one pass; it
/// holds the covered cells only, not a building-sized layer.
struct PlacedCoverage {
  double cell_size_m = 0.0;
  std::vector<std::pair<std::int32_t, std::int32_t>> cells;  ///< (ix, iy), sorted, unique
};

PlacedCoverage placedCoverage(const MagneticMap& map, const Eigen::Isometry3d& T_atlas_session);

/// Area (m²) both coverages hold. Throws std::invalid_argument for different cell sizes.
double commonArea_m2(const PlacedCoverage& a, const PlacedCoverage& b);

struct CandidateRule {
  int max_pairs_per_session = 4;      ///< besides the anchor; 0: every pair of the minimum overlap
  double min_pair_overlap_m2 = 15.0;  ///< for a pair other than an anchor
};

/// The candidate pairs among the placed sessions (`T_atlas[s]` set). `order[s]` says when session
/// `s` was placed (lower: earlier); a session that `ranks[s]` gets its anchor (the largest
/// overlap with a session of lower order, when there is one) and its largest other overlaps; a
/// pair stays when a session that ranks keeps it. A pair in `skip` (a < b) is left out. Ordered by
/// (a, b); deterministic.
std::vector<CandidatePair> selectCandidatePairs(
    const std::vector<std::optional<Eigen::Isometry3d>>& T_atlas,
    const std::vector<PlacedCoverage>& coverage, const std::vector<int>& order,
    const std::vector<bool>& ranks, const std::vector<std::pair<int, int>>& skip,
    const CandidateRule& rule);

}  // namespace mm4mm
