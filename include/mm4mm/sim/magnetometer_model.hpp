#pragma once
// A simulated magnetometer as real ones are (MagnetometerErrorConfig): the robot's own magnetism
// (hard iron), a body-fixed distortion (symmetric soft iron times per-axis gains and a small
// non-orthogonality of the axes), the drive current's field, a slow thermal drift of the offset
// and white noise. "clean" is an ideal sensor with the rig's white noise and a small bias.

#include <Eigen/Core>
#include <random>

#include "mm4mm/session/magnetometer_calibration.hpp"
#include "mm4mm/sim/simulation_config.hpp"

namespace mm4mm::sim {

struct SimulatedMagnetometer {
  Eigen::Matrix3d distortion = Eigen::Matrix3d::Identity();  ///< axis gains · skew · soft iron
  Eigen::Vector3d hard_iron_uT = Eigen::Vector3d::Zero();
  Eigen::Vector3d current_direction = Eigen::Vector3d::UnitX();  ///< body axes, unit
  double speed_gain_uT_per_mps = 0.0;
  double acceleration_gain_uT_per_mps2 = 0.0;
  double noise_uT = 0.0;  ///< white noise std-dev per axis
  double drift_uT = 0.0;  ///< std-dev of the drift, per axis
  double drift_time_constant_s = 1.0;

  /// What the sensor reads for the field `field_body_uT` at forward speed `speed_mps` and
  /// acceleration `acceleration_mps2`, with the current drift and noise added by the caller.
  Eigen::Vector3d read(const Eigen::Vector3d& field_body_uT, double speed_mps,
                       double acceleration_mps2) const;
  /// The calibration a perfect estimator of MagnetometerCalibration's model would find: the hard
  /// iron, the symmetric part of the distortion and the speed term. The distortion's small
  /// antisymmetric part (the axes' non-orthogonality) and the acceleration term lie outside it.
  MagnetometerCalibration trueCalibration() const;
};

/// One sensor of one session: every error drawn from `rng` in a fixed order.
SimulatedMagnetometer drawMagnetometer(const MagnetometerErrorConfig& errors,
                                       const RigConfig& rig, std::mt19937_64* rng);

}  // namespace mm4mm::sim
