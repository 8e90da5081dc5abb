// End to end: simulated corridor sessions merged into an atlas, checked against ground truth,
// written and read back.

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "calibrated_sessions.hpp"
#include "mm4mm/core/pose.hpp"
#include "mm4mm/eval/accuracy.hpp"
#include "mm4mm/io/atlas_io.hpp"
#include "mm4mm/io/config_io.hpp"
#include "mm4mm/io/input_error.hpp"
#include "mm4mm/io/magnetic_map_io.hpp"
#include "mm4mm/io/tum_io.hpp"
#include "mm4mm/merge/growing_map_matching.hpp"
#include "mm4mm/merge/inter_session_edges.hpp"
#include "mm4mm/merge/merge_sessions.hpp"
#include "mm4mm/render/magnetic_map_render.hpp"
#include "mm4mm/sim/simulator.hpp"

namespace mm4mm {
namespace {

namespace fs = std::filesystem;

// Three sessions of the small corridor preset (windows 32 m apart, 40 m long), plus optionally
// one that overlaps none of them.
std::vector<Session> corridorSessions(bool disjoint, std::uint64_t seed) {
  sim::SimulationConfig config =
      loadSimulationConfig(fs::path(MM4MM_SOURCE_DIR) / "configs" / "corridor_small.yaml");
  config.layout.disjoint_session = disjoint;
  return calibrated(sim::simulateSessions(config, disjoint ? 4 : 3, seed));
}

std::vector<const Session*> pointersTo(const std::vector<Session>& sessions) {
  std::vector<const Session*> pointers;
  for (const Session& s : sessions) pointers.push_back(&s);
  return pointers;
}

class MergeEndToEnd : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // The disjoint session (s3) second, so that connected sessions and their indices among
    // all sessions differ: the atlas writer must map between the two.
    std::vector<Session> sessions = corridorSessions(true, 5);
    std::rotate(sessions.begin() + 1, sessions.begin() + 3, sessions.end());
    sessions_ = new std::vector<Session>(std::move(sessions));
    result_ = new MergeResult(mergeSessions(*sessions_, MergeConfig{}));
  }
  static void TearDownTestSuite() {
    delete result_;
    delete sessions_;
  }
  static std::vector<Session>* sessions_;
  static MergeResult* result_;
};
std::vector<Session>* MergeEndToEnd::sessions_ = nullptr;
MergeResult* MergeEndToEnd::result_ = nullptr;

TEST_F(MergeEndToEnd, OverlappingSessionsAreConnectedAndTheDisjointOneIsNot) {
  const auto& connected = result_->solution.connected;
  ASSERT_EQ(connected.size(), 4u);
  ASSERT_EQ((*sessions_)[1].id, "s3");
  EXPECT_TRUE(connected[0]);
  EXPECT_FALSE(connected[1]);
  EXPECT_TRUE(connected[2]);
  EXPECT_TRUE(connected[3]);
  EXPECT_GT(result_->edges.size(), 4u);
}

// What "aligned" means for this atlas: every overlap within 0.1 m and 0.5°, and trajectories no
// worse than its sessions' odometry placed rigidly at the solved frames (a solve that bends the
// odometry to fit the field raises the ATE above that).
testing::AssertionResult alignsEveryOverlap(const std::vector<Session>& sessions,
                                            const std::vector<std::vector<Eigen::Isometry3d>>& T,
                                            const MergeResult& result) {
  const auto pointers = pointersTo(sessions);
  const AtlasEvaluation evaluation = evaluateAtlas(pointers, T, result.solution.connected);
  if (evaluation.pairs.size() < 2) return testing::AssertionFailure() << "fewer than 2 overlaps";
  for (const auto& pair : evaluation.pairs)
    if (pair.overlap.median_translation_m >= 0.1 || pair.overlap.median_rotation_deg >= 0.5)
      return testing::AssertionFailure()
             << pair.a << "+" << pair.b << " off by " << pair.overlap.median_translation_m << " m, "
             << pair.overlap.median_rotation_deg << " deg";
  const double rigid =
      atlasTrajectoryError(pointers, placeOdometry(pointers, result.solution.T_atlas_session),
                           result.solution.connected);
  if (evaluation.ate_m > rigid + 0.02)
    return testing::AssertionFailure()
           << "ATE " << evaluation.ate_m << " m against " << rigid << " m for rigid odometry";
  return testing::AssertionSuccess();
}

