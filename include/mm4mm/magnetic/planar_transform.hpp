#pragma once
// A planar rigid transform (x, y in m, yaw in rad): what magnetic matching searches over.

#include <Eigen/Geometry>

namespace mm4mm {

struct PlanarTransform {
  double x_m = 0.0;
  double y_m = 0.0;
  double yaw_rad = 0.0;

  Eigen::Vector2d apply(const Eigen::Vector2d& p) const {
    return Eigen::Rotation2Dd(yaw_rad) * p + Eigen::Vector2d(x_m, y_m);
  }
  /// The same transform in 3-D (z, roll and pitch zero).
  Eigen::Isometry3d toIsometry() const;
  static PlanarTransform fromIsometry(const Eigen::Isometry3d& T);
};

/// Distance between two planar transforms: translation (m) and absolute yaw difference (rad).
double translationDistance(const PlanarTransform& a, const PlanarTransform& b);
double yawDistance(const PlanarTransform& a, const PlanarTransform& b);

}  // namespace mm4mm
