// The command line as a user meets it: exit codes and one clear message for bad input.

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include "mm4mm/io/atlas_io.hpp"
#include "mm4mm/io/config_io.hpp"
#include "mm4mm/io/session_io.hpp"
#include "test_support.hpp"

namespace {

namespace fs = std::filesystem;

using mm4mm::test::CliRun;
using mm4mm::test::runCli;

std::string readText(const fs::path& file) {
  std::ifstream in(file);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

class CliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("mm4mm_cli_test_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
            "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // A quick corridor scenario: two short sessions, coarse LiDAR.
  std::string writeQuickConfig() {
    const fs::path config = dir_ / "quick.yaml";
    std::ofstream(config) << "world: corridor\nlidar:\n  azimuth_step_deg: 6.0\n"
                             "layout:\n  window_spacing_m: 16.0\n  window_length_m: 16.0\n";
    return config.string();
  }

  // Short corridor sessions that share half their length, written to dir_/d (s0, s1, ...).
  int simulateOverlappingCorridor(int sessions, int seed) {
    const fs::path config = dir_ / "overlapping.yaml";
    std::ofstream(config) << "world: corridor\nlidar:\n  azimuth_step_deg: 3.0\n"
                             "layout:\n  window_spacing_m: 16.0\n  window_length_m: 32.0\n";
    return runCli("simulate --config " + config.string() + " --sessions " +
                  std::to_string(sessions) + " --seed " + std::to_string(seed) + " --out " +
                  (dir_ / "d").string())
        .exit_code;
  }

  fs::path dir_;
};

// The CLI tests that run whole merges: labelled slow (tests/CMakeLists.txt), not run sanitized.
class CliEndToEnd : public CliTest {};

TEST_F(CliTest, SimulateThenRenderSucceeds) {
  const CliRun simulate = runCli("simulate --config " + writeQuickConfig() +
                                 " --sessions 2 --seed 3 --out " + (dir_ / "d").string());
  ASSERT_EQ(simulate.exit_code, 0) << simulate.output;
  for (const char* id : {"s0", "s1"}) {
    for (const char* file : {"session.yaml", "poses.txt", "magnetometer.csv", "ground_truth.txt"})
      EXPECT_TRUE(fs::exists(dir_ / "d" / id / file)) << id << "/" << file;
    EXPECT_TRUE(fs::exists(dir_ / "d" / id / "scans" / "000000.pcd"));
  }
  const CliRun render =
      runCli("render " + (dir_ / "d" / "s0").string() + " --out " + (dir_ / "s0.png").string());
  ASSERT_EQ(render.exit_code, 0) << render.output;
  EXPECT_GT(fs::file_size(dir_ / "s0.png"), 1000u);
}

TEST_F(CliTest, MalformedPoseLineIsBadInputNamingFileAndLine) {
  ASSERT_EQ(runCli("simulate --config " + writeQuickConfig() + " --sessions 1 --out " +
                   (dir_ / "d").string())
                .exit_code,
            0);
  const fs::path poses = dir_ / "d" / "s0" / "poses.txt";
  std::ofstream(poses, std::ios::app) << "99999 1 2 3 0 0 0\n";  // 7 columns
  int lines = 0;
  {
    std::ifstream in(poses);
    std::string line;
    while (std::getline(in, line)) ++lines;
  }
  const CliRun render =
      runCli("render " + (dir_ / "d" / "s0").string() + " --out " + (dir_ / "x.png").string());
  EXPECT_EQ(render.exit_code, 2);
  EXPECT_NE(render.output.find("poses.txt:" + std::to_string(lines) + ":"), std::string::npos)
      << render.output;
  EXPECT_NE(render.output.find("error"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir_ / "x.png"));
}

TEST_F(CliTest, UnknownConfigKeyIsBadInputNamingTheKeyAndLine) {
  const fs::path config = dir_ / "typo.yaml";
  std::ofstream(config) << "world: corridor\nlidar:\n  azimuth_stepp_deg: 2.0\n";
  const CliRun run =
      runCli("simulate --config " + config.string() + " --out " + (dir_ / "d").string());
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.output.find("typo.yaml:3: unknown key 'lidar.azimuth_stepp_deg'"),
            std::string::npos)
      << run.output;
  EXPECT_FALSE(fs::exists(dir_ / "d" / "s0"));
  // Found by fuzz/fuzz_config.cpp: a complex key escaped as a yaml-cpp exception (exit 1).
  std::ofstream(config) << "lidar:\n  ? azimuth_step_deg: 1\n";
  const CliRun complex =
      runCli("simulate --config " + config.string() + " --out " + (dir_ / "d").string());
  EXPECT_EQ(complex.exit_code, 2) << complex.output;
  EXPECT_NE(complex.output.find("typo.yaml:2: 'lidar' has a key that is not a plain name"),
            std::string::npos)
      << complex.output;
}

TEST_F(CliTest, InvalidConfigValueIsBadInput) {
  const fs::path config = dir_ / "bad.yaml";
  std::ofstream(config) << "world: corridor\nrig:\n  magnetometer_count: 0\n";
  const CliRun run =
      runCli("simulate --config " + config.string() + " --out " + (dir_ / "d").string());
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.output.find("rig.magnetometer_count"), std::string::npos) << run.output;
}

