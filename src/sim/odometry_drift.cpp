#include "mm4mm/sim/odometry_drift.hpp"

#include <cmath>
#include <random>

#include "mm4mm/geometry/pose.hpp"
#include "random_draws.hpp"

namespace mm4mm::sim {

std::vector<Eigen::Isometry3d> driftingOdometry(const std::vector<Eigen::Isometry3d>& T_world_body,
                                                const OdometryConfig& config, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> symmetric(-1.0, 1.0);
  const double scale_error = config.scale_error_max * symmetric(rng);
  const double yaw_bias_per_m =
      config.yaw_bias_deg_per_100m_max * symmetric(rng) * M_PI / 180.0 / 100.0;
  const double yaw_noise_per_sqrt_m = config.yaw_noise_deg_per_sqrt_m * M_PI / 180.0;

  std::vector<Eigen::Isometry3d> odometry;
  if (T_world_body.empty()) return odometry;
  const double z0 = T_world_body.front().translation().z();
  Eigen::Vector2d position = Eigen::Vector2d::Zero();
  double yaw = 0.0;
  for (std::size_t i = 0; i < T_world_body.size(); ++i) {
    if (i > 0) {
      // True planar increment in the previous keyframe's heading frame, corrupted, integrated.
      const Eigen::Isometry3d& a = T_world_body[i - 1];
      const Eigen::Isometry3d& b = T_world_body[i];
      const double yaw_a = yawOf(a.linear());
      const Eigen::Vector2d step =
          Eigen::Rotation2Dd(-yaw_a) * (b.translation() - a.translation()).head<2>();
      const double distance = step.norm();
      const double dyaw = wrapAngle(yawOf(b.linear()) - yaw_a);
      const double sigma_t = config.translation_noise_m_per_sqrt_m * std::sqrt(distance);
      const Eigen::Vector2d noisy_step =
          (1.0 + scale_error) * step + sigma_t * drawVector2(gauss, rng);
      const double yaw_noise = gauss(rng);  // sequenced, as in drawVector2
      const double turn_noise = gauss(rng);
      const double noisy_dyaw = dyaw + yaw_bias_per_m * distance +
                                yaw_noise_per_sqrt_m * std::sqrt(distance) * yaw_noise +
                                1e-3 * std::abs(dyaw) * turn_noise;
      position += Eigen::Rotation2Dd(yaw) * noisy_step;
      yaw = wrapAngle(yaw + noisy_dyaw);
    }
    const Eigen::Matrix3d tilt = tiltOf(T_world_body[i].linear());
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = rotationZ(yaw) * tilt;
    pose.translation() << position, T_world_body[i].translation().z() - z0;
    odometry.push_back(pose);
  }
  return odometry;
}

}  // namespace mm4mm::sim