TEST_F(MergeEndToEnd, SolvedAtlasAlignsEveryOverlap) {
  const auto& T = result_->solution.T_atlas_keyframe;
  EXPECT_TRUE(alignsEveryOverlap(*sessions_, T, *result_));
  // A chain of three 40 m windows: s0's drift carries over, and the IMU's attitude error tilts
  // each window (the raw odometry at the true frames: 0.24 m here, the atlas 0.53 m).
  const AtlasEvaluation evaluation =
      evaluateAtlas(pointersTo(*sessions_), T, result_->solution.connected);
  EXPECT_LT(evaluation.ate_m, 3.0 * evaluation.odometry_ate_m);

  // The same checks refuse a solution with the last session 0.3 m to the side, or one whose
  // keyframes zig-zag 0.3 m about the solved ones while the session frames stay put.
  auto shifted = T;
  for (Eigen::Isometry3d& pose : shifted[3]) pose.translation().y() += 0.3;
  EXPECT_FALSE(alignsEveryOverlap(*sessions_, shifted, *result_));
  auto bent = T;
  for (auto& trajectory : bent)
    for (std::size_t k = 0; k < trajectory.size(); ++k)
      trajectory[k].translation().y() += (k % 2 ? 0.3 : -0.3);
  EXPECT_FALSE(alignsEveryOverlap(*sessions_, bent, *result_));
}

