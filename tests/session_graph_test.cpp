#include "mm4mm/graph/session_graph.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "mm4mm/core/pose.hpp"
#include "mm4mm/io/g2o_io.hpp"
#include "mm4mm/io/input_error.hpp"
#include "mm4mm/io/session_io.hpp"
#include "test_support.hpp"

namespace mm4mm {
namespace {

namespace fs = std::filesystem;
using Information = Eigen::Matrix<double, 6, 6>;

constexpr double kDeg = M_PI / 180.0;
const fs::path kExampleGraph = fs::path(MM4MM_SOURCE_DIR) / "graphs" / "example_corridor_s0.g2o";

// A fresh directory per test.
struct TempDir : test::TempDir {
  TempDir() : test::TempDir("mm4mm_session_graph") {}
};

// Four keyframes 1 s apart that drive, turn and tilt; three sensors sampled every 0.25 s (exact
// in binary, so that samples at 0, 1, 2 and 3 s coincide with keyframes) from 0.5 s before the
// first keyframe to 0.5 s after the last. Sensor 1 misses its sample at 0.75 s.
Session handSession() {
  Session session;
  session.id = "hand";
  for (int k = 0; k < 3; ++k) session.rig.magnetometers_body.emplace_back(0.0, -0.5 + 0.5 * k, 0.3);
  session.keyframes = {
      {0.0, poseFromRpy({1.0, 2.0, 0.0}, 0.0, 0.0, 0.3)},
      {1.0, poseFromRpy({1.9, 2.5, 0.02}, 0.01, -0.02, 0.6)},
      {2.0, poseFromRpy({2.4, 3.4, 0.01}, -0.015, 0.01, 1.5)},
      {3.0, poseFromRpy({2.4, 4.6, 0.0}, 0.0, 0.02, 1.6)},
  };
  for (int i = -2; i <= 14; ++i) {
    const double t = 0.25 * i;
    for (int s = 0; s < 3; ++s) {
      if (i == 3 && s == 1) continue;
      session.magnetometer.push_back({t, s, Eigen::Vector3d(20.0 + i + 0.1 * s, -3.0 * s, -40.5)});
    }
  }
  return session;
}

// Every node of `graph` by id: time and pose.
struct NodeInfo {
  double time_s;
  Eigen::Isometry3d pose;
  bool scan;
};
std::map<int, NodeInfo> nodesById(const SessionGraph& graph) {
  std::map<int, NodeInfo> nodes;
  for (const ScanNode& n : graph.scans) nodes[n.id] = {n.time_s, n.T_session_body, true};
  for (const MagneticNode& n : graph.magnetic) nodes[n.id] = {n.time_s, n.T_session_body, false};
  return nodes;
}

void expectPoseNear(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double tolerance) {
  EXPECT_LT((a.matrix() - b.matrix()).cwiseAbs().maxCoeff(), tolerance) << a.matrix() << "\n\n"
                                                                        << b.matrix();
}

std::string readText(const fs::path& file) {
  std::ifstream stream(file);
  std::ostringstream content;
  content << stream.rdbuf();
  return content.str();
}

std::vector<std::string> readLines(const fs::path& file) {
  std::vector<std::string> lines;
  std::istringstream stream(readText(file));
  for (std::string line; std::getline(stream, line);) lines.push_back(line);
  return lines;
}

void writeLines(const fs::path& file, const std::vector<std::string>& lines) {
  std::ofstream stream(file);
  for (const std::string& line : lines) stream << line << '\n';
}

// 1-based number of the first line starting with `prefix`.
int lineStarting(const std::vector<std::string>& lines, const std::string& prefix) {
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (lines[i].rfind(prefix, 0) == 0) return static_cast<int>(i) + 1;
  }
  ADD_FAILURE() << "no line starts with " << prefix;
  return 0;
}

// `line` with its whitespace-separated field `index` (0 = the tag) replaced by `value`.
std::string withField(const std::string& line, std::size_t index, const std::string& value) {
  std::istringstream in(line);
  std::vector<std::string> fields;
  for (std::string field; in >> field;) fields.push_back(field);
  EXPECT_LT(index, fields.size()) << line;
  if (index < fields.size()) fields[index] = value;
  std::string text = fields.front();
  for (std::size_t i = 1; i < fields.size(); ++i) text += " " + fields[i];
  return text;
}

// ---------------------------------------------------------------------------------------------
// Building

TEST(SessionGraph, ScanNodesAreTheKeyframes) {
  const Session session = handSession();
  const SessionGraph graph = buildSessionGraph(session);
  EXPECT_EQ(graph.session_id, "hand");
  ASSERT_EQ(graph.scans.size(), session.keyframes.size());
  for (std::size_t k = 0; k < graph.scans.size(); ++k) {
    EXPECT_EQ(graph.scans[k].keyframe, static_cast<int>(k));
    EXPECT_EQ(graph.scans[k].time_s, session.keyframes[k].time_s);
    EXPECT_TRUE(graph.scans[k].T_session_body.isApprox(session.keyframes[k].T_frame_body, 0.0));
  }
}

TEST(SessionGraph, MagneticNodesAtSampleTimesInsideTheKeyframeSpan) {
  const Session session = handSession();
  const SessionGraph graph = buildSessionGraph(session);
  // 0, 0.25, …, 3 s: 13 sample times inside [0, 3]; the four outside are dropped.
  ASSERT_EQ(graph.magnetic.size(), 13u);
  for (std::size_t i = 0; i < graph.magnetic.size(); ++i) {
    const MagneticNode& node = graph.magnetic[i];
    EXPECT_EQ(node.time_s, 0.25 * i);
    ASSERT_EQ(node.readings_body_uT.size(), 3u);
    ASSERT_EQ(node.has_reading.size(), 3u);
    for (int s = 0; s < 3; ++s) {
      const bool missing = i == 3 && s == 1;
      EXPECT_EQ(node.has_reading[s], !missing);
      const Eigen::Vector3d expected =
          missing ? Eigen::Vector3d::Zero()
                  : Eigen::Vector3d(20.0 + static_cast<double>(i) + 0.1 * s, -3.0 * s, -40.5);
      EXPECT_EQ(node.readings_body_uT[s], expected);
    }
  }
  // Nodes at keyframe times sit exactly on the keyframe.
  for (int k = 0; k < 4; ++k) {
    EXPECT_TRUE(
        graph.magnetic[4 * k].T_session_body.isApprox(session.keyframes[k].T_frame_body, 1e-15));
  }
}

TEST(SessionGraph, MagneticNodeBetweenKeyframesIsAtTheSlerp) {
  const Session session = handSession();
  const SessionGraph graph = buildSessionGraph(session);
  // 1.75 s: three quarters of the way from keyframe 1 to keyframe 2.
  const MagneticNode& node = graph.magnetic[7];
  ASSERT_EQ(node.time_s, 1.75);
  const Eigen::Isometry3d& a = session.keyframes[1].T_frame_body;
  const Eigen::Isometry3d& b = session.keyframes[2].T_frame_body;
  const Eigen::Quaterniond qa(a.linear());
  const Eigen::Quaterniond qb(b.linear());
  const Eigen::Quaterniond expected_q = qa.slerp(0.75, qb);
  const Eigen::Vector3d expected_t = 0.25 * a.translation() + 0.75 * b.translation();
  EXPECT_LT((node.T_session_body.translation() - expected_t).norm(), 1e-12);
  EXPECT_LT(Eigen::Quaterniond(node.T_session_body.linear()).angularDistance(expected_q), 1e-9);
  // And the rotation really is between them, not a copy of either.
  EXPECT_GT(rotationAngle(node.T_session_body.linear().transpose() * a.linear()), 0.1);
  EXPECT_GT(rotationAngle(node.T_session_body.linear().transpose() * b.linear()), 0.1);
}

TEST(SessionGraph, IdsUniqueAndOdometryChainsTheTimeSequence) {
  const SessionGraph graph = buildSessionGraph(handSession());
  const std::map<int, NodeInfo> nodes = nodesById(graph);
  const std::size_t total = graph.scans.size() + graph.magnetic.size();
  ASSERT_EQ(nodes.size(), total) << "node ids are not unique";
  EXPECT_EQ(nodes.begin()->first, 0);
  EXPECT_EQ(nodes.rbegin()->first, static_cast<int>(total) - 1);
  ASSERT_EQ(graph.odometry.size(), total - 1);
  for (std::size_t i = 0; i < graph.odometry.size(); ++i) {
    const OdometryEdge& edge = graph.odometry[i];
    EXPECT_EQ(edge.from, static_cast<int>(i));
    EXPECT_EQ(edge.to, static_cast<int>(i) + 1);
    const NodeInfo& from = nodes.at(edge.from);
    const NodeInfo& to = nodes.at(edge.to);
    EXPECT_LE(from.time_s, to.time_s);
    // On a tie in time the scan node comes first.
    if (from.time_s == to.time_s) {
      EXPECT_TRUE(from.scan);
      EXPECT_FALSE(to.scan);
    }
  }
}

TEST(SessionGraph, ComposingOdometryReproducesEveryNodePose) {
  const SessionGraph graph = buildSessionGraph(handSession());
  const std::map<int, NodeInfo> nodes = nodesById(graph);
  Eigen::Isometry3d T = nodes.at(graph.odometry.front().from).pose;
  for (const OdometryEdge& edge : graph.odometry) {
    T = T * edge.T_from_to;
    expectPoseNear(T, nodes.at(edge.to).pose, 1e-9);
  }
}

TEST(SessionGraph, InformationIsSymmetricPositiveDefiniteAndShrinksWithMotion) {
  const SessionGraphConfig config;
  const SessionGraph graph = buildSessionGraph(handSession(), config);
  for (const OdometryEdge& edge : graph.odometry) {
    EXPECT_TRUE(edge.information.isApprox(edge.information.transpose(), 0.0));
    const Eigen::SelfAdjointEigenSolver<Information> eigen(edge.information);
    EXPECT_GT(eigen.eigenvalues().minCoeff(), 0.0);
    // Matches the noise model for this edge's own motion.
    const Information expected = odometryInformation(
        edge.T_from_to.translation().norm(), rotationAngle(edge.T_from_to.linear()), config);
    EXPECT_TRUE(edge.information.isApprox(expected, 1e-12));
  }
  // Farther and more turning: less information, in both blocks.
  const Information near = odometryInformation(0.1, 0.0, config);
  const Information far = odometryInformation(1.0, 0.0, config);
  const Information turned = odometryInformation(1.0, 1.0, config);
  for (int i = 0; i < 6; ++i) {
    EXPECT_LT(far(i, i), near(i, i));
    if (i >= 3) {
      EXPECT_LT(turned(i, i), far(i, i));
    }
  }
  EXPECT_TRUE((turned.topLeftCorner<3, 3>() == far.topLeftCorner<3, 3>()));
  // The numbers of the model: σ_t² = 0.01² · 1 + 0.001², σ_r² = (0.1°)² · 1 + (0.1°)² · 1 +
  // (0.01°)².
  EXPECT_NEAR(1.0 / turned(0, 0), 1e-4 + 1e-6, 1e-15);
  EXPECT_NEAR(1.0 / turned(5, 5), (0.01 + 0.01 + 0.0001) * kDeg * kDeg, 1e-15);
  // Zero motion: the floors keep the information finite.
  const Information still = odometryInformation(0.0, 0.0, config);
  EXPECT_TRUE(still.allFinite());
  EXPECT_NEAR(still(0, 0), 1e6, 1e-6);
}

TEST(SessionGraph, ConfigValidation) {
  std::string error;
  EXPECT_TRUE(SessionGraphConfig{}.IsValid(&error));
  SessionGraphConfig config;
  config.translation_sigma_floor_m = 0.0;
  EXPECT_FALSE(config.IsValid(&error));
  EXPECT_NE(error.find("translation_sigma_floor_m"), std::string::npos) << error;
  config = {};
  config.rotation_sigma_per_sqrt_rad_deg = -1.0;
  EXPECT_FALSE(config.IsValid(&error));
  EXPECT_NE(error.find("rotation_sigma_per_sqrt_rad_deg"), std::string::npos) << error;
  config = {};
  config.rotation_sigma_floor_deg = std::nan("");
  EXPECT_FALSE(config.IsValid(&error));
  EXPECT_THROW(buildSessionGraph(handSession(), config), std::invalid_argument);
}

TEST(SessionGraph, DegenerateSessions) {
  Session session = handSession();
  session.magnetometer.clear();  // no samples: a keyframe chain only
  SessionGraph graph = buildSessionGraph(session);
  EXPECT_EQ(graph.scans.size(), 4u);
  EXPECT_TRUE(graph.magnetic.empty());
  ASSERT_EQ(graph.odometry.size(), 3u);
  EXPECT_EQ(graph.odometry[2].from, 2);

  session = handSession();
  session.keyframes.resize(1);  // one keyframe at 0 s: only the samples at exactly 0 s remain
  graph = buildSessionGraph(session);
  EXPECT_EQ(graph.scans.size(), 1u);
  ASSERT_EQ(graph.magnetic.size(), 1u);
  ASSERT_EQ(graph.odometry.size(), 1u);
  EXPECT_TRUE(graph.odometry[0].T_from_to.isApprox(Eigen::Isometry3d::Identity(), 1e-15));

  session.keyframes.clear();
  graph = buildSessionGraph(session);
  EXPECT_TRUE(graph.scans.empty() && graph.magnetic.empty() && graph.odometry.empty());

  session = handSession();
  session.magnetometer[5].sensor = 3;
  EXPECT_THROW(buildSessionGraph(session), std::invalid_argument);
  session = handSession();
  std::swap(session.magnetometer[0], session.magnetometer[10]);
  EXPECT_THROW(buildSessionGraph(session), std::invalid_argument);
}

// ---------------------------------------------------------------------------------------------
// g2o text

void expectGraphsEqual(const SessionGraph& a, const SessionGraph& b) {
  EXPECT_EQ(a.session_id, b.session_id);
  EXPECT_EQ(a.noise.translation_sigma_per_sqrt_m, b.noise.translation_sigma_per_sqrt_m);
  EXPECT_EQ(a.noise.translation_sigma_floor_m, b.noise.translation_sigma_floor_m);
  EXPECT_EQ(a.noise.rotation_sigma_per_sqrt_m_deg, b.noise.rotation_sigma_per_sqrt_m_deg);
  EXPECT_EQ(a.noise.rotation_sigma_per_sqrt_rad_deg, b.noise.rotation_sigma_per_sqrt_rad_deg);
  EXPECT_EQ(a.noise.rotation_sigma_floor_deg, b.noise.rotation_sigma_floor_deg);
  // Rotations pass through a quaternion, so they come back to within rounding, not bit for bit.
  constexpr double kPoseTolerance = 1e-14;
  ASSERT_EQ(a.scans.size(), b.scans.size());
  for (std::size_t i = 0; i < a.scans.size(); ++i) {
    EXPECT_EQ(a.scans[i].id, b.scans[i].id);
    EXPECT_EQ(a.scans[i].time_s, b.scans[i].time_s);
    EXPECT_EQ(a.scans[i].keyframe, b.scans[i].keyframe);
    EXPECT_EQ(a.scans[i].T_session_body.translation(), b.scans[i].T_session_body.translation());
    expectPoseNear(a.scans[i].T_session_body, b.scans[i].T_session_body, kPoseTolerance);
  }
  ASSERT_EQ(a.magnetic.size(), b.magnetic.size());
  for (std::size_t i = 0; i < a.magnetic.size(); ++i) {
    EXPECT_EQ(a.magnetic[i].id, b.magnetic[i].id);
    EXPECT_EQ(a.magnetic[i].time_s, b.magnetic[i].time_s);
    EXPECT_EQ(a.magnetic[i].T_session_body.translation(),
              b.magnetic[i].T_session_body.translation());
    expectPoseNear(a.magnetic[i].T_session_body, b.magnetic[i].T_session_body, kPoseTolerance);
    EXPECT_EQ(a.magnetic[i].readings_body_uT, b.magnetic[i].readings_body_uT);
    EXPECT_EQ(a.magnetic[i].has_reading, b.magnetic[i].has_reading);
  }
  ASSERT_EQ(a.odometry.size(), b.odometry.size());
  for (std::size_t i = 0; i < a.odometry.size(); ++i) {
    EXPECT_EQ(a.odometry[i].from, b.odometry[i].from);
    EXPECT_EQ(a.odometry[i].to, b.odometry[i].to);
    EXPECT_EQ(a.odometry[i].T_from_to.translation(), b.odometry[i].T_from_to.translation());
    expectPoseNear(a.odometry[i].T_from_to, b.odometry[i].T_from_to, kPoseTolerance);
    EXPECT_EQ(a.odometry[i].information, b.odometry[i].information);
  }
}

TEST(SessionGraphG2o, RoundTripIsExact) {
  TempDir dir;
  SessionGraphConfig config;
  config.translation_sigma_per_sqrt_m = 0.0123;
  SessionGraph graph = buildSessionGraph(handSession(), config);
  // A full symmetric information matrix, to check the order of the 21 entries.
  Information full = Information::Identity() * 50.0;
  for (int r = 0; r < 6; ++r) {
    for (int c = r + 1; c < 6; ++c) full(r, c) = full(c, r) = 0.1 * r + 0.01 * c + 1.0 / 3.0;
  }
  graph.odometry[4].information = full;
  const fs::path file = dir.path() / "graph.g2o";
  writeSessionGraphG2o(graph, file);
  const SessionGraph back = readSessionGraphG2o(file);
  expectGraphsEqual(graph, back);
  // Writing what was read loses nothing either (rotations stay within rounding; a quaternion
  // to matrix and back is not bit-stable, so the text itself may differ in the last digit).
  writeSessionGraphG2o(back, dir.path() / "again.g2o");
  expectGraphsEqual(back, readSessionGraphG2o(dir.path() / "again.g2o"));
  // No temporary files are left beside the output.
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator()), 2);
}

