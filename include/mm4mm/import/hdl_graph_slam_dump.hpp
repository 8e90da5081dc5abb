#pragma once
// hdl_graph_slam's graph dump, as its dump service writes it (koide3/hdl_graph_slam
// apps/hdl_graph_slam_nodelet.cpp dump_service, src/hdl_graph_slam/keyframe.cpp KeyFrame::save):
//   graph.g2o                 the pose graph (not needed here: each keyframe carries its estimate)
//   NNNNNN/data               "stamp <sec> <nsec>", "estimate" + 4x4, "odom" + 4x4,
//                             "accum_distance d", optional floor_coeffs (4), utm_coord (3),
//                             acceleration (3), orientation (w x y z), "id n"; Eigen operator<<,
//                             6 significant digits
//   NNNNNN/cloud.pcd          pcl::PointXYZI, binary, in the frame of /filtered_points (the
//                             prefilter's base_link_frame when set, else the LiDAR's), already
//                             range-filtered, voxelised (0.1 m) and outlier-filtered
// The keyframe's pose is `estimate` (map <- cloud frame, after optimisation); hdl_graph_slam saves
// no pose stream between keyframes, so the magnetometer is placed on the keyframes.

#include <filesystem>

#include "mm4mm/import/recording.hpp"

namespace mm4mm {

/// Reads an hdl_graph_slam dump directory (keyframes sorted by stamp). Throws InputError naming
/// the file and line on a missing graph.g2o, data or cloud.pcd, or a data file that does not
/// parse.
LidarRecording readHdlGraphSlamDump(const std::filesystem::path& dir);

}  // namespace mm4mm
