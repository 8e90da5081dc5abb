#pragma once
// How a magnetometer's reading relates to the field where it is. Every robot carries its own
// magnetism: hard iron, a constant field in the body frame from motors, batteries and the chassis;
// soft iron, a body-fixed distortion of the field's direction and scale by nearby magnetisable
// material and by the sensor's own axis gains; and the field of the drive current, which grows
// with the speed. In body axes, µT:
//
//   m = S · B + h + v · k
//
// with B the field at the sensor, S the soft iron (symmetric, near identity), h the hard iron and
// v the forward speed (m/s) times k. The field is recovered as B = S⁻¹ (m − h − v · k).

#include <Eigen/Core>
#include <string>

namespace mm4mm {

struct MagnetometerCalibration {
  Eigen::Vector3d hard_iron_uT = Eigen::Vector3d::Zero();
  Eigen::Matrix3d soft_iron = Eigen::Matrix3d::Identity();
  Eigen::Vector3d speed_uT_per_mps = Eigen::Vector3d::Zero();

  /// The field at the sensor (body axes, µT) for `reading_uT` taken at forward speed `speed_mps`.
  Eigen::Vector3d correct(const Eigen::Vector3d& reading_uT, double speed_mps) const;
  /// The reading the sensor gives for the field `field_uT` (the inverse of correct).
  Eigen::Vector3d distort(const Eigen::Vector3d& field_uT, double speed_mps) const;
  bool isIdentity() const;
  /// False with a reason when the soft iron is not a symmetric positive-definite matrix with
  /// eigenvalues in [0.5, 2] or a vector is not finite: no real sensor is that far off.
  bool IsValid(std::string* error) const;
};

}  // namespace mm4mm
