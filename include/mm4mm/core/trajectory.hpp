#pragma once
// Reading a time-ordered pose stream (keyframes, or the odometry's full stream) between its poses.

#include <Eigen/Geometry>
#include <optional>
#include <vector>

namespace mm4mm {

/// A pose of a body in some frame at a time (s): a keyframe, or one pose of an odometry stream.
struct StampedPose {
  double time_s = 0.0;
  Eigen::Isometry3d T_frame_body = Eigen::Isometry3d::Identity();
};

/// The pose at `time_s`: linear in translation, slerp in rotation between the bracketing poses;
/// the first or last pose outside the stream's span. `poses` must be sorted by time, not empty.
Eigen::Isometry3d poseAt(const std::vector<StampedPose>& poses, double time_s);

/// The pose at `time_s` where it lies within the stream's span, none outside it (where `poseAt`
/// would hold the end pose, an extrapolation).
std::optional<Eigen::Isometry3d> poseWithin(const std::vector<StampedPose>& poses, double time_s);

/// Speed along the body's x axis at `time_s` (m/s, negative when reversing): the displacement
/// over ±`half_window_s`, clipped to the stream's span, projected on the heading at `time_s`.
double forwardSpeedAt(const std::vector<StampedPose>& poses, double time_s,
                      double half_window_s = 0.25);

}  // namespace mm4mm
