// The three accuracy metrics (docs/design.md "Accuracy metrics") on hand-built sessions whose
// odometry, ground truth and errors are known exactly.

#include "mm4mm/eval/accuracy.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <vector>

#include "mm4mm/core/pose.hpp"

namespace mm4mm {
namespace {

// A straight drive along x at 1 m per keyframe, in the world from `world_start`; the odometry
// starts at `odometry_start` in the session's own frame.
Session drive(const std::string& id, const Eigen::Isometry3d& world_start,
              const Eigen::Isometry3d& odometry_start, int keyframes = 20) {
  Session session;
  session.id = id;
  std::vector<StampedPose> truth;
  for (int k = 0; k < keyframes; ++k) {
    const Eigen::Isometry3d step = planarPose(static_cast<double>(k), 0.0, 0.0);
    session.keyframes.push_back({static_cast<double>(k), odometry_start * step});
    truth.push_back({static_cast<double>(k), world_start * step});
  }
  session.ground_truth = truth;
  return session;
}

// b drives the same line as a, shifted 0.5 m to the side: every keyframe of b is within 2 m of
// one of a's. Both odometries start at their own origins, in frames turned against the world.
struct OverlappingPair {
  Session a = drive("a", planarPose(10.0, 5.0, 0.3), Eigen::Isometry3d::Identity());
  Session b = drive("b", planarPose(10.0, 5.0, 0.3) * planarPose(0.0, 0.5, 0.0),
                    planarPose(-4.0, 2.0, 1.1));
};

TEST(Accuracy, TheTrueTransformHasNoErrorInEitherMetric) {
  const OverlappingPair p;
  const Eigen::Isometry3d T_a_b = trueRelativeTransform(p.a, p.b);
  const OverlapError overlap = overlapError(p.a, p.b, T_a_b);
  EXPECT_EQ(overlap.pairs, 20);
  EXPECT_NEAR(overlap.median_translation_m, 0.0, 1e-9);
  EXPECT_NEAR(overlap.median_rotation_deg, 0.0, 1e-9);
  EXPECT_TRUE(overlap.aligned());
  const FrameError frame = frameError(p.a, p.b, T_a_b);
  EXPECT_NEAR(frame.translation_m, 0.0, 1e-9);
  EXPECT_NEAR(frame.rotation_deg, 0.0, 1e-9);
}

TEST(Accuracy, AnOffsetInAsFrameIsMeasuredAsItIs) {
  const OverlappingPair p;
  const Eigen::Isometry3d T_true = trueRelativeTransform(p.a, p.b);
  // 0.3 m and 1 degree off, applied in a's frame at a's origin.
  const Eigen::Isometry3d offset = planarPose(0.18, 0.24, 1.0 * M_PI / 180.0);
  const FrameError frame = frameError(p.a, p.b, offset * T_true);
  EXPECT_NEAR(frame.rotation_deg, 1.0, 1e-9);
  // The paper's metric compares frames, so the turn about a's origin moves b's frame origin too.
  EXPECT_GT(frame.translation_m, 0.0);
  // A shift alone reads the same in both metrics.
  const Eigen::Isometry3d shift = planarPose(0.18, 0.24, 0.0);
  EXPECT_NEAR(frameError(p.a, p.b, shift * T_true).translation_m, 0.3, 1e-9);
  const OverlapError overlap = overlapError(p.a, p.b, shift * T_true);
  EXPECT_NEAR(overlap.median_translation_m, 0.3, 1e-9);
  EXPECT_NEAR(overlap.median_rotation_deg, 0.0, 1e-9);
  EXPECT_TRUE(overlap.aligned());
  const OverlapError far = overlapError(p.a, p.b, planarPose(0.6, 0.0, 0.0) * T_true);
  EXPECT_NEAR(far.median_translation_m, 0.6, 1e-9);
  EXPECT_FALSE(far.aligned());
}

TEST(Accuracy, SessionsApartByGroundTruthHaveNoOverlapPairs) {
  const Session a = drive("a", planarPose(0.0, 0.0, 0.0), Eigen::Isometry3d::Identity());
  const Session b = drive("b", planarPose(0.0, 10.0, 0.0), Eigen::Isometry3d::Identity());
  const OverlapError overlap = overlapError(a, b, trueRelativeTransform(a, b));
  EXPECT_EQ(overlap.pairs, 0);
  EXPECT_FALSE(overlap.aligned());
}

TEST(Accuracy, TrajectoryErrorIsTheRmseOfKeyframePositions) {
  const OverlappingPair p;
  const std::vector<const Session*> sessions = {&p.a, &p.b};
  const Eigen::Isometry3d T_atlas_b = trueRelativeTransform(p.a, p.b);
  std::vector<std::vector<Eigen::Isometry3d>> exact =
      placeOdometry(sessions, {Eigen::Isometry3d::Identity(), T_atlas_b});
  EXPECT_NEAR(atlasTrajectoryError(sessions, exact, {true, true}), 0.0, 1e-9);
  // Every keyframe of b 0.2 m off, a exact: RMSE over 40 keyframes = sqrt(20 * 0.04 / 40).
  std::vector<std::vector<Eigen::Isometry3d>> off = exact;
  for (Eigen::Isometry3d& T : off[1]) T.translation() += Eigen::Vector3d(0.0, 0.2, 0.0);
  EXPECT_NEAR(atlasTrajectoryError(sessions, off, {true, true}), std::sqrt(0.02), 1e-9);
  // Sessions left out do not count.
  EXPECT_NEAR(atlasTrajectoryError(sessions, off, {true, false}), 0.0, 1e-9);
  // Drift-free odometry at the true frames has no error.
  EXPECT_NEAR(odometryTrajectoryError(sessions, {true, true}), 0.0, 1e-9);
}

// The atlas figures: exact poses score zero in all three metrics, b placed at a's frame is off by
// the true transform between them, and a session left unconnected neither counts nor needs
// ground truth.
TEST(Accuracy, AnAtlasIsScoredOverItsConnectedSessions) {
  OverlappingPair p;
  const std::vector<const Session*> sessions = {&p.a, &p.b};
  const Eigen::Isometry3d T_true = trueRelativeTransform(p.a, p.b);
  const auto exact = placeOdometry(sessions, {Eigen::Isometry3d::Identity(), T_true});
  const AtlasEvaluation right = evaluateAtlas(sessions, exact, {true, true});
  ASSERT_EQ(right.pairs.size(), 1u);
  EXPECT_EQ(right.pairs[0].overlap.pairs, 20);
  EXPECT_NEAR(right.pairs[0].overlap.median_translation_m, 0.0, 1e-9);
  ASSERT_EQ(right.frames.size(), 1u);
  EXPECT_EQ(right.frames[0].session, 1);
  EXPECT_NEAR(right.frames[0].error.translation_m, 0.0, 1e-9);
  EXPECT_NEAR(right.ate_m, 0.0, 1e-9);

  const auto wrong =
      placeOdometry(sessions, {Eigen::Isometry3d::Identity(), Eigen::Isometry3d::Identity()});
  const AtlasEvaluation off = evaluateAtlas(sessions, wrong, {true, true});
  ASSERT_EQ(off.frames.size(), 1u);
  EXPECT_NEAR(off.frames[0].error.rotation_deg,
              Eigen::AngleAxisd(T_true.linear()).angle() * 180.0 / M_PI, 1e-6);
  EXPECT_GT(off.ate_m, 1.0);

  p.b.ground_truth.reset();
  EXPECT_THROW(evaluateAtlas(sessions, wrong, {true, true}), std::invalid_argument);
  const AtlasEvaluation alone = evaluateAtlas(sessions, wrong, {true, false});
  EXPECT_TRUE(alone.pairs.empty());
  EXPECT_TRUE(alone.frames.empty());
  EXPECT_NEAR(alone.ate_m, 0.0, 1e-9);  // a alone, at its own odometry, is exact
}

}  // namespace
}  // namespace mm4mm