TEST_F(CliTest, RenderOfSomethingThatIsNotASessionIsBadInput) {
  const CliRun run = runCli("render " + dir_.string() + " --out " + (dir_ / "x.png").string());
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.output.find("nor a session directory"), std::string::npos) << run.output;
}

TEST_F(CliTest, MergeOfAMissingSessionIsBadInputAndWritesNoAtlas) {
  // An existing directory that is not a session: the merge itself must refuse it.
  fs::create_directories(dir_ / "not_a_session");
  const CliRun run =
      runCli("merge " + (dir_ / "not_a_session").string() + " --out " + (dir_ / "atlas").string());
  EXPECT_EQ(run.exit_code, 2) << run.output;
  EXPECT_NE(run.output.find("not_a_session: not a session directory"), std::string::npos)
      << run.output;
  EXPECT_FALSE(fs::exists(dir_ / "atlas"));
}

TEST_F(CliTest, MergeThenEvalThenRenderAnAtlas) {
  ASSERT_EQ(simulateOverlappingCorridor(2, 3), 0);
  const std::string atlas = (dir_ / "atlas").string();
  const CliRun merge =
      runCli("merge " + (dir_ / "d" / "s0").string() + " " + (dir_ / "d" / "s1").string() +
             " --out " + atlas + " --octomap-resolution 0.3");
  ASSERT_EQ(merge.exit_code, 0) << merge.output;
  EXPECT_TRUE(fs::exists(dir_ / "atlas" / "octomap.bt"));
  const CliRun eval = runCli("eval " + atlas);
  ASSERT_EQ(eval.exit_code, 0) << eval.output;
  EXPECT_NE(eval.output.find("overlap error"), std::string::npos) << eval.output;
  EXPECT_NE(eval.output.find("ATE"), std::string::npos) << eval.output;
  // The solve's ATE beside the same odometry at the solve's frames and at the true ones.
  EXPECT_NE(eval.output.find("m after the solve"), std::string::npos) << eval.output;
  EXPECT_NE(eval.output.find("m for the raw odometry at the solve's session frames"),
            std::string::npos)
      << eval.output;
  EXPECT_NE(eval.output.find("m for the raw odometry at the true session frames"),
            std::string::npos)
      << eval.output;
  EXPECT_NE(eval.output.find("s0+s1:"), std::string::npos) << eval.output;  // both connected
  EXPECT_EQ(eval.output.find("NOT ALIGNED"), std::string::npos) << eval.output;

  // --out pointing at a session must not replace (delete) it.
  const CliRun clobber =
      runCli("merge " + (dir_ / "d" / "s0").string() + " " + (dir_ / "d" / "s1").string() +
             " --out " + (dir_ / "d" / "s1").string());
  EXPECT_EQ(clobber.exit_code, 2) << clobber.output;
  EXPECT_TRUE(fs::exists(dir_ / "d" / "s1" / "session.yaml"));

  // The same merge with the growing-map matching connects both sessions too.
  const std::string sessions = (dir_ / "d" / "s0").string() + " " + (dir_ / "d" / "s1").string();
  const CliRun growing = runCli("merge " + sessions + " --out " + (dir_ / "atlas2").string() +
                                " --octomap-resolution 0.3 --pair-matching growing");
  ASSERT_EQ(growing.exit_code, 0) << growing.output;
  EXPECT_NE(growing.output.find("s1: connected"), std::string::npos) << growing.output;
  const CliRun bogus = runCli("merge " + sessions + " --out " + (dir_ / "atlas3").string() +
                              " --pair-matching some");
  EXPECT_EQ(bogus.exit_code, 2) << bogus.output;
  EXPECT_NE(bogus.output.find("pair-matching"), std::string::npos) << bogus.output;
  EXPECT_FALSE(fs::exists(dir_ / "atlas3"));
  // `changes` reads what the merge found: the regions (none here), the pairs compared.
  const CliRun changes = runCli("changes " + atlas + " --png " + (dir_ / "changes.png").string());
  ASSERT_EQ(changes.exit_code, 0) << changes.output;
  EXPECT_NE(changes.output.find("region(s)"), std::string::npos) << changes.output;
  EXPECT_TRUE(fs::exists(dir_ / "changes.png"));
  const CliRun stranger = runCli("changes " + atlas + " --session s7");
  EXPECT_EQ(stranger.exit_code, 2) << stranger.output;
  EXPECT_NE(stranger.output.find("no session 's7' in the atlas (its sessions: s0, s1)"),
            std::string::npos)
      << stranger.output;
  const CliRun render = runCli("render " + atlas + " --out " + (dir_ / "atlas.png").string());
  ASSERT_EQ(render.exit_code, 0) << render.output;
  EXPECT_TRUE(fs::exists(dir_ / "atlas.png"));
  EXPECT_TRUE(fs::exists(dir_ / "atlas_magnetic.png"));
  // Where the two sessions disagree, before and after their field offsets, named in the output.
  for (const char* picture : {"atlas_seams_before.png", "atlas_seams_after.png"}) {
    EXPECT_TRUE(fs::exists(dir_ / picture)) << picture;
    EXPECT_NE(render.output.find(picture), std::string::npos) << render.output;
  }

  // add: s1 into an atlas of s0 connects it; adding it again is refused and changes nothing.
  const std::string grown = (dir_ / "grown").string();
  ASSERT_EQ(runCli("merge " + (dir_ / "d" / "s0").string() + " --out " + grown +
                   " --octomap-resolution 0.3")
                .exit_code,
            0);
  const CliRun add = runCli("add " + grown + " " + (dir_ / "d" / "s1").string());
  ASSERT_EQ(add.exit_code, 0) << add.output;
  EXPECT_NE(add.output.find("s1: connected"), std::string::npos) << add.output;
  // The add compared the new session's pairs for change, and said so.
  EXPECT_EQ(mm4mm::readAtlasReportChanges(dir_ / "grown" / "report.json").pairs_of,
            std::vector<std::string>{"s1"});
  EXPECT_NE(add.output.find("pair(s) of sessions with s1 compared"), std::string::npos)
      << add.output;
  const auto manifest = [&] {
    std::ifstream in(dir_ / "grown" / "atlas.yaml");
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  const std::string before = manifest();
  EXPECT_DOUBLE_EQ(mm4mm::readAtlasManifest(dir_ / "grown").config.outputs.octomap.resolution_m,
                   0.3);
  const CliRun again = runCli("add " + grown + " " + (dir_ / "d" / "s1").string());
  EXPECT_EQ(again.exit_code, 2) << again.output;
  EXPECT_NE(again.output.find("already in the atlas"), std::string::npos) << again.output;
  EXPECT_EQ(manifest(), before);
}

// Two overlapping sessions listed after one from another building: the atlas is the first one's
// frame, so they stay out, and `merge` says that they overlap each other and which order would
// build the atlas from them, not that they matched nothing.
// A first session from another corridor matches nothing: the atlas is built from the two that
// overlap, in the frame of the first of them, and evaluated against it.
TEST_F(CliEndToEnd, AFirstSessionThatMatchesNothingDoesNotLeaveTheOthersOut) {
  ASSERT_EQ(simulateOverlappingCorridor(2, 3), 0);
  ASSERT_EQ(runCli("simulate --config " + writeQuickConfig() + " --sessions 4 --seed 99 --out " +
                   (dir_ / "e").string())
                .exit_code,
            0);
  const fs::path atlas = dir_ / "atlas";
  const CliRun merge = runCli("merge " + (dir_ / "e" / "s2").string() + " " +
                              (dir_ / "d" / "s0").string() + " " + (dir_ / "d" / "s1").string() +
                              " --out " + atlas.string() + " --octomap-resolution 0.3");
  ASSERT_EQ(merge.exit_code, 0) << merge.output;
  EXPECT_NE(merge.output.find(
                "atlas frame: s0's (s2 is not in the largest group of sessions that overlap)"),
            std::string::npos)
      << merge.output;
  EXPECT_NE(merge.output.find("s0: connected"), std::string::npos) << merge.output;
  EXPECT_NE(merge.output.find("s1: connected"), std::string::npos) << merge.output;
  EXPECT_NE(merge.output.find("s2: not connected (matches no session)"), std::string::npos)
      << merge.output;
  std::ifstream in(atlas / "report.json");
  const nlohmann::json report = nlohmann::json::parse(in);
  EXPECT_EQ(report.at("frame"), "s0");
  EXPECT_FALSE(report.at("sessions").at(0).at("connected").get<bool>());
  // s0's frame is the atlas's: its first keyframe stays at its odometry pose.
  const nlohmann::json& T = report.at("sessions").at(1).at("T_atlas_session");
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) EXPECT_NEAR(T.at(r).at(c).get<double>(), r == c ? 1.0 : 0.0, 1e-9);
  const CliRun eval = runCli("eval " + atlas.string());
  ASSERT_EQ(eval.exit_code, 0) << eval.output;
  EXPECT_NE(eval.output.find("frame against s0"), std::string::npos) << eval.output;
  EXPECT_NE(eval.output.find("s0+s1:"), std::string::npos) << eval.output;
  EXPECT_EQ(eval.output.find("NOT ALIGNED"), std::string::npos) << eval.output;
  EXPECT_NE(eval.output.find("s2: not connected"), std::string::npos) << eval.output;
  // An add keeps the atlas's frame, whatever the new session joins.
  const std::string s0_trajectory = readText(atlas / "trajectories" / "s0.txt");
  const CliRun add = runCli("add " + atlas.string() + " " + (dir_ / "e" / "s3").string());
  ASSERT_EQ(add.exit_code, 0) << add.output;
  EXPECT_NE(readText(atlas / "atlas.yaml").find("frame: s0\n"), std::string::npos);
  EXPECT_NE(add.output.find("s0: connected"), std::string::npos) << add.output;
  EXPECT_NE(add.output.find("s1: connected"), std::string::npos) << add.output;
  EXPECT_EQ(readText(atlas / "trajectories" / "s0.txt").substr(0, 60), s0_trajectory.substr(0, 60));
}

