#pragma once
// Small helpers over Eigen poses. Frames: z up, gravity-aligned; angles in radians.

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace mm4mm {

/// Heading of a pose: rotation about the world z axis of its body x axis (rad, in (-pi, pi]).
double yawOf(const Eigen::Matrix3d& R_world_body);

/// The roll-and-pitch part of a rotation: R = Rz(yaw) * tilt. Removes heading, keeps tilt.
Eigen::Matrix3d tiltOf(const Eigen::Matrix3d& R_world_body);

/// Rotation about z by `yaw` (rad).
Eigen::Matrix3d rotationZ(double yaw);

/// Pose from roll, pitch, yaw (rad, applied as Rz(yaw) * Ry(pitch) * Rx(roll)) and translation.
Eigen::Isometry3d poseFromRpy(const Eigen::Vector3d& translation, double roll, double pitch,
                              double yaw);

/// Planar pose (x, y in m, yaw in rad) at height z (m).
Eigen::Isometry3d planarPose(double x, double y, double yaw, double z = 0.0);

/// Interpolates between two poses: linear in translation, slerp in rotation; alpha in [0, 1].
Eigen::Isometry3d interpolatePose(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b,
                                  double alpha);

/// Angle of a rotation (rad, in [0, pi]).
double rotationAngle(const Eigen::Matrix3d& R);

/// Wraps an angle to (-pi, pi].
double wrapAngle(double angle);

}  // namespace mm4mm
