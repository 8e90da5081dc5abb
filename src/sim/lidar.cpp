#include "mm4mm/sim/lidar.hpp"

#include <cmath>

namespace mm4mm::sim {

std::vector<Eigen::Vector3d> lidarBeamDirections(const LidarConfig& config) {
  std::vector<Eigen::Vector3d> directions;
  const int columns = static_cast<int>(std::round(360.0 / config.azimuth_step_deg));
  for (int beam = 0; beam < config.beams; ++beam) {
    const double fraction = config.beams > 1 ? static_cast<double>(beam) / (config.beams - 1) : 0.5;
    const double elevation = (config.min_elevation_deg +
                              fraction * (config.max_elevation_deg - config.min_elevation_deg)) *
                             M_PI / 180.0;
    for (int column = 0; column < columns; ++column) {
      const double azimuth = 2.0 * M_PI * column / columns;
      directions.emplace_back(std::cos(elevation) * std::cos(azimuth),
                              std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
    }
  }
  return directions;
}

PointCloud simulateScan(const Raycaster& raycaster, const Eigen::Isometry3d& T_world_lidar,
                        const std::vector<Eigen::Vector3d>& beam_directions,
                        const LidarConfig& config, std::mt19937_64* rng) {
  std::normal_distribution<double> noise(0.0, config.range_noise_m);
  PointCloud points;
  points.reserve(beam_directions.size());
  const Eigen::Vector3d origin = T_world_lidar.translation();
  for (const Eigen::Vector3d& direction : beam_directions) {
    const auto range =
        raycaster.cast(origin, T_world_lidar.linear() * direction, config.max_range_m);
    if (!range || *range < config.min_range_m) continue;
    points.push_back(((*range + noise(*rng)) * direction).cast<float>());
  }
  return points;
}

}  // namespace mm4mm::sim
