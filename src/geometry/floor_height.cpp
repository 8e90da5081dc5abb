#include "mm4mm/geometry/floor_height.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace mm4mm {

std::optional<FloorHeight> floorHeightFromScans(const Session& session,
                                                const FloorHeightConfig& config) {
  const std::size_t n = std::min(session.scans.size(), session.keyframes.size());
  if (n == 0) return std::nullopt;
  // Heights below each keyframe's body, levelled by its pose: the body's height above the floor
  // is one number for a wheeled robot and close to one for a walker, while the keyframes' own
  // z carries the odometry's drift.
  const int bins_below = static_cast<int>(std::ceil(20.0 / config.bin_m));
  const int bins_above = static_cast<int>(std::ceil(5.0 / config.bin_m));
  std::vector<int> histogram(bins_below + bins_above, 0);
  std::vector<double> sum(histogram.size(), 0.0);
  std::vector<double> keyframe_z;
  const std::size_t keyframe_step =
      std::max<std::size_t>(1, (n + config.max_keyframes - 1) / config.max_keyframes);
  const std::size_t points_per_scan = std::max<std::size_t>(
      1, static_cast<std::size_t>(config.max_points) / ((n + keyframe_step - 1) / keyframe_step));
  const double radius2 = config.radius_m * config.radius_m;
  for (std::size_t k = 0; k < n; k += keyframe_step) {
    const Eigen::Isometry3d& T = session.keyframes[k].T_frame_body;
    keyframe_z.push_back(T.translation().z());
    const PointCloud& scan = session.scans[k];
    const std::size_t point_step =
        std::max<std::size_t>(1, (scan.size() + points_per_scan - 1) / points_per_scan);
    const Eigen::Matrix3d R = T.linear();
    // The floor lies below the LiDAR that sees it; above it are the ceiling and the racks' tops.
    // A tenth of a metre above, for a LiDAR whose pose in the body is not stated (identity)
    // though the body's origin is on the floor.
    const Eigen::Vector3f lidar_body = session.rig.T_body_lidar.translation().cast<float>();
    const double below_lidar = (R * session.rig.T_body_lidar.translation()).z() + 0.1;
    for (std::size_t i = 0; i < scan.size(); i += point_step) {
      // Returns at the LiDAR itself are no returns (real drivers write them as zeros).
      if ((scan[i] - lidar_body).squaredNorm() < config.min_range_m * config.min_range_m) continue;
      const Eigen::Vector3d d = R * scan[i].cast<double>();
      if (!d.allFinite() || d.head<2>().squaredNorm() > radius2 || d.z() > below_lidar) continue;
      // In double first: a wild return far below would overflow an int.
      const double slot = std::floor(d.z() / config.bin_m) + bins_below;
      if (slot < 0.0 || slot >= static_cast<double>(histogram.size())) continue;
      const auto bin = static_cast<std::size_t>(slot);
      ++histogram[bin];
      sum[bin] += d.z();
    }
  }
  const int peak = *std::max_element(histogram.begin(), histogram.end());
  if (peak == 0) return std::nullopt;
  const double threshold = config.min_share_of_peak * peak;
  int lowest = 0;
  while (histogram[lowest] < threshold) ++lowest;
  // The floor's points straddle bins, and a floor that is not quite level or flat spreads over a
  // few: its height is the fullest bin within 0.1 m above the lowest, with its neighbours.
  int top = lowest;
  const int last = std::min<int>(histogram.size() - 1,
                                 lowest + static_cast<int>(std::lround(0.1 / config.bin_m)));
  for (int b = lowest + 1; b <= last; ++b)
    if (histogram[b] > histogram[top]) top = b;
  int count = 0;
  double z_sum = 0.0;
  for (int b = std::max(0, top - 1); b <= std::min<int>(histogram.size() - 1, top + 1); ++b) {
    count += histogram[b];
    z_sum += sum[b];
  }
  if (count < config.min_floor_points) return std::nullopt;
  // A floor is a thin layer: the walls' points just above it are far fewer than its own. The
  // bottom of a band of wall points (a LiDAR that sees no floor) is not.
  int above = 0;
  const int above_first = top + static_cast<int>(std::lround(0.1 / config.bin_m));
  const int above_last = top + static_cast<int>(std::lround(0.3 / config.bin_m));
  for (int b = above_first; b <= std::min<int>(histogram.size() - 1, above_last); ++b)
    above += histogram[b];
  const double above_per_bin = above / static_cast<double>(above_last - above_first + 1);
  const double contrast = count / 3.0 / std::max(above_per_bin, 1.0);
  if (contrast < config.min_floor_contrast) return std::nullopt;
  FloorHeight floor;
  floor.body_height_m = -z_sum / count;
  std::nth_element(keyframe_z.begin(), keyframe_z.begin() + keyframe_z.size() / 2,
                   keyframe_z.end());
  floor.frame_height_m = floor.body_height_m - keyframe_z[keyframe_z.size() / 2];
  floor.floor_points = count;
  floor.contrast = contrast;
  floor.keyframes = static_cast<int>(keyframe_z.size());
  return floor;
}

std::optional<FrameHeight> frameHeightAboveFloor(const Session& session) {
  if (session.rig.frame_height_above_floor_m)
    return FrameHeight{*session.rig.frame_height_above_floor_m, false};
  if (const std::optional<FloorHeight> floor = floorHeightFromScans(session))
    return FrameHeight{floor->frame_height_m, true};
  return std::nullopt;
}

}  // namespace mm4mm
