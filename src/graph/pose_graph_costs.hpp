#pragma once
// Ceres cost functors of the multi-session graph. Internal: the tests run them through
// ceres::GradientChecker. Poses are (position, Eigen quaternion) parameter blocks, the quaternion
// stored x, y, z, w as Eigen does (ceres::EigenQuaternionManifold).

#include <ceres/autodiff_cost_function.h>
#include <ceres/cubic_interpolation.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <memory>
#include <vector>

#include "mm4mm/magnetic/magnetic_map.hpp"

namespace mm4mm::internal {

/// Error of a relative-pose measurement T_a_b between poses a and b: [δp; δθ] with
/// δp = R_a^T (p_b − p_a) − p_m and δθ = 2·vec(q_m^-1 · q_a^-1 · q_b) (the rotation vector for
/// small errors), whitened by the square root of the information matrix.
class RelativePoseCost {
 public:
  RelativePoseCost(const Eigen::Isometry3d& T_a_b, const Eigen::Matrix<double, 6, 6>& information)
      : measured_position_(T_a_b.translation()),
        measured_rotation_(Eigen::Quaterniond(T_a_b.linear()).normalized()),
        sqrt_information_(information.llt().matrixL().transpose()) {}

  template <typename T>
  bool operator()(const T* p_a_ptr, const T* q_a_ptr, const T* p_b_ptr, const T* q_b_ptr,
                  T* residual_ptr) const {
    Eigen::Map<const Eigen::Matrix<T, 3, 1>> p_a(p_a_ptr), p_b(p_b_ptr);
    Eigen::Map<const Eigen::Quaternion<T>> q_a(q_a_ptr), q_b(q_b_ptr);
    const Eigen::Quaternion<T> q_a_inverse = q_a.conjugate();
    const Eigen::Matrix<T, 3, 1> p_ab = q_a_inverse * (p_b - p_a);
    const Eigen::Quaternion<T> q_ab = q_a_inverse * q_b;
    const Eigen::Quaternion<T> delta = measured_rotation_.template cast<T>().conjugate() * q_ab;
    Eigen::Matrix<T, 6, 1> error;
    error.template head<3>() = p_ab - measured_position_.template cast<T>();
    error.template tail<3>() = T(2.0) * delta.vec();
    Eigen::Map<Eigen::Matrix<T, 6, 1>> residual(residual_ptr);
    residual = sqrt_information_.template cast<T>() * error;
    return true;
  }

  static ceres::CostFunction* Create(const Eigen::Isometry3d& T_a_b,
                                     const Eigen::Matrix<double, 6, 6>& information) {
    return new ceres::AutoDiffCostFunction<RelativePoseCost, 6, 3, 4, 3, 4>(
        new RelativePoseCost(T_a_b, information));
  }

 private:
  Eigen::Vector3d measured_position_;
  Eigen::Quaterniond measured_rotation_;
  Eigen::Matrix<double, 6, 6> sqrt_information_;
};

/// A magnetic map of one session prepared for the solve: (B_h, B_v) on a grid in that session's
/// odometry frame, uncovered cells filled from their covered neighbours so the bicubic
/// interpolation stays smooth at the swath's edge. Value (ix, iy) sits at the cell centre.
struct InterpolableMagneticMap {
  Eigen::Vector2d origin_m = Eigen::Vector2d::Zero();
  double cell_size_m = 0.25;
  int width = 0;
  int height = 0;
  std::vector<double> values;  ///< interleaved (B_h, B_v), row-major
  std::vector<bool> covered;   ///< the original coverage
  std::unique_ptr<ceres::Grid2D<double, 2>> grid;
  std::unique_ptr<ceres::BiCubicInterpolator<ceres::Grid2D<double, 2>>> interpolator;
};

/// Residual of one magnetic reading of session s against session t's map: the sensor sits at
/// `sensor_in_keyframe` in the body frame of s's keyframe (p_s, q_s); it is carried into t's
/// odometry frame through t's keyframe (p_t, q_t), whose odometry pose is `T_odometry_t`, and
/// the map's (B_h, B_v) there is compared with the reading:
///   ((measured + o_s) − (map + o_t)) / σ
/// with o_s, o_t each session's field offset (B_h, B_v, µT). Self-calibration cannot fix a level
/// body's vertical hard iron, so sessions disagree on B_v by a constant of up to tens of µT
/// (and on B_h by what is left of theirs); the correlation matcher never sees a constant, and
/// the solve must not either: left out, the offset drags the poses towards wherever the other
/// map happens to read the same absolute value.
class MagneticMapCost {
 public:
  MagneticMapCost(const InterpolableMagneticMap& map, const Eigen::Vector3d& sensor_in_keyframe,
                  const Eigen::Isometry3d& T_odometry_t, const Eigen::Vector2d& measured_uT,
                  double sigma_uT)
      : map_(map),
        sensor_in_keyframe_(sensor_in_keyframe),
        T_odometry_t_(T_odometry_t),
        measured_uT_(measured_uT),
        inverse_sigma_(1.0 / sigma_uT) {}