// A session carried by hand reads the field 0.8 m above the robots': not searched by the field
// alone, and said so with the heights, in the merge's lines and in report.json.
TEST_F(CliEndToEnd, SessionsAtDifferentHeightsAreNotSearchedByTheFieldAlone) {
  ASSERT_EQ(simulateOverlappingCorridor(2, 3), 0);
  const fs::path config = dir_ / "handheld.yaml";
  std::ofstream(config) << "world: corridor\nlidar:\n  azimuth_step_deg: 3.0\n"
                           "layout:\n  window_spacing_m: 16.0\n  window_length_m: 32.0\n"
                           "rig:\n  preset: handheld\n";
  ASSERT_EQ(runCli("simulate --config " + config.string() + " --sessions 3 --seed 3 --out " +
                   (dir_ / "h").string())
                .exit_code,
            0);
  // The handheld session does not state its frame's height: its scans show the floor.
  const fs::path handheld_yaml = dir_ / "h" / "s2" / "session.yaml";
  std::string yaml = readText(handheld_yaml);
  const std::size_t stated = yaml.find("frame_height_above_floor_m: 0\n");
  ASSERT_NE(stated, std::string::npos);
  yaml.erase(stated, std::string("frame_height_above_floor_m: 0\n").size());
  std::ofstream(handheld_yaml) << yaml;
  // The two-session diagnostic keeps the same rule, and says how to lift it.
  const std::string pair = (dir_ / "d" / "s0").string() + " " + (dir_ / "h" / "s2").string();
  const CliRun match = runCli("match " + pair);
  EXPECT_EQ(match.exit_code, 3) << match.output;
  EXPECT_NE(match.output.find("not compared: s2's magnetometers are 0."), std::string::npos)
      << match.output;
  EXPECT_NE(match.output.find("m above s0's"), std::string::npos) << match.output;
  const CliRun anyway = runCli("match --across-heights " + pair);
  EXPECT_EQ(anyway.output.find("not compared"), std::string::npos) << anyway.output;
  EXPECT_NE(anyway.output.find("second mode ratio"), std::string::npos) << anyway.output;

  const fs::path atlas = dir_ / "atlas";
  const CliRun merge = runCli("merge " + (dir_ / "d" / "s0").string() + " " +
                              (dir_ / "d" / "s1").string() + " " + (dir_ / "h" / "s2").string() +
                              " --out " + atlas.string() + " --octomap-resolution 0.3");
  ASSERT_EQ(merge.exit_code, 0) << merge.output;
  EXPECT_NE(merge.output.find("s0: connected"), std::string::npos) << merge.output;
  EXPECT_NE(merge.output.find("m above s0's (heights above the floor from the scans of s2), and "
                              "the field alone is not searched across more than 0.20 m of height"),
            std::string::npos)
      << merge.output;
  std::ifstream in(atlas / "report.json");
  const nlohmann::json report = nlohmann::json::parse(in);
  int compared_across_heights = 0;
  for (const nlohmann::json& pair : report.at("pairs")) {
    if (pair.at("b") != "s2") {
      EXPECT_FALSE(pair.contains("height_difference_m")) << pair.dump();
      continue;
    }
    ASSERT_TRUE(pair.contains("height_difference_m")) << pair.dump();
    EXPECT_NEAR(pair.at("height_difference_m").get<double>(), -0.8, 0.05);
    ++compared_across_heights;
  }
  EXPECT_EQ(compared_across_heights, 2);
  const nlohmann::json& sessions = report.at("sessions");
  ASSERT_EQ(sessions.size(), 3u);
  EXPECT_EQ(sessions[0].at("frame_height_from"), "stated");
  EXPECT_EQ(sessions[2].at("frame_height_from"), "scans");
  EXPECT_NEAR(sessions[2].at("frame_height_above_floor_m").get<double>(), 0.0, 0.05);
  EXPECT_NEAR(sessions[2].at("magnetometer_height_above_floor_m").get<double>(), 1.1, 0.05);
  EXPECT_NEAR(sessions[0].at("magnetometer_height_above_floor_m").get<double>(), 0.3, 0.05);
}

