// Degenerate but valid sessions get a clear answer, not a wrong map: a session without
// magnetometer readings and one that never moves cannot be matched magnetically, say why, and are
// placed by their walls (the geometry-only fallback) or, without it, left unconnected; the
// same recording under another id and a session that is a stretch of another are placed where
// they belong (at the identity here: they share the other's odometry frame).

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "calibrated_sessions.hpp"
#include "mm4mm/core/pose.hpp"
#include "mm4mm/io/atlas_io.hpp"
#include "mm4mm/io/config_io.hpp"
#include "mm4mm/io/session_io.hpp"
#include "mm4mm/merge/merge_sessions.hpp"
#include "mm4mm/sim/simulator.hpp"

namespace mm4mm {
namespace {

namespace fs = std::filesystem;

// The first `keyframes` keyframes of `session` with their scans, readings and ground truth.
Session firstStretch(const Session& session, std::size_t keyframes, const std::string& id) {
  Session stretch = session;
  stretch.id = id;
  stretch.keyframes.resize(keyframes);
  stretch.scans.resize(keyframes);
  stretch.ground_truth->resize(keyframes);
  const double end_s = stretch.keyframes.back().time_s;
  stretch.magnetometer.erase(
      std::remove_if(stretch.magnetometer.begin(), stretch.magnetometer.end(),
                     [&](const MagnetometerSample& sample) { return sample.time_s > end_s; }),
      stretch.magnetometer.end());
  stretch.odometry.erase(
      std::remove_if(stretch.odometry.begin(), stretch.odometry.end(),
                     [&](const StampedPose& pose) { return pose.time_s > end_s; }),
      stretch.odometry.end());
  return stretch;
}

TEST(DegenerateSessionsEndToEnd, EachGetsAClearAnswer) {
  const sim::SimulationConfig world =
      loadSimulationConfig(fs::path(MM4MM_SOURCE_DIR) / "configs" / "corridor_small.yaml");
  const Session s0 = calibrated(sim::simulateSessions(world, 1, 3)).front();

  Session no_readings = firstStretch(s0, s0.keyframes.size(), "no_readings");
  no_readings.magnetometer.clear();
  // Twenty keyframes at the first pose, each seeing the first scan, for the first 20 s.
  Session standing = firstStretch(s0, 20, "standing");
  for (std::size_t k = 0; k < standing.keyframes.size(); ++k) {
    standing.keyframes[k].T_frame_body = s0.keyframes[0].T_frame_body;
    (*standing.ground_truth)[k].T_frame_body = (*s0.ground_truth)[0].T_frame_body;
    standing.scans[k] = s0.scans[0];
  }
  for (StampedPose& pose : standing.odometry) pose.T_frame_body = s0.keyframes[0].T_frame_body;
  Session twin = s0;
  twin.id = "twin";
  const Session inside = firstStretch(s0, s0.keyframes.size() * 2 / 5, "inside");

  const std::vector<Session> sessions{s0, no_readings, standing, twin, inside};
  MergeConfig without_fallback;
  without_fallback.geometry_fallback = false;
  for (const MergeConfig& config : {MergeConfig{}, without_fallback}) {
    const MergeResult result = mergeSessions(sessions, config);
    ASSERT_EQ(result.match_obstacles.size(), sessions.size());
    using Reason = MatchObstacle::Reason;
    EXPECT_EQ(result.match_obstacles[0].reason, Reason::kNone);
    EXPECT_EQ(result.match_obstacles[1].reason, Reason::kNoReadings);
    EXPECT_NE(describe(result.match_obstacles[1]).find("no magnetometer readings"),
              std::string::npos);
    EXPECT_EQ(result.match_obstacles[2].reason, Reason::kTooLittleCoverage);
    EXPECT_NEAR(result.match_obstacles[2].travelled_m, 0.0, 0.05);
    EXPECT_LT(result.match_obstacles[2].covered_m2, result.match_obstacles[2].needed_m2);
    EXPECT_NE(describe(result.match_obstacles[2]).find("after 0.0 m of travel"), std::string::npos)
        << describe(result.match_obstacles[2]);
    // Their pairs (7 of the 10) are not matched magnetically; with the fallback, by their walls.
    EXPECT_EQ(result.magnetic_matches, 3);
    EXPECT_EQ(result.geometry_matches, config.geometry_fallback ? 7 : 0);
    // The twin and the stretch are always placed, by the field; the two that cannot be matched
    // magnetically only by their walls.
    for (int s = 1; s < static_cast<int>(sessions.size()); ++s) {
      const bool placed = s >= 3 || config.geometry_fallback;
      ASSERT_EQ(result.solution.connected[s], placed) << sessions[s].id;
      if (!placed) continue;
      // Each placed one is where it belongs: at the identity (they share s0's odometry frame).
      EXPECT_EQ(result.match_obstacles[s].any(), s < 3);
      const Eigen::Isometry3d& T = result.solution.T_atlas_session[s];
      EXPECT_LT(T.translation().norm(), 0.03) << sessions[s].id;
      EXPECT_LT(rotationAngle(T.linear()) * 180.0 / M_PI, 0.1) << sessions[s].id;
    }
  }
  const MergeResult result = mergeSessions(sessions, MergeConfig{});

  // The report says why, per session.
  const fs::path dir =
      fs::temp_directory_path() / ("mm4mm_degenerate_" + std::to_string(::getpid()));
  std::vector<fs::path> sources;
  for (const Session& s : sessions) {
    sources.push_back(dir / "sources" / s.id);
    writeSession(s, sources.back());
  }
  AtlasOutputConfig outputs;
  outputs.octomap.resolution_m = 0.3;
  writeAtlas(dir / "atlas", sessions, sources, result,
             buildAtlasOutputs(sessions, result, outputs));
  std::ifstream in(dir / "atlas" / "report.json");
  const nlohmann::json report = nlohmann::json::parse(in);
  EXPECT_EQ(report.at("sessions").at(1).at("not_matchable").get<std::string>(),
            describe(result.match_obstacles[1]));
  EXPECT_EQ(report.at("sessions").at(1).at("not_matchable_reason").get<std::string>(),
            "no_readings");
  EXPECT_FALSE(report.at("sessions").at(3).contains("not_matchable"));
  // s0 + no_readings: matched on structure maps and said so, never as a magnetic match.
  const nlohmann::json& by_walls = report.at("pairs").at(0);
  EXPECT_NE(by_walls.at("geometry_only").get<std::string>().find("no_readings cannot be matched"),
            std::string::npos);
  EXPECT_TRUE(by_walls.contains("structure_match"));
  EXPECT_FALSE(by_walls.contains("magnetic"));
  const nlohmann::json& by_field = report.at("pairs").at(2);  // s0 + twin
  EXPECT_FALSE(by_field.contains("geometry_only"));
  EXPECT_TRUE(by_field.contains("magnetic"));
  // The atlas reads its geometry-only pairs back as such (add needs them).
  const std::vector<PairResult> read_back = loadAtlas(dir / "atlas").pairs;
  ASSERT_EQ(read_back.size(), result.pairs.size());
  EXPECT_TRUE(read_back[0].geometry_only);
  EXPECT_FALSE(read_back[2].geometry_only);
  EXPECT_DOUBLE_EQ(read_back[0].magnetic.r, result.pairs[0].magnetic.r);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace mm4mm
