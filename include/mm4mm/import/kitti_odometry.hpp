#pragma once
// The KITTI odometry layout (Geiger et al., devkit of the odometry benchmark) and the plain TUM +
// folder of PCDs that many tools export.
//
// KITTI: a sequence directory with calib.txt (P0..P3 and "Tr:", 12 numbers each; Tr maps velodyne
// points into camera 0), times.txt (s since the sequence start, one per scan), velodyne/NNNNNN.bin
// (float32 x y z reflectance per point), and a pose file of 12 numbers per line (row-major 3x4,
// camera 0 in the frame of the first camera 0). Camera axes are x right, y down, z forward; the
// session is in the velodyne's axes (x forward, z up): T_world_velo = Tr^-1 T_cam0 Tr. Keyframes
// are chosen by distance and angle travelled; every pose is the odometry stream.

#include <filesystem>

#include "mm4mm/import/recording.hpp"

namespace mm4mm {

LidarRecording readKittiOdometry(const std::filesystem::path& sequence_dir,
                                 const std::filesystem::path& pose_file, double time_origin_s,
                                 const KeyframeSpacing& spacing);

/// Reads 12-number pose lines (row-major 3x4); InputError with file and line otherwise.
std::vector<Eigen::Isometry3d> readKittiPoses(const std::filesystem::path& file);

/// A TUM pose file and a directory of PCDs, one per pose in the order of the numbers in their
/// names (scan_2 before scan_10); names with no number, of more than one pattern or with the
/// same numbers are refused with InputError, never paired by text order.
/// `scans_in_world` says the clouds are in the poses' frame (as many exporters write them) and
/// are taken back into each pose's body frame.
LidarRecording readTumWithPcds(const std::filesystem::path& pose_file,
                               const std::filesystem::path& pcd_dir, bool scans_in_world);

}  // namespace mm4mm
