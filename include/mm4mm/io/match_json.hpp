#pragma once
// The JSON of a magnetic match, shared by `mm4mm match --json` and an atlas's report.json so
// both speak docs/design.md's fields the same way.

#include <Eigen/Geometry>
#include <string>

#include "mm4mm/magnetic/magnetic_matcher.hpp"

namespace mm4mm {

/// 1 − (credible second mode's z / best z) for an accepted match; 0 when refused.
double matchConfidence(const MagneticMatchResult& result);

/// {"overlap", "verdict", "T_a_b" (4×4 row-major), "fitness", "confidence", "seconds", "z", "r",
/// "overlap_m2", "second_mode_ratio", "yaw_uncertainty_deg", "evaluations",
/// "modes"}, indented by `indent` (-1: one line).
std::string matchResultJson(const MagneticMatchResult& result, int indent = 2);

}  // namespace mm4mm
