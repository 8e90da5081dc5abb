#include "mm4mm/magnetic/fingerprint.hpp"

#include "mm4mm/core/pose.hpp"

namespace mm4mm {

Eigen::Vector3d levelReading(const Eigen::Matrix3d& R_world_body,
                             const Eigen::Vector3d& field_body_uT) {
  // R_world_body = Rz(yaw) * tilt; tilt maps body axes into the heading-aligned levelled frame.
  return tiltOf(R_world_body) * field_body_uT;
}

MagneticFingerprint fingerprintOf(const Eigen::Matrix3d& R_world_body,
                                  const Eigen::Vector3d& field_body_uT) {
  const Eigen::Vector3d levelled = levelReading(R_world_body, field_body_uT);
  MagneticFingerprint fingerprint;
  fingerprint.horizontal_uT = levelled.head<2>().norm();
  fingerprint.vertical_uT = levelled.z();
  fingerprint.total_uT = levelled.norm();
  return fingerprint;
}

}  // namespace mm4mm
