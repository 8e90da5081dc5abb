#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "mm4mm/core/pose.hpp"
#include "mm4mm/magnetic/fingerprint.hpp"

namespace mm4mm {
namespace {

TEST(Pose, YawAndTiltDecomposeRollPitchYaw) {
  const Eigen::Isometry3d T = poseFromRpy(Eigen::Vector3d(1, 2, 3), 0.05, -0.03, 2.5);
  EXPECT_NEAR(yawOf(T.linear()), 2.5, 1e-12);
  const Eigen::Matrix3d expected_tilt =
      poseFromRpy(Eigen::Vector3d::Zero(), 0.05, -0.03, 0).linear();
  EXPECT_TRUE(tiltOf(T.linear()).isApprox(expected_tilt, 1e-12));
}

TEST(Pose, InterpolationHitsEndpointsAndMidpoint) {
  const Eigen::Isometry3d a = planarPose(0, 0, 0.0);
  const Eigen::Isometry3d b = planarPose(2, 4, 1.0);
  EXPECT_TRUE(interpolatePose(a, b, 0.0).isApprox(a, 1e-12));
  EXPECT_TRUE(interpolatePose(a, b, 1.0).isApprox(b, 1e-12));
  const Eigen::Isometry3d mid = interpolatePose(a, b, 0.5);
  EXPECT_NEAR(yawOf(mid.linear()), 0.5, 1e-12);
  EXPECT_TRUE(mid.translation().isApprox(Eigen::Vector3d(1, 2, 0)));
}

TEST(Pose, WrapAngle) {
  EXPECT_NEAR(wrapAngle(3 * M_PI / 2), -M_PI / 2, 1e-12);
  EXPECT_NEAR(wrapAngle(-M_PI), M_PI, 1e-12);
  EXPECT_NEAR(wrapAngle(0.3), 0.3, 1e-12);
}

// A tilted robot reads the world field rotated into its body axes; levelling with the pose's
// roll and pitch must give back the field in the heading-aligned levelled frame.
TEST(Fingerprint, LevellingUndoesRollAndPitch) {
  const Eigen::Vector3d field_world(20.0, 5.0, -40.0);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> tilt(-0.2, 0.2), heading(-M_PI, M_PI);
  for (int i = 0; i < 100; ++i) {
    const double yaw = heading(rng);
    const Eigen::Matrix3d R =
        poseFromRpy(Eigen::Vector3d::Zero(), tilt(rng), tilt(rng), yaw).linear();
    const Eigen::Vector3d body = R.transpose() * field_world;
    const Eigen::Vector3d levelled = levelReading(R, body);
    EXPECT_TRUE(levelled.isApprox(rotationZ(-yaw) * field_world, 1e-12));
  }
}

TEST(Fingerprint, InvariantToYawAndTilt) {
  const Eigen::Vector3d field_world(18.0, -9.0, -42.0);
  const MagneticFingerprint reference = fingerprintOf(Eigen::Matrix3d::Identity(), field_world);
  EXPECT_NEAR(reference.horizontal_uT, std::hypot(18.0, -9.0), 1e-12);
  EXPECT_NEAR(reference.vertical_uT, -42.0, 1e-12);
  EXPECT_NEAR(reference.total_uT, field_world.norm(), 1e-12);
  for (double yaw = -3.0; yaw < 3.2; yaw += 0.5) {
    const Eigen::Matrix3d R = poseFromRpy(Eigen::Vector3d::Zero(), 0.1, -0.07, yaw).linear();
    const MagneticFingerprint f = fingerprintOf(R, R.transpose() * field_world);
    EXPECT_NEAR(f.horizontal_uT, reference.horizontal_uT, 1e-9);
    EXPECT_NEAR(f.vertical_uT, reference.vertical_uT, 1e-9);
    EXPECT_NEAR(f.total_uT, reference.total_uT, 1e-9);
  }
}

// Without levelling, a tilt of a few degrees changes B_v by about |B_h| * tilt: it matters.
TEST(Fingerprint, TiltWithoutLevellingWouldBias) {
  const Eigen::Vector3d field_world(20.0, 0.0, -40.0);
  const Eigen::Matrix3d R = poseFromRpy(Eigen::Vector3d::Zero(), 0.0, 0.05, 0.0).linear();
  const Eigen::Vector3d body = R.transpose() * field_world;
  EXPECT_GT(std::abs(body.z() - field_world.z()), 0.5);
  EXPECT_NEAR(fingerprintOf(R, body).vertical_uT, -40.0, 1e-9);
}

}  // namespace
}  // namespace mm4mm
