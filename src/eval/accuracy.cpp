#include "mm4mm/eval/accuracy.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "mm4mm/core/pose.hpp"

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

OverlapError overlapError(const Session& a, const Session& b,
                          const std::vector<Eigen::Isometry3d>& estimated_a,
                          const std::vector<Eigen::Isometry3d>& estimated_b, double radius_m) {
  const auto& ga = truthOf(a);
  const auto& gb = truthOf(b);
  if (estimated_a.size() != ga.size() || estimated_b.size() != gb.size())
    throw std::invalid_argument("overlapError: one estimated pose per keyframe of " + a.id +
                                " and " + b.id + " is needed");
  std::vector<double> translation, rotation;
  for (std::size_t i = 0; i < gb.size(); ++i) {
    std::size_t nearest = ga.size();
    double best = radius_m;
    for (std::size_t j = 0; j < ga.size(); ++j) {
      const double d = (ga[j].T_frame_body.translation() - gb[i].T_frame_body.translation()).norm();
      if (d <= best) best = d, nearest = j;
    }
    if (nearest == ga.size()) continue;
    const Eigen::Isometry3d estimated = estimated_a[nearest].inverse() * estimated_b[i];
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

OverlapError overlapError(const Session& a, const Session& b, const Eigen::Isometry3d& T_a_b,
                          double radius_m) {
  std::vector<Eigen::Isometry3d> estimated_a, estimated_b;
  for (const StampedPose& k : a.keyframes) estimated_a.push_back(k.T_frame_body);
  for (const StampedPose& k : b.keyframes) estimated_b.push_back(T_a_b * k.T_frame_body);
  return overlapError(a, b, estimated_a, estimated_b, radius_m);
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

double atlasTrajectoryError(const std::vector<const Session*>& sessions,
                            const std::vector<std::vector<Eigen::Isometry3d>>& T_atlas_keyframe,
                            const std::vector<bool>& include, int reference) {
  if (T_atlas_keyframe.size() != sessions.size() || include.size() != sessions.size())
    throw std::invalid_argument("atlasTrajectoryError: one trajectory and flag per session");
  const Session& ref = *sessions.at(reference);
  const Eigen::Isometry3d T_atlas_world =
      ref.keyframes.front().T_frame_body * truthOf(ref).front().T_frame_body.inverse();
  double sum = 0.0;
  std::size_t count = 0;
  for (std::size_t s = 0; s < sessions.size(); ++s) {
    if (!include[s]) continue;
    const auto& truth = truthOf(*sessions[s]);
    if (T_atlas_keyframe[s].size() != truth.size())
      throw std::invalid_argument("atlasTrajectoryError: session " + sessions[s]->id + " has " +
                                  std::to_string(T_atlas_keyframe[s].size()) +
                                  " estimated poses for " + std::to_string(truth.size()) +
                                  " keyframes");
    for (std::size_t k = 0; k < truth.size(); ++k) {
      sum += (T_atlas_keyframe[s][k].translation() -
              T_atlas_world * truth[k].T_frame_body.translation())
                 .squaredNorm();
      ++count;
    }
  }
  return count == 0 ? 0.0 : std::sqrt(sum / count);
}

std::vector<std::vector<Eigen::Isometry3d>> placeOdometry(
    const std::vector<const Session*>& sessions,
    const std::vector<Eigen::Isometry3d>& T_atlas_session) {
  if (T_atlas_session.size() != sessions.size())
    throw std::invalid_argument("placeOdometry: one transform per session is needed");
  std::vector<std::vector<Eigen::Isometry3d>> placed(sessions.size());
  for (std::size_t s = 0; s < sessions.size(); ++s)
    for (const StampedPose& keyframe : sessions[s]->keyframes)
      placed[s].push_back(T_atlas_session[s] * keyframe.T_frame_body);
  return placed;
}

double odometryTrajectoryError(const std::vector<const Session*>& sessions,
                               const std::vector<bool>& include, int reference) {
  std::vector<Eigen::Isometry3d> true_frames;
  for (std::size_t s = 0; s < sessions.size(); ++s)
    true_frames.push_back(include[s] ? trueRelativeTransform(*sessions.at(reference), *sessions[s])
                                     : Eigen::Isometry3d::Identity());
  return atlasTrajectoryError(sessions, placeOdometry(sessions, true_frames), include, reference);
}

AtlasEvaluation evaluateAtlas(const std::vector<const Session*>& sessions,
                              const std::vector<std::vector<Eigen::Isometry3d>>& T_atlas_keyframe,
                              const std::vector<bool>& connected, int reference) {
  AtlasEvaluation evaluation;
  const int n = static_cast<int>(sessions.size());
  for (int a = 0; a < n; ++a) {
    if (!connected[a]) continue;
    for (int b = a + 1; b < n; ++b) {
      if (!connected[b]) continue;
      const OverlapError error =
          overlapError(*sessions[a], *sessions[b], T_atlas_keyframe[a], T_atlas_keyframe[b]);
      if (error.pairs > 0) evaluation.pairs.push_back({a, b, error});
    }
  }
  const auto frameOf = [&](int s) {
    return T_atlas_keyframe[s].front() * sessions[s]->keyframes.front().T_frame_body.inverse();
  };
  for (int s = 0; s < n; ++s) {
    if (!connected[s] || s == reference || !connected[reference]) continue;
    const Eigen::Isometry3d T_e = frameOf(reference).inverse() * frameOf(s);
    evaluation.frames.push_back({s, frameError(*sessions[reference], *sessions[s], T_e)});
  }
  evaluation.ate_m = atlasTrajectoryError(sessions, T_atlas_keyframe, connected, reference);
  evaluation.odometry_ate_m = odometryTrajectoryError(sessions, connected, reference);
  return evaluation;
}

}  // namespace mm4mm