// The graph at other keyframe poses (a solve's) is the graph of the session moved there.
TEST(SessionGraph, BuiltAtOtherPosesIsTheGraphOfTheMovedSession) {
  const Session session = handSession();
  std::vector<Eigen::Isometry3d> poses;
  Session moved = session;
  for (std::size_t k = 0; k < session.keyframes.size(); ++k) {
    poses.push_back(poseFromRpy({0.1 * k, -0.2, 0.05}, 0.01 * k, 0.0, 0.2 * k) *
                    session.keyframes[k].T_frame_body);
    moved.keyframes[k].T_frame_body = poses.back();
  }
  const SessionGraph at = buildSessionGraphAt(session, poses);
  expectGraphsEqual(buildSessionGraph(moved), at);
  EXPECT_FALSE(at.magnetic.front().T_session_body.isApprox(
      buildSessionGraph(session).magnetic.front().T_session_body, 1e-6));
  poses.pop_back();
  EXPECT_THROW(buildSessionGraphAt(session, poses), std::invalid_argument);
}

// A 1 kHz log over the hand session's 3 s: a file of megabytes, written in pieces.
TEST(SessionGraphG2o, RoundTripOfAGraphLargerThanTheWritersChunk) {
  TempDir dir;
  Session session = handSession();
  session.magnetometer.clear();
  for (int i = 0; i <= 3000; ++i) {
    for (int s = 0; s < 3; ++s)
      session.magnetometer.push_back(
          {1e-3 * i, s, Eigen::Vector3d(20.0 + 1e-3 * i, -3.0 * s + 1.0 / (i + 1), -40.5)});
  }
  const SessionGraph graph = buildSessionGraph(session);
  ASSERT_EQ(graph.magnetic.size(), 3001u);
  const fs::path file = dir.path() / "graph.g2o";
  writeSessionGraphG2o(graph, file);
  EXPECT_GT(fs::file_size(file), 1u << 20);  // the writer hands over a megabyte at a time
  expectGraphsEqual(graph, readSessionGraphG2o(file));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator()), 1);
}