TEST_F(MergeEndToEnd, AtlasDirectoryRoundTrips) {
  const fs::path dir =
      fs::temp_directory_path() / ("mm4mm_merge_test_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  std::vector<fs::path> sources;
  for (const Session& s : *sessions_) sources.push_back("/nowhere/" + s.id);
  AtlasOutputConfig outputs;
  outputs.octomap.resolution_m = 0.2;
  AtlasOutputs built = buildAtlasOutputs(*sessions_, *result_, outputs);
  ASSERT_TRUE(built.fused);
  // A region as the change score reports one, so that the report carries at least one.
  MagneticChangeRegion planted;
  planted.area_m2 = 3.25;
  planted.centroid_m = Eigen::Vector2d(12.125, -3.5);
  planted.mean_delta_uT = 4.75;
  planted.max_delta_uT = 9.0625;
  built.fused->changes.push_back({0, 1, 42.0, {planted}});
  built.fused->change_unchecked.back() = true;  // and a session left out of the comparison
  // Its cells in the change map: a pair compared every covered cell, and the planted region
  // holds a few of them.
  ChangeMap& cells = built.fused->change_map;
  ASSERT_EQ(cells.width, built.fused->map.width);
  std::size_t marked = 0;
  for (std::size_t i = 0; i < cells.pairs.size(); ++i)
    if (!std::isnan(built.fused->map.total_uT[i]) && cells.pairs[i] == 0) {
      cells.pairs[i] = 1;
      cells.chi2[i] = 0.5f;
      cells.delta_uT[i] = 0.25f;
      if (marked++ < 40) cells.region[i] = static_cast<std::uint32_t>(cells.region.size() % 7 + 1);
    }
  ASSERT_GT(cells.comparedCells(), 40u);
  std::map<std::string, std::string> pictures =
      atlasPictures(built.fused->map, built.placed.size());
  pictures["changes/magnetic_change.png"] =
      encodeChangePicture(cells.deltaMap(), MapRegionOverlay{cells.region, {planted.centroid_m}},
                          built.fused->changes.size());
  writeAtlas(dir / "atlas", *sessions_, sources, *result_, built, pictures);
  for (const char* name : {"atlas.yaml", "graph.g2o", "merged.pcd", "merged.ply",
                           "magnetic_map.pcd", "magnetic_map.png", "octomap.bt", "report.json",
                           "changes/magnetic_change.pcd", "changes/magnetic_change.png"})
    EXPECT_TRUE(fs::exists(dir / "atlas" / name)) << name;
  // The change map reads back as built, and the manifest vouches for both files.
  const ChangeMap read_cells = readChangeMapPcd(dir / "atlas" / "changes" / "magnetic_change.pcd");
  EXPECT_EQ(read_cells.pairs, cells.pairs);
  EXPECT_EQ(read_cells.region, cells.region);
  EXPECT_EQ(read_cells.origin_m, cells.origin_m);
  EXPECT_EQ(read_cells.height_m, cells.height_m);
  {
    const AtlasManifest listed = readAtlasManifest(dir / "atlas");
    for (const std::string name : {"changes/magnetic_change.pcd", "changes/magnetic_change.png"})
      EXPECT_TRUE(std::any_of(listed.files.begin(), listed.files.end(), [&](const auto& file) {
        return file.first == name;
      })) << name;
  }

  // The change section reads back as the fused map found it: every pair compared, each region.
  const ReportedChanges changes = readAtlasReportChanges(dir / "atlas" / "report.json");
  EXPECT_EQ(changes.pairs_compared, built.fused->changes.size());
  EXPECT_GT(changes.pairs_compared, 0u);
  std::size_t region = 0;
  for (const LayerChange& change : built.fused->changes)
    for (const MagneticChangeRegion& r : change.regions) {
      ASSERT_LT(region, changes.regions.size());
      const ReportedChanges::Region& read = changes.regions[region++];
      EXPECT_EQ(read.a, (*sessions_)[built.placed[change.a]].id);
      EXPECT_EQ(read.b, (*sessions_)[built.placed[change.b]].id);
      EXPECT_DOUBLE_EQ(read.region.area_m2, r.area_m2);
      EXPECT_DOUBLE_EQ(read.region.centroid_m.y(), r.centroid_m.y());
      EXPECT_DOUBLE_EQ(read.region.max_delta_uT, r.max_delta_uT);
    }
  EXPECT_EQ(region, changes.regions.size());
  // A merge compares the pairs of every placed session.
  std::vector<std::string> placed_ids;
  for (const int s : built.placed) placed_ids.push_back((*sessions_)[s].id);
  EXPECT_EQ(changes.pairs_of, placed_ids);
  EXPECT_EQ(changes.calibration_unchecked, std::vector<std::string>{placed_ids.back()});

  const AtlasManifest manifest = readAtlasManifest(dir / "atlas");
  ASSERT_EQ(manifest.sessions.size(), 4u);
  for (std::size_t s = 0; s < 4; ++s) {
    EXPECT_EQ(manifest.sessions[s].id, (*sessions_)[s].id);
    EXPECT_EQ(manifest.sessions[s].connected, result_->solution.connected[s]);
    EXPECT_TRUE(
        manifest.sessions[s].T_atlas_session.isApprox(result_->solution.T_atlas_session[s], 1e-9));
  }
  const auto trajectory = readTumPoses(dir / "atlas" / "trajectories" / "s1.txt");
  ASSERT_EQ(trajectory.size(), (*sessions_)[2].keyframes.size());
  EXPECT_TRUE(trajectory[7].T_frame_body.isApprox(result_->solution.T_atlas_keyframe[2][7], 1e-6));
  // graph.g2o: the kept inter-session edges, between the connected sessions' scan nodes.
  std::ifstream graph(dir / "atlas" / "graph.g2o");
  const std::string text((std::istreambuf_iterator<char>(graph)), std::istreambuf_iterator<char>());
  const std::size_t edges_start = text.find("# inter-session edges");
  ASSERT_NE(edges_start, std::string::npos);
  EXPECT_NE(text.find("EDGE_SE3:QUAT", edges_start), std::string::npos);
  EXPECT_EQ(text.find("mm4mm session graph s3"), std::string::npos);    // not connected
  EXPECT_FALSE(fs::exists(dir / "atlas" / "trajectories" / "s3.txt"));  // not connected

  std::ifstream report_file(dir / "atlas" / "report.json");
  const nlohmann::json report = nlohmann::json::parse(report_file);
  ASSERT_EQ(report["sessions"].size(), 4u);
  EXPECT_EQ(report["sessions"][1]["id"], "s3");
  EXPECT_EQ(report["sessions"][1]["connected"], false);
  ASSERT_EQ(report["pairs"].size(), 6u);
  EXPECT_EQ(report["pairs"][0]["a"], "s0");
  EXPECT_EQ(report["pairs"][0]["T_a_b"].size(), 4u);
  EXPECT_TRUE(report.contains("evaluation"));
  EXPECT_LT(report["evaluation"]["ate_m"].get<double>(), 1.0);
  // The field offsets the fused map applied: one per placed session, as built, B_v anchored on
  // the Earth's vertical field the simulated sessions state.
  const nlohmann::json& offsets = report["field_offsets"];
  ASSERT_EQ(offsets["sessions"].size(), built.placed.size());
  EXPECT_NE(offsets["anchor"].get<std::string>().find("Earth's vertical field"), std::string::npos)
      << offsets["anchor"];
  EXPECT_FALSE(offsets["pairs"].empty());
  for (std::size_t l = 0; l < built.placed.size(); ++l) {
    const nlohmann::json& entry = offsets["sessions"][l];
    EXPECT_EQ(entry["id"], (*sessions_)[built.placed[l]].id);
    EXPECT_EQ(entry["solved"].get<bool>(), static_cast<bool>(built.fused->offsets.linked[l]));
    EXPECT_TRUE(entry["earth_anchored"].get<bool>());
    EXPECT_DOUBLE_EQ(entry["vertical_uT"].get<double>(),
                     built.fused->offsets.offsets[l].vertical_uT);
  }

  // The picture render drew is the file io wrote, and the manifest vouches for it.
  std::ifstream png(dir / "atlas" / "magnetic_map.png", std::ios::binary);
  const std::string png_bytes((std::istreambuf_iterator<char>(png)),
                              std::istreambuf_iterator<char>());
  EXPECT_EQ(png_bytes, atlasPictures(built.fused->map, built.placed.size()).at("magnetic_map.png"));
  std::ifstream manifest_file(dir / "atlas" / "atlas.yaml");
  const std::string manifest_text((std::istreambuf_iterator<char>(manifest_file)),
                                  std::istreambuf_iterator<char>());
  EXPECT_NE(manifest_text.find("magnetic_map.png"), std::string::npos);

  // A picture may neither leave the atlas nor replace one of its files (it may go into changes/,
  // nowhere else below the atlas); the atlas stays as it was.
  for (const char* bad : {"../escape.png", "sub/x.png", "report.json", "..", "changes/../x.png",
                          "changes/", "changes/magnetic_change.pcd", "trajectories/s0.png"})
    EXPECT_THROW(writeAtlas(dir / "atlas", *sessions_, sources, *result_, built, {{bad, "x"}}),
                 std::invalid_argument)
        << bad;
  EXPECT_FALSE(fs::exists(dir / "escape.png"));
  EXPECT_TRUE(fs::exists(dir / "atlas" / "magnetic_map.png"));

  // Writing again over the atlas replaces it whole, here without the picture; no staging
  // directory is left behind.
  writeAtlas(dir / "atlas", *sessions_, sources, *result_, built);
  EXPECT_FALSE(fs::exists(dir / "atlas" / "magnetic_map.png"));
  int entries = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    (void)entry;
    ++entries;
  }
  EXPECT_EQ(entries, 1);
  fs::remove_all(dir);
}