TEST_F(CliEndToEnd, TheSameInputsGiveTheSameAtlasWithAnyThreadCount) {
  // Three corridor sessions, the first two overlapping: matching, ICP-EM, the solve and every
  // output run, with one worker thread and with up to three (every core of this 2-core machine).
  ASSERT_EQ(simulateOverlappingCorridor(3, 4), 0);
  std::string sessions;
  for (const char* id : {"s0", "s1", "s2"}) sessions += (dir_ / "d" / id).string() + " ";
  for (const char* threads : {"1", "3"}) {
    const CliRun merge =
        runCli("merge " + sessions + "--octomap-resolution 0.3 --out " +
               (dir_ / (std::string("t") + threads)).string() + " --threads " + threads);
    ASSERT_EQ(merge.exit_code, 0) << merge.output;
  }
  const auto read = [](const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  int compared = 0;
  for (const auto& entry : fs::recursive_directory_iterator(dir_ / "t1")) {
    if (!entry.is_regular_file()) continue;
    const fs::path relative = fs::relative(entry.path(), dir_ / "t1");
    if (relative == "timings.json") continue;  // wall-clock seconds, the one file that differs
    if (relative == "atlas.yaml") {            // the same but for the checksum of timings.json
      const auto withoutTimings = [&](const fs::path& file) {
        std::string text = read(file);
        const std::size_t line = text.find("timings.json:");
        EXPECT_NE(line, std::string::npos);
        return text.erase(line, text.find('\n', line) - line);
      };
      EXPECT_EQ(withoutTimings(entry.path()), withoutTimings(dir_ / "t3" / relative));
    } else {
      EXPECT_TRUE(read(entry.path()) == read(dir_ / "t3" / relative)) << relative;
    }
    ++compared;
  }
  EXPECT_GE(compared, 10);  // report.json, the manifest, 3 trajectories, graph, clouds, maps
  EXPECT_TRUE(fs::exists(dir_ / "t3" / "timings.json"));
  const nlohmann::json report = nlohmann::json::parse(read(dir_ / "t1" / "report.json"));
  EXPECT_TRUE(report.at("sessions").at(1).at("connected").get<bool>());  // a real merge ran
  EXPECT_EQ(runCli("--threads 0 merge " + sessions + "--out " + (dir_ / "t0").string()).exit_code,
            2);
}

TEST_F(CliTest, EvalOfADirectoryWithoutManifestNamesTheFile) {
  const CliRun run = runCli("eval " + dir_.string());
  EXPECT_EQ(run.exit_code, 2) << run.output;
  EXPECT_NE(run.output.find("not an atlas directory (no atlas.yaml)"), std::string::npos)
      << run.output;
}

TEST_F(CliTest, MissingRequiredOptionAndUnknownWorldAreBadInput) {
  EXPECT_EQ(runCli("simulate --world warehouse").exit_code, 2);
  const CliRun run = runCli("simulate --world moon --out " + dir_.string());
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.output.find("moon"), std::string::npos) << run.output;
}

