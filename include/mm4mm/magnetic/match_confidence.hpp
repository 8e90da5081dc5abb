#pragma once
// The probability that a magnetic match's best mode is the right place, from what the match
// itself shows: how well the fields agree and over how much, how close a distinct rival comes,
// the overlap's shape, how much field it holds and how well its yaw is pinned. A logistic model
// fitted on simulated tuning worlds of many building types (scripts/fit_match_confidence.py),
// so that the acceptance rule is one calibrated probability instead of thresholds picked on one
// world, and a user sees how sure each match is.

#include <string>

namespace mm4mm {

struct MagneticMatchResult;

/// The model's inputs, as scripts/fit_match_confidence.py computes them from match_bench's CSV.
struct MatchFeatures {
  double atanh_r = 0.0;
  double log_overlap_m2 = 0.0;
  double second_mode_ratio = 0.0;    ///< capped at 1.5
  double log_aspect = 0.0;           ///< log(length / width) of the overlap
  double log_field_std = 0.0;        ///< log of the field's spread in the overlap (µT)
  double log_yaw_uncertainty = 0.0;  ///< log of the yaw interval's half-width (deg), in [0.1, 30]
  double single_track = 0.0;         ///< 1 where either map is one magnetometer's track
};

/// Logistic weights on the raw features and the probability a match must reach. The defaults are
/// the fit of scripts/fit_match_confidence.py on the procedural tuning worlds, seeds 1-20, every
/// rig, the one-sensor rigs at the Gaussian-process length scale 0.25 m with their single-track
/// count (docs/bench/procedural_tuning_{husky3,array7}.csv, field_thin_{imu,handheld}.csv; the
/// fit and its threshold choice in docs/bench/match_confidence_fit.md).
struct MatchConfidenceConfig {
  double intercept = -3.9741;
  double atanh_r = 3.3548;
  double log_overlap_m2 = 0.7798;
  double second_mode_ratio = -4.8564;
  double log_aspect = -0.3788;
  double log_field_std = -0.3185;
  double log_yaw_uncertainty = -1.2107;
  double single_track = 0.9820;
  /// The lowest probability at which no wrong pair of the tuning worlds was accepted, scored
  /// leave-one-seed-out, with the next lower step at most 1 % wrong (148 of 174 aligned overlaps
  /// accepted, 0 wrong; the z / r thresholds: 167, 0 wrong).
  double min_probability = 0.90;
  /// true: the probability decides instead of the min_z / min_r thresholds: a match at
  /// >= min_probability with its yaw within the yaw rule; yaw uncertain where the place reaches
  /// min_probability once its yaw uncertainty is taken at the rule's limit; ambiguous where it
  /// would reach it without its rival too and that rival comes within max_second_ratio; else
  /// no overlap.
  /// false: the probability is only reported. Off by default: fitted on the procedural worlds
  /// alone it extrapolates to large overlaps of mediocre r (a look-alike of the small corridor's
  /// disjoint session, r 0.55 over 150 m², alone-probability above 0.9, offered to the geometry
  /// as ambiguous and accepted there), which the r threshold refuses.
  bool decides = false;

  bool IsValid(std::string* error) const;
};

/// The features of `result`'s best mode; `single_track` where either map is one track.
MatchFeatures matchFeatures(const MagneticMatchResult& result, bool single_track);

/// The model's probability that the best mode is right, in (0, 1).
double matchProbability(const MatchFeatures& features, const MatchConfidenceConfig& config);

}  // namespace mm4mm