// An add compares the new session with the others: the pairs with it, as comparing every pair
// finds them, and no other.
TEST_F(MergeEndToEnd, ChangesOfOneSessionAreItsPairsOfEveryPair) {
  std::vector<Session> placed;
  std::vector<std::vector<Eigen::Isometry3d>> poses;
  for (std::size_t s = 0; s < sessions_->size(); ++s)
    if (result_->solution.connected[s]) {
      placed.push_back((*sessions_)[s]);
      poses.push_back(result_->solution.T_atlas_keyframe[s]);
    }
  ASSERT_EQ(placed.size(), 3u);
  FusedMagneticMapConfig config;
  config.change.min_region_area_m2 =
      0.0;  // every changed cell makes a region, so some pair has one
  config.change.min_chi2 = 4.0;
  const FusedMagneticMap every = fuseMagneticMaps(placed, poses, config);
  std::vector<SessionFacts> facts(3);
  facts[0].compare_changes = facts[1].compare_changes = false;
  const FusedMagneticMap last = fuseMagneticMaps(placed, poses, config, facts);
  EXPECT_EQ(every.changes_of, std::vector<bool>(3, true));
  EXPECT_EQ(last.changes_of, (std::vector<bool>{false, false, true}));
  std::vector<const LayerChange*> with_last;
  for (const LayerChange& change : every.changes)
    if (change.b == 2) with_last.push_back(&change);
  ASSERT_FALSE(with_last.empty());
  ASSERT_LT(with_last.size(), every.changes.size());  // some pair does not involve the last
  ASSERT_EQ(last.changes.size(), with_last.size());
  std::size_t regions = 0;
  for (std::size_t k = 0; k < with_last.size(); ++k) {
    EXPECT_EQ(last.changes[k].a, with_last[k]->a);
    EXPECT_EQ(last.changes[k].b, 2);
    EXPECT_DOUBLE_EQ(last.changes[k].compared_m2, with_last[k]->compared_m2);
    ASSERT_EQ(last.changes[k].regions.size(), with_last[k]->regions.size());
    regions += last.changes[k].regions.size();
  }
  EXPECT_GT(regions, 0u);
  // The fused map itself does not depend on which pairs were compared.
  EXPECT_EQ(last.map.horizontal_uT.size(), every.map.horizontal_uT.size());
  EXPECT_TRUE(std::equal(
      last.map.horizontal_uT.begin(), last.map.horizontal_uT.end(), every.map.horizontal_uT.begin(),
      [](float x, float y) { return (std::isnan(x) && std::isnan(y)) || x == y; }));
  EXPECT_THROW(fuseMagneticMaps(placed, poses, config, {SessionFacts{}}), std::invalid_argument);

  // A session whose calibration could not check itself is compared with none, and said to be.
  std::vector<SessionFacts> unchecked(3);
  unchecked[2].calibration.checked = false;
  const FusedMagneticMap without = fuseMagneticMaps(placed, poses, config, unchecked);
  EXPECT_EQ(without.change_unchecked, (std::vector<bool>{false, false, true}));
  ASSERT_EQ(without.changes.size(), every.changes.size() - with_last.size());
  for (const LayerChange& change : without.changes) EXPECT_NE(change.b, 2);
}