TEST(SessionGraphG2o, RoundTripWithoutMagneticNodes) {
  TempDir dir;
  Session session = handSession();
  session.magnetometer.clear();
  const SessionGraph graph = buildSessionGraph(session);
  writeSessionGraphG2o(graph, dir.path() / "g.g2o");
  expectGraphsEqual(graph, readSessionGraphG2o(dir.path() / "g.g2o"));
}

// The lines a plain g2o reader uses, parsed the way it would.
struct StandardGraph {
  std::map<int, Eigen::Isometry3d> vertices;
  std::vector<OdometryEdge> edges;
};

Eigen::Isometry3d poseFromStream(std::istringstream* in) {
  double x, y, z, qx, qy, qz, qw;
  *in >> x >> y >> z >> qx >> qy >> qz >> qw;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(qw, qx, qy, qz).normalized().toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, z);
  return T;
}

StandardGraph readStandardSubset(const fs::path& file) {
  StandardGraph graph;
  for (const std::string& line : readLines(file)) {
    std::istringstream in(line);
    std::string tag;
    in >> tag;
    if (tag == "VERTEX_SE3:QUAT") {
      int id;
      in >> id;
      graph.vertices[id] = poseFromStream(&in);
    } else if (tag == "EDGE_SE3:QUAT") {
      OdometryEdge edge;
      in >> edge.from >> edge.to;
      edge.T_from_to = poseFromStream(&in);
      for (int r = 0; r < 6; ++r) {
        for (int c = r; c < 6; ++c) {
          in >> edge.information(r, c);
          edge.information(c, r) = edge.information(r, c);
        }
      }
      EXPECT_TRUE(in && (in >> std::ws).eof()) << line;
      graph.edges.push_back(edge);
    }
  }
  return graph;
}

