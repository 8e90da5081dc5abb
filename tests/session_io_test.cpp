#include "mm4mm/io/session_io.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "mm4mm/io/input_error.hpp"
#include "mm4mm/io/pcd_io.hpp"
#include "mm4mm/io/tum_io.hpp"
#include "test_support.hpp"

namespace mm4mm {
namespace {

namespace fs = std::filesystem;

// A fresh directory per test.
struct TempDir : test::TempDir {
  TempDir() : test::TempDir("mm4mm_session_io") {}
};

Eigen::Isometry3d randomPose(std::mt19937_64* rng, double extent_m) {
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(-extent_m, extent_m);
  Eigen::Quaterniond q(gauss(*rng), gauss(*rng), gauss(*rng), gauss(*rng));
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = q.normalized().toRotationMatrix();
  T.translation() = Eigen::Vector3d(uniform(*rng), uniform(*rng), uniform(*rng));
  return T;
}

// Keyframes 0.7 s apart; all sensors sampled at the same times 0.05 s apart, so that ties in
// time are the rule, as with a real rig.
Session syntheticSession(std::size_t keyframes, int sensors, bool with_scans,
                         std::uint64_t seed = 7) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  Session session;
  session.id = "s0";
  for (int k = 0; k < sensors; ++k)
    session.rig.magnetometers_body.emplace_back(0.1, -1.5 + 0.5 * k, 0.3);
  session.rig.T_body_lidar = randomPose(&rng, 1.0);
  std::vector<StampedPose> truth;
  for (std::size_t i = 0; i < keyframes; ++i) {
    const double t = 1.25 + 0.7 * i;
    session.keyframes.push_back({t, randomPose(&rng, 100.0)});
    truth.push_back({t, randomPose(&rng, 100.0)});
  }
  session.ground_truth = truth;
  for (double t = 1.0; t < 1.25 + 0.7 * keyframes; t += 0.05) {
    for (int k = 0; k < sensors; ++k) {
      const Eigen::Vector3d field =
          Eigen::Vector3d(20, 0, -40) + 10 * Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng));
      session.magnetometer.push_back({t, k, field});
    }
  }
  if (!with_scans) return session;
  std::uniform_real_distribution<float> coordinate(-30.0f, 30.0f);
  for (std::size_t i = 0; i < keyframes; ++i) {
    PointCloud scan(i == 1 ? 0 : 50 + 10 * i);  // keyframe 1: an empty scan (open space)
    for (auto& p : scan) p = Eigen::Vector3f(coordinate(rng), coordinate(rng), coordinate(rng));
    session.scans.push_back(scan);
  }
  return session;
}

void expectPosesNear(const std::vector<StampedPose>& expected,
                     const std::vector<StampedPose>& actual) {
  ASSERT_EQ(expected.size(), actual.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    EXPECT_NEAR(expected[i].time_s, actual[i].time_s, 1e-9) << "pose " << i;
    EXPECT_TRUE(expected[i].T_frame_body.translation().isApprox(
        actual[i].T_frame_body.translation(), 1e-14))
        << "pose " << i;
    EXPECT_TRUE(expected[i].T_frame_body.linear().isApprox(actual[i].T_frame_body.linear(), 1e-12))
        << "pose " << i;
  }
}

void expectSessionsNear(const Session& expected, const Session& actual) {
  EXPECT_EQ(expected.id, actual.id);
  EXPECT_EQ(expected.rig.magnetometers_body, actual.rig.magnetometers_body);
  EXPECT_TRUE(expected.rig.T_body_lidar.isApprox(actual.rig.T_body_lidar, 1e-12));
  expectPosesNear(expected.keyframes, actual.keyframes);
  ASSERT_EQ(expected.ground_truth.has_value(), actual.ground_truth.has_value());
  if (expected.ground_truth) expectPosesNear(*expected.ground_truth, *actual.ground_truth);
  ASSERT_EQ(expected.magnetometer.size(), actual.magnetometer.size());
  for (std::size_t i = 0; i < expected.magnetometer.size(); ++i) {
    const MagnetometerSample& e = expected.magnetometer[i];
    const MagnetometerSample& a = actual.magnetometer[i];
    EXPECT_NEAR(e.time_s, a.time_s, 0.5e-6) << "sample " << i;
    EXPECT_EQ(e.sensor, a.sensor) << "sample " << i;
    EXPECT_LE((e.field_body_uT - a.field_body_uT).cwiseAbs().maxCoeff(), 0.5e-4) << "sample " << i;
  }
  // Binary PCD stores the floats themselves.
  EXPECT_EQ(expected.scans, actual.scans);
}

