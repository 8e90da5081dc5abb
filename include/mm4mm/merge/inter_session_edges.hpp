#pragma once
// Inter-session edges (docs/design.md "Data flow"): from a refined session pair, keyframe pairs
// across the two sessions inside the overlap, each refined locally by ICP-EM between submaps around
// the two keyframes, seeded by the pair's transform. Local submaps keep each edge true where it is
// even when the odometry drifts between one end of the overlap and the other.

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "mm4mm/geometry/icp_em.hpp"
#include "mm4mm/graph/multi_session_graph.hpp"
#include "mm4mm/session/session.hpp"

namespace mm4mm {

struct InterSessionEdgeConfig {
  /// A keyframe of b pairs with the nearest keyframe of a when, under the pair's transform, they
  /// are closer than this (m).
  double pair_radius_m = 2.0;
  /// Chosen pairs are at least this far apart along a's trajectory (m).
  double spacing_m = 6.0;
  int max_edges_per_pair = 12;
  /// Keyframes on each side whose scans, moved by odometry, make a keyframe's submap.
  int submap_half_width = 3;
  /// Returns beyond this range are left out of the submaps (m).
  double max_range_m = 30.0;
  /// Local refinement: finer than the pair's, prior tighter (the pair is already refined).
  IcpEmConfig icp = [] {
    IcpEmConfig c;
    c.voxel_sizes_m = {0.5, 0.25};
    c.prior_sigma_horizontal_m = 0.3;
    c.prior_sigma_yaw_deg = 1.5;
    c.prior_sigma_vertical_m = 0.2;
    c.prior_sigma_tilt_deg = 1.0;
    c.source_crop_margin_m = 1e9;
    return c;
  }();
  /// An edge is kept when ICP-EM converged and this share of the source submap matched.
  double min_inlier_ratio = 0.3;
  /// The ICP information counts every point as independent, which it is not; it is divided by
  /// this before it enters the graph.
  double information_deflation = 100.0;
  bool IsValid(std::string* error) const;
};

/// The stitched scans of keyframes [k - half_width, k + half_width] of `session`, in keyframe
/// k's body frame, returns beyond `max_range_m` of their own keyframe dropped.
PointCloud keyframeSubmap(const Session& session, int keyframe, int half_width, double max_range_m);

/// Edges between session a (index `index_a` in the solve) and b (`index_b`) given the pair's
/// transform `T_a_b` between their odometry frames. Both sessions need scans. Keyframe pairs are
/// refined in parallel; the result is in a's keyframe order whatever the thread count.
std::vector<InterSessionEdge> interSessionEdges(const Session& a, int index_a, const Session& b,
                                                int index_b, const Eigen::Isometry3d& T_a_b,
                                                const InterSessionEdgeConfig& config);

/// Edges for sessions without scans (magnetic-only): the same keyframe pairs, each taking the
/// pair's transform as measured with a fixed information (σ in metres and degrees).
std::vector<InterSessionEdge> magneticOnlyEdges(const Session& a, int index_a, const Session& b,
                                                int index_b, const Eigen::Isometry3d& T_a_b,
                                                const InterSessionEdgeConfig& config,
                                                double sigma_m, double sigma_deg);

}  // namespace mm4mm