  template <typename T>
  bool operator()(const T* p_s_ptr, const T* q_s_ptr, const T* p_t_ptr, const T* q_t_ptr,
                  const T* o_s, const T* o_t, T* residual) const {
    Eigen::Map<const Eigen::Matrix<T, 3, 1>> p_s(p_s_ptr), p_t(p_t_ptr);
    Eigen::Map<const Eigen::Quaternion<T>> q_s(q_s_ptr), q_t(q_t_ptr);
    const Eigen::Matrix<T, 3, 1> in_atlas = q_s * sensor_in_keyframe_.template cast<T>() + p_s;
    const Eigen::Matrix<T, 3, 1> in_keyframe_t = q_t.conjugate() * (in_atlas - p_t);
    const Eigen::Matrix<T, 3, 1> in_odometry_t =
        T_odometry_t_.linear().template cast<T>() * in_keyframe_t +
        T_odometry_t_.translation().template cast<T>();
    const T column = (in_odometry_t.x() - T(map_.origin_m.x())) / T(map_.cell_size_m) - T(0.5);
    const T row = (in_odometry_t.y() - T(map_.origin_m.y())) / T(map_.cell_size_m) - T(0.5);
    T map_value[2];
    map_.interpolator->Evaluate(row, column, map_value);
    residual[0] = (T(measured_uT_.x()) + o_s[0] - map_value[0] - o_t[0]) * T(inverse_sigma_);
    residual[1] = (T(measured_uT_.y()) + o_s[1] - map_value[1] - o_t[1]) * T(inverse_sigma_);
    return true;
  }

  static ceres::CostFunction* Create(const InterpolableMagneticMap& map,
                                     const Eigen::Vector3d& sensor_in_keyframe,
                                     const Eigen::Isometry3d& T_odometry_t,
                                     const Eigen::Vector2d& measured_uT, double sigma_uT) {
    return new ceres::AutoDiffCostFunction<MagneticMapCost, 2, 3, 4, 3, 4, 2, 2>(
        new MagneticMapCost(map, sensor_in_keyframe, T_odometry_t, measured_uT, sigma_uT));
  }

 private:
  const InterpolableMagneticMap& map_;
  Eigen::Vector3d sensor_in_keyframe_;
  Eigen::Isometry3d T_odometry_t_;
  Eigen::Vector2d measured_uT_;
  double inverse_sigma_;
};

/// A weak prior pulling a session's field offset towards zero: (o / σ).
struct OffsetPriorCost {
  explicit OffsetPriorCost(double sigma_uT) : inverse_sigma(1.0 / sigma_uT) {}
  template <typename T>
  bool operator()(const T* o, T* residual) const {
    residual[0] = o[0] * T(inverse_sigma);
    residual[1] = o[1] * T(inverse_sigma);
    return true;
  }
  double inverse_sigma;
};

/// Prepares a session's magnetic map for the solve (see InterpolableMagneticMap), at the map's
/// own resolution.
std::unique_ptr<InterpolableMagneticMap> makeInterpolable(const MagneticMap& map);

}  // namespace mm4mm::internal