// Two magnetic-only warehouse sessions that overlap (the paper's set-up, seed 11 overlaps well)
// and a third that overlaps neither.
TEST_F(CliEndToEnd, MatchPrintsJsonAndSaysNoOverlapWithExitCode3) {
  const fs::path config = dir_ / "mag.yaml";
  std::ofstream(config) << "world: warehouse\nlidar:\n  enabled: false\n"
                           "layout:\n  route_length_m: 200.0\n  disjoint_session: true\n";
  const fs::path d = dir_ / "d";
  ASSERT_EQ(
      runCli("simulate --config " + config.string() + " --sessions 3 --seed 11 --out " + d.string())
          .exit_code,
      0);
  EXPECT_FALSE(fs::exists(d / "s0" / "scans"));
  const CliRun match =
      runCli("match " + (d / "s0").string() + " " + (d / "s1").string() + " --json");
  ASSERT_EQ(match.exit_code, 0) << match.output;
  const auto json = nlohmann::json::parse(match.output);
  EXPECT_TRUE(json.at("overlap").get<bool>());
  ASSERT_EQ(json.at("T_a_b").size(), 4u);
  EXPECT_EQ(json.at("T_a_b")[3], nlohmann::json::parse("[0.0, 0.0, 0.0, 1.0]"));
  // The paper's set-up: s1 starts 0.2 m from s0 facing the other way.
  EXPECT_NEAR(json.at("T_a_b")[0][0].get<double>(), -1.0, 0.01);
  EXPECT_NEAR(json.at("T_a_b")[0][3].get<double>(), 0.2, 0.5);
  for (const char* key : {"fitness", "confidence", "seconds", "z", "overlap_m2"})
    EXPECT_TRUE(json.contains(key)) << key;

  const CliRun disjoint =
      runCli("match " + (d / "s0").string() + " " + (d / "s2").string() + " --json");
  EXPECT_EQ(disjoint.exit_code, 3) << disjoint.output;
  EXPECT_FALSE(nlohmann::json::parse(disjoint.output).at("overlap").get<bool>());
}