std::vector<std::string> readLines(const fs::path& file) {
  std::ifstream stream(file);
  std::vector<std::string> lines;
  for (std::string line; std::getline(stream, line);) lines.push_back(line);
  return lines;
}

void writeLines(const fs::path& file, const std::vector<std::string>& lines) {
  std::ofstream stream(file, std::ios::trunc);
  for (const std::string& line : lines) stream << line << '\n';
}

void writeText(const fs::path& file, const std::string& text) {
  std::ofstream stream(file, std::ios::trunc | std::ios::binary);
  stream << text;
}

// Replaces 1-based line `line` of `file` with `text`.
void replaceLine(const fs::path& file, int line, const std::string& text) {
  std::vector<std::string> lines = readLines(file);
  ASSERT_LE(line, static_cast<int>(lines.size()));
  lines[line - 1] = text;
  writeLines(file, lines);
}

// Replaces the whitespace-separated token `column` (0-based) of 1-based line `line`.
void replaceToken(const fs::path& file, int line, int column, const std::string& token) {
  std::istringstream stream(readLines(file).at(line - 1));
  std::vector<std::string> tokens;
  for (std::string t; stream >> t;) tokens.push_back(t);
  tokens.at(column) = token;
  std::string joined;
  for (const std::string& t : tokens) joined += (joined.empty() ? "" : " ") + t;
  replaceLine(file, line, joined);
}

std::string tokenAt(const fs::path& file, int line, int column) {
  std::istringstream stream(readLines(file).at(line - 1));
  std::string token;
  for (int i = 0; i <= column; ++i) stream >> token;
  return token;
}

// ---- round trips ----------------------------------------------------------------------------

TEST(SessionIo, FullSessionRoundTrip) {
  TempDir tmp;
  const Session session = syntheticSession(12, 7, /*with_scans=*/true);
  writeSession(session, tmp.path() / "s0");
  EXPECT_TRUE(fs::is_directory(tmp.path() / "s0" / "scans"));
  EXPECT_TRUE(fs::exists(tmp.path() / "s0" / "ground_truth.txt"));
  const Session read = readSession(tmp.path() / "s0");
  expectSessionsNear(session, read);
  EXPECT_TRUE(read.hasScans());
  EXPECT_TRUE(read.scans[1].empty());
}

TEST(SessionIo, MagneticOnlySessionRoundTrip) {
  TempDir tmp;
  Session session = syntheticSession(6, 1, /*with_scans=*/false);
  session.ground_truth.reset();
  writeSession(session, tmp.path() / "s0");
  EXPECT_FALSE(fs::exists(tmp.path() / "s0" / "scans"));
  EXPECT_FALSE(fs::exists(tmp.path() / "s0" / "ground_truth.txt"));
  const Session read = readSession(tmp.path() / "s0");
  expectSessionsNear(session, read);
  EXPECT_FALSE(read.hasScans());
  EXPECT_FALSE(read.ground_truth.has_value());
}

