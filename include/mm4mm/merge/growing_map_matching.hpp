#pragma once
// Matching N sessions without matching every pair (issue 5's scaling): each session is matched
// once against the fused magnetic map of the sessions already placed, which grows pass by pass
// from the first session's map. The cost of a pass grows with the area the atlas covers (bounded
// by the building), not with the number of sessions; matching every pair grows with N².
//
// The session pairs whose placed magnetic maps then overlap are the candidates for geometric
// refinement and inter-session edges, at most `max_pairs_per_session` per session (its largest
// overlaps), so that refinement too stays linear in N where sessions crowd one place.

#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "mm4mm/magnetic/magnetic_map.hpp"
#include "mm4mm/magnetic/magnetic_matcher.hpp"
#include "mm4mm/session/session.hpp"

namespace mm4mm {

struct GrowingMapConfig {
  /// Passes over the sessions not yet placed; a pass that places none ends the search early.
  int max_passes = 4;
  /// Candidate pairs per session, its largest overlaps first (0: every overlapping pair).
  int max_pairs_per_session = 4;
  /// Smallest common magnetic coverage of a candidate pair once placed (m²).
  double min_pair_overlap_m2 = 15.0;

  bool IsValid(std::string* error) const;
};

/// A pair of placed sessions whose magnetic maps overlap: `a < b`, T_a_b from the placements.
struct CandidatePair {
  int a = 0;
  int b = 0;
  double overlap_m2 = 0.0;
  Eigen::Isometry3d T_a_b = Eigen::Isometry3d::Identity();
};

struct GrowingMapMatch {
  /// Each session's frame in the atlas (the first session's frame); empty where it matched
  /// nothing.
  std::vector<std::optional<Eigen::Isometry3d>> T_atlas_session;
  /// Each session's last match against the growing map (the first session's is empty).
  std::vector<MagneticMatchResult> against_atlas;
  std::vector<CandidatePair> pairs;  ///< ordered by (a, b)
  int passes = 0;
  int matches = 0;  ///< magnetic matches run
};

/// Places `sessions` (their fine magnetic maps `maps`, each in its own frame, built with
/// `matcher.map`) by matching each against the fused map of the ones already placed; a pass
/// matches every unplaced session against the same map (in parallel) and places those the
/// matcher accepts. Deterministic for a config. Throws std::invalid_argument for an invalid config
/// or when `maps` and `sessions` differ in length.
GrowingMapMatch matchAgainstGrowingMap(const std::vector<Session>& sessions,
                                       const std::vector<MagneticMap>& maps,
                                       const MagneticMatcherConfig& matcher,
                                       const GrowingMapConfig& config);

/// Area (m²) covered by both maps, which share one grid (same cell size, origins on multiples of
/// it, as buildMagneticMap makes them in one frame).
double commonCoverage_m2(const MagneticMap& a, const MagneticMap& b);

}  // namespace mm4mm
