// The small pieces every match is stated in: the planar transform the search runs over, and the
// JSON that `mm4mm match --json` and report.json share (docs/design.md "Atlas directory").

#include "mm4mm/io/match_json.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

#include "mm4mm/core/pose.hpp"
#include "mm4mm/magnetic/magnetic_matcher.hpp"
#include "mm4mm/magnetic/planar_transform.hpp"

namespace mm4mm {
namespace {

TEST(PlanarTransform, AppliesAsItsIsometryDoesAndComesBackFromIt) {
  const PlanarTransform T{3.0, -2.0, 2.5};
  const Eigen::Isometry3d iso = T.toIsometry();
  const Eigen::Vector2d p(1.5, 4.0);
  const Eigen::Vector3d q = iso * Eigen::Vector3d(p.x(), p.y(), 0.7);
  EXPECT_NEAR((T.apply(p) - q.head<2>()).norm(), 0.0, 1e-12);
  EXPECT_NEAR(q.z(), 0.7, 1e-12);  // planar: heights are kept
  const PlanarTransform back = PlanarTransform::fromIsometry(iso);
  EXPECT_NEAR(back.x_m, 3.0, 1e-12);
  EXPECT_NEAR(back.y_m, -2.0, 1e-12);
  EXPECT_NEAR(back.yaw_rad, 2.5, 1e-12);
  // A yaw past pi comes back wrapped, the same rotation.
  const PlanarTransform wrapped =
      PlanarTransform::fromIsometry(PlanarTransform{0, 0, 4.0}.toIsometry());
  EXPECT_NEAR(std::remainder(wrapped.yaw_rad - 4.0, 2 * M_PI), 0.0, 1e-12);
  EXPECT_LE(std::abs(wrapped.yaw_rad), M_PI);
}

TEST(PlanarTransform, DistancesTakeTheShortWayRound) {
  const PlanarTransform a{1.0, 1.0, M_PI - 0.05};
  const PlanarTransform b{4.0, 5.0, -M_PI + 0.05};
  EXPECT_NEAR(translationDistance(a, b), 5.0, 1e-12);
  EXPECT_NEAR(yawDistance(a, b), 0.1, 1e-12);
  EXPECT_NEAR(yawDistance(b, a), 0.1, 1e-12);
}

MagneticMatchResult acceptedMatch() {
  MagneticMatchResult result;
  result.verdict = MatchVerdict::kMatch;
  result.T_a_b = PlanarTransform{2.0, -1.0, 0.3};
  result.z = 12.5;
  result.r = 0.93;
  result.second_mode_ratio = 0.4;
  result.overlap_m2 = 31.0;
  CorrelationMode mode;
  mode.T_a_b = result.T_a_b;
  mode.z = 12.5;
  result.modes = {mode};
  return result;
}

TEST(MatchJson, StatesTheTransformRowMajorAndTheConfidence) {
  const MagneticMatchResult result = acceptedMatch();
  const nlohmann::json json = nlohmann::json::parse(matchResultJson(result));
  EXPECT_TRUE(json.at("overlap").get<bool>());
  EXPECT_EQ(json.at("verdict").get<std::string>(), "match");
  const Eigen::Matrix4d T = result.T_a_b.toIsometry().matrix();
  ASSERT_EQ(json.at("T_a_b").size(), 4u);
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) EXPECT_DOUBLE_EQ(json["T_a_b"][i][j].get<double>(), T(i, j));
  EXPECT_DOUBLE_EQ(json.at("confidence").get<double>(), 0.6);
  EXPECT_DOUBLE_EQ(matchConfidence(result), 0.6);
  ASSERT_EQ(json.at("modes").size(), 1u);
  EXPECT_NEAR(json["modes"][0].at("yaw_deg").get<double>(), 0.3 * 180.0 / M_PI, 1e-12);
  // One line when asked.
  EXPECT_EQ(matchResultJson(result, -1).find('\n'), std::string::npos);
}

TEST(MatchJson, ARefusedMatchHasNoOverlapAndNoConfidence) {
  MagneticMatchResult result = acceptedMatch();
  result.verdict = MatchVerdict::kYawUncertain;
  const nlohmann::json json = nlohmann::json::parse(matchResultJson(result));
  EXPECT_FALSE(json.at("overlap").get<bool>());
  EXPECT_EQ(json.at("verdict").get<std::string>(), "yaw uncertain");
  EXPECT_EQ(json.at("confidence").get<double>(), 0.0);
  // A match without any overlap scores z = -inf, which JSON cannot hold: written as null.
  result.verdict = MatchVerdict::kNoOverlap;
  result.z = -std::numeric_limits<double>::infinity();
  const nlohmann::json none = nlohmann::json::parse(matchResultJson(result));
  EXPECT_TRUE(none.at("z").is_null());
}

}  // namespace
}  // namespace mm4mm
