#include "mm4mm/magnetic/planar_transform.hpp"

#include <cmath>

#include "mm4mm/core/pose.hpp"

namespace mm4mm {

Eigen::Isometry3d PlanarTransform::toIsometry() const { return planarPose(x_m, y_m, yaw_rad); }

PlanarTransform PlanarTransform::fromIsometry(const Eigen::Isometry3d& T) {
  return {T.translation().x(), T.translation().y(), yawOf(T.linear())};
}

double translationDistance(const PlanarTransform& a, const PlanarTransform& b) {
  return std::hypot(a.x_m - b.x_m, a.y_m - b.y_m);
}

double yawDistance(const PlanarTransform& a, const PlanarTransform& b) {
  return std::abs(wrapAngle(a.yaw_rad - b.yaw_rad));
}

}  // namespace mm4mm
