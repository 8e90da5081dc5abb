#include "mm4mm/geometry/icp_em.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>

#include "icp_em_costs.hpp"
#include "kd_tree.hpp"
#include "mm4mm/core/pose.hpp"
#include "mm4mm/geometry/point_map.hpp"

namespace mm4mm {
namespace {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

constexpr double kDeg = M_PI / 180.0;
// Fewer associated pairs than this and a level cannot fix six degrees of freedom.
constexpr std::size_t kMinPairs = 10;

// ---------------------------------------------------------------------------------------------
// E-step (Eq. 10).

// One level of the pyramid: both clouds voxelised with GICP covariances, and a kd-tree over the
// target points.
struct Level {
  double voxel_m = 0.0;
  PointMap target;
  PointMap source;
  std::unique_ptr<KdTree3f> tree;  // over target.points
};

// Associated pairs of one E-step (the weights ω of Eq. 10 are inside the whitenings).
struct Association {
  std::vector<icp_em::Correspondence> pairs;
  std::size_t considered = 0;  // source points inside the region
  std::size_t inliers = 0;     // pairs within one association sigma
};

PointMap voxelised(const PointCloud& cloud, double voxel_m, const IcpEmConfig& config) {
  PointMapConfig map_config;
  map_config.voxel_size_m = voxel_m;
  map_config.covariance_neighbours = config.covariance_neighbours;
  map_config.covariance_epsilon = config.covariance_epsilon;
  return buildPointMapFromCloud(cloud, map_config);
}

std::unique_ptr<Level> buildLevel(PointMap target, PointMap source, double voxel_m) {
  auto level = std::make_unique<Level>();
  level->voxel_m = voxel_m;
  level->target = std::move(target);
  level->source = std::move(source);
  level->tree = std::make_unique<KdTree3f>(level->target.points);
  return level;
}

// Associates every source point with its nearest target point under T_a_b (Eq. 10) and weighs
// the pair by ω = exp(-d²/2), d its Mahalanobis distance under the E-step's Gaussian. With the
// pair's GICP covariance C = C_a + R C_b Rᵀ (dimensionless, eigenvalues about 2ε across two
// coplanar patches and 2 along them), that Gaussian is Σ_E = σ_E² / (2ε) · C: standard deviation
// σ_E = association_sigma_voxels voxels across the surface.
//
// The M-step metric of Eq. 11 is Σ_g⁻¹ = ε / σ_n² · (C⁻¹ - I/2). C⁻¹ alone is GICP's; its
// eigenvalues are at least 1/2 (each covariance's are at most 1), and the floor of 1/2 is what
// it puts along directions both surfaces leave free: no measurement (on a featureless wall every
// shift fits equally well), but a spring towards wherever the voxel grids happen to line up.
// Without the floor, a direction the geometry does not fix is left to the prior, as Eq. 7 asks;
// across two coplanar patches the metric is 1 / (2σ_n²), i.e. σ_n of noise per point.
Association associate(const Level& level, const Eigen::Isometry3d& T_a_b, const IcpEmConfig& config,
                      const PlanarRegion* overlap) {
  const std::size_t n = level.source.size();
  const Eigen::Matrix3d R = T_a_b.rotation();
  const double gate2 = std::pow(config.max_correspondence_voxels * level.voxel_m, 2);
  const double sigma_e = config.association_sigma_voxels * level.voxel_m;
  const double eps = config.covariance_epsilon;
  const double weight_scale = 2.0 * eps / (sigma_e * sigma_e);  // C⁻¹ → Σ_E⁻¹
  const double metric_scale = std::sqrt(eps) / config.surface_sigma_m;
  const double inlier_weight = std::exp(-0.5);

  struct Slot {
    bool considered = false;
    bool paired = false;
    icp_em::Correspondence pair;
    double weight = 0.0;
  };
  std::vector<Slot> slots(n);
  if (level.tree->size() > 0) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 512), [&](const auto& range) {
      for (std::size_t i = range.begin(); i != range.end(); ++i) {
        Slot& slot = slots[i];
        const Eigen::Vector3d b = level.source.points[i].cast<double>();
        const Eigen::Vector3d p = T_a_b * b;
        if (overlap != nullptr && !overlap->contains(p.head<2>())) continue;
        slot.considered = true;
        std::size_t j = 0;
        float distance2 = 0.0f;
        if (level.tree->nearest(p.cast<float>(), 1, &j, &distance2) != 1) continue;
        if (distance2 > gate2) continue;
        const Eigen::Vector3d a = level.target.points[j].cast<double>();
        const Eigen::Matrix3d C = level.target.covariances[j].cast<double>() +
                                  R * level.source.covariances[i].cast<double>() * R.transpose();
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen;  // C = U diag(λ) Uᵀ
        eigen.computeDirect(C);
        const Eigen::Vector3d r_eigen = eigen.eigenvectors().transpose() * (a - p);
        slot.weight = std::exp(-0.5 * weight_scale *
                               r_eigen.cwiseAbs2().cwiseQuotient(eigen.eigenvalues()).sum());
        // Whitening W = diag(√(1/λ - 1/2)) Uᵀ, so that WᵀW = C⁻¹ - I/2.
        const Eigen::Vector3d root =
            (eigen.eigenvalues().cwiseInverse().array() - 0.5).max(0.0).sqrt().matrix();
        slot.pair.a = a;
        slot.pair.b = b;
        slot.pair.whitening = std::sqrt(slot.weight) * metric_scale * root.asDiagonal() *
                              eigen.eigenvectors().transpose();
        slot.paired = true;
      }
    });
  }
  Association association;
  const auto paired =
      std::count_if(slots.begin(), slots.end(), [](const Slot& s) { return s.paired; });
  association.pairs.reserve(paired);
  for (const Slot& slot : slots) {  // in source order: deterministic whatever the threads did
    association.considered += slot.considered;
    if (!slot.paired) continue;
    association.pairs.push_back(slot.pair);
    association.inliers += slot.weight >= inlier_weight;
  }
  return association;
}

