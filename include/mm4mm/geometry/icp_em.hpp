#pragma once
// ICP-EM: the geometric refinement of a magnetic seed (paper Section III-B.2, Eq. 7-11).
//
// The MAP estimate of Eq. 7 combines the point-map likelihood p(M_a | T_M, M_b) with a prior
// p(T_M | T_B) centred on the magnetic seed T_B. The unknown point associations make the
// likelihood an EM problem (Eq. 9): the E-step (Eq. 10) associates every source point with its
// nearest target point under the current estimate and weighs the pair by a Gaussian of their
// Mahalanobis distance; the M-step (Eq. 11) minimises the weighted plane-to-plane (GICP-shaped)
// distances plus the prior with Levenberg-Marquardt on SE(3). The two alternate coarse to fine
// over voxel levels. Along directions the geometry leaves open (a featureless corridor's axis)
// the estimate is held at the seed, Eq. 7's answer there. Frames: `T_a_b` maps points of the
// source (frame b) into the target (frame a); z is up in both (gravity-aligned session frames).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "mm4mm/core/planar_region.hpp"
#include "mm4mm/session/session.hpp"

namespace mm4mm {

struct IcpEmConfig {
  /// Voxel edges of the coarse-to-fine levels (m), strictly decreasing. The finest level
  /// voxelises the inputs, each coarser one the finest level's points; every level computes its
  /// own GICP covariances.
  std::vector<double> voxel_sizes_m{1.0, 0.5, 0.25};
  /// E/M iterations at most per level.
  int max_iterations_per_level = 30;
  /// Levenberg-Marquardt iterations at most per M-step (the associations are fixed within one).
  int m_step_iterations = 10;
  /// A source point further than this from its nearest target point is not associated, in
  /// voxels of the level (so 3 m, 1.5 m and 0.75 m with the default levels).
  double max_correspondence_voxels = 3.0;
  /// Width of the E-step's Gaussian (Eq. 10) along a surface normal, in voxels of the level: a
  /// pair whose plane-to-plane distance is k of these gets weight exp(-k²/2). Wide at coarse
  /// levels (a large basin), narrow at fine ones (outliers fade out).
  double association_sigma_voxels = 1.0;
  /// Noise of a map point along its surface normal (m): LiDAR range noise plus the spread of a
  /// voxel centroid. Scales the M-step's Mahalanobis distances (Eq. 11) against the prior and
  /// sets the information matrix's scale.
  double surface_sigma_m = 0.05;
  /// Prior p(T_M | T_B) of Eq. 7: the magnetic seed's standard deviations. The seed is a planar
  /// (x, y, yaw) match of gravity-aligned frames, so height, roll and pitch get their own.
  /// +infinity removes a term (pure maximum likelihood, Eq. 8, along it).
  double prior_sigma_horizontal_m = 1.0;  ///< x and y of frame a (m)
  double prior_sigma_vertical_m = 0.5;    ///< z of frame a (m)
  double prior_sigma_yaw_deg = 5.0;       ///< about b's z axis (deg)
  double prior_sigma_tilt_deg = 2.0;      ///< about b's x and y axes (deg)
  /// A level has converged when one E/M iteration moves the estimate by less than these. They
  /// apply at the finest level; coarser levels scale them by their voxel size over the finest.
  double translation_tolerance_m = 1e-3;
  double rotation_tolerance_deg = 0.01;
  /// Neighbours and flatness of the GICP covariances, as in PointMapConfig.
  int covariance_neighbours = 20;
  double covariance_epsilon = 1e-3;
  /// `degenerate` is set when the smallest eigenvalue of the (normalised) geometric information
  /// is below this fraction of the largest: a direction the geometry barely constrains, such as
  /// the axis of a featureless corridor, where the prior decides. Measured on simulated corridor
  /// overlaps (0.25 m maps, 2 cm range noise): about 3e-5 without pillars (noise of normals
  /// only), 2.4e-3 with a pillar every 8 m (which fixes the axis to millimetres); rooms and
  /// warehouse aisles are above 1e-2.
  double degeneracy_eigenvalue_ratio = 1e-3;
  /// After every M-step, put the estimate back to the seed along such directions (solution
  /// remapping, Zhang et al. ICRA 2016): the overlap's points stay where the seed puts them along
  /// a weak direction. The geometric pull there is noise of normals and voxel grids summed over
  /// thousands of points, strong enough to drag the estimate metres along a corridor against any
  /// sensible prior; Eq. 7's answer there is the prior's mean.
  bool hold_seed_along_degenerate_directions = true;
  /// With an overlap region: source points whose position under the seed is further than this
  /// outside the region are dropped before voxelising (m), so that a whole session map need not
  /// be processed for a small overlap. The estimate is assumed to stay this close to the seed;
  /// +infinity keeps every source point.
  double source_crop_margin_m = 5.0;

