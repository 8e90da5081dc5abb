#pragma once
// FAST-LIO2's saved output (hku-mars/FAST_LIO src/laserMapping.cpp), and the pose-graph forks'
// keyframe layout (gisbi-kim/FAST_LIO_SLAM SC-PGO/src/laserPosegraphOptimization.cpp).
//
// FAST-LIO2 with pcd_save_en and pcd_save/interval N writes PCD/scans_1.pcd, scans_2.pcd, ...,
// each N motion-compensated scans transformed into the world frame (camera_init, the IMU frame at
// start), and with runtime_pos_log_enable Log/pos_log.txt, one line per scan:
//   t (s since the first scan) | rotation vector (rad, 3) | position (3) | 0 0 0 | velocity (3) |
//   0 0 0 | gyro bias (3) | accelerometer bias (3) | gravity (3)
// of the IMU (body) in the world frame. File k holds the scans of log lines (k-1)N .. kN-1; its
// keyframe is the middle one, and its points are taken back into that body frame. FAST-LIO's
// world frame is not levelled (gravity is estimated in it): the poses are rotated so that the
// last logged gravity points down. pos_log times are relative: `time_origin_s` (the first scan's
// time on the magnetometer's clock) is added. They are the scans' starts while the states are
// the scans' ends: each pose is stamped at its start plus the median time between lines (one
// scan's sweep).
//
// The fork layout: Scans/NNNNNN.pcd (pcl::PointXYZI, the IMU body frame of FAST-LIO's
// /cloud_registered_body), times.txt (one ROS time per keyframe), optimized_poses.txt and
// odom_poses.txt (KITTI style: 12 numbers, row-major 3x4 of the body in camera_init).

#include <filesystem>

#include "mm4mm/import/recording.hpp"

namespace mm4mm {

LidarRecording readFastLioPcdSave(const std::filesystem::path& pcd_dir,
                                  const std::filesystem::path& pos_log, int interval,
                                  double time_origin_s);

/// `optimized` selects optimized_poses.txt (else odom_poses.txt); the optimised file may lag the
/// scans by the last keyframes, which are then left out and noted.
LidarRecording readFastLioKeyframes(const std::filesystem::path& dir, bool optimized = true);

}  // namespace mm4mm