// ---------------------------------------------------------------------------------------------
// M-step (Eq. 11 with the prior of Eq. 7).

Vector6d priorSqrtInformation(const IcpEmConfig& config) {
  // An infinite sigma gives 0: no pull along that axis.
  const auto inverse = [](double sigma) { return std::isinf(sigma) ? 0.0 : 1.0 / sigma; };
  Vector6d s;
  s << inverse(config.prior_sigma_horizontal_m), inverse(config.prior_sigma_horizontal_m),
      inverse(config.prior_sigma_vertical_m), inverse(config.prior_sigma_tilt_deg * kDeg),
      inverse(config.prior_sigma_tilt_deg * kDeg), inverse(config.prior_sigma_yaw_deg * kDeg);
  return s;
}

// Levenberg-Marquardt over the frozen pairs from the current estimate, on SE(3) as a unit
// quaternion (ceres::EigenQuaternionManifold) and a translation. The pairs enter through their
// exact twelve-residual compression, so an iteration costs microseconds and the M-step can run
// to convergence.
Eigen::Isometry3d maximise(const std::vector<icp_em::Correspondence>& pairs,
                           const Eigen::Isometry3d& T_a_b, const Eigen::Isometry3d& seed_T_a_b,
                           const Vector6d& prior_sqrt_information, const IcpEmConfig& config) {
  const Eigen::Quaterniond q_start = Eigen::Quaterniond(T_a_b.rotation()).normalized();
  double q[4] = {q_start.x(), q_start.y(), q_start.z(), q_start.w()};
  double t[3] = {T_a_b.translation().x(), T_a_b.translation().y(), T_a_b.translation().z()};
  ceres::Problem problem;
  problem.AddResidualBlock(new icp_em::CompressedCorrespondencesCost(pairs), nullptr, q, t);
  if (!prior_sqrt_information.isZero())
    problem.AddResidualBlock(icp_em::SeedPriorCost::Create(seed_T_a_b, prior_sqrt_information),
                             nullptr, q, t);
  problem.SetManifold(q, new ceres::EigenQuaternionManifold);

  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  options.max_num_iterations = config.m_step_iterations;
  options.num_threads = 1;  // one residual block: nothing for Ceres to split
  options.logging_type = ceres::SILENT;
  options.function_tolerance = 1e-10;
  options.parameter_tolerance = 1e-10;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);

  Eigen::Isometry3d result = Eigen::Isometry3d::Identity();
  result.linear() = Eigen::Quaterniond(q[3], q[0], q[1], q[2]).normalized().toRotationMatrix();
  result.translation() = Eigen::Vector3d(t[0], t[1], t[2]);
  return result;
}

// ---------------------------------------------------------------------------------------------
// Information and degeneracy.

