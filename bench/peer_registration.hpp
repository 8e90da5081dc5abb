#pragma once
// The registration pipelines a user would reach for instead of mm4mm, on PCL's implementations
// with settings tuned for building-scale point maps (voxels of 0.25 m, rooms of tens of metres).
// PCL stays inside peer_registration.cpp: its headers take about 20 s per translation unit.

#include <Eigen/Geometry>
#include <map>
#include <string>

#include "mm4mm/session/session.hpp"

namespace mm4mm::peers {

/// Correspondence distance of the fit measures below: Open3D's ICP distance in
/// scripts/open3d_peer.py, two voxels of the 0.25 m point maps.
constexpr double kFitDistanceM = 0.5;

struct PeerResult {
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
  bool converged = false;  ///< the method's own flag (PCL's hasConverged())
  /// Open3D's fitness: the share of source points with a target point within kFitDistanceM once
  /// aligned; and its inlier_rmse, their RMS distance (m). Measured by measureFit for every
  /// method alike, so one rule can judge them all.
  double fitness = 0.0;
  double inlier_rmse_m = 0.0;
};

/// Fills `result`'s fitness and inlier RMSE at its transform: PCL's CorrespondenceEstimation
/// (nearest target point of each source point) kept within kFitDistanceM.
void measureFit(const PointCloud& target, const PointCloud& source, PeerResult* result);

/// When a peer claims an overlap: its own convergence flag, and a fit no worse than the
/// thresholds (chosen per method on tuning seeds by scripts/choose_peer_rules.py). The default
/// claims whatever converged.
struct ClaimRule {
  double min_fitness = 0.0;
  double max_inlier_rmse_m = 1e9;
  bool claims(const PeerResult& r) const {
    return r.converged && r.fitness >= min_fitness && r.inlier_rmse_m <= max_inlier_rmse_m;
  }
};

/// PCL's Generalized-ICP from `guess`: 2 m correspondences, 100 iterations.
PeerResult registerGicp(const PointCloud& target, const PointCloud& source,
                        const Eigen::Isometry3d& guess);

/// PCL's Normal Distributions Transform from `guess`: 2 m cells, 0.5 m steps, 35 iterations.
PeerResult registerNdt(const PointCloud& target, const PointCloud& source,
                       const Eigen::Isometry3d& guess);

/// The usual global pipeline without an initial guess: both clouds thinned to 1 m voxels, FPFH
/// features (normals over 2 m, features over 5 m), PCL's SAC-IA (Rusu et al. 2009; 3 samples at
/// least 2 m apart, 1000 iterations, `seed` drives its sampling through std::rand), then GICP on
/// the full clouds from its answer.
PeerResult registerFpfhSacIaGicp(const PointCloud& target, const PointCloud& source, unsigned seed);

/// Open3D's global pipeline (scripts/open3d_peer.py: FPFH on 1 m voxels, RANSAC, point-to-plane
/// ICP) in a child process of Debian's python3; `child_peak_mb` is raised to the child's peak
/// RSS. Throws std::runtime_error when the child fails.
Eigen::Isometry3d registerOpen3d(const PointCloud& target, const PointCloud& source, unsigned seed,
                                 double* child_peak_mb);

/// The claim rules of the cloud methods (CSV: method,min_fitness,max_inlier_rmse_m[,...]) as
/// scripts/choose_peer_rules.py writes them; empty for an empty path. A method not listed claims
/// whatever converged.
std::map<std::string, ClaimRule> readClaimRules(const std::string& path);

}  // namespace mm4mm::peers