// The standard part alone is a chain over the scan nodes whose edges compose to the scan poses.
void expectStandardChain(const fs::path& file, const SessionGraph& graph) {
  const StandardGraph standard = readStandardSubset(file);
  ASSERT_EQ(standard.vertices.size(), graph.scans.size());
  ASSERT_EQ(standard.edges.size(), graph.scans.size() - 1);
  Eigen::Isometry3d T = standard.vertices.at(graph.scans.front().id);
  for (std::size_t k = 0; k + 1 < graph.scans.size(); ++k) {
    const OdometryEdge& edge = standard.edges[k];
    ASSERT_EQ(edge.from, graph.scans[k].id);
    ASSERT_EQ(edge.to, graph.scans[k + 1].id);
    T = T * edge.T_from_to;
    expectPoseNear(T, standard.vertices.at(edge.to), 1e-9);
    expectPoseNear(T, graph.scans[k + 1].T_session_body, 1e-9);
    const Eigen::SelfAdjointEigenSolver<Information> eigen(edge.information);
    EXPECT_GT(eigen.eigenvalues().minCoeff(), 0.0);
  }
}

TEST(SessionGraphG2o, StandardSubsetIsAConnectedScanChain) {
  TempDir dir;
  const SessionGraphConfig config;
  const SessionGraph graph = buildSessionGraph(handSession(), config);
  const fs::path file = dir.path() / "graph.g2o";
  writeSessionGraphG2o(graph, file);
  expectStandardChain(file, graph);
  // The composed edge from keyframe 0 to 1 crosses three magnetic nodes (0.25, 0.5, 0.75 s) and
  // gets the noise model's information for the summed distance and turn, less than any of its
  // four segments have.
  const StandardGraph standard = readStandardSubset(file);
  double distance = 0.0, turned = 0.0;
  for (int i = 0; i < 5; ++i) {  // scan 0 → mag 0 s → mag .25 → mag .5 → mag .75 → scan 1
    distance += graph.odometry[i].T_from_to.translation().norm();
    turned += rotationAngle(graph.odometry[i].T_from_to.linear());
  }
  ASSERT_EQ(graph.odometry[4].to, graph.scans[1].id);
  const Information expected = odometryInformation(distance, turned, config);
  EXPECT_TRUE(standard.edges[0].information.isApprox(expected, 1e-12));
  for (int i = 0; i < 5; ++i) {
    EXPECT_LT(expected(0, 0), graph.odometry[i].information(0, 0));
    EXPECT_LT(expected(3, 3), graph.odometry[i].information(3, 3));
  }
}

