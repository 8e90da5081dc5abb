// The pure logic that decides where each session goes once its pairs are matched: the
// maximum-confidence spanning tree, the placement along it, and the other pairs' consistency with
// it (merge/pair_refinement.hpp), and which placed sessions become candidate pairs
// (merge/candidate_pairs.hpp). Pairs are built by hand from known session frames, so every
// placement has a ground truth.

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <tuple>
#include <vector>

#include "mm4mm/core/pose.hpp"
#include "mm4mm/merge/candidate_pairs.hpp"
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

// What `merge` says of an unplaced session: the sessions it was matched with, unplaced with it.
TEST(SpanningTree, TheComponentOfAnUnplacedSessionNamesItsPartners) {
  std::vector<PairResult> pairs = {acceptedPair(0, 1, 9.0), acceptedPair(3, 4, 8.0),
                                   acceptedPair(2, 4, 7.0), acceptedPair(2, 3, 6.0)};
  pairs.push_back(acceptedPair(1, 4, 5.0));
  pairs.back().accepted = false;  // refused: joins nothing
  markSpanningTree(6, &pairs);
  EXPECT_EQ(treeComponent(3, pairs), (std::vector<int>{2, 3, 4}));
  EXPECT_EQ(treeComponent(2, pairs), (std::vector<int>{2, 3, 4}));
  EXPECT_EQ(treeComponent(1, pairs), (std::vector<int>{0, 1}));
  EXPECT_EQ(treeComponent(5, pairs), (std::vector<int>{5}));  // matched with nothing
}

// A new atlas takes the frame of its largest group: a first session that matched nothing must not
// leave the others out, and ties go to the group holding the earliest session.
TEST(SpanningTree, TheAtlasTakesTheFrameOfTheLargestGroup) {
  std::vector<PairResult> pairs = {acceptedPair(1, 2, 9.0), acceptedPair(2, 3, 8.0)};
  markSpanningTree(4, &pairs);
  EXPECT_EQ(largestComponentRoot(4, pairs), 1);
  const auto T_atlas = placeByTree(4, pairs, 1);
  EXPECT_FALSE(T_atlas[0].has_value());
  ASSERT_TRUE(T_atlas[1] && T_atlas[2] && T_atlas[3]);
  EXPECT_TRUE(T_atlas[1]->isApprox(Eigen::Isometry3d::Identity()));
  EXPECT_TRUE(T_atlas[3]->isApprox(pairs[0].T_a_b * pairs[1].T_a_b));
  // Two groups of two: the one with session 0.
  std::vector<PairResult> tied = {acceptedPair(2, 3, 9.0), acceptedPair(0, 1, 1.0)};
  markSpanningTree(4, &tied);
  EXPECT_EQ(largestComponentRoot(4, tied), 0);
  // Nothing matched: session 0, alone.
  std::vector<PairResult> none;
  EXPECT_EQ(largestComponentRoot(3, none), 0);
  EXPECT_THROW(placeByTree(3, none, 3), std::invalid_argument);
}

// A map of `w` x `h` covered cells of 0.1 m in its own frame, its origin at `origin`.
MagneticMap coveredRectangle(int w, int h, Eigen::Vector2d origin = Eigen::Vector2d::Zero()) {
  MagneticMap map;
  map.cell_size_m = 0.1;
  map.origin_m = origin;
  map.width = w;
  map.height = h;
  for (auto* channel :
       {&map.horizontal_uT, &map.vertical_uT, &map.total_uT, &map.session_x_uT, &map.session_y_uT})
    channel->assign(static_cast<std::size_t>(w) * h, 1.0f);
  return map;
}

TEST(CandidatePairs, PlacedCoverageKeepsTheAreaAndFollowsThePlacement) {
  const MagneticMap map = coveredRectangle(20, 10);  // 2 m x 1 m
  const PlacedCoverage at_rest = placedCoverage(map, Eigen::Isometry3d::Identity());
  EXPECT_EQ(at_rest.cells.size(), 200u);
  EXPECT_TRUE(std::is_sorted(at_rest.cells.begin(), at_rest.cells.end()));
  // Turned by 90° and moved: the rectangle now spans x in [4, 5], y in [3, 5] of the atlas.
  const PlacedCoverage turned = placedCoverage(map, planarPose(5.0, 3.0, M_PI / 2));
  EXPECT_NEAR(static_cast<double>(turned.cells.size()), 200.0, 20.0);  // edge cells on the seam
  for (const auto& [ix, iy] : turned.cells) {
    EXPECT_GE(ix, 39);
    EXPECT_LE(ix, 50);
    EXPECT_GE(iy, 29);
    EXPECT_LE(iy, 50);
  }
  // At 30° every cell of the rotated rectangle is still counted about once.
  const PlacedCoverage oblique = placedCoverage(map, planarPose(-2.0, 1.0, M_PI / 6));
  EXPECT_NEAR(oblique.cells.size() * 0.01, 2.0, 0.15);
}