// A calibration stated per magnetometer, the site's Earth field, the odometry's full stream and
// the simulator's true calibrations come back as written.
TEST(SessionIo, CalibrationEarthFieldAndOdometryStreamRoundTrip) {
  TempDir tmp;
  Session session = syntheticSession(6, 2, /*with_scans=*/false);
  MagnetometerCalibration c;
  c.hard_iron_uT = Eigen::Vector3d(5.25, -3.5, 1.125);
  c.soft_iron << 1.03, 0.01, -0.02, 0.01, 0.97, 0.005, -0.02, 0.005, 1.01;
  c.speed_uT_per_mps = Eigen::Vector3d(0.5, 0.0, -0.25);
  session.rig.calibrations = {std::nullopt, c};  // sensor 0 left to estimate
  session.rig.earth_field_horizontal_uT = 19.5;
  session.rig.earth_field_vertical_uT = -45.25;
  session.rig.frame_height_above_floor_m = 0.875;
  const double first_s = session.keyframes.front().time_s;
  for (int i = 0; first_s + 0.02 * i <= session.keyframes.back().time_s + 0.02; ++i)
    session.odometry.push_back({first_s + 0.02 * i, session.keyframes[i % 6].T_frame_body});
  session.true_calibration = std::vector<MagnetometerCalibration>{c, MagnetometerCalibration{}};
  writeSession(session, tmp.path() / "s0");
  EXPECT_TRUE(fs::exists(tmp.path() / "s0" / "odometry.txt"));
  EXPECT_TRUE(fs::exists(tmp.path() / "s0" / "ground_truth_magnetometers.yaml"));
  const Session read = readSession(tmp.path() / "s0");
  expectSessionsNear(session, read);
  ASSERT_EQ(read.rig.calibrations.size(), 2u);
  EXPECT_FALSE(read.rig.calibrations[0].has_value());
  ASSERT_TRUE(read.rig.calibrations[1].has_value());
  EXPECT_TRUE(read.rig.calibrations[1]->hard_iron_uT.isApprox(c.hard_iron_uT, 1e-12));
  EXPECT_TRUE(read.rig.calibrations[1]->soft_iron.isApprox(c.soft_iron, 1e-12));
  EXPECT_TRUE(read.rig.calibrations[1]->speed_uT_per_mps.isApprox(c.speed_uT_per_mps, 1e-12));
  ASSERT_TRUE(read.rig.earth_field_horizontal_uT.has_value());
  EXPECT_DOUBLE_EQ(*read.rig.earth_field_horizontal_uT, 19.5);
  ASSERT_TRUE(read.rig.earth_field_vertical_uT.has_value());
  EXPECT_DOUBLE_EQ(*read.rig.earth_field_vertical_uT, -45.25);
  ASSERT_TRUE(read.rig.frame_height_above_floor_m.has_value());
  EXPECT_DOUBLE_EQ(*read.rig.frame_height_above_floor_m, 0.875);
  expectPosesNear(session.odometry, read.odometry);
  ASSERT_TRUE(read.true_calibration.has_value());
  ASSERT_EQ(read.true_calibration->size(), 2u);
  EXPECT_TRUE((*read.true_calibration)[0].soft_iron.isApprox(c.soft_iron, 1e-12));
  EXPECT_TRUE((*read.true_calibration)[1].isIdentity());
}

TEST(SessionIo, WriteReplacesAnExistingSessionAndLeavesNoTemporaries) {
  TempDir tmp;
  const fs::path dir = tmp.path() / "s0";
  writeSession(syntheticSession(5, 2, /*with_scans=*/true), dir);
  writeText(dir / "stale.txt", "left over from an earlier run");
  Session replacement = syntheticSession(3, 2, /*with_scans=*/false, /*seed=*/99);
  writeSession(replacement, dir.string() + "/");  // a trailing '/' names the same directory
  EXPECT_FALSE(fs::exists(dir / "scans"));
  EXPECT_FALSE(fs::exists(dir / "stale.txt"));
  expectSessionsNear(replacement, readSession(dir));
  std::vector<std::string> entries;
  for (const auto& entry : fs::directory_iterator(tmp.path()))
    entries.push_back(entry.path().filename().string());
  EXPECT_EQ(entries, std::vector<std::string>{"s0"});
}

TEST(SessionIo, WriterRejectsScanCountNotMatchingKeyframes) {
  TempDir tmp;
  Session session = syntheticSession(5, 2, /*with_scans=*/true);
  session.scans.pop_back();
  EXPECT_THROW(writeSession(session, tmp.path() / "s0"), std::invalid_argument);
  EXPECT_FALSE(fs::exists(tmp.path() / "s0"));
  EXPECT_TRUE(fs::is_empty(tmp.path()));
}

