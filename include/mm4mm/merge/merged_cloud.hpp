#pragma once
// The merged point cloud of an atlas (paper Section III-C, Eq. 13): every keyframe scan of every
// session moved into the atlas frame by its optimised pose, each session voxelised into points
// with a Gaussian position uncertainty, and points of different sessions that describe the same
// spot of surface fused into one by the product of their Gaussians, so that overlapping sessions
// give one layer of points rather than one per session.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "mm4mm/merge/atlas_poses.hpp"
#include "mm4mm/session/session.hpp"

namespace mm4mm {

struct MergedCloudConfig {
  /// Edge of the cubic voxels (m) of the atlas-frame grid (aligned with its origin); each session
  /// keeps one point per voxel it hit.
  double voxel_size_m = 0.1;
  /// Returns nearer to or farther from the LiDAR than this are dropped (m), as in PointMapConfig.
  double min_range_m = 0.0;
  double max_range_m = 100.0;
  /// Standard deviation of a single return's position (m): the LiDAR's range noise. It keeps the
  /// covariance of a voxel hit by few, or collinear, returns from being singular.
  double point_sigma_m = 0.02;
  /// A point that no other session shares its voxel with is fused with the nearest point of
  /// another session in a neighbouring voxel when closer than this (m): the same surface of two
  /// sessions a few centimetres apart may straddle a voxel boundary. 0 fuses within voxels only.
  double neighbour_fusion_radius_m = 0.05;

  /// False, with the offending field named in `error`, when a setting is out of range.
  bool IsValid(std::string* error) const;
};

/// Points in the atlas frame (m). The vectors are parallel: entry i describes point i. Points are
/// in a fixed order (by voxel), so the same inputs give the same cloud.
struct MergedCloud {
  std::vector<Eigen::Vector3f> points;
  /// Covariance of each point's position (m^2): the product of the per-session Gaussians fused
  /// into it, Sigma = (sum_s Sigma_s^-1)^-1. A session's Gaussian for a voxel with n returns of
  /// scatter S (their covariance about their mean) is (S + sigma^2 I) / n: the uncertainty of a
  /// mean of n returns spread like S, each with noise sigma = point_sigma_m.
  std::vector<Eigen::Matrix3f> covariances;
  /// Index (into the `sessions` argument) of the session that contributed most returns.
  std::vector<std::uint32_t> session;
  /// Number of sessions fused into the point (1: seen by one session only).
  std::vector<std::uint16_t> session_count;
  /// Scan returns behind the point, over all its sessions.
  std::vector<std::uint32_t> return_count;
  /// Scan returns that passed the range filter, over all sessions.
  std::size_t input_points = 0;
  /// Points before fusion: the sum over sessions of their occupied voxels.
  std::size_t session_points = 0;

  std::size_t size() const { return points.size(); }
  bool empty() const { return points.empty(); }
};

/// Builds the merged cloud (Eq. 13). Scan k of session i is placed by `T_atlas_keyframe[i][k]`
/// (body to atlas frame); sessions without scans contribute nothing. Pass only the sessions that
/// belong in the atlas (for example, leave out unconnected ones). Each session is voxelised on
/// its own (one Gaussian per voxel, see MergedCloud::covariances), then the Gaussians of all
/// sessions in one voxel are fused, and a point left alone in its voxel is fused with its nearest
/// other-session point in a neighbouring voxel within `neighbour_fusion_radius_m` (never two of
/// the same session: its own voxels are already distinct points). Cost: O(n log n) in the
/// returns, on all cores. Throws std::invalid_argument (see checkAtlasPoses) on inconsistent
/// input or an invalid config.
MergedCloud buildMergedCloud(const std::vector<Session>& sessions,
                             const std::vector<std::vector<Eigen::Isometry3d>>& T_atlas_keyframe,
                             const MergedCloudConfig& config = {});

}  // namespace mm4mm
