#pragma once
// A single-session point map: every keyframe scan moved into the session frame, voxelised, with a
// plane-shaped covariance and a normal per point for GICP-style registration (paper Section
// III-A.2, the geometric map the ICP-EM refinement of Eq. 7-11 registers).

#include <Eigen/Core>
#include <cstddef>
#include <string>
#include <vector>

#include "mm4mm/session/session.hpp"

namespace mm4mm {

struct PointMapConfig {
  /// Edge of the cubic voxels the map is thinned to (m); one point (the centroid) per voxel.
  double voxel_size_m = 0.2;
  /// Neighbours (the point itself included) whose spread gives a point's covariance and normal.
  int covariance_neighbours = 20;
  /// Smallest eigenvalue of the regularised covariance, relative to the other two (1): how thin
  /// the flat Gaussian of a planar patch is (dimensionless; GICP uses 1e-3).
  double covariance_epsilon = 1e-3;
  /// Returns nearer to or farther from the LiDAR than this are dropped before voxelising (m):
  /// hits on the robot itself, and sparse far returns whose neighbours span metres.
  double min_range_m = 0.0;
  double max_range_m = 100.0;

  /// False, with the offending field named in `error`, when a setting is out of range.
  bool IsValid(std::string* error) const;
};

/// Points in the session frame (m). The three vectors are parallel: entry i describes point i.
struct PointMap {
  std::vector<Eigen::Vector3f> points;
  /// GICP-regularised covariances (dimensionless shape): the eigenvalues of the neighbourhood's
  /// scatter replaced by (eps, 1, 1), i.e. C = I - (1 - eps) n n^T with n the normal. Identity
  /// where a point has fewer than three neighbours.
  std::vector<Eigen::Matrix3f> covariances;
  /// Unit normal: the eigenvector of the smallest eigenvalue of the neighbourhood's scatter.
  /// Unoriented (its sign is arbitrary); zero where the covariance is the identity.
  std::vector<Eigen::Vector3f> normals;
  /// Scan points that went into the map (after the range filter, before voxelising).
  std::size_t input_points = 0;

  std::size_t size() const { return points.size(); }
  bool empty() const { return points.empty(); }
};

/// Moves every keyframe scan into the session frame by its keyframe pose, keeps the returns
/// within the range band (measured from the LiDAR, `session.rig.T_body_lidar`), keeps one
/// centroid per occupied voxel of a grid aligned with the session frame's origin, and computes
/// each kept point's covariance and normal from its `covariance_neighbours` nearest kept points.
/// A magnetic-only session (no scans) gives an empty map. Any extent works: the voxel grid is
/// processed in tiles small enough for PCL's 32-bit voxel indices. Cost: about O(n log n) in
/// the scan points plus O(m k log m) for m kept points and k neighbours; uses all cores.
/// Throws std::invalid_argument for an invalid config or a session whose scan count differs from
/// its keyframe count.
PointMap buildPointMap(const Session& session, const PointMapConfig& config);

/// buildPointMap's points alone, the same ones, without covariances and normals: for a caller that
/// crops the map and computes its own on the crop (ICP-EM's levels), where the whole map's would be
/// thrown away. The k-nearest-neighbour searches for them were a fifth of an add's cycles.
PointCloud buildVoxelisedPoints(const Session& session, const PointMapConfig& config);

/// The same map built from a cloud already in one frame (m): the keyframe submaps and the
/// coarse-to-fine levels of ICP-EM (geometry/icp_em.hpp). Points with a non-finite coordinate are
/// dropped; the range band of `config` is not applied (the cloud has no sensor position), every
/// other setting is. The result's points are in the cloud's frame. Throws std::invalid_argument
/// for an invalid config.
PointMap buildPointMapFromCloud(const PointCloud& points, const PointMapConfig& config);

}  // namespace mm4mm
