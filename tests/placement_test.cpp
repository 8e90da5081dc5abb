// The pure logic that decides where each session goes once its pairs are matched: the
// maximum-confidence spanning tree, the placement along it, and the other pairs' consistency with
// it (merge/pair_refinement.hpp). Pairs are built by hand from known session frames, so every
// placement has a ground truth.

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <optional>
#include <vector>

#include "mm4mm/core/pose.hpp"
#include "mm4mm/merge/pair_refinement.hpp"

namespace mm4mm {
namespace {

// Session frames in the world; session 0's frame is the atlas frame.
const std::vector<Eigen::Isometry3d> kTruth = {
    planarPose(0.0, 0.0, 0.0), planarPose(12.0, -3.0, 0.6), planarPose(-7.5, 20.0, 2.9),
    planarPose(30.0, 4.0, -1.2), planarPose(5.0, 5.0, 0.1)};

PairResult acceptedPair(int a, int b, double z, bool geometry_only = false) {
  PairResult pair;
  pair.a = a;
  pair.b = b;
  pair.accepted = true;
  pair.geometry_only = geometry_only;
  pair.magnetic.z = z;
  pair.T_a_b = kTruth[a].inverse() * kTruth[b];
  return pair;
}

// Session s's frame in session 0's.
Eigen::Isometry3d trueAtlasFrame(int s) { return kTruth[0].inverse() * kTruth[s]; }

void expectNear(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth) {
  const Eigen::Isometry3d delta = estimate.inverse() * truth;
  EXPECT_LT(delta.translation().norm(), 1e-9);
  EXPECT_LT(rotationAngle(delta.linear()), 1e-9);
}

TEST(SpanningTree, TakesTheMostConfidentPairsThatJoinNewSessions) {
  std::vector<PairResult> pairs = {acceptedPair(0, 1, 5.0), acceptedPair(1, 2, 9.0),
                                   acceptedPair(0, 2, 7.0)};
  markSpanningTree(3, &pairs);
  EXPECT_EQ(pairs[1].role, PairRole::kTree);
  EXPECT_EQ(pairs[2].role, PairRole::kTree);
  // 0-1 would close the cycle 0-2-1: left as it was.
  EXPECT_EQ(pairs[0].role, PairRole::kRefused);
}

TEST(SpanningTree, RefusedPairsNeverJoinAndMagneticPairsGoFirst) {
  PairResult refused = acceptedPair(0, 1, 50.0);
  refused.accepted = false;
  // The geometry-only pair has the highest z, but a correlation of walls ranks after the field.
  std::vector<PairResult> pairs = {refused, acceptedPair(0, 1, 80.0, true), acceptedPair(1, 2, 4.0),
                                   acceptedPair(0, 2, 3.0)};
  markSpanningTree(3, &pairs);
  EXPECT_EQ(pairs[0].role, PairRole::kRefused);
  EXPECT_EQ(pairs[1].role, PairRole::kRefused);
  EXPECT_EQ(pairs[2].role, PairRole::kTree);
  EXPECT_EQ(pairs[3].role, PairRole::kTree);

  // Where no magnetic pair reaches a session, the geometry-only one joins the tree.
  std::vector<PairResult> only = {acceptedPair(0, 1, 80.0, true), acceptedPair(1, 2, 4.0)};
  markSpanningTree(3, &only);
  EXPECT_EQ(only[0].role, PairRole::kTree);
  EXPECT_EQ(only[1].role, PairRole::kTree);
}

TEST(SpanningTree, PlacesEverySessionItReachesAtItsTrueFrame) {
  // A chain whose pairs point both ways (2-1 is stored as a = 1, b = 2 but reached from 2's side
  // only through 3), and session 4 joined to nothing.
  std::vector<PairResult> pairs = {acceptedPair(0, 3, 6.0), acceptedPair(2, 3, 5.0),
                                   acceptedPair(1, 2, 4.0)};
  markSpanningTree(5, &pairs);
  const std::vector<std::optional<Eigen::Isometry3d>> T_atlas = placeByTree(5, pairs);
  ASSERT_EQ(T_atlas.size(), 5u);
  for (int s = 0; s < 4; ++s) {
    ASSERT_TRUE(T_atlas[s].has_value()) << "session " << s;
    expectNear(*T_atlas[s], trueAtlasFrame(s));
  }
  EXPECT_FALSE(T_atlas[4].has_value());
}

TEST(SpanningTree, PairsOutsideTheTreeAreConsistentOnlyWhenTheyAgreeWithIt) {
  MergeConfig config;
  std::vector<PairResult> pairs = {acceptedPair(0, 1, 9.0), acceptedPair(1, 2, 8.0),
                                   acceptedPair(0, 2, 3.0), acceptedPair(0, 2, 2.0),
                                   acceptedPair(0, 2, 1.5), acceptedPair(1, 4, 1.0)};
  // Just inside the thresholds, then just outside them in translation and in rotation.
  pairs[2].T_a_b = pairs[2].T_a_b * planarPose(0.6 * config.consistency_translation_m, 0.0,
                                               0.5 * config.consistency_rotation_deg * M_PI / 180);
  pairs[3].T_a_b = pairs[3].T_a_b * planarPose(1.2 * config.consistency_translation_m, 0.0, 0.0);
  pairs[4].T_a_b =
      pairs[4].T_a_b * planarPose(0.0, 0.0, 1.2 * config.consistency_rotation_deg * M_PI / 180);
  pairs[5].accepted = false;  // a refused pair keeps its role
  markSpanningTree(5, &pairs);
  const auto T_atlas = placeByTree(5, pairs);
  markConsistency(T_atlas, config, &pairs);
  EXPECT_EQ(pairs[0].role, PairRole::kTree);
  EXPECT_EQ(pairs[1].role, PairRole::kTree);
  EXPECT_EQ(pairs[2].role, PairRole::kConsistent);
  EXPECT_EQ(pairs[3].role, PairRole::kInconsistent);
  EXPECT_EQ(pairs[4].role, PairRole::kInconsistent);
  EXPECT_EQ(pairs[5].role, PairRole::kRefused);
}

TEST(SpanningTree, APairOfUnplacedSessionsIsInconsistent) {
  // 2, 3 and 4 are matched among themselves but to nothing placed: the tree of that component
  // places none of them, and its third pair has nothing to agree with.
  std::vector<PairResult> pairs = {acceptedPair(0, 1, 9.0), acceptedPair(2, 3, 8.0),
                                   acceptedPair(3, 4, 7.0), acceptedPair(2, 4, 6.0)};
  markSpanningTree(5, &pairs);
  EXPECT_EQ(pairs[1].role, PairRole::kTree);
  EXPECT_EQ(pairs[2].role, PairRole::kTree);
  const auto T_atlas = placeByTree(5, pairs);
  for (int s : {2, 3, 4}) EXPECT_FALSE(T_atlas[s].has_value()) << "session " << s;
  markConsistency(T_atlas, MergeConfig{}, &pairs);
  EXPECT_EQ(pairs[3].role, PairRole::kInconsistent);
}

}  // namespace
}  // namespace mm4mm