// Gauss-Newton Hessian of the M-step's geometric term, Σ Jᵢᵀ Wᵢᵀ Wᵢ Jᵢ, for the error [δt; δθ]
// with T = (t + δt, R Exp(δθ)):  ∂(a - T b)/∂δt = -I,  ∂(a - T b)/∂δθ = R [b]×.
Matrix6d geometricInformation(const Association& association, const Eigen::Isometry3d& T_a_b) {
  const Eigen::Matrix3d R = T_a_b.rotation();
  Matrix6d H = Matrix6d::Zero();
  for (const icp_em::Correspondence& c : association.pairs) {
    Eigen::Matrix<double, 3, 6> J;
    J.leftCols<3>() = -c.whitening;
    J.rightCols<3>() = c.whitening * R * icp_em::skew(c.b);
    H.noalias() += J.transpose() * J;
  }
  return H;
}

// Eigen-analysis of the information in a parametrisation where translation and rotation compare:
// a translation δt' and rotations φ_k / L_k about axes through the centroid c of the matched
// points, L_k the RMS distance of the points from axis k (so that φ_k is the arc, in metres,
// that a typical point moves). With w = L⁻¹ φ, a point p moves by δt' + w × (p - c), and in the
// [δt; δθ] parametrisation by δt + (R δθ) × (p - t); equal for δθ = Rᵀ w and
// δt = δt' - [t - c]× w, i.e. [δt; δθ] = A [δt'; φ] and the information there is Aᵀ H A.
struct Degeneracy {
  Matrix6d A = Matrix6d::Identity();
  Eigen::SelfAdjointEigenSolver<Matrix6d> eigen;  // of Aᵀ H A, eigenvalues ascending
  int weak_directions = 0;  // eigenvalues below the threshold's fraction of the largest
};

Degeneracy analyseDegeneracy(const Association& association, const Matrix6d& information,
                             const Eigen::Isometry3d& T_a_b, double ratio_threshold) {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const icp_em::Correspondence& c : association.pairs) centroid += T_a_b * c.b;
  centroid /= static_cast<double>(association.pairs.size());
  Eigen::Vector3d mean_square = Eigen::Vector3d::Zero();  // per axis, of the distance from it
  for (const icp_em::Correspondence& c : association.pairs) {
    const Eigen::Vector3d d = T_a_b * c.b - centroid;
    mean_square += Eigen::Vector3d::Constant(d.squaredNorm()) - d.cwiseAbs2();
  }
  const Eigen::Vector3d inverse_radius =
      (mean_square / static_cast<double>(association.pairs.size()))
          .cwiseSqrt()
          .cwiseMax(1e-3)
          .cwiseInverse();

  Degeneracy degeneracy;
  degeneracy.A.topRightCorner<3, 3>() =
      -icp_em::skew(T_a_b.translation() - centroid) * inverse_radius.asDiagonal();
  degeneracy.A.bottomRightCorner<3, 3>() =
      T_a_b.rotation().transpose() * inverse_radius.asDiagonal();
  degeneracy.eigen.compute(degeneracy.A.transpose() * information * degeneracy.A);
  const Vector6d& eigenvalues = degeneracy.eigen.eigenvalues();
  while (degeneracy.weak_directions < 6 &&
         !(eigenvalues[degeneracy.weak_directions] >= ratio_threshold * eigenvalues[5]))
    ++degeneracy.weak_directions;
  return degeneracy;
}

// Solution remapping (Zhang, Kaess & Singh, ICRA 2016): along directions the geometry barely
// constrains, the estimate goes back to the seed. There the geometric term's pull is not
// information but the noise of surface normals and of where the voxel grids line up, yet it
// outweighs any sensible prior because it sums over thousands of points; Eq. 7's answer along
// such a direction is the prior's mean. The deviation e = T ⊖ seed = [t - t_s; Log(R_sᵀ R)] is
// taken to the normalised coordinates (A⁻¹ e), its weak components are removed, and the rest
// is applied to the seed.
Eigen::Isometry3d holdSeedAlongWeakDirections(const Eigen::Isometry3d& T_a_b,
                                              const Eigen::Isometry3d& seed_T_a_b,
                                              const Degeneracy& degeneracy) {
  if (degeneracy.weak_directions == 0) return T_a_b;
  const Eigen::AngleAxisd rotation(seed_T_a_b.rotation().transpose() * T_a_b.rotation());
  Vector6d e;
  e << T_a_b.translation() - seed_T_a_b.translation(), rotation.angle() * rotation.axis();
  Vector6d e_normalised = degeneracy.A.inverse() * e;
  for (int k = 0; k < degeneracy.weak_directions; ++k) {
    const Vector6d v = degeneracy.eigen.eigenvectors().col(k);
    e_normalised -= v * v.dot(e_normalised);
  }
  e = degeneracy.A * e_normalised;
  Eigen::Isometry3d held = seed_T_a_b;
  held.translation() += e.head<3>();
  const double angle = e.tail<3>().norm();
  if (angle > 0.0)
    held.linear() = seed_T_a_b.rotation() * Eigen::AngleAxisd(angle, e.tail<3>() / angle).matrix();
  return held;
}

