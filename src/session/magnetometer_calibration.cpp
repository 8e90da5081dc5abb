#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <string>

#include "mm4mm/session/magnetometer_calibration.hpp"

namespace mm4mm {

Eigen::Vector3d MagnetometerCalibration::correct(const Eigen::Vector3d& reading_uT,
                                                 double speed_mps) const {
  return soft_iron.inverse() * (reading_uT - hard_iron_uT - speed_mps * speed_uT_per_mps);
}

Eigen::Vector3d MagnetometerCalibration::distort(const Eigen::Vector3d& field_uT,
                                                 double speed_mps) const {
  return soft_iron * field_uT + hard_iron_uT + speed_mps * speed_uT_per_mps;
}

bool MagnetometerCalibration::isIdentity() const {
  return hard_iron_uT.isZero(0.0) && soft_iron.isIdentity(0.0) && speed_uT_per_mps.isZero(0.0);
}

bool MagnetometerCalibration::IsValid(std::string* error) const {
  const auto fail = [&](const char* message) {
    if (error) *error = message;
    return false;
  };
  if (!hard_iron_uT.allFinite() || !speed_uT_per_mps.allFinite() || !soft_iron.allFinite())
    return fail("calibration values must be finite");
  if (!soft_iron.isApprox(soft_iron.transpose(), 1e-9) &&
      (soft_iron - soft_iron.transpose()).cwiseAbs().maxCoeff() > 1e-9)
    return fail("soft_iron must be symmetric");
  const Eigen::Vector3d eigenvalues =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(soft_iron, Eigen::EigenvaluesOnly)
          .eigenvalues();
  if (!(eigenvalues.minCoeff() >= 0.5 && eigenvalues.maxCoeff() <= 2.0))
    return fail("soft_iron must have eigenvalues in [0.5, 2] (a scale near 1 on every axis)");
  return true;
}

}  // namespace mm4mm
