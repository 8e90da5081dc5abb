#pragma once
// GLIM's dump directory, as GlobalMapping::save writes it (koide3/glim
// src/glim/mapping/global_mapping.cpp) with one SubMap::save per submap
// (src/glim/mapping/sub_map.cpp) and its merged cloud by gtsam_points' PointCloud::save_compact
// (koide3/gtsam_points src/gtsam_points/types/point_cloud.cpp):
//   traj_imu.txt, traj_lidar.txt   TUM "%.9f %.6f ..." lines, every frame, after global
//   optimisation NNNNNN/data.txt                id, T_world_origin (4x4, Eigen operator<<, 6
//   digits), ...,
//                                  frame_id (1 lidar, 2 imu), num_frames, frame_i {id, stamp, ...}
//   NNNNNN/points_compact.bin      float32 x y z packed, no header, in the submap's origin frame
// GLIM keeps no per-frame scan: each submap's cloud is merged from its keyframes (randomly
// subsampled, voxelised at 0.25 m by default). The session has one keyframe per submap, at the
// submap origin (T_world_origin, the pose of the submap's middle frame), whose scan is the
// submap's cloud; traj_imu.txt (or traj_lidar.txt for LiDAR-only odometry) is its odometry.

#include <filesystem>

#include "mm4mm/import/recording.hpp"

namespace mm4mm {

/// Reads a GLIM dump directory. Throws InputError naming the file and line on a missing file, a
/// data.txt that does not parse, a points_compact.bin whose size is no multiple of 12 bytes or an
/// empty one; submaps whose middle frame is not in the trajectory (pruned) are left out and noted.
LidarRecording readGlimDump(const std::filesystem::path& dir);

}  // namespace mm4mm
