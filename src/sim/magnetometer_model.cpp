#include "mm4mm/sim/magnetometer_model.hpp"

#include <Eigen/Geometry>
#include <cmath>

#include "random_draws.hpp"

namespace mm4mm::sim {
namespace {

double uniform(double lo, double hi, std::mt19937_64* rng) {
  return std::uniform_real_distribution<double>(lo, hi)(*rng);
}

Eigen::Vector3d unitVector(std::mt19937_64* rng) {
  std::normal_distribution<double> gauss(0.0, 1.0);
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  while (v.norm() < 1e-6) v = drawVector3(gauss, *rng);
  return v.normalized();
}

}  // namespace

Eigen::Vector3d SimulatedMagnetometer::read(const Eigen::Vector3d& field_body_uT, double speed_mps,
                                            double acceleration_mps2) const {
  return distortion * field_body_uT + hard_iron_uT +
         (speed_gain_uT_per_mps * speed_mps + acceleration_gain_uT_per_mps2 * acceleration_mps2) *
             current_direction;
}

MagnetometerCalibration SimulatedMagnetometer::trueCalibration() const {
  MagnetometerCalibration c;
  c.hard_iron_uT = hard_iron_uT;
  c.soft_iron = 0.5 * (distortion + distortion.transpose());
  c.speed_uT_per_mps = speed_gain_uT_per_mps * current_direction;
  return c;
}

SimulatedMagnetometer drawMagnetometer(const MagnetometerErrorConfig& errors,
                                       const RigConfig& rig, std::mt19937_64* rng) {
  SimulatedMagnetometer m;
  std::normal_distribution<double> gauss(0.0, 1.0);
  if (errors.model == "clean") {
    m.hard_iron_uT = rig.magnetometer_bias_uT * drawVector3(gauss, *rng);
    m.noise_uT = rig.magnetometer_noise_uT;
    return m;
  }
  m.hard_iron_uT = uniform(errors.hard_iron_min_uT, errors.hard_iron_max_uT, rng) * unitVector(rng);
  // Soft iron I + Q diag(e) Qᵀ: eigenvalue deviations within ±d along random axes.
  const double d = uniform(errors.soft_iron_min, errors.soft_iron_max, rng);
  Eigen::Vector3d e;
  for (int i = 0; i < 3; ++i) e[i] = uniform(-d, d, rng);
  e[static_cast<int>(uniform(0.0, 3.0, rng)) % 3] = uniform(0.0, 1.0, rng) < 0.5 ? -d : d;
  // A uniformly random rotation: a normalised 4-D Gaussian (draws sequenced, see random_draws.hpp).
  const Eigen::Vector3d xyz = drawVector3(gauss, *rng);
  const double w = gauss(*rng);
  Eigen::Quaterniond q(w, xyz.x(), xyz.y(), xyz.z());
  q.normalize();
  const Eigen::Matrix3d Q = q.toRotationMatrix();
  const Eigen::Matrix3d soft = Eigen::Matrix3d::Identity() + Q * e.asDiagonal() * Q.transpose();
  Eigen::Matrix3d gains = Eigen::Matrix3d::Identity();
  for (int i = 0; i < 3; ++i)
    gains(i, i) += uniform(-errors.axis_scale_error_max, errors.axis_scale_error_max, rng);
  // Non-orthogonal axes: each sensor axis leans towards the others by a small angle.
  const double skew = errors.misalignment_max_deg * M_PI / 180.0;
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();
  axes(0, 1) = uniform(-skew, skew, rng);
  axes(0, 2) = uniform(-skew, skew, rng);
  axes(1, 2) = uniform(-skew, skew, rng);
  m.distortion = gains * axes * soft;
  m.current_direction = unitVector(rng);
  m.speed_gain_uT_per_mps = uniform(0.0, errors.current_speed_max_uT_per_mps, rng);
  m.acceleration_gain_uT_per_mps2 = uniform(0.0, errors.current_acceleration_max_uT_per_mps2, rng);
  m.noise_uT = uniform(errors.noise_min_uT, errors.noise_max_uT, rng);
  m.drift_uT = errors.drift_uT;
  m.drift_time_constant_s = errors.drift_time_constant_s;
  return m;
}

}  // namespace mm4mm::sim
