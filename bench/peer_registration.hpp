#pragma once
// The registration pipelines a user would reach for instead of mm4mm, on PCL's implementations
// with settings tuned for building-scale point maps (voxels of 0.25 m, rooms of tens of metres).
// PCL stays inside peer_registration.cpp: its headers take about 20 s per translation unit.

#include <Eigen/Geometry>
#include <map>
#include <string>
#include <vector>

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

/// A cloud peer run from several starts, judged as mm4mm judges its modes (issue 31 slice 6): the
/// best-fitting converged answer, and how well the best answer *distinct* from it fits. Two
/// distinct answers that fit alike mean the clouds cannot say which is right (look-alike aisles).
struct MultiStartResult {
  PeerResult best;              ///< highest fitness among converged answers (else the first)
  double second_fitness = 0.0;  ///< best fitness of a converged answer distinct from `best`
  int starts = 0, converged = 0;
  /// second_fitness over the best's: 1 when the two fit alike, 0 when nothing else converged.
  double secondRatio() const { return best.fitness > 0.0 ? second_fitness / best.fitness : 0.0; }
};

/// Two answers are distinct when they put the source's centroid more than kDistinctM apart or
/// differ by more than kDistinctDeg in rotation: the tolerance within which a pair counts as
/// aligned (docs/design.md metric 1), so two answers both aligned are never called distinct.
constexpr double kDistinctM = 0.5;
constexpr double kDistinctDeg = 2.0;

/// Measures every answer's fit (measureFit) and keeps the best and the best distinct one.
MultiStartResult bestOfStarts(const PointCloud& target, const PointCloud& source,
                              std::vector<PeerResult> answers);

/// Initial guesses for a method that needs one, as a user without a guess would try them: the
/// identity, then the source's centroid put on the target's at `yaws` headings evenly spaced about
/// the vertical (session frames are levelled, so roll and pitch agree already).
std::vector<Eigen::Isometry3d> guessStarts(const PointCloud& target, const PointCloud& source,
                                           int yaws);

/// A refusal rule of mm4mm's kind for a multi-start peer: it claims an overlap when its best
/// answer converged, fits at least `min_fitness`, and no distinct answer fits within
/// `max_second_ratio` of it. Chosen per method on tuning seeds (scripts/choose_peer_rules.py
/// --multi-start); the default claims whatever converged.
struct AmbiguityRule {
  double min_fitness = 0.0;
  double max_second_ratio = 1.0;
  bool claims(const MultiStartResult& r) const {
    return r.best.converged && r.best.fitness >= min_fitness && r.secondRatio() <= max_second_ratio;
  }
};

/// The ambiguity rules (CSV: method,min_fitness,max_second_ratio[,...]); empty for an empty path.
std::map<std::string, AmbiguityRule> readAmbiguityRules(const std::string& path);

/// The claim rules of the cloud methods (CSV: method,min_fitness,max_inlier_rmse_m[,...]) as
/// scripts/choose_peer_rules.py writes them; empty for an empty path. A method not listed claims
/// whatever converged.
std::map<std::string, ClaimRule> readClaimRules(const std::string& path);

}  // namespace mm4mm::peers