TEST(SessionIo, WriterRejectsDuplicateMagnetometerSample) {
  TempDir tmp;
  Session session = syntheticSession(5, 2, /*with_scans=*/false);
  session.magnetometer.insert(session.magnetometer.begin() + 1, session.magnetometer.front());
  EXPECT_THROW(writeSession(session, tmp.path() / "s0"), std::invalid_argument);
}

TEST(SessionIo, TiesInTimeComeBackSortedBySensor) {
  TempDir tmp;
  const fs::path dir = tmp.path() / "s0";
  writeSession(syntheticSession(3, 2, /*with_scans=*/false), dir);
  writeLines(dir / "magnetometer.csv",
             {"  t, sensor ,bx,by,bz \r", "1.0,1,1,2,3\r", "1.0,0,4,5,6\r", "", "1.5,0,7,8,9"});
  const Session read = readSession(dir);
  ASSERT_EQ(read.magnetometer.size(), 3u);
  EXPECT_EQ(read.magnetometer[0].sensor, 0);
  EXPECT_EQ(read.magnetometer[0].field_body_uT, Eigen::Vector3d(4, 5, 6));
  EXPECT_EQ(read.magnetometer[1].sensor, 1);
  EXPECT_EQ(read.magnetometer[2].time_s, 1.5);
}

TEST(SessionIo, HeaderOnlyMagnetometerCsvIsAllowed) {
  TempDir tmp;
  const fs::path dir = tmp.path() / "s0";
  writeSession(syntheticSession(3, 2, /*with_scans=*/false), dir);
  writeText(dir / "magnetometer.csv", "t,sensor,bx,by,bz\n");
  EXPECT_TRUE(readSession(dir).magnetometer.empty());
}

TEST(SessionIo, LidarKeyIsOptional) {
  TempDir tmp;
  const fs::path dir = tmp.path() / "s0";
  writeSession(syntheticSession(3, 1, /*with_scans=*/false), dir);
  writeText(dir / "session.yaml",
            "id: s7\nnotes: unknown keys are ignored\nmagnetometers:\n"
            "  - [0.0, -1.5, 0.3]\n");
  const Session read = readSession(dir);
  EXPECT_EQ(read.id, "s7");
  EXPECT_TRUE(read.rig.T_body_lidar.isApprox(Eigen::Isometry3d::Identity()));
  ASSERT_EQ(read.rig.magnetometers_body.size(), 1u);
}

TEST(TumIo, CommentsAndBlankLinesAreSkippedAndQuaternionsNormalised) {
  TempDir tmp;
  const fs::path file = tmp.path() / "poses.txt";
  writeText(file, "# header\n\n0.5 1 2 3 0 0 0 1.0005\n  \n1.0 4 5 6 0 0 0.7071068 0.7071068\n");
  std::vector<int> lines;
  const std::vector<StampedPose> poses = readTumPoses(file, &lines);
  ASSERT_EQ(poses.size(), 2u);
  EXPECT_EQ(lines, (std::vector<int>{3, 5}));
  EXPECT_TRUE(poses[0].T_frame_body.linear().isApprox(Eigen::Matrix3d::Identity(), 1e-12));
  EXPECT_NEAR(Eigen::AngleAxisd(poses[1].T_frame_body.linear()).angle(), M_PI / 2, 1e-6);
}

class PcdRoundTrip : public ::testing::TestWithParam<PcdEncoding> {};

TEST_P(PcdRoundTrip, PointsComeBackExactly) {
  TempDir tmp;
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<float> coordinate(-80.0f, 80.0f);
  PointCloud cloud(1000);
  for (auto& p : cloud) p = Eigen::Vector3f(coordinate(rng), coordinate(rng), coordinate(rng));
  writePcd(tmp.path() / "scan.pcd", cloud, GetParam());
  EXPECT_EQ(readPcd(tmp.path() / "scan.pcd"), cloud);
  writePcd(tmp.path() / "empty.pcd", {}, GetParam());
  EXPECT_TRUE(readPcd(tmp.path() / "empty.pcd").empty());
}

INSTANTIATE_TEST_SUITE_P(AllEncodings, PcdRoundTrip,
                         ::testing::Values(PcdEncoding::kAscii, PcdEncoding::kBinary,
                                           PcdEncoding::kBinaryCompressed));

