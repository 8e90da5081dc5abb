#pragma once
// Levelling a frame that is not gravity-aligned by the floor its scans see. FAST-LIO's camera_init
// is the IMU frame at start (FAST_LIO src/laserMapping.cpp: the state starts at identity and
// gravity is estimated in it), and the pose-graph forks save their keyframe poses in it
// (FAST_LIO_SLAM SC-PGO optimized_poses.txt) without the gravity estimate, so a body that started
// 5° off level gives a session frame 5° off "z up", which mixes the field's horizontal and
// vertical components. A building's floor and ceiling are level to a small fraction of a degree
// (flatness tolerances are a few mm per 3 m), so the normal of the largest plane near the frame's
// z axis in the scans gives the frame's tilt.

#include <Eigen/Geometry>
#include <optional>
#include <vector>

#include "mm4mm/session/session.hpp"

namespace mm4mm {

struct FloorLevellingConfig {
  double voxel_m = 0.1;        ///< points thinned to one per voxel first
  double max_tilt_deg = 20.0;  ///< the frame's z is within this of up (a body that started upright)
  double distance_m = 0.03;    ///< RANSAC inlier distance: a LiDAR's range noise
  double min_inlier_share =
      0.05;               ///< the plane holds at least this share of the thinned points ...
  int min_inliers = 500;  ///< ... and at least this many
  int iterations = 2000;
};

struct FloorLevelling {
  /// Rotates the frame's vectors into a frame whose z is up (the plane's normal), turning about
  /// the horizontal axis only: the frame's heading is kept.
  Eigen::Quaterniond R_level_frame = Eigen::Quaterniond::Identity();
  double tilt_deg = 0.0;  ///< angle between the frame's z and the plane's normal
  int inliers = 0;
  int points = 0;  ///< after thinning
};

/// The levelling from the largest plane within config.max_tilt_deg of horizontal among
/// `points_frame` (any points of the building in the frame to level: keyframe scans placed by their
/// poses); nullopt when no plane holds enough of them (outdoors, a scan that sees no floor).
/// Deterministic (RANSAC with a fixed seed).
std::optional<FloorLevelling> levellingFromFloor(const PointCloud& points_frame,
                                                 const FloorLevellingConfig& config = {});

}  // namespace mm4mm
