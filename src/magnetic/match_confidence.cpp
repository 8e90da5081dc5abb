#include "mm4mm/magnetic/match_confidence.hpp"

#include <algorithm>
#include <cmath>

#include "mm4mm/magnetic/magnetic_matcher.hpp"

namespace mm4mm {

bool MatchConfidenceConfig::IsValid(std::string* error) const {
  for (double w : {intercept, atanh_r, log_overlap_m2, second_mode_ratio, log_aspect, log_field_std,
                   log_yaw_uncertainty, single_track})
    if (!std::isfinite(w)) {
      if (error) *error = "weights must be finite";
      return false;
    }
  if (!(min_probability > 0.0 && min_probability < 1.0)) {
    if (error) *error = "min_probability must be in (0, 1)";
    return false;
  }
  return true;
}

// The same clamps as scripts/fit_match_confidence.py's features(): keep a degenerate overlap
// (no extent, no field) finite.
MatchFeatures matchFeatures(const MagneticMatchResult& result, bool single_track) {
  MatchFeatures f;
  f.atanh_r = std::atanh(std::clamp(result.r, -0.999, 0.999));
  f.log_overlap_m2 = std::log(std::max(result.overlap_m2, 1.0));
  f.second_mode_ratio = std::min(result.second_mode_ratio, 1.5);
  f.log_aspect = std::log(std::max(result.overlap_statistics.length_m, 0.1) /
                          std::max(result.overlap_statistics.width_m, 0.1));
  f.log_field_std = std::log(std::max(result.overlap_statistics.field_std_uT, 0.05));
  f.log_yaw_uncertainty = std::log(std::clamp(result.yaw_uncertainty_deg, 0.1, 30.0));
  f.single_track = single_track ? 1.0 : 0.0;
  return f;
}

double matchProbability(const MatchFeatures& f, const MatchConfidenceConfig& c) {
  const double logit = c.intercept + c.atanh_r * f.atanh_r + c.log_overlap_m2 * f.log_overlap_m2 +
                       c.second_mode_ratio * f.second_mode_ratio + c.log_aspect * f.log_aspect +
                       c.log_field_std * f.log_field_std +
                       c.log_yaw_uncertainty * f.log_yaw_uncertainty +
                       c.single_track * f.single_track;
  return 1.0 / (1.0 + std::exp(-logit));
}

}  // namespace mm4mm
