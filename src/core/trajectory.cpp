#include "mm4mm/core/trajectory.hpp"

#include <algorithm>
#include <iterator>

#include "mm4mm/core/pose.hpp"

namespace mm4mm {

Eigen::Isometry3d poseAt(const std::vector<StampedPose>& poses, double time_s) {
  const auto after = std::upper_bound(poses.begin(), poses.end(), time_s,
                                      [](double t, const StampedPose& p) { return t < p.time_s; });
  if (after == poses.begin()) return poses.front().T_frame_body;
  if (after == poses.end()) return poses.back().T_frame_body;
  const StampedPose& a = *std::prev(after);
  const StampedPose& b = *after;
  return interpolatePose(a.T_frame_body, b.T_frame_body,
                         (time_s - a.time_s) / (b.time_s - a.time_s));
}

std::optional<Eigen::Isometry3d> poseWithin(const std::vector<StampedPose>& poses, double time_s) {
  if (poses.empty() || time_s < poses.front().time_s || time_s > poses.back().time_s)
    return std::nullopt;
  return poseAt(poses, time_s);
}

double forwardSpeedAt(const std::vector<StampedPose>& poses, double time_s, double half_window_s) {
  const double t0 = std::max(poses.front().time_s, time_s - half_window_s);
  const double t1 = std::min(poses.back().time_s, time_s + half_window_s);
  if (!(t1 > t0)) return 0.0;
  const Eigen::Vector3d displacement =
      poseAt(poses, t1).translation() - poseAt(poses, t0).translation();
  const Eigen::Vector3d heading = poseAt(poses, time_s).linear().col(0);
  return displacement.dot(heading) / (t1 - t0);
}

}  // namespace mm4mm