TEST_F(CliTest, ConfigDumpPrintsTheDefaultsAndTheEffectiveConfigOfAFile) {
  const CliRun defaults = runCli("config --dump");
  ASSERT_EQ(defaults.exit_code, 0) << defaults.output;
  EXPECT_EQ(defaults.output, mm4mm::pipelineConfigYaml(mm4mm::PipelineConfig{}));
  const fs::path file = dir_ / "c.yaml";
  std::ofstream(file) << "merge:\n  matcher:\n    min_z: 7.5\n";
  const CliRun effective = runCli("config --dump --config " + file.string());
  ASSERT_EQ(effective.exit_code, 0) << effective.output;
  EXPECT_NE(effective.output.find("\n    min_z: 7.5\n"), std::string::npos) << effective.output;
  std::ofstream(dir_ / "dump.yaml") << effective.output;
  EXPECT_EQ(runCli("config --dump --config " + (dir_ / "dump.yaml").string()).output,
            effective.output);
  std::ofstream(file) << "merge:\n  matcher:\n    min_r: 2\n";
  const CliRun invalid = runCli("config --config " + file.string());
  EXPECT_EQ(invalid.exit_code, 2) << invalid.output;
  EXPECT_NE(invalid.output.find("c.yaml:3: merge.matcher.min_r must be in (-1, 1)"),
            std::string::npos)
      << invalid.output;
  // match and map read the same file's merge.matcher; a matcher file of before is said to be one.
  std::ofstream(file) << "confidence:\n  min_z: 8.0\n";
  const CliRun old = runCli("match " + (dir_ / "a").string() + " " + (dir_ / "b").string() +
                            " --config " + file.string());
  EXPECT_EQ(old.exit_code, 2) << old.output;
  EXPECT_NE(old.output.find("a matcher file of the old format"), std::string::npos) << old.output;
}

TEST_F(CliEndToEnd, AnAtlasKeepsItsSettingsAndAddRunsWithThem) {
  ASSERT_EQ(simulateOverlappingCorridor(4, 3), 0);
  const auto session = [&](int s) { return (dir_ / "d" / ("s" + std::to_string(s))).string(); };
  const fs::path atlas = dir_ / "atlas";
  const fs::path merge_config = dir_ / "merge.yaml";
  std::ofstream(merge_config) << "merge:\n  matcher:\n    min_z: 7.5\n  graph:\n"
                                 "    magnetic_stride_m: 0.75\n";
  const CliRun merge =
      runCli("merge " + session(0) + " --out " + atlas.string() + " --config " +
             merge_config.string() + " --octomap-resolution 0.25 --no-magnetic-residuals");
  ASSERT_EQ(merge.exit_code, 0) << merge.output;
  // The file's settings and the flags' end up in the atlas.
  const auto expectMergeSettings = [&](const std::string& when) {
    const mm4mm::AtlasManifest manifest = mm4mm::readAtlasManifest(atlas);
    EXPECT_TRUE(manifest.config_stored) << when;
    EXPECT_EQ(manifest.config.merge.matcher.min_z, 7.5) << when;
    EXPECT_EQ(manifest.config.merge.graph.magnetic_stride_m, 0.75) << when;
    EXPECT_FALSE(manifest.config.merge.graph.use_magnetic_residuals) << when;
    EXPECT_EQ(manifest.config.outputs.octomap.resolution_m, 0.25) << when;
    EXPECT_NE(readText(atlas / "octomap.bt").find("\nres 0.25\n"), std::string::npos) << when;
  };
  expectMergeSettings("after merge");

  // add without --config runs with them, and says nothing about settings.
  const CliRun add = runCli("add " + atlas.string() + " " + session(1) + " --octomap");
  ASSERT_EQ(add.exit_code, 0) << add.output;
  EXPECT_NE(add.output.find("s1: connected"), std::string::npos) << add.output;
  EXPECT_EQ(add.output.find("settings"), std::string::npos) << add.output;
  expectMergeSettings("after add");

  // add --config runs with the file's settings instead, and says so.
  const fs::path add_config = dir_ / "add.yaml";
  std::ofstream(add_config) << "merge:\n  matcher:\n    min_z: 7.0\noutputs:\n  octomap:\n"
                               "    resolution_m: 0.2\n";
  const CliRun other =
      runCli("add " + atlas.string() + " " + session(2) + " --config " + add_config.string());
  ASSERT_EQ(other.exit_code, 0) << other.output;
  EXPECT_NE(other.output.find("this add runs with the settings of " + add_config.string() +
                              ", not those " + atlas.string() + " was built with"),
            std::string::npos)
      << other.output;
  mm4mm::AtlasManifest manifest = mm4mm::readAtlasManifest(atlas);
  EXPECT_EQ(manifest.config.merge.matcher.min_z, 7.0);
  EXPECT_TRUE(manifest.config.merge.graph.use_magnetic_residuals);
  EXPECT_EQ(manifest.config.outputs.octomap.resolution_m, 0.2);

  // An atlas of before (version 2: no config.yaml, the OctoMap resolution in its manifest) loads
  // as the defaults with that resolution, and add says so.
  std::string text = readText(atlas / "atlas.yaml");
  text.replace(text.find("version: 3\n"), 11,
               "version: 2\nsettings:\n  octomap_resolution_m: 0.2\n");
  const std::size_t listed = text.find("  config.yaml: ");
  ASSERT_NE(listed, std::string::npos) << text;
  text.erase(listed, text.find('\n', listed) + 1 - listed);
  std::ofstream(atlas / "atlas.yaml") << text;
  fs::remove(atlas / "config.yaml");
  manifest = mm4mm::readAtlasManifest(atlas);
  EXPECT_FALSE(manifest.config_stored);
  EXPECT_EQ(manifest.config.outputs.octomap.resolution_m, 0.2);
  EXPECT_EQ(manifest.config.merge.matcher.min_z, mm4mm::MagneticMatcherConfig{}.min_z);
  const CliRun old = runCli("add " + atlas.string() + " " + session(3));
  ASSERT_EQ(old.exit_code, 0) << old.output;
  EXPECT_NE(old.output.find("written before atlases kept their settings: running with the "
                            "defaults and its OctoMap resolution (0.2 m)"),
            std::string::npos)
      << old.output;
  manifest = mm4mm::readAtlasManifest(atlas);
  EXPECT_TRUE(manifest.config_stored);
  EXPECT_EQ(manifest.config.merge.matcher.min_z, mm4mm::MagneticMatcherConfig{}.min_z);
  EXPECT_EQ(manifest.config.outputs.octomap.resolution_m, 0.2);
  // Built on request at the resolution of the settings the atlas now holds.
  EXPECT_FALSE(fs::exists(atlas / "octomap.bt"));
  const CliRun exported = runCli("export octomap " + atlas.string());
  ASSERT_EQ(exported.exit_code, 0) << exported.output;
  EXPECT_NE(readText(atlas / "octomap.bt").find("\nres 0.2\n"), std::string::npos);
}