// --- bad input: each case names its line ---

class G2oBadInput : public ::testing::Test {
 protected:
  void SetUp() override {
    graph_ = buildSessionGraph(handSession());
    writeSessionGraphG2o(graph_, dir_.path() / "good.g2o");
    lines_ = readLines(dir_.path() / "good.g2o");
  }

  // Writes `lines` and expects readSessionGraphG2o to fail at `line` with `problem` in the text.
  void expectError(const std::vector<std::string>& lines, int line, const std::string& problem) {
    const fs::path file = dir_.path() / "bad.g2o";
    writeLines(file, lines);
    try {
      readSessionGraphG2o(file);
      ADD_FAILURE() << "no error; expected line " << line << ": " << problem;
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), file.string());
      EXPECT_EQ(e.line(), line) << e.what();
      EXPECT_NE(e.problem().find(problem), std::string::npos) << e.what();
    }
  }

  TempDir dir_;
  SessionGraph graph_;
  std::vector<std::string> lines_;
};

TEST_F(G2oBadInput, EdgeToUnknownVertex) {
  auto lines = lines_;
  const int edge = lineStarting(lines, "EDGE_SE3:QUAT");
  lines[edge - 1] = withField(lines[edge - 1], 2, "999");
  expectError(lines, edge, "vertex 999 is not defined");

  lines = lines_;
  const int mag_edge = lineStarting(lines, "EDGE_MAG:SE3:QUAT");
  lines[mag_edge - 1] = withField(lines[mag_edge - 1], 1, "-4");
  expectError(lines, mag_edge, "vertex -4 is not defined");

  lines = lines_;
  lines.push_back("MAG_READING 555 0 1 2 3");
  expectError(lines, static_cast<int>(lines.size()), "vertex 555 is not defined");

  lines = lines_;
  lines.push_back("SCAN_TIME 556 1.5");
  expectError(lines, static_cast<int>(lines.size()), "vertex 556 is not defined");
}

