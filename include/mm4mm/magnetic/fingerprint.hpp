#pragma once
// Rotation-invariant magnetic fingerprint of one reading (paper Section III-A.1).

#include <Eigen/Core>

namespace mm4mm {

/// Field components that do not depend on the robot's heading (µT).
struct MagneticFingerprint {
  double horizontal_uT = 0.0;  ///< B_h = |(B_x, B_y)| of the levelled field
  double vertical_uT = 0.0;    ///< B_v = B_z of the levelled field (z up)
  double total_uT = 0.0;       ///< B_F = |B|
};

/// Rotates a body-frame reading into the levelled frame (z along gravity, heading kept), using
/// only the roll and pitch of `R_world_body`. The result still turns with the robot's yaw.
Eigen::Vector3d levelReading(const Eigen::Matrix3d& R_world_body,
                             const Eigen::Vector3d& field_body_uT);

/// Fingerprint of a body-frame reading taken with attitude `R_world_body`.
MagneticFingerprint fingerprintOf(const Eigen::Matrix3d& R_world_body,
                                  const Eigen::Vector3d& field_body_uT);

}  // namespace mm4mm
