#pragma once
// Geometry proposes, the field decides: where both sessions have scans and the field alone did
// not accept a place, the structure maps' match proposes its credible modes (in repetitive
// geometry a lattice of equally good ones: pillars every 8 m, identical aisles) and the two
// magnetic maps are compared at each. The field has to tell a handful of candidates apart, not
// find one place among all (x, y, yaw), so a weaker correlation suffices: a single magnetometer's
// track where the two tracks run within its map's reach. ICP-EM then fixes the yaw (merge's
// pair refinement), which the field on a narrow swath knows only to degrees.

#include <string>

#include "mm4mm/magnetic/magnetic_matcher.hpp"

namespace mm4mm {

struct JointMatchConfig {
  bool enabled = true;
  /// At most this many of the structure match's modes are put to the field, best first; a mode
  /// is a candidate when its structure r is within the geometry matcher's credible_r_gap of the
  /// best one's. Not its min_r: in a warehouse the two sessions' occupancy grids correlate at r
  /// 0.5-0.65 at the true place and at every place of the lattice alike.
  int max_candidates = 8;
  /// The structure maps' search that proposes them: 1, the exhaustive sweep (the geometry
  /// matcher's own); above 1, coarse to fine at this factor (correlation_search.hpp) without the
  /// exhaustive sweep after it where it accepts no place, since the structure match's verdict is
  /// not used here, only its modes (matchForProposals). 2 by default: it gave the joint stage's
  /// decision in every pair and its pose in every pair both accept, on the tuning worlds (104
  /// pairs, 54 refused by the field) and on held-out seeds 16001-16005 (80 pairs, 23 refused by
  /// the field), the rule fixed before the run (docs/heldout_set.md; docs/benchmarks.md, "The
  /// joint stage's structure match").
  int structure_pyramid_factor = 2;
  /// The field's own look around each candidate: translations within ± window_m in step_m steps,
  /// yaws within ± window_deg in step_deg steps (a structure map's cells are 0.2 m).
  double window_m = 0.2;
  double step_m = 0.05;
  double window_deg = 1.0;
  double step_deg = 0.5;
  /// The best candidate is accepted when its field z >= min_z and r >= min_r, and no other
  /// candidate with an r within the field matcher's credible_r_gap reaches max_second_ratio of
  /// its z. Chosen by scripts/choose_thresholds.py --stage joint on the procedural tuning worlds
  /// (seeds 1-20, every rig, the rule opened up: scripts/joint_tuning.sh,
  /// docs/bench/joint_thresholds.md): of the 159 pairs the field refused (60 overlapping, 94
  /// separate) it accepts 25 aligned and nothing wrong, with a step of margin in z and in r. The
  /// separate pairs' best candidates correlate at r 0.685 at most (z up to 6.1, at r 0.51); one
  /// misplaced overlap reached z 7.8 at r 0.76 and is refused only as ambiguous (its rival at 0.80
  /// of its z).
  double min_z = 1.5;
  double min_r = 0.75;
  double max_second_ratio = 0.75;

  /// Where either map is one magnetometer's track, the field compares the candidates over these
  /// instead (issue 31's thin overlaps): two tracks that share a pass or two (one walk along a
  /// corridor each way) share a strip of 1-4 m², under the 4 m² the field's own single-track match
  /// needs, and yet the structure maps' best candidate is right in most such pairs.
  struct SingleTrack {
    /// Five of the samples below (z's Fisher approximation counts n − 3 of them): a metre or two
    /// of two tracks run side by side, or one crossing at a shallow angle.
    double min_overlap_m2 = 1.0;
    /// z counts one independent sample per πℓ² (MatchScoreConfig::area_per_sample_m2), ℓ the
    /// Gaussian-process map's length scale (GaussianProcessMapConfig: 0.25 m): the map's values
    /// decorrelate over that area (∫ρ² dA of its squared-exponential kernel), while one per m²
    /// would leave a 2 m² strip fewer than the 3 samples z needs.
    double area_per_sample_m2 = 0.196;
    /// Chosen by scripts/choose_thresholds.py --stage joint on the procedural tuning worlds (seeds
    /// 1-20, one magnetometer: imu and handheld, the rule opened up:
    /// bench/joint_thin_features.yaml, docs/bench/joint_thin_thresholds.md): of the 91 pairs the
    /// field refused (40 overlapping, 49 separate) it accepts 33 aligned, nothing wrong and no
    /// separate pair, with a step of margin; the same values as the rule above. The separate pairs'
    /// best candidates reach r 0.685 (z 4.6).
    double min_z = 1.5;
    double min_r = 0.75;

    bool IsValid(std::string* error) const;
  } single_track;

  bool IsValid(std::string* error) const;
};

/// The structure maps' match whose modes matchJointly puts to the field: `geometry` (the config
/// the geometry-only fallback matches structure maps with) at config.structure_pyramid_factor.
/// Throws std::invalid_argument for an invalid config.
MagneticMatchResult matchStructureForJoint(const MagneticMap& structure_a,
                                           const MagneticMap& structure_b,
                                           const MagneticMatcherConfig& geometry,
                                           const JointMatchConfig& config);

/// The field's choice among the credible modes of `structure` (a match of the two sessions'
/// structure maps): a result whose modes are the candidates at their field-refined poses with the
/// field's z, r and overlap, best first, and whose verdict says whether the field chose one
/// (kMatch), none (kNoOverlap) or could not tell two apart (kAmbiguous). `geometry` is the
/// matcher config `structure` was found with, `field` the magnetic one; maps a and b are the two
/// sessions' fine magnetic maps. Throws std::invalid_argument for an invalid config.
MagneticMatchResult matchJointly(const MagneticMap& field_a, const MagneticMap& field_b,
                                 const MagneticMatchResult& structure,
                                 const MagneticMatcherConfig& geometry,
                                 const MagneticMatcherConfig& field,
                                 const JointMatchConfig& config);

}  // namespace mm4mm
