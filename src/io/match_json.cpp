#include "mm4mm/io/match_json.hpp"

#include <algorithm>
#include <cmath>

#include "json_util.hpp"

namespace mm4mm {
namespace io_detail {

nlohmann::json matrixJson(const Eigen::Isometry3d& T) {
  nlohmann::json rows = nlohmann::json::array();
  for (int i = 0; i < 4; ++i) {
    nlohmann::json row = nlohmann::json::array();
    for (int j = 0; j < 4; ++j) row.push_back(T.matrix()(i, j));
    rows.push_back(row);
  }
  return rows;
}

nlohmann::json matchJson(const MagneticMatchResult& r) {
  nlohmann::json modes = nlohmann::json::array();
  for (const auto& m : r.modes)
    modes.push_back({{"x_m", m.T_a_b.x_m},
                     {"y_m", m.T_a_b.y_m},
                     {"yaw_deg", m.T_a_b.yaw_rad * 180.0 / M_PI},
                     {"z", m.z},
                     {"r", m.r},
                     {"overlap_m2", m.overlap_m2}});
  return {{"overlap", r.overlap()},
          {"verdict", toString(r.verdict)},
          {"T_a_b", matrixJson(r.T_a_b.toIsometry())},
          {"fitness", r.fitness},
          {"confidence", matchConfidence(r)},
          {"probability", r.probability},
          {"seconds", r.seconds},
          {"z", r.z},
          {"r", r.r},
          {"overlap_m2", r.overlap_m2},
          {"second_mode_ratio", r.second_mode_ratio},
          {"yaw_uncertainty_deg", r.yaw_uncertainty_deg},
          {"evaluations", r.evaluations},
          {"modes", modes}};
}

}  // namespace io_detail

double matchConfidence(const MagneticMatchResult& r) {
  return r.overlap() ? std::max(0.0, 1.0 - r.second_mode_ratio) : 0.0;
}

std::string matchResultJson(const MagneticMatchResult& result, int indent) {
  return io_detail::matchJson(result).dump(indent);
}

}  // namespace mm4mm