// ---------------------------------------------------------------------------------------------
// Inputs.

PointCloud pointsInside(const PointCloud& cloud, const Eigen::Isometry3d& T_a_cloud,
                        const PlanarRegion& region) {
  PointCloud kept;
  for (const Eigen::Vector3f& p : cloud) {
    if (!p.allFinite()) continue;
    if (region.contains((T_a_cloud * p.cast<double>()).head<2>())) kept.push_back(p);
  }
  return kept;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Public API.

bool IcpEmConfig::IsValid(std::string* error) const {
  const auto fail = [error](const char* message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (voxel_sizes_m.empty()) return fail("voxel_sizes_m must hold at least one level");
  for (std::size_t i = 0; i < voxel_sizes_m.size(); ++i) {
    if (!std::isfinite(voxel_sizes_m[i]) || voxel_sizes_m[i] < 1e-3)
      return fail("voxel_sizes_m must be at least 0.001 (m) and finite");
    if (i > 0 && !(voxel_sizes_m[i] < voxel_sizes_m[i - 1]))
      return fail("voxel_sizes_m must be strictly decreasing (coarse to fine)");
  }
  if (max_iterations_per_level < 1) return fail("max_iterations_per_level must be >= 1");
  if (m_step_iterations < 1) return fail("m_step_iterations must be >= 1");
  if (!std::isfinite(max_correspondence_voxels) || max_correspondence_voxels <= 0.0)
    return fail("max_correspondence_voxels must be > 0 and finite");
  if (!std::isfinite(association_sigma_voxels) || association_sigma_voxels <= 0.0)
    return fail("association_sigma_voxels must be > 0 and finite");
  if (!std::isfinite(surface_sigma_m) || surface_sigma_m <= 0.0)
    return fail("surface_sigma_m must be > 0 (m) and finite");
  // +infinity is allowed for the prior: no pull along that axis.
  if (!(prior_sigma_horizontal_m > 0.0))
    return fail("prior_sigma_horizontal_m must be > 0 (m; +inf: no prior)");
  if (!(prior_sigma_vertical_m > 0.0))
    return fail("prior_sigma_vertical_m must be > 0 (m; +inf: no prior)");
  if (!(prior_sigma_yaw_deg > 0.0))
    return fail("prior_sigma_yaw_deg must be > 0 (deg; +inf: no prior)");
  if (!(prior_sigma_tilt_deg > 0.0))
    return fail("prior_sigma_tilt_deg must be > 0 (deg; +inf: no prior)");
  if (!std::isfinite(translation_tolerance_m) || translation_tolerance_m <= 0.0)
    return fail("translation_tolerance_m must be > 0 (m) and finite");
  if (!std::isfinite(rotation_tolerance_deg) || rotation_tolerance_deg <= 0.0)
    return fail("rotation_tolerance_deg must be > 0 (deg) and finite");
  if (covariance_neighbours < 3) return fail("covariance_neighbours must be >= 3");
  if (!std::isfinite(covariance_epsilon) || covariance_epsilon <= 0.0 || covariance_epsilon > 1.0)
    return fail("covariance_epsilon must be in (0, 1]");
  if (!std::isfinite(degeneracy_eigenvalue_ratio) || degeneracy_eigenvalue_ratio < 0.0 ||
      degeneracy_eigenvalue_ratio >= 1.0)
    return fail("degeneracy_eigenvalue_ratio must be in [0, 1)");
  if (!(source_crop_margin_m >= 0.0))
    return fail("source_crop_margin_m must be >= 0 (m; +inf: no crop)");
  return true;
}

OverlapInputs overlapInputs(const PointCloud& target_a, const PointCloud& source_b,
                            const Eigen::Isometry3d& seed_T_a_b, const PlanarRegion& overlap,
                            const IcpEmConfig& config) {
  OverlapInputs inputs;
  inputs.target_a = pointsInside(target_a, Eigen::Isometry3d::Identity(), overlap);
  inputs.source_b =
      std::isfinite(config.source_crop_margin_m)
          ? pointsInside(source_b, seed_T_a_b, dilateRegion(overlap, config.source_crop_margin_m))
          : source_b;
  return inputs;
}

IcpEmResult refineIcpEm(const PointCloud& target_a, const PointCloud& source_b,
                        const Eigen::Isometry3d& seed_T_a_b, const IcpEmConfig& config,
                        const PlanarRegion* overlap) {
  const auto start = std::chrono::steady_clock::now();
  std::string error;
  if (!config.IsValid(&error)) throw std::invalid_argument("IcpEmConfig: " + error);
  if (!seed_T_a_b.matrix().allFinite())
    throw std::invalid_argument("refineIcpEm: the seed T_a_b must be finite");

  // Only the overlap takes part: target points inside the region, source points near it at the
  // seed (the E-step then checks them at every estimate).
  std::optional<OverlapInputs> cropped;
  if (overlap != nullptr) cropped = overlapInputs(target_a, source_b, seed_T_a_b, *overlap, config);
  const PointCloud& target = cropped ? cropped->target_a : target_a;
  const PointCloud& source = cropped ? cropped->source_b : source_b;

  IcpEmResult result;
  result.T_a_b = seed_T_a_b;
  const Vector6d prior_sqrt_information = priorSqrtInformation(config);
  const double finest_m = config.voxel_sizes_m.back();
  bool all_levels_ran = true, finest_converged = false;
  // The finest level comes from the inputs; the coarser ones from its points, which are far
  // fewer than raw scans (a centroid of centroids is close enough for a coarse level).
  PointMap finest_target = voxelised(target, finest_m, config);
  PointMap finest_source = voxelised(source, finest_m, config);
  std::unique_ptr<Level> level;
  for (const double voxel_m : config.voxel_sizes_m) {
    level = voxel_m == finest_m
                ? buildLevel(std::move(finest_target), std::move(finest_source), voxel_m)
                : buildLevel(voxelised(finest_target.points, voxel_m, config),
                             voxelised(finest_source.points, voxel_m, config), voxel_m);
    const double scale = voxel_m / finest_m;
    bool converged = false, enough_pairs = true;
    for (int iteration = 0; iteration < config.max_iterations_per_level; ++iteration) {
      const Association association = associate(*level, result.T_a_b, config, overlap);  // E
      ++result.iterations;
      if (association.pairs.size() < kMinPairs) {
        enough_pairs = false;
        break;
      }
      Eigen::Isometry3d next = maximise(association.pairs, result.T_a_b, seed_T_a_b,
                                        prior_sqrt_information, config);  // M
      if (config.hold_seed_along_degenerate_directions)
        next = holdSeedAlongWeakDirections(
            next, seed_T_a_b,
            analyseDegeneracy(association, geometricInformation(association, next), next,
                              config.degeneracy_eigenvalue_ratio));
      const Eigen::Isometry3d step = result.T_a_b.inverse() * next;
      result.T_a_b = next;
      if (step.translation().norm() < config.translation_tolerance_m * scale &&
          rotationAngle(step.rotation()) < config.rotation_tolerance_deg * kDeg * scale) {
        converged = true;
        break;
      }
    }
    if (!enough_pairs) {
      all_levels_ran = false;
      break;
    }
    finest_converged = converged;
  }
  result.converged = all_levels_ran && finest_converged;

  // Quality of the solution: one more E-step there, at the finest level.
  result.degenerate = true;  // until an information matrix says otherwise
  if (all_levels_ran) {
    const Association association = associate(*level, result.T_a_b, config, overlap);
    result.correspondences = association.pairs.size();
    result.inlier_ratio = association.considered == 0
                              ? 0.0
                              : static_cast<double>(association.inliers) / association.considered;
    if (!association.pairs.empty()) {
      result.information = geometricInformation(association, result.T_a_b);
      const Degeneracy degeneracy = analyseDegeneracy(association, result.information, result.T_a_b,
                                                      config.degeneracy_eigenvalue_ratio);
      result.hessian_eigenvalues = degeneracy.eigen.eigenvalues();
      result.weakest_direction =
          (degeneracy.A * degeneracy.eigen.eigenvectors().col(0)).normalized();
      result.degenerate = degeneracy.weak_directions > 0;
    }
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace mm4mm