TEST_F(G2oBadInput, MalformedLines) {
  auto lines = lines_;
  const int vertex = lineStarting(lines, "VERTEX_SE3:QUAT");
  lines[vertex - 1] += " 7";
  expectError(lines, vertex, "expects 8 fields");

  lines = lines_;
  const int edge = lineStarting(lines, "EDGE_MAG:SE3:QUAT");
  lines[edge - 1] = lines[edge - 1].substr(0, lines[edge - 1].rfind(' '));
  expectError(lines, edge, "expects 30 fields");

  lines = lines_;
  const int reading = lineStarting(lines, "MAG_READING");
  lines[reading - 1] += " 4";
  expectError(lines, reading, "expects 5 fields");

  lines = lines_;
  lines[vertex - 1] = "VERTEX_SE3:QUAT zero 0 0 0 0 0 0 1";
  expectError(lines, vertex, "id 'zero' is not an integer");

  lines = lines_;
  lines[vertex - 1] = "VERTEX_SE3:QUAT 0 1 2 x 0 0 0 1";
  expectError(lines, vertex, "is not a number");
}

TEST_F(G2oBadInput, NonFiniteValues) {
  auto lines = lines_;
  const int vertex = lineStarting(lines, "VERTEX_MAG:SE3:QUAT");
  lines[vertex - 1] = withField(lines[vertex - 1], 2, "nan");
  expectError(lines, vertex, "t is not finite");

  lines = lines_;
  const int reading = lineStarting(lines, "MAG_READING");
  lines[reading - 1] = withField(lines[reading - 1], 5, "inf");
  expectError(lines, reading, "bz is not finite");

  lines = lines_;
  const int edge = lineStarting(lines, "EDGE_SE3:QUAT");
  lines[edge - 1] = withField(lines[edge - 1], 4, "-inf");
  expectError(lines, edge, "y is not finite");
}

