#pragma once
// Matching N sessions without matching every pair (issue 5's scaling): each session is matched
// once against the fused magnetic map of the sessions already placed, which grows pass by pass
// from the first session's map. The cost of a pass grows with the area the atlas covers (bounded
// by the building), not with the number of sessions; matching every pair grows with N².
//
// The session pairs whose placed magnetic maps then overlap are the candidates for geometric
// refinement and inter-session edges (candidate_pairs.hpp, the rule add uses too): each session's
// anchor (its largest overlap with a session placed in an earlier pass) and its
// `max_pairs_per_session` largest other overlaps, at most N · (max_pairs_per_session + 1) pairs.
// Sessions more than `max_passes` links from the first stay unplaced.

#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "mm4mm/magnetic/magnetic_map.hpp"
#include "mm4mm/magnetic/magnetic_matcher.hpp"
#include "mm4mm/merge/candidate_pairs.hpp"
#include "mm4mm/merge/field_offsets.hpp"
#include "mm4mm/session/session.hpp"

namespace mm4mm {

struct GrowingMapConfig {
  /// Passes over the sessions not yet placed; a pass that places none ends the search early.
  int max_passes = 4;
  /// Largest overlaps kept per session besides its anchor (0: every pair of at least
  /// `min_pair_overlap_m2`).
  int max_pairs_per_session = 4;
  /// Smallest common magnetic coverage of a candidate pair other than an anchor (m²).
  double min_pair_overlap_m2 = 15.0;
  /// The placed sessions' field offsets, applied before they are fused into the map a pass
  /// matches against (as the atlas's fused map applies them).
  FieldOffsetConfig offsets;

  CandidateRule candidateRule() const {
    CandidateRule rule;
    rule.max_pairs_per_session = max_pairs_per_session;
    rule.min_pair_overlap_m2 = min_pair_overlap_m2;
    return rule;
  }
  bool IsValid(std::string* error) const;
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

}  // namespace mm4mm
