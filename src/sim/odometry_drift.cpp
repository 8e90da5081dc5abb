#include "mm4mm/sim/odometry_drift.hpp"

#include <cmath>
#include <random>
#include <stdexcept>

#include "mm4mm/core/pose.hpp"
#include "random_draws.hpp"

namespace mm4mm::sim {

std::vector<Eigen::Isometry3d> driftingOdometry(
    const std::vector<Eigen::Isometry3d>& T_world_body, const OdometryConfig& config,
    std::uint64_t seed, const std::vector<double>& times_s,
    const std::vector<std::optional<Eigen::Vector2d>>& degenerate_axes) {
  if (!times_s.empty() && times_s.size() != T_world_body.size())
    throw std::invalid_argument("driftingOdometry: one time per pose");
  if (!degenerate_axes.empty() && degenerate_axes.size() != T_world_body.size())
    throw std::invalid_argument("driftingOdometry: one degenerate axis entry per pose");
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> symmetric(-1.0, 1.0);
  const double scale_error = config.scale_error_max * symmetric(rng);
  const double yaw_bias_per_m =
      config.yaw_bias_deg_per_100m_max * symmetric(rng) * M_PI / 180.0 / 100.0;
  const double yaw_noise_per_sqrt_m = config.yaw_noise_deg_per_sqrt_m * M_PI / 180.0;
  // Drawn after the earlier settings so that those stay what they were for a seed.
  const double degenerate_scale_error = config.degenerate_scale_error_max * symmetric(rng);
  const double attitude_sigma =
      (config.attitude_error_min_deg +
       0.5 * (1.0 + symmetric(rng)) *
           (config.attitude_error_max_deg - config.attitude_error_min_deg)) *
      M_PI / 180.0;
  // Attitude error: a first-order Gauss-Markov process per axis, started from its stationary
  // distribution; its own stream, so that its draws do not shift the translation noise's.
  std::mt19937_64 attitude_rng(seed ^ 0x5bd1e995ULL);
  Eigen::Vector2d attitude_error = attitude_sigma * drawVector2(gauss, attitude_rng);

  std::vector<Eigen::Isometry3d> odometry;
  if (T_world_body.empty()) return odometry;
  const double z0 = T_world_body.front().translation().z();
  Eigen::Vector2d position = Eigen::Vector2d::Zero();
  double yaw = 0.0;
  for (std::size_t i = 0; i < T_world_body.size(); ++i) {
    if (i > 0) {
      // True planar increment in the previous pose's heading frame, corrupted, integrated.
      const Eigen::Isometry3d& a = T_world_body[i - 1];
      const Eigen::Isometry3d& b = T_world_body[i];
      const double yaw_a = yawOf(a.linear());
      const Eigen::Vector2d step =
          Eigen::Rotation2Dd(-yaw_a) * (b.translation() - a.translation()).head<2>();
      const double distance = step.norm();
      const double dyaw = wrapAngle(yawOf(b.linear()) - yaw_a);
      const double sigma_t = config.translation_noise_m_per_sqrt_m * std::sqrt(distance);
      Eigen::Vector2d noisy_step = (1.0 + scale_error) * step + sigma_t * drawVector2(gauss, rng);
      const double yaw_noise = gauss(rng);  // sequenced, as in drawVector2
      const double turn_noise = gauss(rng);
      if (!degenerate_axes.empty() && degenerate_axes[i - 1]) {
        const Eigen::Vector2d axis =
            Eigen::Rotation2Dd(-yaw_a) * degenerate_axes[i - 1]->normalized();
        const double along = step.dot(axis);
        noisy_step +=
            axis * (degenerate_scale_error * along +
                    config.degenerate_noise_m_per_sqrt_m * std::sqrt(std::abs(along)) * gauss(rng));
      }
      const double noisy_dyaw = dyaw + yaw_bias_per_m * distance +
                                yaw_noise_per_sqrt_m * std::sqrt(distance) * yaw_noise +
                                1e-3 * std::abs(dyaw) * turn_noise;
      position += Eigen::Rotation2Dd(yaw) * noisy_step;
      yaw = wrapAngle(yaw + noisy_dyaw);
      if (!times_s.empty()) {
        const double decay =
            std::exp(-(times_s[i] - times_s[i - 1]) / config.attitude_error_time_constant_s);
        attitude_error = decay * attitude_error + attitude_sigma * std::sqrt(1.0 - decay * decay) *
                                                      drawVector2(gauss, attitude_rng);
      }
    }
    Eigen::Matrix3d tilt = tiltOf(T_world_body[i].linear());
    if (!times_s.empty())
      tilt = tilt * (Eigen::AngleAxisd(attitude_error.y(), Eigen::Vector3d::UnitY()) *
                     Eigen::AngleAxisd(attitude_error.x(), Eigen::Vector3d::UnitX()))
                        .toRotationMatrix();
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = rotationZ(yaw) * tiltOf(tilt);
    pose.translation() << position, T_world_body[i].translation().z() - z0;
    odometry.push_back(pose);
  }
  return odometry;
}

}  // namespace mm4mm::sim