TEST_F(G2oBadInput, NonUnitQuaternion) {
  auto lines = lines_;
  const int vertex = lineStarting(lines, "VERTEX_SE3:QUAT");
  lines[vertex - 1] = "VERTEX_SE3:QUAT " + std::to_string(graph_.scans[0].id) + " 0 0 0 0 0 0 1.01";
  expectError(lines, vertex, "quaternion");
  // Six digits of rounding pass.
  lines[vertex - 1] =
      "VERTEX_SE3:QUAT " + std::to_string(graph_.scans[0].id) + " 0 0 0 0 0 0 1.0000004";
  writeLines(dir_.path() / "rounded.g2o", lines);
  EXPECT_NO_THROW(readSessionGraphG2o(dir_.path() / "rounded.g2o"));
}

TEST_F(G2oBadInput, DuplicateVertexIds) {
  auto lines = lines_;
  const int vertex = lineStarting(lines, "VERTEX_SE3:QUAT");
  lines.push_back(lines[vertex - 1]);
  expectError(lines, static_cast<int>(lines.size()), "duplicate vertex id");

  // A magnetic vertex with the id of a scan vertex.
  lines = lines_;
  lines.push_back("VERTEX_MAG:SE3:QUAT " + std::to_string(graph_.scans[1].id) +
                  " 0.5 0 0 0 0 0 0 1 3");
  expectError(lines, static_cast<int>(lines.size()), "duplicate vertex id");
}

TEST_F(G2oBadInput, WrongKindsAndMissingPieces) {
  auto lines = lines_;
  const int time = lineStarting(lines, "SCAN_TIME");
  lines.erase(lines.begin() + time - 1);
  expectError(lines, time - 1, "has no SCAN_TIME");  // the vertex line just above it

  lines = lines_;
  lines.push_back("SCAN_TIME " + std::to_string(graph_.magnetic[0].id) + " 1");
  expectError(lines, static_cast<int>(lines.size()), "not a scan vertex");

  lines = lines_;
  lines.push_back("MAG_READING " + std::to_string(graph_.magnetic[0].id) + " 3 1 2 3");
  expectError(lines, static_cast<int>(lines.size()), "sensor 3 is not in [0, 3)");

  lines = lines_;
  const int reading = lineStarting(lines, "MAG_READING");
  lines.push_back(lines[reading - 1]);
  expectError(lines, static_cast<int>(lines.size()), "second reading");

  // A standard edge into a magnetic vertex.
  lines = lines_;
  const int mag_edge = lineStarting(lines, "EDGE_MAG:SE3:QUAT");
  lines[mag_edge - 1].replace(0, std::string("EDGE_MAG:SE3:QUAT").size(), "EDGE_SE3:QUAT");
  expectError(lines, mag_edge, "must join two scan vertices");

  lines = {"# nothing here", "FIX 0"};
  expectError(lines, 0, "no vertices");
}

