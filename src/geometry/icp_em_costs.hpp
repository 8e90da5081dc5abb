#pragma once
// Ceres costs of the ICP-EM M-step (paper Eq. 7 and 11). Internal: included by icp_em.cpp and by
// the test that checks their Jacobians with ceres::GradientChecker. Header-only, so the test
// needs Ceres but none of the library's internals.
//
// Parameters, shared by both costs: the rotation of b in a as an Eigen quaternion (memory order
// x, y, z, w; ceres::EigenQuaternionManifold keeps it unit) and the translation t of b in a (m).

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <vector>

namespace mm4mm::icp_em {

/// [b]×, the matrix of b × ·.
inline Eigen::Matrix3d skew(const Eigen::Vector3d& b) {
  Eigen::Matrix3d m;
  m << 0.0, -b.z(), b.y(), b.z(), 0.0, -b.x(), -b.y(), b.x(), 0.0;
  return m;
}

/// One association of the E-step, frozen for the M-step: target point a (frame a), source point
/// b (frame b), and the whitening W with WᵀW = ω·Ω, the E-step weight ω times the pair's metric
/// (icp_em.cpp: GICP's inverse combined covariance less its along-surface floor, R taken at the
/// E-step).
struct Correspondence {
  Eigen::Vector3d a = Eigen::Vector3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  Eigen::Matrix3d whitening = Eigen::Matrix3d::Identity();
};

/// ∂(R(q) b)/∂q, 3 x 4 in the order (x, y, z, w). For q = (v, w) of unit norm,
/// R(q) b = b + 2w (v × b) + 2 v × (v × b), so
///   ∂(Rb)/∂w = 2 (v × b),
///   ∂(Rb)/∂v = -2w [b]× + 2 (v bᵀ + (v·b) I - 2 b vᵀ).
/// Off the unit sphere this polynomial is no rotation, but the quaternion manifold's tangent
/// directions are orthogonal to q, so the radial part never reaches the solver.
inline Eigen::Matrix<double, 3, 4> rotatedPointJacobian(const Eigen::Vector4d& q,
                                                        const Eigen::Vector3d& b) {
  const Eigen::Vector3d v = q.head<3>();
  const double w = q[3];
  Eigen::Matrix<double, 3, 4> J;
  J.leftCols<3>() =
      -2.0 * w * skew(b) +
      2.0 * (v * b.transpose() + v.dot(b) * Eigen::Matrix3d::Identity() - 2.0 * b * v.transpose());
  J.col(3) = 2.0 * v.cross(b);
  return J;
}

/// Eq. 11 summed in closed form. Residual i, W_i (a_i - R b_i - t), is linear in the twelve
/// numbers x = [τ; vec(R)] once the points are centred (a' = a - ā, b' = b - b̄,
/// τ = t + R b̄ - ā): W_i (a'_i - B_i x) with B_i = [I, b'_i0 I, b'_i1 I, b'_i2 I]. So the sum of
/// squares is the quadratic form xᵀQx - 2gᵀx + c with Q = Σ B_iᵀ M_i B_i, g = Σ B_iᵀ M_i a'_i,
/// M_i = W_iᵀ W_i, and with Q = U diag(λ) Uᵀ it equals |S x - d|² + (c - |d|²) for
/// S = diag(√λ) Uᵀ and d = diag(1/√λ) Uᵀ g (rows of vanishing λ dropped). One pass over the
/// pairs builds it; the solver then iterates on twelve residuals instead of three per pair,
/// with no approximation. Centring keeps Q well conditioned far from the frames' origins.
class CompressedCorrespondencesCost final : public ceres::SizedCostFunction<12, 4, 3> {
 public:
  explicit CompressedCorrespondencesCost(const std::vector<Correspondence>& pairs) {
    for (const Correspondence& c : pairs) a_mean_ += c.a, b_mean_ += c.b;
    if (!pairs.empty()) a_mean_ /= double(pairs.size()), b_mean_ /= double(pairs.size());
    Eigen::Matrix<double, 12, 12> Q = Eigen::Matrix<double, 12, 12>::Zero();
    Eigen::Matrix<double, 12, 1> g = Eigen::Matrix<double, 12, 1>::Zero();
    double c_sum = 0.0;
    for (const Correspondence& c : pairs) {
      const Eigen::Matrix3d M = c.whitening.transpose() * c.whitening;
      const Eigen::Vector3d a = c.a - a_mean_, b = c.b - b_mean_;
      const Eigen::Vector3d Ma = M * a;
      const double B[4] = {1.0, b.x(), b.y(), b.z()};  // block weights of B_i's four columns
      for (int j = 0; j < 4; ++j) {
        g.segment<3>(3 * j) += B[j] * Ma;
        for (int k = j; k < 4; ++k) Q.block<3, 3>(3 * j, 3 * k) += (B[j] * B[k]) * M;
      }
      c_sum += a.dot(Ma);
    }
    Q.triangularView<Eigen::StrictlyLower>() = Q.transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 12, 12>> eigen(Q);
    const double largest = eigen.eigenvalues()[11];
    double d_norm2 = 0.0;
    for (int k = 0; k < 12; ++k) {
      const double lambda = eigen.eigenvalues()[k];
      if (!(lambda > 1e-12 * largest)) continue;  // leaves the row zero
      S_.row(k) = std::sqrt(lambda) * eigen.eigenvectors().col(k).transpose();
      d_[k] = eigen.eigenvectors().col(k).dot(g) / std::sqrt(lambda);
      d_norm2 += d_[k] * d_[k];
    }
    constant_ = 0.5 * (c_sum - d_norm2);
  }

