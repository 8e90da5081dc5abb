#include "mm4mm/merge/structure_map.hpp"

#include <octomap/OcTree.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
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

  // Every ray lies in one layer of voxels: the plane through the centres of key z = 2^15. What
  // OcTree::insertPointCloud(..., discretize) does to that layer, done on a flat grid: the tree
  // is kept only for its key arithmetic and its rays (OcTreeBaseImpl::computeRayKeys), since its
  // hash sets and node searches cost most of the time (a test compares cell by cell with the
  // tree's own insertion).
  const octomap::OcTree tree(config.cell_size_m);
  const float plane_z = static_cast<float>(0.5 * config.cell_size_m);
  struct FlatScan {
    octomap::point3d origin;
    std::vector<octomap::point3d> endpoints;  // voxel centres of the returns, each voxel once
  };
  std::vector<FlatScan> scans;
  int key_min[2] = {65535, 65535}, key_max[2] = {0, 0};
  const auto extend = [&](const octomap::OcTreeKey& key) {
    for (int a = 0; a < 2; ++a)
      key_min[a] = std::min<int>(key_min[a], key[a]),
      key_max[a] = std::max<int>(key_max[a], key[a]);
  };
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
    FlatScan scan;
    scan.origin =
        octomap::point3d(static_cast<float>(lidar.x()), static_cast<float>(lidar.y()), plane_z);
    // Outside the key range (kilometres from the frame's origin) no ray can be cast, and a
    // wrapped key would stretch the grid over the whole range.
    octomap::OcTreeKey origin_key;
    if (!tree.coordToKeyChecked(scan.origin, origin_key)) continue;
    extend(origin_key);
    // OccupancyOcTreeBase::computeDiscreteUpdate: each return's voxel once, at its centre.
    std::vector<std::uint64_t> keys;
    for (const Eigen::Vector3f& p_body : session.scans[k]) {
      const Eigen::Vector3d p = T_session_body * p_body.cast<double>();
      const double dz = p.z() - lidar.z();
      if (!p.allFinite() || dz < -config.band_below_lidar_m || dz > config.band_above_lidar_m)
        continue;
      octomap::OcTreeKey key;
      if (!tree.coordToKeyChecked(
              octomap::point3d(static_cast<float>(p.x()), static_cast<float>(p.y()), plane_z), key))
        continue;
      keys.push_back(std::uint64_t{key[0]} | std::uint64_t{key[1]} << 16 |
                     std::uint64_t{key[2]} << 32);
    }
    std::sort(keys.begin(), keys.end());
    keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
    for (const std::uint64_t packed : keys) {
      const octomap::OcTreeKey key(static_cast<octomap::key_type>(packed & 0xffff),
                                   static_cast<octomap::key_type>((packed >> 16) & 0xffff),
                                   static_cast<octomap::key_type>(packed >> 32));
      extend(key);
      scan.endpoints.push_back(tree.keyToCoord(key));
    }
    scans.push_back(std::move(scan));
  }
  if (scans.empty()) return map;

  // A ray's voxels lie between its ends' keys, and a ray cut at the maximum range ends on its
  // way to a return: the box of the origins' and returns' keys holds every voxel touched.
  const octomap::key_type layer = tree.coordToKey(static_cast<double>(plane_z));
  const int nx = key_max[0] - key_min[0] + 1, ny = key_max[1] - key_min[1] + 1;
  const std::size_t cells = static_cast<std::size_t>(nx) * ny;
  std::vector<float> log_odds(cells, 0.0f);
  std::vector<bool> observed(cells, false);
  std::vector<int> free_stamp(cells, -1), occupied_stamp(cells, -1);
  const auto cellOf = [&](const octomap::OcTreeKey& key) {
    return static_cast<std::size_t>(key[1] - key_min[1]) * nx + (key[0] - key_min[0]);
  };
  // OccupancyOcTreeBase::updateNodeLogOdds: add, then clamp (a voxel already at the bound the
  // update points to keeps its value, as updateNode's early return leaves it).
  const float hit = tree.getProbHitLog(), miss = tree.getProbMissLog();
  const float clamp_min = tree.getClampingThresMinLog(), clamp_max = tree.getClampingThresMaxLog();
  const auto update = [&](std::size_t c, float change) {
    float value = log_odds[c] + change;
    log_odds[c] = value < clamp_min ? clamp_min : value > clamp_max ? clamp_max : value;
    observed[c] = true;
  };
  octomap::KeyRay ray;
  std::vector<std::size_t> occupied;
  for (int s = 0; s < static_cast<int>(scans.size()); ++s) {
    const FlatScan& scan = scans[s];
    // OccupancyOcTreeBase::computeUpdate: a return within range marks its voxel occupied and the
    // ray's free; one beyond marks free the ray cut at the range. A voxel both is occupied, and
    // each is updated once a scan.
    occupied.clear();
    for (const octomap::point3d& p : scan.endpoints) {
      octomap::OcTreeKey key;
      if ((p - scan.origin).norm() <= config.max_range_m && tree.coordToKeyChecked(p, key) &&
          key[2] == layer) {
        const std::size_t c = cellOf(key);
        if (occupied_stamp[c] != s) occupied_stamp[c] = s, occupied.push_back(c);
      }
    }
    for (const octomap::point3d& p : scan.endpoints) {
      const bool within = (p - scan.origin).norm() <= config.max_range_m;
      const octomap::point3d end = within
                                       ? p
                                       : scan.origin + (p - scan.origin).normalized() *
                                                           static_cast<float>(config.max_range_m);
      if (!tree.computeRayKeys(scan.origin, end, ray)) continue;
      for (const octomap::OcTreeKey& key : ray) {
        if (key[2] != layer) continue;
        const std::size_t c = cellOf(key);
        if (occupied_stamp[c] == s || free_stamp[c] == s) continue;
        free_stamp[c] = s;
        update(c, miss);
      }
    }
    for (const std::size_t c : occupied) update(c, hit);
  }
  if (std::none_of(observed.begin(), observed.end(), [](bool seen) { return seen; })) return map;
  map.lidar_height_m = lidar_height_sum / scans_used;

  // The grid spans the observed voxels, as the tree's leaves in the layer did.
  const double half = 0.5 * config.cell_size_m;
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector2d hi = -lo;
  for (int y = 0; y < ny; ++y)
    for (int x = 0; x < nx; ++x) {
      if (!observed[static_cast<std::size_t>(y) * nx + x]) continue;
      const Eigen::Vector2d centre(tree.keyToCoord(static_cast<octomap::key_type>(key_min[0] + x)),
                                   tree.keyToCoord(static_cast<octomap::key_type>(key_min[1] + y)));
      lo = lo.cwiseMin(centre - Eigen::Vector2d::Constant(half));
      hi = hi.cwiseMax(centre + Eigen::Vector2d::Constant(half));
    }
  if (!(lo.x() < hi.x())) return map;
  map.origin_m = lo;
  map.width = static_cast<int>(std::lround((hi.x() - lo.x()) / config.cell_size_m));
  map.height = static_cast<int>(std::lround((hi.y() - lo.y()) / config.cell_size_m));
  map.occupancy.assign(static_cast<std::size_t>(map.width) * map.height,
                       std::numeric_limits<float>::quiet_NaN());
  for (int y = 0; y < ny; ++y)
    for (int x = 0; x < nx; ++x) {
      const std::size_t c = static_cast<std::size_t>(y) * nx + x;
      if (!observed[c]) continue;
      const double cx = tree.keyToCoord(static_cast<octomap::key_type>(key_min[0] + x));
      const double cy = tree.keyToCoord(static_cast<octomap::key_type>(key_min[1] + y));
      const int ix = static_cast<int>(std::lround((cx - half - lo.x()) / config.cell_size_m));
      const int iy = static_cast<int>(std::lround((cy - half - lo.y()) / config.cell_size_m));
      if (ix < 0 || iy < 0 || ix >= map.width || iy >= map.height) continue;
      map.occupancy[static_cast<std::size_t>(iy) * map.width + ix] =
          static_cast<float>(octomap::probability(log_odds[c]));
    }
  return map;
}

}  // namespace mm4mm