std::string asciiPcd(const std::string& fields, const std::vector<std::string>& rows) {
  std::string text = "VERSION 0.7\nFIELDS " + fields + "\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n";
  text += "WIDTH " + std::to_string(rows.size()) + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\n";
  text += "POINTS " + std::to_string(rows.size()) + "\nDATA ascii\n";
  for (const std::string& row : rows) text += row + "\n";
  return text;
}

TEST(PcdIo, NonFinitePointsAreDropped) {
  TempDir tmp;
  const fs::path file = tmp.path() / "scan.pcd";
  writeText(file, asciiPcd("x y z", {"1 2 3", "nan nan nan", "4 5 6"}));
  EXPECT_EQ(readPcd(file), (PointCloud{{1, 2, 3}, {4, 5, 6}}));
}

// Headers PCL 1.13 crashes on (SIGSEGV in PCDReader::read), found by fuzz/fuzz_pcd.cpp: refused
// before PCL reads them, naming the line.
TEST(PcdIo, HeadersPclCrashesOnAreRefusedWithTheLine) {
  TempDir tmp;
  const fs::path file = tmp.path() / "scan.pcd";
  const std::string tail =
      "SIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 1\n"
      "DATA ascii\n1.0 2.0 3.0\n";
  const auto expectRefused = [&](const std::string& text, int line, const std::string& fragment) {
    writeText(file, text);
    try {
      readPcd(file);
      ADD_FAILURE() << "accepted:\n" << text;
    } catch (const InputError& e) {
      EXPECT_EQ(e.line(), line) << e.what();
      EXPECT_NE(e.problem().find(fragment), std::string::npos) << e.what();
    }
  };
  // The fuzzer's input: a mangled VERSION line.
  expectRefused(
      "# .PCD v0.7 - Point Cloud Data file format\nVERSI7 - Point Cloud Data file "
      "format\nVERSION 0.7\nFIELDS x y z\n" +
          tail,
      2, "'VERSI7' is not a PCD header keyword");
  expectRefused("VERSION 0.7\nFIELDS x y z w\n" + tail, 10, "4 FIELDS but 3 SIZE, 3 TYPE, 3 COUNT");
  expectRefused("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 3\n" + tail.substr(tail.find("TYPE")), 3,
                "SIZE '3'");
  // A line that starts with a blank ends PCL's header before the fields; a count glued to the
  // next keyword is no count.
  expectRefused("# .PCD v0.7\n \nVERSION 0.7\nFIELDS x y z\n" + tail, 2,
                "a header line starts with a blank");
  expectRefused("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1POINTS 1\n", 5,
                "WIDTH is not a count");
  // Binary data whose first bytes spell a header keyword: PCL parses them as one.
  std::string binary = "VERSION 0.7\nFIELDS x y z\n" + tail.substr(0, tail.find("DATA")) +
                       "DATA binary\nCOUNT 1 1 1\n";
  binary.resize(binary.size() + 12, '\0');
  expectRefused(binary, 11, "its data starts with 'COUNT'");
  // A form feed between DATA and its type: one word to PCL, which then reads past its word list
  // and throws std::out_of_range, uncaught (CI's fuzz run).
  std::string feed = "VERSION 0.7\nFIELDS x y z\n" + tail;
  feed.replace(feed.find("DATA ascii"), 10, "DATA\fascii");
  expectRefused(feed, 10, "a header line holds a control character");
  // The same file without the damage reads.
  writeText(file, "VERSION 0.7\nFIELDS x y z\n" + tail);
  EXPECT_EQ(readPcd(file), (PointCloud{{1, 2, 3}}));
}

// ---- bad input: each test corrupts one file of a valid session --------------------------------

template <typename Action>
void expectInputError(Action&& action, const fs::path& file, int line,
                      const std::string& fragment) {
  try {
    action();
    ADD_FAILURE() << "no InputError thrown; expected one about " << fragment;
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), file.string()) << e.what();
    EXPECT_EQ(e.line(), line) << e.what();
    EXPECT_NE(e.problem().find(fragment), std::string::npos) << e.what();
  }
}

