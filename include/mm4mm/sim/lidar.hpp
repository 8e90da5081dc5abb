#pragma once
// A spinning multi-beam LiDAR (HDL-32E-like) ray-cast against the world. One full revolution per
// scan, no motion distortion: the simulated keyframe scans are already de-skewed, as a
// LiDAR-inertial odometry delivers them.

#include <Eigen/Geometry>
#include <random>

#include "mm4mm/session/session.hpp"
#include "mm4mm/sim/raycaster.hpp"
#include "mm4mm/sim/simulation_config.hpp"

namespace mm4mm::sim {

/// Unit beam directions in the LiDAR frame, beam-major (all azimuths of beam 0 first).
std::vector<Eigen::Vector3d> lidarBeamDirections(const LidarConfig& config);

/// Points (m) in the LiDAR frame of a scan taken at pose `T_world_lidar`, with Gaussian range
/// noise. Beams that hit nothing within range return no point.
PointCloud simulateScan(const Raycaster& raycaster, const Eigen::Isometry3d& T_world_lidar,
                        const std::vector<Eigen::Vector3d>& beam_directions,
                        const LidarConfig& config, std::mt19937_64* rng);

}  // namespace mm4mm::sim
