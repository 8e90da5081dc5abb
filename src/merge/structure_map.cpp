#include "mm4mm/merge/structure_map.hpp"

#include <octomap/OcTree.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace mm4mm {

bool StructureMapConfig::IsValid(std::string* error) const {
  const auto fail = [&](const char* message) {
    if (error) *error = message;
    return false;
  };
  if (!(cell_size_m >= 0.01 && cell_size_m <= 10.0))
    return fail("cell_size_m must be in [0.01, 10]");
  if (!(band_below_lidar_m >= 0.0) || !(band_above_lidar_m >= 0.0) ||
      !(band_below_lidar_m + band_above_lidar_m > 0.0))
    return fail("band_below_lidar_m and band_above_lidar_m must be >= 0 and not both 0");
  if (!(max_range_m > 0.0)) return fail("max_range_m must be > 0");
  if (!(keyframe_spacing_m >= 0.0)) return fail("keyframe_spacing_m must be >= 0");
  return true;
}

std::size_t StructureMap::observedCells() const {
  return static_cast<std::size_t>(
      std::count_if(occupancy.begin(), occupancy.end(), [](float p) { return std::isfinite(p); }));
}

MagneticMap StructureMap::asMatchGrid() const {
  MagneticMap grid;
  grid.origin_m = origin_m;
  grid.cell_size_m = cell_size_m;
  grid.width = width;
  grid.height = height;
  grid.height_m = lidar_height_m;
  // The levelled channels (B_h, B_v) and the total both carry the occupancy, so that every
  // channel choice but the heading-dependent one correlates walls with walls.
  grid.horizontal_uT = grid.vertical_uT = grid.total_uT = grid.session_x_uT = occupancy;
  grid.session_y_uT.assign(occupancy.size(), 0.0f);
  return grid;
}

StructureMap buildStructureMap(const Session& session, const StructureMapConfig& config) {
  std::string error;
  if (!config.IsValid(&error)) throw std::invalid_argument("buildStructureMap: " + error);
  StructureMap map;
  map.cell_size_m = config.cell_size_m;
  if (!session.hasScans()) return map;
  if (session.scans.size() != session.keyframes.size())
    throw std::invalid_argument("buildStructureMap: session " + session.id +
                                " has not one scan per keyframe");

  // Every ray lies in one layer of voxels: the plane through the centres of key z = 2^15.
  octomap::OcTree tree(config.cell_size_m);
  const float plane_z = static_cast<float>(0.5 * config.cell_size_m);
  double lidar_height_sum = 0.0;
  int scans_used = 0;
  Eigen::Vector3d last_used = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  for (std::size_t k = 0; k < session.keyframes.size(); ++k) {
    const Eigen::Isometry3d& T_session_body = session.keyframes[k].T_frame_body;
    const Eigen::Vector3d lidar = T_session_body * session.rig.T_body_lidar.translation();
    if ((lidar - last_used).norm() < config.keyframe_spacing_m) continue;
    last_used = lidar;
    lidar_height_sum += lidar.z();
    ++scans_used;
    octomap::Pointcloud flattened;
    for (const Eigen::Vector3f& p_body : session.scans[k]) {
      const Eigen::Vector3d p = T_session_body * p_body.cast<double>();
      const double dz = p.z() - lidar.z();
      if (!p.allFinite() || dz < -config.band_below_lidar_m || dz > config.band_above_lidar_m)
        continue;
      flattened.push_back(static_cast<float>(p.x()), static_cast<float>(p.y()), plane_z);
    }
    tree.insertPointCloud(
        flattened,
        octomap::point3d(static_cast<float>(lidar.x()), static_cast<float>(lidar.y()), plane_z),
        config.max_range_m, /*lazy_eval=*/false, /*discretize=*/true);
  }
  if (tree.size() == 0) return map;
  map.lidar_height_m = lidar_height_sum / scans_used;

  // Leaves may be pruned into larger cubes; each covers every cell beneath it.
  const double half = 0.5 * config.cell_size_m;
  double min_x, min_y, min_z, max_x, max_y, max_z;
  tree.getMetricMin(min_x, min_y, min_z);
  tree.getMetricMax(max_x, max_y, max_z);
  const octomap::point3d layer_min(static_cast<float>(min_x + half),
                                   static_cast<float>(min_y + half), plane_z);
  const octomap::point3d layer_max(static_cast<float>(max_x - half),
                                   static_cast<float>(max_y - half), plane_z);
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector2d hi = -lo;
  for (auto it = tree.begin_leafs_bbx(layer_min, layer_max), end = tree.end_leafs_bbx(); it != end;
       ++it) {
    const double size = it.getSize();
    const Eigen::Vector2d centre(it.getX(), it.getY());
    lo = lo.cwiseMin(centre - Eigen::Vector2d::Constant(0.5 * size));
    hi = hi.cwiseMax(centre + Eigen::Vector2d::Constant(0.5 * size));
  }
  if (!(lo.x() < hi.x())) return map;
  map.origin_m = lo;
  map.width = static_cast<int>(std::lround((hi.x() - lo.x()) / config.cell_size_m));
  map.height = static_cast<int>(std::lround((hi.y() - lo.y()) / config.cell_size_m));
  const std::size_t cells = static_cast<std::size_t>(map.width) * map.height;
  map.occupancy.assign(cells, std::numeric_limits<float>::quiet_NaN());
  for (auto it = tree.begin_leafs_bbx(layer_min, layer_max), end = tree.end_leafs_bbx(); it != end;
       ++it) {
    const double size = it.getSize();
    const int first_x =
        static_cast<int>(std::lround((it.getX() - 0.5 * size - lo.x()) / config.cell_size_m));
    const int first_y =
        static_cast<int>(std::lround((it.getY() - 0.5 * size - lo.y()) / config.cell_size_m));
    const int span = static_cast<int>(std::lround(size / config.cell_size_m));
    const float occupancy = static_cast<float>(it->getOccupancy());
    for (int iy = std::max(0, first_y); iy < std::min(map.height, first_y + span); ++iy)
      for (int ix = std::max(0, first_x); ix < std::min(map.width, first_x + span); ++ix) {
        map.occupancy[static_cast<std::size_t>(iy) * map.width + ix] = occupancy;
      }
  }
  return map;
}

}  // namespace mm4mm