TEST(CandidatePairs, CommonAreaCountsCellsBothCover) {
  MagneticMap a = coveredRectangle(10, 10);
  const MagneticMap b = coveredRectangle(10, 10, {0.5, 0.3});
  const PlacedCoverage ca = placedCoverage(a, Eigen::Isometry3d::Identity());
  const PlacedCoverage cb = placedCoverage(b, Eigen::Isometry3d::Identity());
  EXPECT_NEAR(commonArea_m2(ca, cb), 0.5 * 0.7, 1e-9);
  EXPECT_NEAR(commonArea_m2(cb, ca), 0.5 * 0.7, 1e-9);
  a.total_uT[a.index(9, 9)] = std::numeric_limits<float>::quiet_NaN();  // uncovered
  EXPECT_NEAR(commonArea_m2(placedCoverage(a, Eigen::Isometry3d::Identity()), cb), 0.34, 1e-9);
  // The same map placed where b is in the atlas covers what b covers.
  EXPECT_NEAR(commonArea_m2(placedCoverage(b, Eigen::Isometry3d::Identity()),
                            placedCoverage(coveredRectangle(10, 10), planarPose(0.5, 0.3, 0.0))),
              1.0, 1e-9);
  PlacedCoverage coarse = cb;
  coarse.cell_size_m = 0.2;
  EXPECT_THROW(commonArea_m2(ca, coarse), std::invalid_argument);
}

TEST(CandidatePairs, EachRankingSessionKeepsItsAnchorAndItsLargestOverlaps) {
  // Five 4 m x 4 m maps in a row, each shifted by 1 m from the last, so neighbours share 12 m²,
  // sessions two apart 8 m², three apart 4 m².
  std::vector<std::optional<Eigen::Isometry3d>> T_atlas;
  std::vector<PlacedCoverage> coverage;
  for (int s = 0; s < 5; ++s) {
    T_atlas.push_back(planarPose(1.0 * s, 0.0, 0.0));
    coverage.push_back(placedCoverage(coveredRectangle(40, 40), *T_atlas.back()));
  }
  T_atlas.push_back(std::nullopt);  // an unplaced sixth session takes part in nothing
  coverage.emplace_back();
  coverage.back().cell_size_m = 0.1;
  const std::vector<int> order = {0, 1, 2, 2, 3, -1};
  CandidateRule rule;
  rule.max_pairs_per_session = 1;
  rule.min_pair_overlap_m2 = 5.0;
  const std::vector<bool> all(6, true);
  const auto pairs = selectCandidatePairs(T_atlas, coverage, order, all, {}, rule);
  const auto has = [&](int a, int b, bool anchor) {
    return std::any_of(pairs.begin(), pairs.end(), [&](const CandidatePair& p) {
      return p.a == a && p.b == b && p.anchor == anchor;
    });
  };
  // Anchors, the largest overlap with a session placed in an earlier pass: 0-1 for 1, 1-2 for 2,
  // 1-3 for 3 (2 was placed in the same pass, so 1's 8 m² and not 2's 12 m²), 3-4 for 4; 0 has
  // none.
  EXPECT_TRUE(has(0, 1, true) && has(1, 2, true) && has(1, 3, true) && has(3, 4, true));
  // Besides its anchor each keeps its largest other overlap of >= 5 m²: 0-2 (8 m²) for 0, 2-3
  // (12 m²) for 2 and 3, 2-4 for 4; 0-3 and 1-4 (4 m²) are below the minimum.
  EXPECT_TRUE(has(0, 2, false) && has(2, 3, false) && has(2, 4, false));
  EXPECT_FALSE(has(0, 3, false) || has(1, 4, false) || has(0, 4, false));
  EXPECT_EQ(pairs.size(), 7u);
  for (const CandidatePair& p : pairs) {
    EXPECT_LT(p.a, p.b);
    EXPECT_NE(p.b, 5);
    const Eigen::Isometry3d delta = p.T_a_b.inverse() * (T_atlas[p.a]->inverse() * *T_atlas[p.b]);
    EXPECT_LT(delta.translation().norm(), 1e-12);
  }
  EXPECT_TRUE(std::is_sorted(pairs.begin(), pairs.end(), [](const auto& x, const auto& y) {
    return std::tie(x.a, x.b) < std::tie(y.a, y.b);
  }));

  // Only session 4 ranks (an add): its anchor and its one largest other overlap; a skipped pair is
  // left out and the next one takes its place.
  std::vector<bool> only_4(6, false);
  only_4[4] = true;
  const auto added = selectCandidatePairs(T_atlas, coverage, order, only_4, {}, rule);
  ASSERT_EQ(added.size(), 2u);
  EXPECT_TRUE(added[0].a == 2 && added[0].b == 4 && !added[0].anchor);
  EXPECT_TRUE(added[1].a == 3 && added[1].b == 4 && added[1].anchor);
  const auto skipped = selectCandidatePairs(T_atlas, coverage, order, only_4, {{3, 4}}, rule);
  ASSERT_EQ(skipped.size(), 1u);
  EXPECT_TRUE(skipped[0].a == 2 && skipped[0].b == 4 && skipped[0].anchor);
  // No cap: every overlap of >= 5 m² besides the anchor.
  rule.max_pairs_per_session = 0;
  EXPECT_EQ(selectCandidatePairs(T_atlas, coverage, order, only_4, {}, rule).size(), 2u);
  rule.min_pair_overlap_m2 = 3.0;  // 1-4 too; 0-4 do not overlap at all
  EXPECT_EQ(selectCandidatePairs(T_atlas, coverage, order, only_4, {}, rule).size(), 3u);
}

}  // namespace
}  // namespace mm4mm
