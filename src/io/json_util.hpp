#pragma once
// JSON pieces shared by the library's writers. Internal: nlohmann stays out of public headers.

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "mm4mm/magnetic/magnetic_matcher.hpp"

namespace mm4mm::io_detail {

/// A transform as docs/design.md writes it in JSON: a 4×4 row-major nested array.
nlohmann::json matrixJson(const Eigen::Isometry3d& T);

/// The fields of `mm4mm match --json` (see match_json.hpp).
nlohmann::json matchJson(const MagneticMatchResult& result);

}  // namespace mm4mm::io_detail