TEST_F(G2oBadInput, InformationNotPositiveDefinite) {
  auto lines = lines_;
  const int edge = lineStarting(lines, "EDGE_MAG:SE3:QUAT");
  lines[edge - 1] = withField(lines[edge - 1], 10, "-1");  // I11
  expectError(lines, edge, "not positive definite");
}

TEST_F(G2oBadInput, UnknownTagsAreSkipped) {
  auto lines = lines_;
  lines.insert(lines.begin() + 2, "FIX 0");
  lines.insert(lines.begin() + 5, "VERTEX_XY 1000 1 2");
  lines.push_back("PARAMS_SE3OFFSET 0 0 0 0 0 0 0 1");
  lines.push_back("");
  writeLines(dir_.path() / "extra.g2o", lines);
  expectGraphsEqual(graph_, readSessionGraphG2o(dir_.path() / "extra.g2o"));
}

TEST(SessionGraphG2o, WriterRejectsGraphsItCannotWrite) {
  TempDir dir;
  const fs::path file = dir.path() / "g.g2o";
  EXPECT_THROW(writeSessionGraphG2o(SessionGraph{}, file), std::invalid_argument);
  SessionGraph graph = buildSessionGraph(handSession());
  std::swap(graph.odometry[1], graph.odometry[2]);
  EXPECT_THROW(writeSessionGraphG2o(graph, file), std::invalid_argument);
  graph = buildSessionGraph(handSession());
  graph.magnetic[2].id = graph.scans[0].id;
  EXPECT_THROW(writeSessionGraphG2o(graph, file), std::invalid_argument);
  EXPECT_FALSE(fs::exists(file));
}

// ---------------------------------------------------------------------------------------------
// The committed example (graphs/README.md)

TEST(SessionGraphExample, CommittedCorridorGraphReadsBack) {
  const SessionGraph graph = readSessionGraphG2o(kExampleGraph);
  EXPECT_EQ(graph.session_id, "s0");
  ASSERT_EQ(graph.scans.size(), 40u);
  // 20 Hz over the first 40 keyframes' span (about 40 s at 1 m/s), seven sensors sampled together.
  EXPECT_GT(graph.magnetic.size(), 600u);
  EXPECT_LT(graph.magnetic.size(), 1000u);
  EXPECT_EQ(graph.odometry.size(), graph.scans.size() + graph.magnetic.size() - 1);
  for (const MagneticNode& node : graph.magnetic) {
    ASSERT_EQ(node.readings_body_uT.size(), 7u);
    for (bool has : node.has_reading) EXPECT_TRUE(has);
    for (const Eigen::Vector3d& b : node.readings_body_uT) {
      EXPECT_GT(b.norm(), 20.0);  // the Earth's field plus anomalies, µT
      EXPECT_LT(b.norm(), 150.0);
    }
  }
  const std::map<int, NodeInfo> nodes = nodesById(graph);
  Eigen::Isometry3d T = nodes.at(graph.odometry.front().from).pose;
  for (const OdometryEdge& edge : graph.odometry) {
    T = T * edge.T_from_to;
    expectPoseNear(T, nodes.at(edge.to).pose, 1e-8);
  }
  expectStandardChain(kExampleGraph, graph);
  EXPECT_LT(fs::file_size(kExampleGraph), 2u * 1024 * 1024);
}

// Not a test: regenerates graphs/example_corridor_s0.g2o from a simulated session directory.
//   MM4MM_EXAMPLE_SESSION=/tmp/x/s0 session_graph_test --gtest_also_run_disabled_tests
//   --gtest_filter='*DISABLED_WriteExample*'
TEST(SessionGraphExample, DISABLED_WriteExample) {
  const char* session_dir = std::getenv("MM4MM_EXAMPLE_SESSION");
  ASSERT_NE(session_dir, nullptr) << "set MM4MM_EXAMPLE_SESSION to a session directory";
  Session session = readSession(session_dir);
  constexpr std::size_t kKeyframes = 40;
  ASSERT_GE(session.keyframes.size(), kKeyframes);
  session.keyframes.resize(kKeyframes);
  session.scans.clear();
  session.ground_truth.reset();
  writeSessionGraphG2o(buildSessionGraph(session), kExampleGraph);
}

}  // namespace
}  // namespace mm4mm