  /// What ½|residual|² leaves out of ½ Σ |W_i (a_i - R b_i - t)|² (independent of the pose).
  double constant() const { return constant_; }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const Eigen::Map<const Eigen::Vector4d> q(parameters[0]);  // x, y, z, w
    const Eigen::Map<const Eigen::Vector3d> t(parameters[1]);
    // R from the same polynomial as the Jacobian (a rotation for unit q).
    Eigen::Matrix<double, 12, 1> x;
    for (int j = 0; j < 3; ++j) {
      const Eigen::Vector3d e = Eigen::Vector3d::Unit(j);
      const Eigen::Vector3d v = q.head<3>();
      x.segment<3>(3 + 3 * j) = e + 2.0 * q[3] * v.cross(e) + 2.0 * v.cross(v.cross(e));
    }
    const Eigen::Vector3d R_b_mean = x.segment<3>(3) * b_mean_.x() + x.segment<3>(6) * b_mean_.y() +
                                     x.segment<3>(9) * b_mean_.z();
    x.head<3>() = t + R_b_mean - a_mean_;
    Eigen::Map<Eigen::Matrix<double, 12, 1>> r(residuals);
    r = S_ * x - d_;
    if (jacobians == nullptr) return true;
    if (jacobians[0] != nullptr) {
      // ∂x/∂q: ∂(R b̄)/∂q for τ and ∂(R e_j)/∂q for the columns of R.
      Eigen::Matrix<double, 12, 4> dx_dq;
      const Eigen::Vector4d q_value = q;
      dx_dq.topRows<3>() = rotatedPointJacobian(q_value, b_mean_);
      for (int j = 0; j < 3; ++j)
        dx_dq.middleRows<3>(3 + 3 * j) = rotatedPointJacobian(q_value, Eigen::Vector3d::Unit(j));
      Eigen::Map<Eigen::Matrix<double, 12, 4, Eigen::RowMajor>> J_q(jacobians[0]);
      J_q = S_ * dx_dq;
    }
    if (jacobians[1] != nullptr) {
      Eigen::Map<Eigen::Matrix<double, 12, 3, Eigen::RowMajor>> J_t(jacobians[1]);
      J_t = S_.leftCols<3>();
    }
    return true;
  }

 private:
  Eigen::Vector3d a_mean_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d b_mean_ = Eigen::Vector3d::Zero();
  Eigen::Matrix<double, 12, 12> S_ = Eigen::Matrix<double, 12, 12>::Zero();
  Eigen::Matrix<double, 12, 1> d_ = Eigen::Matrix<double, 12, 1>::Zero();
  double constant_ = 0.0;
};

/// The prior of Eq. 7, p(T_M | T_B): a Gaussian on the deviation from the magnetic seed,
///   r = S [t - t_B; Log(R_Bᵀ R)],
/// translation in frame a, rotation vector in b's axes (the right-perturbation of OdometryEdge),
/// S the square root of the prior's information (diagonal: 1/σ per axis, 0 for an infinite σ).
struct SeedPriorCost {
  SeedPriorCost(const Eigen::Isometry3d& seed_T_a_b, const Eigen::Matrix<double, 6, 1>& sqrt_info)
      : q_seed(seed_T_a_b.rotation()), t_seed(seed_T_a_b.translation()), sqrt_info(sqrt_info) {}

  template <typename T>
  bool operator()(const T* q_ptr, const T* t_ptr, T* residuals) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q(q_ptr);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t(t_ptr);
    const Eigen::Quaternion<T> dq = q_seed.conjugate().cast<T>() * q;
    // ceres' angle-axis conversion takes (w, x, y, z) and is exact (and Jet-safe) near zero.
    const T dq_wxyz[4] = {dq.w(), dq.x(), dq.y(), dq.z()};
    T rotation_vector[3];
    ceres::QuaternionToAngleAxis(dq_wxyz, rotation_vector);
    for (int k = 0; k < 3; ++k) {
      residuals[k] = T(sqrt_info[k]) * (t[k] - T(t_seed[k]));
      residuals[3 + k] = T(sqrt_info[3 + k]) * rotation_vector[k];
    }
    return true;
  }

  static ceres::CostFunction* Create(const Eigen::Isometry3d& seed_T_a_b,
                                     const Eigen::Matrix<double, 6, 1>& sqrt_info) {
    return new ceres::AutoDiffCostFunction<SeedPriorCost, 6, 4, 3>(
        new SeedPriorCost(seed_T_a_b, sqrt_info));
  }

  Eigen::Quaterniond q_seed;
  Eigen::Vector3d t_seed;
  Eigen::Matrix<double, 6, 1> sqrt_info;
};

}  // namespace mm4mm::icp_em
