#include "mm4mm/magnetic/compass_prior.hpp"

#include <algorithm>
#include <cmath>

#include "mm4mm/core/pose.hpp"

namespace mm4mm {

double meanFieldDirection(const MagneticMap& map, double* resultant) {
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  double length = 0.0;
  for (std::size_t i = 0; i < map.total_uT.size(); ++i) {
    if (std::isnan(map.total_uT[i])) continue;
    const Eigen::Vector2d h(map.session_x_uT[i], map.session_y_uT[i]);
    sum += h;
    length += h.norm();
  }
  if (resultant) *resultant = length > 0.0 ? sum.norm() / length : 0.0;
  return std::atan2(sum.y(), sum.x());
}

CompassHeading compassHeading(const MagneticMap& a, const MagneticMap& b) {
  double resultant_a = 0.0, resultant_b = 0.0;
  const double direction_a = meanFieldDirection(a, &resultant_a);
  const double direction_b = meanFieldDirection(b, &resultant_b);
  return {wrapAngle(direction_a - direction_b), std::min(resultant_a, resultant_b)};
}

}  // namespace mm4mm
