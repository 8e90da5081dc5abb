#include "mm4mm/core/pose.hpp"

#include <cmath>

namespace mm4mm {

double yawOf(const Eigen::Matrix3d& R_world_body) {
  // With R = Rz(yaw) Ry(pitch) Rx(roll), the first column is the body x axis in the world.
  return std::atan2(R_world_body(1, 0), R_world_body(0, 0));
}

Eigen::Matrix3d tiltOf(const Eigen::Matrix3d& R_world_body) {
  return rotationZ(-yawOf(R_world_body)) * R_world_body;
}

Eigen::Matrix3d rotationZ(double yaw) {
  return Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

Eigen::Isometry3d poseFromRpy(const Eigen::Vector3d& translation, double roll, double pitch,
                              double yaw) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  T.translation() = translation;
  return T;
}

Eigen::Isometry3d planarPose(double x, double y, double yaw, double z) {
  return poseFromRpy(Eigen::Vector3d(x, y, z), 0.0, 0.0, yaw);
}

Eigen::Isometry3d interpolatePose(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b,
                                  double alpha) {
  const Eigen::Quaterniond qa(a.linear());
  const Eigen::Quaterniond qb(b.linear());
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = qa.slerp(alpha, qb).normalized().toRotationMatrix();
  T.translation() = (1.0 - alpha) * a.translation() + alpha * b.translation();
  return T;
}

double rotationAngle(const Eigen::Matrix3d& R) { return Eigen::AngleAxisd(R).angle(); }

double wrapAngle(double angle) {
  angle = std::remainder(angle, 2.0 * M_PI);
  return angle <= -M_PI ? angle + 2.0 * M_PI : angle;
}

}  // namespace mm4mm
