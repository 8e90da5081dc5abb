#pragma once
// LIO-SAM's saved map, as saveMapService writes it (TixiaoShan/LIO-SAM src/mapOptmization.cpp):
//   transformations.pcd   PointXYZIRPYT per key pose: x y z, intensity = key-pose index, roll
//                         pitch yaw (rad; pcl::getTransformation, R = Rz(yaw) Ry(pitch) Rx(roll)),
//                         time (double, ROS time in s); the LiDAR frame in the odom frame, after
//                         loop closure
//   GlobalMap.pcd         (cloudGlobal.pcd in older versions) every keyframe's corner and surface
//                         features in the odom frame; CornerMap.pcd, SurfMap.pcd, trajectory.pcd
// LIO-SAM does not save per-keyframe scans (its corner and surface clouds per keyframe live in
// memory only), nor a pose stream between key poses. The session therefore holds the key poses
// and, by default, no scans: it is magnetic-only (matched and mapped by the field, no ICP-EM).
// With `map_crop_radius_m` > 0 each keyframe instead gets the saved map's points within that
// radius, in its own frame: not what the LiDAR saw from there, but the map around it.

#include <filesystem>

#include "mm4mm/import/recording.hpp"

namespace mm4mm {

LidarRecording readLioSamMap(const std::filesystem::path& dir, double map_crop_radius_m = 0.0);

}  // namespace mm4mm