class BadSession : public ::testing::Test {
 protected:
  // poses.txt: line 1 a comment, line 2 + i keyframe i. magnetometer.csv: line 1 the header,
  // then sensor 0 and sensor 1 at t = 1.0 (lines 2, 3), at t = 1.05 (lines 4, 5), ...
  void SetUp() override { writeSession(syntheticSession(5, 2, /*with_scans=*/true), dir_); }

  void expectError(const fs::path& file, int line, const std::string& fragment) const {
    expectInputError([&] { readSession(dir_); }, file, line, fragment);
  }

  TempDir tmp_;
  const fs::path dir_ = tmp_.path() / "s0";
  const fs::path poses_ = dir_ / "poses.txt";
  const fs::path csv_ = dir_ / "magnetometer.csv";
  const fs::path yaml_ = dir_ / "session.yaml";
};

TEST_F(BadSession, MissingDirectory) {
  expectInputError([&] { readSession(tmp_.path() / "nowhere"); }, tmp_.path() / "nowhere", 0,
                   "not found");
  expectInputError([&] { readSession(poses_); }, poses_, 0, "not a directory");
}

TEST_F(BadSession, MissingPosesTxt) {
  fs::remove(poses_);
  expectError(poses_, 0, "not found");
}

TEST_F(BadSession, MissingMagnetometerCsv) {
  fs::remove(csv_);
  expectError(csv_, 0, "not found");
}

TEST_F(BadSession, MissingIdKey) {
  writeText(yaml_, "magnetometers:\n  - [0, 0, 0]\n  - [0, 1, 0]\n");
  expectError(yaml_, 0, "missing required key 'id'");
}

TEST_F(BadSession, MissingMagnetometersKey) {
  writeText(yaml_, "id: s0\n");
  expectError(yaml_, 0, "missing required key 'magnetometers'");
}

TEST_F(BadSession, MagnetometerPositionNotThreeNumbers) {
  writeText(yaml_, "id: s0\nmagnetometers:\n  - [0, 0, 0]\n  - [0, 1]\n");
  expectError(yaml_, 4, "'magnetometers[1]' must be a list of 3 numbers");
}

TEST_F(BadSession, SoftIronThatNoSensorHasIsRefusedWithItsLine) {
  writeText(yaml_,
            "id: s0\nmagnetometers:\n  - [0, 0, 0]\n  - position: [0, 1, 0]\n"
            "    soft_iron: [[1, 0.5, 0], [0, 1, 0], [0, 0, 1]]\n");
  try {
    readSession(dir_);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), yaml_.string());
    EXPECT_GE(e.line(), 4) << e.what();
    EXPECT_NE(e.problem().find("symmetric"), std::string::npos) << e.what();
  }
}

TEST_F(BadSession, UnknownCalibrationKeyIsRefused) {
  writeText(yaml_,
            "id: s0\nmagnetometers:\n  - [0, 0, 0]\n  - position: [0, 1, 0]\n"
            "    hard_iron: [1, 2, 3]\n");
  expectError(yaml_, 5, "unknown key 'hard_iron'");
}

// The Earth's field is 25-65 µT everywhere: a vertical component past 100 µT is a unit mistake
// (nT given as µT), and an earth_field with neither component says nothing.
TEST_F(BadSession, EarthFieldOutOfRangeOrEmptyIsRefusedWithItsLine) {
  writeText(yaml_,
            "id: s0\nmagnetometers:\n  - [0, 0, 0]\n  - [0, 1, 0]\n"
            "earth_field: {horizontal_uT: 19.5,\n  vertical_uT: -45000}\n");
  expectError(yaml_, 6, "'earth_field.vertical_uT' must be in [-100, 100]");
  writeText(yaml_, "id: s0\nmagnetometers:\n  - [0, 0, 0]\n  - [0, 1, 0]\nearth_field: {}\n");
  expectError(yaml_, 5, "needs 'horizontal_uT' or 'vertical_uT'");
}

