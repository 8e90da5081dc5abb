#pragma once
// ROS 1 bags, read with ROS's own rosbag_storage library (Debian's librosbag-storage-dev) and the
// message packages' generated types; no hand-written bag parser.
//
// - sensor_msgs/MagneticField: the field in tesla along header.frame_id's axes (converted to µT);
//   the magnetometer's pose in the body frame from the bag's /tf_static where it links the two.
// - nav_msgs/Odometry: the pose stream (pose.pose of child_frame_id in header.frame_id).
// - sensor_msgs/Imu: roll and pitch for odometry that has only heading (optional).
// - sensor_msgs/PointCloud2 (float32 x y z): keyframes where the odometry has moved or turned
//   enough since the last one, each cloud moved into the odometry's body frame by /tf_static.
// Times are the messages' header stamps, not the bag's record times.

#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "mm4mm/import/recording.hpp"

namespace mm4mm {

/// Topic and type of every connection in the bag, sorted by topic. InputError on a file that is
/// not a readable bag.
std::vector<std::pair<std::string, std::string>> bagTopics(const std::filesystem::path& bag);

/// The samples of `topics` (sensor_msgs/MagneticField), sensor i from topics[i] (a rig with
/// several magnetometers publishes one topic each). `body_frame` names the frame to look each
/// magnetometer's pose up in /tf_static (none: leave it to the caller's extrinsics). InputError
/// naming the bag and topic when a topic is absent (listing the bag's topics) or of another
/// type, when stamps go backwards, or when /tf_static does not link a sensor's frame.
MagnetometerRecording readBagMagnetometer(const std::filesystem::path& bag,
                                          const std::vector<std::string>& topics,
                                          const std::optional<std::string>& body_frame);

struct BagLidarOptions {
  std::string odometry_topic;
  /// Empty: no clouds, a magnetic-only session.
  std::string cloud_topic;
  KeyframeSpacing spacing;
  /// sensor_msgs/Imu with orientation: where set, the odometry keeps its heading and position and
  /// takes roll and pitch from the IMU (odometry that knows only heading, such as wheel odometry
  /// or a planar SLAM). The IMU's pose in the body frame comes from /tf_static.
  std::string imu_topic;
  /// The LiDAR's pose in the body frame when /tf_static does not give it.
  std::optional<Eigen::Isometry3d> T_body_lidar;
};

LidarRecording readBagLidar(const std::filesystem::path& bag, const BagLidarOptions& options);

}  // namespace mm4mm