  /// False, with the offending field named in `error`, when a setting is out of range.
  bool IsValid(std::string* error) const;
};

struct IcpEmResult {
  /// The refined pose of frame b in frame a (the seed when nothing could be associated).
  Eigen::Isometry3d T_a_b = Eigen::Isometry3d::Identity();
  /// Information of the geometric term alone (no prior) at the solution, for the pose of b in a
  /// with the error [δt (m, frame a); δθ (rad, rotation vector, b's axes: T = (t + δt,
  /// R·Exp(δθ)))], the order of OdometryEdge::information: the Gauss-Newton Hessian of the
  /// M-step's weighted plane-to-plane distances at the last association. Directions no surface
  /// constrains (along a featureless corridor) get none. Residuals are treated as independent,
  /// so the matrix is optimistic by about the number of points per independent surface patch.
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Zero();
  /// Source points (inside the region, at the finest level) whose match lies within one
  /// association sigma, over all source points inside the region.
  double inlier_ratio = 0.0;
  /// Associated pairs in the final E-step (finest level, at the solution).
  std::size_t correspondences = 0;
  /// Every level ran and the finest stopped by the tolerances, not the iteration limit.
  bool converged = false;
  /// E/M iterations over all levels.
  int iterations = 0;
  /// Eigenvalues (ascending, 1/m²) of `information` re-expressed for rotations about axes
  /// through the matched points' centroid, each scaled by the points' RMS distance from its axis
  /// (rotation as the arc a typical point moves, m), so that translation and rotation compare.
  Eigen::Matrix<double, 6, 1> hessian_eigenvalues = Eigen::Matrix<double, 6, 1>::Zero();
  /// Smallest over largest eigenvalue below IcpEmConfig::degeneracy_eigenvalue_ratio; also true
  /// when a level found too few pairs (no information).
  bool degenerate = false;
  /// Unit vector (sign arbitrary), in the [δt; δθ] order of `information`, of the least
  /// constrained direction.
  Eigen::Matrix<double, 6, 1> weakest_direction = Eigen::Matrix<double, 6, 1>::Zero();
  double seconds = 0.0;  ///< wall time of the call
};

/// Refines `seed_T_a_b` by ICP-EM (Eq. 7-11) between `target_a` (points in frame a, m) and
/// `source_b` (frame b). Raw scans or point maps both work: the finest level voxelises the inputs
/// and each coarser level the finest level's points. With `overlap`, only target points inside
/// the region, and source points whose current estimate puts them inside it, are associated.
/// Deterministic: the same inputs give the same result whatever the thread count. Cost per E/M
/// iteration: one nearest-neighbour query per source point of the level plus one pass over the
/// pairs (the M-step itself works on a fixed-size compression of them); uses all cores. When a
/// level associates fewer than 10 pairs it stops with `converged` false and T_a_b the estimate so
/// far (the seed when the first level fails). Throws std::invalid_argument for an invalid config
/// or a non-finite seed.
IcpEmResult refineIcpEm(const PointCloud& target_a, const PointCloud& source_b,
                        const Eigen::Isometry3d& seed_T_a_b, const IcpEmConfig& config,
                        const PlanarRegion* overlap = nullptr);

/// The clouds refineIcpEm registers when given `overlap`: the target points inside it, and the
/// source points that the seed puts within `config.source_crop_margin_m` of it (all of them when
/// that margin is infinite). Public so that another method can be run on the same input.
struct OverlapInputs {
  PointCloud target_a;
  PointCloud source_b;
};
OverlapInputs overlapInputs(const PointCloud& target_a, const PointCloud& source_b,
                            const Eigen::Isometry3d& seed_T_a_b, const PlanarRegion& overlap,
                            const IcpEmConfig& config);

}  // namespace mm4mm
