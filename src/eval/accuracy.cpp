#include "mm4mm/eval/accuracy.hpp"

#include <algorithm>
#include <stdexcept>

#include "mm4mm/geometry/pose.hpp"

namespace mm4mm {
namespace {

const std::vector<StampedPose>& truthOf(const Session& s) {
  if (!s.ground_truth || s.ground_truth->size() != s.keyframes.size())
    throw std::invalid_argument("session " + s.id + " has no ground truth for its keyframes");
  return *s.ground_truth;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + v.size() / 2;
  std::nth_element(v.begin(), mid, v.end());
  if (v.size() % 2 == 1) return *mid;
  return 0.5 * (*mid + *std::max_element(v.begin(), mid));
}

}  // namespace

OverlapError overlapError(const Session& a, const Session& b, const Eigen::Isometry3d& T_a_b,
                          double radius_m) {
  const auto& ga = truthOf(a);
  const auto& gb = truthOf(b);
  std::vector<double> translation, rotation;
  for (std::size_t i = 0; i < gb.size(); ++i) {
    std::size_t nearest = ga.size();
    double best = radius_m;
    for (std::size_t j = 0; j < ga.size(); ++j) {
      const double d = (ga[j].T_frame_body.translation() - gb[i].T_frame_body.translation()).norm();
      if (d <= best) best = d, nearest = j;
    }
    if (nearest == ga.size()) continue;
    const Eigen::Isometry3d estimated =
        a.keyframes[nearest].T_frame_body.inverse() * (T_a_b * b.keyframes[i].T_frame_body);
    const Eigen::Isometry3d truth = ga[nearest].T_frame_body.inverse() * gb[i].T_frame_body;
    const Eigen::Isometry3d delta = estimated * truth.inverse();
    translation.push_back(delta.translation().norm());
    rotation.push_back(rotationAngle(delta.linear()) * 180.0 / M_PI);
  }
  OverlapError error;
  error.pairs = static_cast<int>(translation.size());
  error.median_translation_m = median(translation);
  error.median_rotation_deg = median(rotation);
  return error;
}

Eigen::Isometry3d trueRelativeTransform(const Session& a, const Session& b) {
  const Eigen::Isometry3d T_world_a =
      truthOf(a).front().T_frame_body * a.keyframes.front().T_frame_body.inverse();
  const Eigen::Isometry3d T_world_b =
      truthOf(b).front().T_frame_body * b.keyframes.front().T_frame_body.inverse();
  return T_world_a.inverse() * T_world_b;
}

FrameError frameError(const Session& a, const Session& b, const Eigen::Isometry3d& T_a_b) {
  const Eigen::Isometry3d delta = T_a_b * trueRelativeTransform(a, b).inverse();
  return {delta.translation().norm(), rotationAngle(delta.linear()) * 180.0 / M_PI};
}

}  // namespace mm4mm
