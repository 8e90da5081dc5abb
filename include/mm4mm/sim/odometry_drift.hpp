#pragma once
// Odometry of a good LiDAR-inertial system: gravity-aligned, with a per-session scale error,
// noise that grows with distance, a slow yaw random walk, roll and pitch as an IMU estimates them
// (the truth plus a slowly varying error), and extra drift along the axis of a featureless
// stretch, where the scans constrain nothing.

#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <vector>

#include "mm4mm/sim/simulation_config.hpp"

namespace mm4mm::sim {

/// Odometry poses in the session frame for true poses `T_world_body` (same order). The session
/// frame is the gravity-aligned frame at the first pose with its heading: the first odometry pose
/// has zero position and yaw. `times_s` (one per pose) drive the attitude error, which is left
/// out when they are not given; `degenerate_axes` (one per pose, world x-y) name where the
/// odometry drifts along an axis, none when not given.
std::vector<Eigen::Isometry3d> driftingOdometry(
    const std::vector<Eigen::Isometry3d>& T_world_body, const OdometryConfig& config,
    std::uint64_t seed, const std::vector<double>& times_s = {},
    const std::vector<std::optional<Eigen::Vector2d>>& degenerate_axes = {});

}  // namespace mm4mm::sim
