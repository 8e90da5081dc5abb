#pragma once
// Odometry of a good LiDAR-inertial system: gravity-aligned (roll and pitch are observed), with a
// per-session scale error, noise that grows with distance, and a slow yaw random walk.

#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "mm4mm/sim/simulation_config.hpp"

namespace mm4mm::sim {

/// Odometry poses in the session frame for true keyframe poses `T_world_body` (same order). The
/// session frame is the gravity-aligned frame at the first keyframe with its heading: the first
/// odometry pose has zero position and yaw and the true roll and pitch.
std::vector<Eigen::Isometry3d> driftingOdometry(const std::vector<Eigen::Isometry3d>& T_world_body,
                                                const OdometryConfig& config, std::uint64_t seed);

}  // namespace mm4mm::sim
