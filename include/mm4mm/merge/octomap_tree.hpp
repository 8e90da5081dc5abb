#pragma once
// The atlas as an OctoMap (docs/design.md: octomap.bt): every keyframe scan ray-cast into one
// occupancy octree in the atlas frame, encoded as OctoMap's binary tree stream, which
// io/octomap_io.hpp writes as a .bt file that octovis, octomap_server and
// octomap::OcTree::readBinary load. OctoMap stays inside the .cpp.

#include <Eigen/Geometry>
#include <cstddef>
#include <string>
#include <vector>

#include "mm4mm/session/session.hpp"

namespace mm4mm {

/// OctoMap's sensor model and the scan preprocessing. Probabilities as OctoMap's defaults.
struct OctoMapConfig {
  /// Edge of the smallest voxels (m). Scans are discretised to this grid before ray casting.
  double resolution_m = 0.1;
  /// Returns nearer to the LiDAR than this are dropped (m): hits on the robot itself.
  double min_range_m = 0.0;
  /// OctoMap's maxrange (m): a longer return clears space up to this distance along its ray and
  /// marks nothing occupied; far returns are sparse and their long rays dominate the cost.
  /// Negative: no limit.
  double max_range_m = 30.0;
  double probability_hit = 0.7;   ///< occupancy update of a voxel holding a return
  double probability_miss = 0.4;  ///< update of a voxel a ray passes through
  double clamping_min = 0.1192;   ///< occupancy probabilities are clamped to [min, max]
  double clamping_max = 0.971;

  /// False, with the offending field named in `error`, when a setting is out of range.
  bool IsValid(std::string* error) const;
};

/// What was built.
struct OctoMapStats {
  std::size_t scans = 0;            ///< keyframe scans inserted
  std::size_t endpoints = 0;        ///< discretised returns ray-cast (one per voxel and scan)
  std::size_t nodes = 0;            ///< octree nodes in the file, inner nodes included
  std::size_t occupied_leaves = 0;  ///< leaves (of any size) classified occupied
  std::size_t free_leaves = 0;      ///< leaves classified free
  double occupied_volume_m3 = 0.0;  ///< volume of the occupied leaves
  double free_volume_m3 = 0.0;      ///< volume of the free leaves
  double seconds = 0.0;             ///< wall time of the build
};

/// A pruned maximum-likelihood octree as OctoMap's binary format stores it after its header:
/// the bytes of OcTree::writeBinaryData, two bits per child, depth first.
struct OctoMapTree {
  double resolution_m = 0.1;
  std::string data;  ///< empty for a map without any scan
  OctoMapStats stats;
};

/// Builds the occupancy octree of all scans. Scan k of session i is
/// placed by `T_atlas_keyframe[i][k]` (body to atlas frame); its rays start at the LiDAR,
/// `T_atlas_keyframe[i][k] * sessions[i].rig.T_body_lidar`. Sessions are passed only if they
/// belong in the map; magnetic-only sessions (no scans) contribute nothing.
///
/// The tree, written by writeOctoMap, is the file OctoMap itself writes after inserting every scan,
/// session by session and keyframe by keyframe, with `insertPointCloud(scan, origin, max_range_m,
/// lazy_eval = true, discretize = true)`, then `updateInnerOccupancy()`, `prune()` and
/// `writeBinary()`: byte for byte, since every voxel gets the same sequence of clamped log-odds
/// updates and the binary format holds the pruned maximum-likelihood tree. It is computed without
/// OctoMap's per-voxel tree descents, though (about 30 times faster on one core, and parallel): the
/// rays of one scan are cast in parallel into a sparse voxel grid, and the file is encoded from
/// that grid. Cost: O(voxels crossed by rays) time on all cores, about 6 bytes per voxel ever
/// observed. Returns that are not finite, or beyond OctoMap's key range (about +-3276 m at 0.1 m),
/// are skipped.
///
/// Throws std::invalid_argument for an invalid config, a pose list whose length differs from its
/// session's keyframes, or scans not one per keyframe.
OctoMapTree buildOctoMap(const std::vector<Session>& sessions,
                         const std::vector<std::vector<Eigen::Isometry3d>>& T_atlas_keyframe,
                         const OctoMapConfig& config = {});

}  // namespace mm4mm