// A frame's height above the floor in centimetres, or a word, is refused with its line.
TEST_F(BadSession, FrameHeightAboveTheFloorOutOfRangeIsRefusedWithItsLine) {
  writeText(yaml_, "id: s0\nmagnetometers:\n  - [0, 0, 0]\nframe_height_above_floor_m: 55\n");
  expectError(yaml_, 4, "'frame_height_above_floor_m' must be in [-1, 10] m, got 55");
  writeText(yaml_, "id: s0\nmagnetometers:\n  - [0, 0, 0]\nframe_height_above_floor_m: high\n");
  expectError(yaml_, 4, "'frame_height_above_floor_m' must be a number (m)");
}

TEST_F(BadSession, OdometryStreamNotCoveringTheKeyframes) {
  // The keyframes span 1.25 to 4.05 s; the stream stops at 2 s.
  writeLines(dir_ / "odometry.txt", {"1.0 0 0 0 0 0 0 1", "2.0 1 0 0 0 0 0 1"});
  expectError(dir_ / "odometry.txt", 0, "but the keyframes of poses.txt span");
}

TEST_F(BadSession, YamlSyntaxErrorGivesYamlCppsLine) {
  writeText(yaml_, "id: s0\nmagnetometers:\n  - [0, 0, 0\n  - [0, 1, 0]\nlidar: {\n");
  try {
    readSession(dir_);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), yaml_.string());
    EXPECT_GT(e.line(), 1) << e.what();
  }
}

TEST_F(BadSession, TumLineWithSevenColumns) {
  replaceLine(poses_, 3, "1.95 1 2 3 0 0 0");
  expectError(poses_, 3, "expected 8 numbers (t x y z qx qy qz qw), got 7");
}

TEST_F(BadSession, TumTokenNotANumber) {
  replaceToken(poses_, 4, 2, "abc");
  expectError(poses_, 4, "y 'abc' is not a number");
}

TEST_F(BadSession, NanInPoses) {
  replaceToken(poses_, 3, 1, "nan");
  expectError(poses_, 3, "x is not finite");
}

TEST_F(BadSession, AbsurdCoordinateInPoses) {
  replaceToken(poses_, 5, 3, "2e6");
  expectError(poses_, 5, "beyond 1e6 m");
}

TEST_F(BadSession, NonMonotonicTimeInPoses) {
  replaceToken(poses_, 4, 0, "1.0");
  expectError(poses_, 4, "time 1 is not after the previous line's 1.95");
}

TEST_F(BadSession, NonUnitQuaternion) {
  for (int column = 4; column < 7; ++column) replaceToken(poses_, 3, column, "0");
  replaceToken(poses_, 3, 7, "1.5");
  expectError(poses_, 3, "quaternion (qx qy qz qw) has norm 1.5");
}

TEST_F(BadSession, EmptyPosesTxt) {
  writeText(poses_, "# t x y z qx qy qz qw\n\n");
  expectError(poses_, 0, "no poses");
}

TEST_F(BadSession, MagnetometerCsvBadHeader) {
  replaceLine(csv_, 1, "time,sensor,bx,by,bz");
  expectError(csv_, 1, "expected 't,sensor,bx,by,bz'");
}

TEST_F(BadSession, MagnetometerCsvWrongColumnCount) {
  replaceLine(csv_, 3, "1.000000,1,20.0,0.0");
  expectError(csv_, 3, "expected 5 values (t,sensor,bx,by,bz), got 4");
}

TEST_F(BadSession, MagnetometerCsvNotANumber) {
  replaceLine(csv_, 3, "1.000000,1,20.0,oops,1.0");
  expectError(csv_, 3, "by 'oops' is not a number");
}

TEST_F(BadSession, MagnetometerCsvUnknownSensorIndex) {
  replaceLine(csv_, 3, "1.000000,9,20.0,0.0,-40.0");
  expectError(csv_, 3, "sensor index 9 is not in session.yaml's 2 magnetometers");
}

TEST_F(BadSession, MagnetometerCsvSensorIndexNotAnInteger) {
  replaceLine(csv_, 3, "1.000000,1.5,20.0,0.0,-40.0");
  expectError(csv_, 3, "sensor index '1.5' is not an integer");
}

TEST_F(BadSession, MagnetometerCsvNanField) {
  replaceLine(csv_, 4, "1.050000,0,NaN,0.0,-40.0");
  expectError(csv_, 4, "bx is not finite");
}