// add leaves the OctoMap out unless asked, so an atlas never holds one of older poses; export
// builds it at the atlas's poses, into the atlas (listed in the manifest, every other file as it
// was) or to a file of its own.
TEST_F(CliEndToEnd, TheOctoMapOfAnAtlasIsBuiltOnRequest) {
  ASSERT_EQ(simulateOverlappingCorridor(3, 3), 0);
  const auto session = [&](int s) { return (dir_ / "d" / ("s" + std::to_string(s))).string(); };
  const fs::path atlas = dir_ / "atlas";
  const auto files = [&] {
    std::map<std::string, std::string> content;
    for (const auto& entry : fs::recursive_directory_iterator(atlas))
      if (entry.is_regular_file())
        content[fs::relative(entry.path(), atlas).string()] = readText(entry.path());
    return content;
  };
  const CliRun merge = runCli("merge " + session(0) + " " + session(1) + " --out " +
                              atlas.string() + " --octomap-resolution 0.3");
  ASSERT_EQ(merge.exit_code, 0) << merge.output;
  const std::string merged_octomap = readText(atlas / "octomap.bt");
  ASSERT_FALSE(merged_octomap.empty());

  // From the poses the atlas stores, the merge's own OctoMap, byte for byte.
  const fs::path elsewhere = dir_ / "elsewhere.bt";
  CliRun run = runCli("export octomap " + atlas.string() + " --out " + elsewhere.string());
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_EQ(readText(elsewhere), merged_octomap);
  EXPECT_NE(run.output.find("octomap of "), std::string::npos) << run.output;
  run = runCli("export octomap " + atlas.string() + " --out " + elsewhere.string() +
               " --resolution 0.6");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(readText(elsewhere).find("\nres 0.6\n"), std::string::npos);
  EXPECT_LT(readText(elsewhere).size(), merged_octomap.size());

  const CliRun add = runCli("add " + atlas.string() + " " + session(2));
  ASSERT_EQ(add.exit_code, 0) << add.output;
  EXPECT_NE(add.output.find("s2: connected"), std::string::npos) << add.output;
  EXPECT_NE(add.output.find("octomap.bt left out"), std::string::npos) << add.output;
  EXPECT_NE(add.output.find("mm4mm export octomap " + atlas.string()), std::string::npos)
      << add.output;
  EXPECT_FALSE(fs::exists(atlas / "octomap.bt"));
  EXPECT_EQ(mm4mm::readAtlasManifest(atlas).files.size(), files().size() - 1);  // all but itself

  const auto before = files();
  run = runCli("export octomap " + atlas.string());
  ASSERT_EQ(run.exit_code, 0) << run.output;
  auto after = files();
  ASSERT_EQ(after.count("octomap.bt"), 1u);
  const std::string octomap = after["octomap.bt"];
  EXPECT_NE(octomap.find("\nres 0.3\n"), std::string::npos);
  EXPECT_GT(octomap.size(), merged_octomap.size());  // three sessions' scans, not two
  after.erase("octomap.bt");
  after.erase("atlas.yaml");
  auto unchanged = before;
  unchanged.erase("atlas.yaml");
  EXPECT_TRUE(after == unchanged) << "export changed a file other than octomap.bt";
  const mm4mm::AtlasManifest manifest = mm4mm::readAtlasManifest(atlas);  // every checksum
  EXPECT_EQ(manifest.sessions.size(), 3u);
  EXPECT_TRUE(std::any_of(manifest.files.begin(), manifest.files.end(),
                          [](const auto& file) { return file.first == "octomap.bt"; }));
  // The same atlas exported again: the same file (the build is deterministic).
  run = runCli("export octomap " + atlas.string() + " --out " + elsewhere.string());
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_EQ(readText(elsewhere), octomap);
  for (const auto& entry : fs::directory_iterator(dir_))
    EXPECT_EQ(entry.path().filename().string().find("atlas.partial"), std::string::npos)
        << entry.path();

  // Refused, with the atlas as it was: a file inside the atlas, a resolution for the atlas's own
  // file, a directory that is no atlas.
  const auto whole = files();
  run = runCli("export octomap " + atlas.string() + " --out " + (atlas / "x.bt").string());
  EXPECT_EQ(run.exit_code, 2) << run.output;
  EXPECT_NE(run.output.find("is inside the atlas"), std::string::npos) << run.output;
  run = runCli("export octomap " + atlas.string() + " --resolution 0.5");
  EXPECT_EQ(run.exit_code, 2) << run.output;
  EXPECT_NE(run.output.find("--resolution needs --out"), std::string::npos) << run.output;
  EXPECT_TRUE(files() == whole);
  run = runCli("export octomap " + session(0));
  EXPECT_EQ(run.exit_code, 2) << run.output;
  EXPECT_NE(run.output.find("atlas.yaml"), std::string::npos) << run.output;
  EXPECT_FALSE(fs::exists(session(0) + ".lock"));
}