TEST_F(MergeEndToEnd, ManifestErrorsNameTheFieldAndTheFile) {
  const fs::path dir =
      fs::temp_directory_path() / ("mm4mm_manifest_f_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "atlas.yaml") << "version: 2\nsettings:\n  octomap_resolution_m: "
                                       "0.1\nsessions:\n  - id: s0\n    source: /x\n";
  try {
    readAtlasManifest(dir);
    FAIL() << "no exception";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("session 's0': missing field 'connected'"),
              std::string::npos)
        << e.what();
  }
  fs::remove_all(dir);
}

TEST_F(MergeEndToEnd, ManifestFrameMustBeAConnectedSessionOfIt) {
  const fs::path dir =
      fs::temp_directory_path() / ("mm4mm_manifest_frame_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string identity = "    T_atlas_session: [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]\n";
  const auto refusal = [&](const std::string& frame) {
    std::ofstream(dir / "atlas.yaml") << "version: 3\n"
                                      << frame << "sessions:\n  - id: s0\n    source: /x\n"
                                      << "    connected: false\n"
                                      << identity << "  - id: s1\n    source: /y\n"
                                      << "    connected: true\n"
                                      << identity;
    try {
      readAtlasManifest(dir);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no exception");
  };
  EXPECT_NE(refusal("frame: s7\n")
                .find("atlas.yaml:2: 'frame' names session 's7', which is not "
                      "in 'sessions'"),
            std::string::npos)
      << refusal("frame: s7\n");
  EXPECT_NE(refusal("frame: s0\n")
                .find("session 's0', whose frame is the atlas's, is marked "
                      "unconnected"),
            std::string::npos)
      << refusal("frame: s0\n");
  // Without `frame` (an atlas written before it was stated) the first session's is the atlas's.
  EXPECT_NE(refusal("").find("session 's0', whose frame is the atlas's"), std::string::npos)
      << refusal("");
  // Named and connected: the reader goes on to the files.
  EXPECT_NE(refusal("frame: s1\n").find("missing field 'files'"), std::string::npos)
      << refusal("frame: s1\n");
  fs::remove_all(dir);
}

TEST_F(MergeEndToEnd, ManifestErrorsNameTheFile) {
  const fs::path dir = fs::temp_directory_path() / ("mm4mm_manifest_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "atlas.yaml")
      << "version: 2\nsettings:\n  octomap_resolution_m: 0.1\nsessions: []\n";
  try {
    readAtlasManifest(dir);
    FAIL() << "no exception";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("atlas.yaml"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("sessions"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

TEST(InterSessionEdges, LocalRefinementRecoversTheTrueRelativePoses) {
  const std::vector<Session> sessions = corridorSessions(false, 8);
  const Session& a = sessions[0];
  const Session& b = sessions[1];
  // Seed 0.3 m and 1° off the truth; each edge must land on the true keyframe-to-keyframe pose.
  const Eigen::Isometry3d seed =
      trueRelativeTransform(a, b) *
      Eigen::Isometry3d(Eigen::Translation3d(0.3, -0.2, 0.0) *
                        Eigen::AngleAxisd(M_PI / 180.0, Eigen::Vector3d::UnitZ()));
  const std::vector<InterSessionEdge> edges =
      interSessionEdges(a, 0, b, 1, seed, InterSessionEdgeConfig{});
  ASSERT_GE(edges.size(), 2u);
  for (const InterSessionEdge& edge : edges) {
    const Eigen::Isometry3d truth = (*a.ground_truth)[edge.keyframe_a].T_frame_body.inverse() *
                                    (*b.ground_truth)[edge.keyframe_b].T_frame_body;
    const Eigen::Isometry3d delta = edge.T_a_b * truth.inverse();
    EXPECT_LT(delta.translation().norm(), 0.05) << edge.keyframe_a << "-" << edge.keyframe_b;
    // Yaw from the scans to 0.3°; roll and pitch are the odometry's, whose IMU attitude errs by
    // up to 0.5° at each end.
    EXPECT_LT(std::abs(yawOf(delta.linear())) * 180.0 / M_PI, 0.3);
    EXPECT_LT(Eigen::AngleAxisd(delta.linear()).angle() * 180.0 / M_PI, 1.0);
    EXPECT_GT(edge.information.trace(), 0.0);
  }
}

// Seed 3 of the corridor preset: the magnetic match of s0+s1 is right but "ambiguous" (a second
// mode 13.5 m across the corridor correlates almost as well). Across the corridor the walls
// disagree, so the geometry settles it; along the corridor (one pillar pitch) it could not.
TEST(MergeSessionsEndToEnd, GeometrySettlesAMagneticallyAmbiguousPair) {
  const sim::SimulationConfig config =
      loadSimulationConfig(fs::path(MM4MM_SOURCE_DIR) / "configs" / "corridor.yaml");
  // Seed 3: s0 and s1 share about 78 m² of swath; a second credible magnetic mode across the
  // corridor reaches 0.73 of the best's z, ambiguous under a stricter second-mode rule.
  const std::vector<Session> sessions = calibrated(sim::simulateSessions(config, 3, 3));
  MergeConfig merge;
  merge.matcher.max_second_ratio = 0.6;
  merge.joint.enabled = false;  // ICP-EM from the field's modes, not the field at the walls' modes
  const MergeResult result = mergeSessions(sessions, merge);
  const PairResult& pair = result.pairs[0];
  ASSERT_EQ(pair.a, 0);
  ASSERT_EQ(pair.b, 1);
  ASSERT_EQ(pair.magnetic.verdict, MatchVerdict::kAmbiguous)
      << "the scenario no longer produces an ambiguous match; pick another seed";
  ASSERT_GE(pair.mode_inlier_ratios.size(), 2u);
  EXPECT_TRUE(pair.accepted);
  EXPECT_GE(pair.geometry_chosen_mode, 0);
  const OverlapError error =
      overlapError(sessions[0], sessions[1], result.solution.T_atlas_keyframe[0],
                   result.solution.T_atlas_keyframe[1]);
  EXPECT_TRUE(error.aligned()) << error.median_translation_m << " m";
  EXPECT_LT(error.median_translation_m, 0.05);

  MergeConfig magnetic_only = merge;
  magnetic_only.verify_ambiguous_with_geometry = false;
  magnetic_only.graph.use_magnetic_residuals = false;
  const MergeResult refused = mergeSessions(sessions, magnetic_only);
  EXPECT_FALSE(refused.pairs[0].accepted);
}

// A session without scans is placed by the field alone, whose transform is planar: its height
// comes from the floor the two frames share. s1's frame is 0.5 m above the floor (an odometry whose
// origin is at its sensor), as session.yaml states; s0's frame is on the floor.
TEST(MergeSessionsEndToEnd, AMagneticOnlySessionSitsAtItsFramesHeightAboveTheFloor) {
  std::vector<Session> sessions = corridorSessions(false, 5);
  Session& raised = sessions[1];
  raised.scans.clear();
  for (auto* poses : {&raised.keyframes, &raised.odometry})
    for (StampedPose& pose : *poses) pose.T_frame_body.translation().z() -= 0.5;
  raised.rig.frame_height_above_floor_m = 0.5;
  const MergeResult result = mergeSessions(sessions, MergeConfig{});
  ASSERT_EQ(result.frame_session, 0);
  ASSERT_TRUE(result.solution.connected[1]);
  EXPECT_NEAR(result.solution.T_atlas_session[1].translation().z(), 0.5, 0.05);
  for (const PairResult& pair : result.pairs)
    if (pair.accepted && pair.b == 1) {
      EXPECT_NEAR(pair.T_a_b.translation().z(), 0.5, 1e-9);
    }
  // Its magnetometers, 0.3 m above the floor as the others', are as high as theirs in the atlas.
  ASSERT_TRUE(result.magnetometer_heights_m[1]);
  EXPECT_NEAR(*result.magnetometer_heights_m[1], 0.3, 0.03);
}

// One magnetometer in a warehouse (tuning seed 1, sessions 1 and 2). Counting one sample per m²
// (the single-track default before the thin-overlap count), the field alone calls the pair
// ambiguous (a second mode close behind over an 8 m² swath); the walls propose a lattice of
// shifts one aisle apart, and at the true one the field correlates at r 0.84 where it reaches
// 0.57 at the next. Geometry proposes, the field decides, ICP-EM refines. Counting one sample
// per πℓ² (the default now), the field alone places it.
TEST(MergeSessionsEndToEnd, GeometryProposesAndTheFieldDecides) {
  sim::SimulationConfig config;  // warehouse, one IMU magnetometer, realistic sensors
  std::vector<Session> all = calibrated(sim::simulateSessions(config, 4, 1));
  const std::vector<Session> sessions{all[1], all[2]};
  MergeConfig per_m2;
  per_m2.matcher.single_track.area_per_sample_m2 = 1.0;
  per_m2.matcher.single_track.min_overlap_m2 = 4.0;
  per_m2.matcher.single_track.min_z = 2.5;
  per_m2.matcher.single_track.min_r = 0.825;
  const MergeResult result = mergeSessions(sessions, per_m2);
  const PairResult& pair = result.pairs.at(0);
  EXPECT_TRUE(pair.joint) << "field verdict " << toString(pair.magnetic.verdict);
  EXPECT_TRUE(pair.accepted);
  EXPECT_TRUE(pair.refined);
  EXPECT_GE(pair.magnetic.modes.size(), 2u);
  const OverlapError error = overlapError(sessions[0], sessions[1], pair.T_a_b);
  EXPECT_TRUE(error.aligned()) << error.median_translation_m << " m, " << error.median_rotation_deg
                               << " deg";
  EXPECT_LT(error.median_translation_m, 0.2);

  MergeConfig field_alone = per_m2;
  field_alone.joint.enabled = false;
  field_alone.verify_ambiguous_with_geometry = false;
  EXPECT_FALSE(mergeSessions(sessions, field_alone).pairs.at(0).accepted);

  MergeConfig field_alone_now;
  field_alone_now.joint.enabled = false;
  field_alone_now.verify_ambiguous_with_geometry = false;
  const PairResult now = mergeSessions(sessions, field_alone_now).pairs.at(0);
  EXPECT_TRUE(now.accepted) << "field verdict " << toString(now.magnetic.verdict);
  EXPECT_FALSE(now.joint);
  EXPECT_TRUE(overlapError(sessions[0], sessions[1], now.T_a_b).aligned());
}

// Four magnetic-only warehouse sessions of the paper's set-up (seed 3: every consecutive pair
// overlaps). Matched against the growing map, every session is placed with fewer matches than
// all pairs need, and every candidate pair that truly overlaps is placed within 1 m and 2°.
TEST(GrowingMapMatchingEndToEnd, PlacesEverySessionWithFewerMatchesThanAllPairs) {
  sim::SimulationConfig config;
  config.lidar.enabled = false;
  sim::applyRigPreset("array7", &config);
  // Clean sensors: this is about the growing map's bookkeeping; the matcher's accuracy on
  // realistic sensors is match_bench's.
  config.magnetometer_errors.model = "clean";
  std::vector<Session> sessions = sim::simulateSessions(config, 4, 3);
  const MagneticMatcherConfig matcher;
  calibrate(&sessions, matcher.calibration);
  std::vector<MagneticMap> maps;
  for (const Session& s : sessions)
    maps.push_back(buildMagneticMap(placeFingerprints(s), s.rig, matcher.map));
  GrowingMapConfig growing;
  growing.max_pairs_per_session = 0;
  const GrowingMapMatch result = matchAgainstGrowingMap(sessions, maps, matcher, growing);
  for (std::size_t s = 0; s < sessions.size(); ++s)
    EXPECT_TRUE(result.T_atlas_session[s].has_value()) << "session " << s;
  EXPECT_LT(result.matches, 6);
  int judged = 0;
  for (const CandidatePair& pair : result.pairs) {
    const Session& a = sessions[pair.a];
    const Session& b = sessions[pair.b];
    EXPECT_GE(pair.overlap_m2, growing.min_pair_overlap_m2);
    if (overlapError(a, b, trueRelativeTransform(a, b)).pairs < 10) continue;
    ++judged;
    // A pair's transform comes from placements through the growing map and seeds its ICP-EM
    // refinement, which converges from a metre off.
    const OverlapError error = overlapError(a, b, pair.T_a_b);
    EXPECT_LT(error.median_translation_m, 1.0) << pair.a << "+" << pair.b;
    EXPECT_LT(error.median_rotation_deg, 2.0) << pair.a << "+" << pair.b;
  }
  EXPECT_GE(judged, 3);

  growing.max_pairs_per_session = 1;
  const GrowingMapMatch capped = matchAgainstGrowingMap(sessions, maps, matcher, growing);
  EXPECT_LE(capped.pairs.size(), result.pairs.size());
  // One largest overlap per session plus one anchor per session after the first.
  EXPECT_LE(capped.pairs.size(), 2 * sessions.size() - 1);
  // Every session after the first keeps the pair that placed it, so the pairs connect them all.
  for (int s = 1; s < static_cast<int>(sessions.size()); ++s)
    EXPECT_TRUE(std::any_of(capped.pairs.begin(), capped.pairs.end(),
                            [&](const auto& p) { return p.anchor && (p.a == s || p.b == s); }))
        << "session " << s << " has no anchor pair";
}

TEST(MergeSessionsEndToEnd, GrowingMapMergeConnectsTheOverlappingCorridorSessions) {
  const std::vector<Session> sessions = corridorSessions(true, 5);
  MergeConfig config;
  config.pair_matching = PairMatching::kGrowingMap;
  const MergeResult result = mergeSessions(sessions, config);
  // A chain (each window overlaps only its neighbours) takes one pass per link.
  EXPECT_EQ(result.solution.connected, (std::vector<bool>{true, true, true, false}));
  for (int b = 1; b < 3; ++b) {
    const OverlapError error =
        overlapError(sessions[b - 1], sessions[b], result.solution.T_atlas_keyframe[b - 1],
                     result.solution.T_atlas_keyframe[b]);
    EXPECT_TRUE(error.aligned()) << b << ": " << error.median_translation_m << " m";
  }
}

TEST(MergeSessions, RejectsAnEmptySessionList) {
  EXPECT_THROW(mergeSessions({}, MergeConfig{}), std::invalid_argument);
}

}  // namespace
}  // namespace mm4mm