TEST_F(BadSession, MagnetometerCsvDecreasingTime) {
  replaceLine(csv_, 6, "0.900000,0,20.0,0.0,-40.0");
  expectError(csv_, 6, "time 0.9 is before the previous row's 1.05");
}

TEST_F(BadSession, MagnetometerCsvDuplicateSample) {
  replaceLine(csv_, 3, "1.000000,0,20.0,0.0,-40.0");
  expectError(csv_, 3, "duplicate sample: sensor 0 already has one at time 1 (line 2)");
}

TEST_F(BadSession, MagnetometerCsvAbsurdField) {
  replaceLine(csv_, 5, "1.050000,1,20.0,0.0,-4000.0");
  expectError(csv_, 5, "is absurd");
}

TEST_F(BadSession, ScanMissing) {
  fs::remove(dir_ / "scans" / "000003.pcd");
  expectError(dir_ / "scans" / "000003.pcd", 0, "missing: poses.txt has 5 keyframes");
}

TEST_F(BadSession, ScanExtra) {
  fs::copy_file(dir_ / "scans" / "000000.pcd", dir_ / "scans" / "000005.pcd");
  expectError(dir_ / "scans" / "000005.pcd", 0, "unexpected file: poses.txt has 5 keyframes");
}

TEST_F(BadSession, ScanGarbled) {
  writeText(dir_ / "scans" / "000002.pcd", "this is not a point cloud\n");
  expectError(dir_ / "scans" / "000002.pcd", 1, "not a PCD file");
}

TEST_F(BadSession, ScanEmptyFile) {
  writeText(dir_ / "scans" / "000000.pcd", "");
  expectError(dir_ / "scans" / "000000.pcd", 0, "not a PCD file");
}

TEST_F(BadSession, ScanTruncated) {
  const fs::path scan = dir_ / "scans" / "000003.pcd";
  writePcd(scan, PointCloud(100, Eigen::Vector3f(1, 2, 3)), PcdEncoding::kBinary);
  fs::resize_file(scan, fs::file_size(scan) - 100);
  expectError(scan, 0, "not a readable PCD file");
}

TEST_F(BadSession, ScanDeclaringMorePointsThanItCanHold) {
  // PCL would allocate the declared billion points before noticing the file is too short.
  std::string text = asciiPcd("x y z", {"1 2 3"});
  for (const char* key : {"WIDTH 1\n", "POINTS 1\n"}) {
    const std::size_t at = text.find(key);
    text.replace(at, std::string(key).size(),
                 std::string(key).substr(0, std::string(key).find(' ')) + " 1000000000\n");
  }
  writeText(dir_ / "scans" / "000002.pcd", text);
  expectError(dir_ / "scans" / "000002.pcd", 10, "declares 1000000000 points");
}

TEST_F(BadSession, ScanWithoutXyzFields) {
  writeText(dir_ / "scans" / "000002.pcd", asciiPcd("a b c", {"1 2 3"}));
  expectError(dir_ / "scans" / "000002.pcd", 0, "has no x y z fields (fields: a b c)");
}

TEST_F(BadSession, ScanWithAbsurdCoordinate) {
  writeText(dir_ / "scans" / "000004.pcd", asciiPcd("x y z", {"1 2 3", "1 2 3e7"}));
  expectError(dir_ / "scans" / "000004.pcd", 0, "point 1 lies beyond 1e6 m");
}

TEST_F(BadSession, GroundTruthWithDifferentCount) {
  std::vector<std::string> lines = readLines(dir_ / "ground_truth.txt");
  lines.pop_back();
  writeLines(dir_ / "ground_truth.txt", lines);
  expectError(dir_ / "ground_truth.txt", 0, "has 4 poses but poses.txt has 5");
}

TEST_F(BadSession, GroundTruthWithDifferentTime) {
  const fs::path truth = dir_ / "ground_truth.txt";
  EXPECT_EQ(tokenAt(truth, 4, 0), "2.650000000");
  replaceToken(truth, 4, 0, "2.7");
  expectError(truth, 4, "time 2.7 differs from keyframe 2's time 2.65");
}

}  // namespace
}  // namespace mm4mm