// Inputs whose estimated peak memory exceeds the limit are refused before any is read whole, with
// the figure: the scan points and magnetometer rows counted from the files' headers, as the
// sessions hold them. Nothing is written, no lock is taken, an atlas is left as it was.
TEST_F(CliEndToEnd, InputsTooLargeForTheMemoryAreRefusedUpFrontWithTheFigure) {
  ASSERT_EQ(simulateOverlappingCorridor(3, 3), 0);
  const auto session = [&](int s) { return (dir_ / "d" / ("s" + std::to_string(s))).string(); };
  std::size_t points = 0, rows = 0;
  for (int s = 0; s < 2; ++s) {
    const mm4mm::Session read = mm4mm::readSession(session(s));
    for (const auto& scan : read.scans) points += scan.size();
    rows += read.magnetometer.size();
  }
  ASSERT_GT(points, 0u);
  const std::string counts = "(" + std::to_string(points) + " scan points, " +
                             std::to_string(rows) + " magnetometer rows)";
  const fs::path atlas = dir_ / "atlas";
  CliRun run = runCli("merge " + session(0) + " " + session(1) + " --out " + atlas.string() +
                      " --memory-limit 0.2");
  EXPECT_EQ(run.exit_code, 6) << run.output;
  EXPECT_NE(run.output.find("mm4mm: error: merging 2 sessions needs about "), std::string::npos)
      << run.output;
  EXPECT_NE(run.output.find(counts), std::string::npos) << counts << "\n" << run.output;
  EXPECT_NE(run.output.find("more than --memory-limit 0.2 GiB"), std::string::npos) << run.output;
  EXPECT_EQ(run.output.find("read s0"), std::string::npos) << run.output;  // refused before
  EXPECT_FALSE(fs::exists(atlas));
  EXPECT_FALSE(fs::exists(atlas.string() + ".lock"));

  run = runCli("merge " + session(0) + " " + session(1) + " --out " + atlas.string());
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("merging 2 sessions needs about "), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("this system has available"), std::string::npos) << run.output;
  const std::string manifest = readText(atlas / "atlas.yaml");
  run = runCli("add " + atlas.string() + " " + session(2) + " --memory-limit 0.2");
  EXPECT_EQ(run.exit_code, 6) << run.output;
  EXPECT_NE(run.output.find("adding a session to 2 in the atlas needs about "), std::string::npos)
      << run.output;
  EXPECT_EQ(readText(atlas / "atlas.yaml"), manifest);
  run = runCli("merge " + session(0) + " --out " + atlas.string() + " --memory-limit 0");
  EXPECT_EQ(run.exit_code, 2) << run.output;  // a limit must be positive
}

TEST_F(CliTest, HelpListsTheCommands) {
  const CliRun run = runCli("--help");
  EXPECT_EQ(run.exit_code, 0);
  EXPECT_NE(run.output.find("simulate"), std::string::npos);
  EXPECT_NE(run.output.find("render"), std::string::npos);
  EXPECT_NE(run.output.find("config"), std::string::npos);
  EXPECT_NE(run.output.find("changes"), std::string::npos);
}

}  // namespace
