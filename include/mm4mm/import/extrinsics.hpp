#pragma once
// The rig's extrinsics as a small YAML file, for `mm4mm import --extrinsics`:
//
//   T_body_magnetometer: {translation: [0.1, 0.0, 0.3], quaternion: [0, 0, 0, 1]}   # x y z w
//   T_body_lidar:        {translation: [0.0, 0.0, 0.8], quaternion: [0, 0, 0, 1]}
//
// Either key may be absent. Each maps points of the sensor's frame into the body frame.

#include <Eigen/Geometry>
#include <filesystem>
#include <optional>

namespace mm4mm {

struct Extrinsics {
  std::optional<Eigen::Isometry3d> T_body_magnetometer;
  std::optional<Eigen::Isometry3d> T_body_lidar;
};

/// Reads the file. InputError naming file and line on an unknown key, a translation that is not
/// three numbers, or a quaternion that is not four numbers of norm 1 (within 1e-3).
Extrinsics readExtrinsicsYaml(const std::filesystem::path& file);

}  // namespace mm4mm
