// Atlas outputs: the OctoMap (read back with octomap::OcTree, compared with OctoMap's own
// insertion), the merged point cloud (fusion of overlapping sessions, Eq. 13), PLY and PCD files,
// and the fused magnetic map (Eq. 12). Scenes are synthetic: a closed box room scanned by an
// ideal LiDAR, flat walls, and a linear magnetic field, so every expected value is known.

#include <gtest/gtest.h>
#include <octomap/OcTree.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>

#include "mm4mm/core/pose.hpp"
#include "mm4mm/io/atlas_io.hpp"
#include "mm4mm/io/input_error.hpp"
#include "mm4mm/io/magnetic_map_io.hpp"
#include "mm4mm/io/octomap_io.hpp"
#include "mm4mm/io/pcd_io.hpp"
#include "mm4mm/io/ply_io.hpp"
#include "mm4mm/merge/field_offsets.hpp"
#include "mm4mm/merge/fused_magnetic_map.hpp"
#include "mm4mm/merge/magnetic_change.hpp"
#include "mm4mm/merge/merged_cloud.hpp"
#include "test_support.hpp"

namespace mm4mm {
namespace {

namespace fs = std::filesystem;
using Poses = std::vector<Eigen::Isometry3d>;

constexpr double kLidarHeight_m = 0.8;

class OutputFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("mm4mm_merge_outputs_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Names of the files in the test directory.
  std::vector<std::string> files() const {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(dir_))
      names.push_back(entry.path().filename().string());
    return names;
  }

  fs::path dir_;
};

using test::readBytes;

// ---------------------------------------------------------------------------------------------
// Box room scenes

// Walls a few centimetres off the 0.1 m voxel boundaries: a return exactly on a boundary could
// fall on either side depending on the last bit of its transform.
const Eigen::AlignedBox3d kRoom(Eigen::Vector3d(-4.97, -3.96, -0.02),
                                Eigen::Vector3d(5.03, 4.04, 2.98));

// An ideal LiDAR at `T_world_body` * (0, 0, 0.8) inside the room: one return per direction
// (azimuth every `azimuth_step_deg`, elevation -25 to +25 degrees every 5), where the ray leaves
// the room. Points in the body frame.
PointCloud boxRoomScan(const Eigen::Isometry3d& T_world_body, double azimuth_step_deg) {
  const Eigen::Vector3d lidar_body(0.0, 0.0, kLidarHeight_m);
  const Eigen::Vector3d o = T_world_body * lidar_body;
  PointCloud scan;
  for (double el = -25.0; el <= 25.0; el += 5.0)
    for (double az = 0.0; az < 360.0; az += azimuth_step_deg) {
      const double e = el * M_PI / 180.0, a = az * M_PI / 180.0;
      const Eigen::Vector3d d_body(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a),
                                   std::sin(e));
      const Eigen::Vector3d d = T_world_body.linear() * d_body;
      double t = std::numeric_limits<double>::infinity();
      for (int i = 0; i < 3; ++i)
        if (std::abs(d[i]) > 1e-12)
          t = std::min(t, ((d[i] > 0 ? kRoom.max()[i] : kRoom.min()[i]) - o[i]) / d[i]);
      scan.push_back((T_world_body.inverse() * (o + t * d)).cast<float>());
    }
  return scan;
}

SensorRig boxRoomRig() {
  SensorRig rig;
  rig.magnetometers_body = {Eigen::Vector3d(0.0, 0.0, 0.3)};
  rig.T_body_lidar.translation() = Eigen::Vector3d(0.0, 0.0, kLidarHeight_m);
  return rig;
}

// A session whose keyframes sit at `T_world_body` (the atlas poses) but whose odometry frame is
// `T_world_session`, so that using the odometry poses instead of the atlas poses would show.
Session boxRoomSession(const std::string& id, const Poses& T_world_body,
                       const Eigen::Isometry3d& T_world_session, double azimuth_step_deg) {
  Session session;
  session.id = id;
  session.rig = boxRoomRig();
  for (std::size_t k = 0; k < T_world_body.size(); ++k) {
    session.keyframes.push_back(
        {static_cast<double>(k), T_world_session.inverse() * T_world_body[k]});
    session.scans.push_back(boxRoomScan(T_world_body[k], azimuth_step_deg));
  }
  return session;
}

// Keyframes along a loop around the room's centre, facing along the path.
Poses loopPoses(int count, double radius_m, double phase) {
  Poses poses;
  for (int k = 0; k < count; ++k) {
    const double a = phase + 2.0 * M_PI * k / count;
    poses.push_back(
        planarPose(radius_m * std::cos(a), 0.8 * radius_m * std::sin(a), a + M_PI / 2.0));
  }
  return poses;
}

// Builds the octree and writes it, as the atlas writer does.
OctoMapStats buildAndWriteOctoMap(const fs::path& file, const std::vector<Session>& sessions,
                                  const std::vector<Poses>& T_atlas_keyframe,
                                  const OctoMapConfig& config = {}) {
  const OctoMapTree tree = buildOctoMap(sessions, T_atlas_keyframe, config);
  writeOctoMap(file, tree);
  return tree.stats;
}

// What octomap::OcTree::insertPointCloud makes of the same scans, written by OctoMap itself.
std::string octomapOwnBinary(const std::vector<Session>& sessions,
                             const std::vector<Poses>& T_atlas_keyframe,
                             const OctoMapConfig& config) {
  octomap::OcTree tree(config.resolution_m);
  for (std::size_t i = 0; i < sessions.size(); ++i) {
    const Eigen::Vector3f lidar_body = sessions[i].rig.T_body_lidar.translation().cast<float>();
    for (std::size_t k = 0; k < sessions[i].scans.size(); ++k) {
      const Eigen::Isometry3d& T = T_atlas_keyframe[i][k];
      octomap::Pointcloud cloud;
      for (const Eigen::Vector3f& p : sessions[i].scans[k]) {
        if ((p - lidar_body).norm() < config.min_range_m) continue;
        const Eigen::Vector3d q = T * p.cast<double>();
        cloud.push_back(static_cast<float>(q.x()), static_cast<float>(q.y()),
                        static_cast<float>(q.z()));
      }
      const Eigen::Vector3d o = T * sessions[i].rig.T_body_lidar.translation();
      tree.insertPointCloud(cloud,
                            octomap::point3d(static_cast<float>(o.x()), static_cast<float>(o.y()),
                                             static_cast<float>(o.z())),
                            config.max_range_m, /*lazy_eval=*/true, /*discretize=*/true);
    }
  }
  tree.updateInnerOccupancy();
  tree.prune();
  std::ostringstream bytes;
  tree.writeBinary(bytes);
  return bytes.str();
}

// ---------------------------------------------------------------------------------------------
// OctoMap

TEST_F(OutputFiles, OctoMapReadsBackWithOccupiedSurfacesAndFreeRays) {
  const Poses poses = loopPoses(4, 2.0, 0.3);
  const std::vector<Session> sessions{boxRoomSession("s0", poses, planarPose(3.0, -1.0, 0.7), 3.0)};
  OctoMapConfig config;
  config.max_range_m = -1.0;  // the whole room: every return marks its voxel
  const OctoMapStats stats = buildAndWriteOctoMap(dir_ / "octomap.bt", sessions, {poses}, config);

  octomap::OcTree tree(0.5);  // readBinary takes the file's resolution
  ASSERT_TRUE(tree.readBinary((dir_ / "octomap.bt").string()));
  EXPECT_DOUBLE_EQ(tree.getResolution(), 0.1);
  EXPECT_EQ(stats.scans, 4u);
  EXPECT_EQ(stats.nodes, tree.size());
  EXPECT_EQ(stats.occupied_leaves + stats.free_leaves, tree.getNumLeafNodes());
  EXPECT_GT(stats.occupied_leaves, 100u);

  // Returns are occupied; points half-way along their rays are free (the room is empty).
  std::size_t returns = 0, occupied = 0, midpoints = 0, free = 0;

  const MergedCloud cloud = buildMergedCloud(sessions, {poses});
  for (const Eigen::Vector3f& p : cloud.points) {
    const octomap::OcTreeNode* node = tree.search(p.x(), p.y(), p.z());
    ++returns;
    occupied += node != nullptr && tree.isNodeOccupied(node);
  }
  for (std::size_t k = 0; k < poses.size(); ++k) {
    const Eigen::Vector3d o = poses[k] * Eigen::Vector3d(0.0, 0.0, kLidarHeight_m);
    for (const Eigen::Vector3f& p_body : sessions[0].scans[k]) {
      // Rays end at the centre of the return's voxel (OctoMap's discretize, in float).
      const Eigen::Vector3f p_float = (poses[k] * p_body.cast<double>()).cast<float>();
      const Eigen::Vector3d p = p_float.cast<double>();
      const Eigen::Vector3d centre = ((p / 0.1).array().floor() + 0.5) * 0.1;
      const Eigen::Vector3d mid = 0.5 * (o + centre);
      const octomap::OcTreeNode* node = tree.search(mid.x(), mid.y(), mid.z());
      ++midpoints;
      free += node != nullptr && !tree.isNodeOccupied(node);
    }
  }
  EXPECT_GT(occupied, 0.97 * returns) << occupied << " of " << returns << " surface points";
  EXPECT_EQ(free, midpoints);
  EXPECT_EQ(tree.search(20.0, 0.0, 1.0), nullptr) << "outside the room is unknown";
  // Free space only inside the room, occupied leaves only on its surfaces.
  Eigen::AlignedBox3d inside = kRoom;  // a voxel holding a wall's returns may lie behind it
  inside.min().array() -= 0.11;
  inside.max().array() += 0.11;
  double free_volume = 0.0;
  for (auto it = tree.begin_leafs(); it != tree.end_leafs(); ++it) {
    const Eigen::Vector3d c(it.getX(), it.getY(), it.getZ());
    const double half = 0.5 * it.getSize();
    ASSERT_TRUE(inside.contains(c - Eigen::Vector3d::Constant(half)) &&
                inside.contains(c + Eigen::Vector3d::Constant(half)))
        << c.transpose();
    if (!tree.isNodeOccupied(*it)) {
      free_volume += std::pow(it.getSize(), 3);
      continue;
    }
    const Eigen::Vector3d to_min = c - kRoom.min(), to_max = kRoom.max() - c;
    ASSERT_LT(std::abs(std::min(to_min.minCoeff(), to_max.minCoeff())), 0.1) << c.transpose();
  }
  EXPECT_NEAR(stats.free_volume_m3, free_volume, 1e-6 * free_volume);
  EXPECT_GT(free_volume, 0.3 * kRoom.volume());
}

TEST_F(OutputFiles, OctoMapEqualsOctomapsOwnInsertionByteForByte) {
  // Two sessions in different odometry frames, more scans than one cycle of the grid's stamps
  // (126), returns beyond the maximum range (clipped rays) and a minimum range.
  const Poses a = loopPoses(70, 2.5, 0.0), b = loopPoses(70, 1.5, 1.0);
  const std::vector<Session> sessions{boxRoomSession("a", a, planarPose(1.0, 2.0, 0.5), 6.0),
                                      boxRoomSession("b", b, planarPose(-3.0, 0.5, 2.5), 6.0)};
  OctoMapConfig config;
  config.max_range_m = 5.0;
  config.min_range_m = 0.3;
  const OctoMapStats stats = buildAndWriteOctoMap(dir_ / "octomap.bt", sessions, {a, b}, config);
  EXPECT_EQ(stats.scans, 140u);
  const std::string ours = readBytes(dir_ / "octomap.bt");
  const std::string theirs = octomapOwnBinary(sessions, {a, b}, config);
  EXPECT_EQ(ours.size(), theirs.size());
  EXPECT_TRUE(ours == theirs) << "the .bt differs from octomap::OcTree::insertPointCloud's";
}

TEST_F(OutputFiles, OctoMapOfNoScansIsAnEmptyTree) {
  Session magnetic_only;
  magnetic_only.id = "m";
  magnetic_only.rig = boxRoomRig();
  magnetic_only.keyframes = {{0.0, Eigen::Isometry3d::Identity()}};
  const OctoMapStats stats =
      buildAndWriteOctoMap(dir_ / "octomap.bt", {magnetic_only}, {{Eigen::Isometry3d::Identity()}});
  EXPECT_EQ(stats.nodes, 0u);
  octomap::OcTree tree(0.1);
  ASSERT_TRUE(tree.readBinary((dir_ / "octomap.bt").string()));
  EXPECT_EQ(tree.size(), 0u);
}

TEST_F(OutputFiles, OctoMapRejectsBadInputAndLeavesNoFile) {
  const Poses poses = loopPoses(3, 2.0, 0.0);
  const std::vector<Session> sessions{
      boxRoomSession("s7", poses, Eigen::Isometry3d::Identity(), 10.0)};
  const fs::path file = dir_ / "octomap.bt";
  try {
    buildAndWriteOctoMap(file, sessions, {Poses(poses.begin(), poses.end() - 1)});
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("session 's7' has 3 keyframes but 2 optimised poses"),
              std::string::npos)
        << e.what();
  }
  EXPECT_THROW(buildAndWriteOctoMap(file, sessions, {}), std::invalid_argument);
  OctoMapConfig bad;
  bad.resolution_m = 0.0;
  EXPECT_THROW(buildAndWriteOctoMap(file, sessions, {poses}, bad), std::invalid_argument);
  Session broken = sessions[0];
  broken.scans.pop_back();
  EXPECT_THROW(buildAndWriteOctoMap(file, {broken}, {poses}), std::invalid_argument);
  EXPECT_TRUE(files().empty());

  // A directory that cannot exist (its parent is a file): an error, and nothing left behind.
  std::ofstream(dir_ / "plain_file") << "x";
  EXPECT_ANY_THROW(buildAndWriteOctoMap(dir_ / "plain_file" / "octomap.bt", sessions, {poses}));
  EXPECT_EQ(files(), std::vector<std::string>{"plain_file"});
}

// ---------------------------------------------------------------------------------------------
// Merged cloud (Eq. 13)

// A flat wall x = `x_m` (1 m <= y <= 3 m, 0 <= z <= 2 m) seen from the origin of the body frame,
// with `noise_m` of range noise, one return every ~2 cm.
PointCloud wallScan(double x_m, double noise_m, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_m);
  PointCloud scan;
  for (double y = 1.0; y <= 3.0; y += 0.02)
    for (double z = 0.0; z <= 2.0; z += 0.02) {
      const Eigen::Vector3d p(x_m, y, z);
      scan.push_back((p + noise(rng) * p.normalized()).cast<float>());
    }
  return scan;
}

// One keyframe at atlas pose `T_atlas_body` holding `scan` (in the body frame); the session's
// own odometry frame is deliberately elsewhere.
Session oneScanSession(const std::string& id, const PointCloud& scan) {
  Session s;
  s.id = id;
  s.rig.magnetometers_body = {Eigen::Vector3d::Zero()};
  s.keyframes = {{0.0, planarPose(7.0, -3.0, 1.2)}};
  s.scans = {scan};
  return s;
}

TEST(MergedCloud, SameWallOfTwoSessionsFusesIntoOneLayer) {
  const Eigen::Isometry3d T_atlas_body = planarPose(0.5, -0.2, 0.3);
  // The same wall in the atlas frame, scanned with independent noise by two sessions.
  const PointCloud scan_a = wallScan(2.03, 0.01, 1), scan_b = wallScan(2.03, 0.01, 2);
  const Session a = oneScanSession("a", scan_a), b = oneScanSession("b", scan_b);
  MergedCloudConfig config;
  const MergedCloud only_a = buildMergedCloud({a}, {{T_atlas_body}}, config);
  const MergedCloud only_b = buildMergedCloud({b}, {{T_atlas_body}}, config);
  const MergedCloud both = buildMergedCloud({a, b}, {{T_atlas_body}, {T_atlas_body}}, config);

  const std::size_t stacked = only_a.size() + only_b.size();
  EXPECT_EQ(both.session_points, stacked);
  EXPECT_LT(both.size(), 0.55 * stacked) << "fused " << both.size() << " of " << stacked;
  EXPECT_GE(both.size(), std::max(only_a.size(), only_b.size()) * 9 / 10);
  EXPECT_EQ(both.input_points, scan_a.size() + scan_b.size());

  // Fused Gaussians are tighter than either session's; points lie on the wall.
  double trace_single = 0.0, trace_fused = 0.0;
  std::size_t fused = 0;
  for (const auto& c : only_a.covariances) trace_single += c.trace() / only_a.size();
  // On the wall: voxels that cut the noisy wall keep a biased part of it, so a few points sit a
  // centimetre or two off the plane; most sit on it.
  const Eigen::Isometry3d T_body_atlas = T_atlas_body.inverse();
  std::size_t on_wall = 0;
  for (std::size_t i = 0; i < both.size(); ++i) {
    const double off = (T_body_atlas * both.points[i].cast<double>()).x() - 2.03;
    ASSERT_LT(std::abs(off), 0.03);
    on_wall += std::abs(off) < 0.01;
    if (both.session_count[i] != 2) continue;
    ++fused;
    trace_fused += both.covariances[i].trace();
    EXPECT_LT(both.session[i], 2u);
  }
  EXPECT_GT(on_wall, both.size() * 8 / 10);
  ASSERT_GT(fused, both.size() * 3 / 4);
  EXPECT_LT(trace_fused / fused, 0.65 * trace_single);
  std::size_t returns = 0;
  for (const auto n : both.return_count) returns += n;
  EXPECT_EQ(returns, both.input_points);
}

TEST(MergedCloud, SurfacesStraddlingAVoxelBoundaryFuseWithinTheRadius) {
  // Session b's wall lies 2 cm behind a's, across the boundary x = 2.0 of the 0.1 m grid.
  const Session a = oneScanSession("a", wallScan(1.99, 0.0, 1));
  const Session b = oneScanSession("b", wallScan(2.01, 0.0, 2));
  const std::vector<Poses> poses{{Eigen::Isometry3d::Identity()}, {Eigen::Isometry3d::Identity()}};
  MergedCloudConfig within_voxels;
  within_voxels.neighbour_fusion_radius_m = 0.0;
  const MergedCloud stacked = buildMergedCloud({a, b}, poses, within_voxels);
  const MergedCloud fused = buildMergedCloud({a, b}, poses, MergedCloudConfig{});
  EXPECT_EQ(stacked.size(), stacked.session_points) << "two layers when fusing within voxels";
  EXPECT_LT(fused.size(), 0.55 * fused.session_points) << "one layer with the neighbour radius";
  for (std::size_t i = 0; i < fused.size(); ++i) {
    if (fused.session_count[i] == 2) {
      EXPECT_NEAR(fused.points[i].x(), 2.0, 0.011);
    }
  }
}

TEST(MergedCloud, UsesTheAtlasPosesAndIsDeterministic) {
  const Poses poses = loopPoses(3, 2.0, 0.0);
  const std::vector<Session> sessions{boxRoomSession("s0", poses, planarPose(30.0, 5.0, 2.0), 5.0)};
  const MergedCloud first = buildMergedCloud(sessions, {poses});
  const MergedCloud second = buildMergedCloud(sessions, {poses});
  ASSERT_EQ(first.size(), second.size());
  std::size_t on_surface = 0;
  for (std::size_t i = 0; i < first.size(); ++i) {
    ASSERT_EQ(first.points[i], second.points[i]);
    ASSERT_EQ(first.covariances[i], second.covariances[i]);
    // On the room's walls, floor or ceiling (atlas frame); a voxel at an edge of the room holds
    // returns of two surfaces and its point lies between them.
    const Eigen::Vector3d p = first.points[i].cast<double>();
    const double to_surface =
        std::min({p.x() - kRoom.min().x(), kRoom.max().x() - p.x(), p.y() - kRoom.min().y(),
                  kRoom.max().y() - p.y(), p.z() - kRoom.min().z(), kRoom.max().z() - p.z()});
    ASSERT_LT(std::abs(to_surface), 0.05) << p.transpose();
    on_surface += std::abs(to_surface) < 0.001;
  }
  EXPECT_GT(on_surface, first.size() * 8 / 10);
}

TEST(MergedCloud, RejectsInconsistentInput) {
  const Session a = oneScanSession("a", wallScan(2.0, 0.0, 1));
  try {
    buildMergedCloud({a}, {{}});
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("session 'a' has 1 keyframes but 0 optimised poses"),
              std::string::npos)
        << e.what();
  }
  EXPECT_THROW(buildMergedCloud({a}, {}), std::invalid_argument);
  Eigen::Isometry3d nan_pose = Eigen::Isometry3d::Identity();
  nan_pose.translation().x() = std::nan("");
  EXPECT_THROW(buildMergedCloud({a}, {{nan_pose}}), std::invalid_argument);
  MergedCloudConfig bad;
  bad.voxel_size_m = 0.0;
  EXPECT_THROW(buildMergedCloud({a}, {{Eigen::Isometry3d::Identity()}}, bad),
               std::invalid_argument);
  Session magnetic_only = a;
  magnetic_only.scans.clear();
  EXPECT_TRUE(buildMergedCloud({magnetic_only}, {{Eigen::Isometry3d::Identity()}}).empty());
}

// ---------------------------------------------------------------------------------------------
// PLY and PCD files

PointCloud randomPoints(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-50.0f, 50.0f);
  PointCloud points;
  for (std::size_t i = 0; i < n; ++i) points.emplace_back(u(rng), u(rng), u(rng));
  return points;
}

TEST_F(OutputFiles, PlyRoundTripsExactly) {
  const PointCloud points = randomPoints(1000, 3);
  writePly(dir_ / "cloud.ply", points);
  EXPECT_EQ(readPly(dir_ / "cloud.ply"), points);
  writePly(dir_ / "empty.ply", {});
  EXPECT_TRUE(readPly(dir_ / "empty.ply").empty());
  EXPECT_EQ(files().size(), 2u) << "no temporary files left";
}

// readPly is PCL's reader (pcl::PLYReader); these are the files it must take from other tools.
TEST_F(OutputFiles, PlyReaderTakesOtherToolsFiles) {
  // ASCII with double coordinates (PCL keeps them as FLOAT64 fields), a colour, a face list
  // and comments.
  std::ofstream(dir_ / "ascii.ply")
      << "ply\nformat ascii 1.0\ncomment made by hand\nelement vertex 3\nproperty double x\n"
         "property double y\nproperty double z\nproperty uchar red\nelement face 1\n"
         "property list uchar int vertex_indices\nend_header\n"
         "1 2 3 255\n-4.5 5 6 0\n7 8 9.25 1\n3 0 1 2\n";
  EXPECT_EQ(readPly(dir_ / "ascii.ply"), (PointCloud{{1, 2, 3}, {-4.5f, 5, 6}, {7, 8, 9.25f}}));

  // Binary big-endian, properties in another order, a 16-bit integer among them.
  std::string big =
      "ply\nformat binary_big_endian 1.0\nelement vertex 2\nproperty float z\n"
      "property short id\nproperty float x\nproperty float y\nend_header\n";
  const auto put = [&big](const auto value) {
    char bytes[sizeof(value)];
    std::memcpy(bytes, &value, sizeof(value));
    for (int i = sizeof(value) - 1; i >= 0; --i) big.push_back(bytes[i]);
  };
  put(3.0f), put(std::int16_t{7}), put(1.0f), put(2.0f);
  put(-6.0f), put(std::int16_t{8}), put(-4.0f), put(-5.0f);
  std::ofstream(dir_ / "big.ply", std::ios::binary) << big;
  EXPECT_EQ(readPly(dir_ / "big.ply"), (PointCloud{{1, 2, 3}, {-4, -5, -6}}));

  // Signed integer coordinates (PCL's int32 callback), CRLF line ends, and a vertex that is
  // not finite, which is dropped.
  std::string ints =
      "ply\r\nformat binary_little_endian 1.0\r\nelement vertex 1\r\nproperty int x\r\n"
      "property int y\r\nproperty int z\r\nend_header\r\n";
  for (const std::int32_t v : {1, -2, 3}) ints.append(reinterpret_cast<const char*>(&v), 4);
  std::ofstream(dir_ / "ints.ply", std::ios::binary) << ints;
  EXPECT_EQ(readPly(dir_ / "ints.ply"), (PointCloud{{1, -2, 3}}));
  std::ofstream(dir_ / "nan.ply") << "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\n"
                                     "property float y\nproperty float z\nend_header\n"
                                     "nan 0 0\n1 2 3\n";
  EXPECT_EQ(readPly(dir_ / "nan.ply"), (PointCloud{{1, 2, 3}}));
  // PCL reads an ASCII value it cannot parse as NaN (ply_parser::parse_scalar_property), so that
  // vertex is dropped too, not the file refused.
  std::ofstream(dir_ / "words.ply")
      << "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
         "property float z\nend_header\n1 two 3\n4 5 6\n";
  EXPECT_EQ(readPly(dir_ / "words.ply"), (PointCloud{{4, 5, 6}}));
}

TEST_F(OutputFiles, PlyReaderRejectsBrokenFiles) {
  // Each refused with one InputError naming the file, whose problem contains `expected`.
  const auto refused = [&](const std::string& file, const std::string& expected) {
    try {
      readPly(dir_ / file);
      ADD_FAILURE() << file << ": expected InputError";
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), (dir_ / file).string());
      EXPECT_NE(e.problem().find(expected), std::string::npos) << file << ": " << e.what();
    }
  };
  std::ofstream(dir_ / "not.ply") << "hello\n";
  refused("not.ply", "not a PLY file");
  std::ofstream(dir_ / "empty.ply");
  refused("empty.ply", "not a PLY file");
  std::ofstream(dir_ / "no_end.ply") << "ply\nformat ascii 1.0\nelement vertex 1\n";
  refused("no_end.ply", "end_header");
  std::ofstream(dir_ / "no_xyz.ply")
      << "ply\nformat ascii 1.0\nelement vertex 1\nproperty float a\nend_header\n1\n";
  refused("no_xyz.ply", "no x y z");
  writePly(dir_ / "cut.ply", randomPoints(100, 4));
  const std::string whole = readBytes(dir_ / "cut.ply");
  std::ofstream(dir_ / "cut.ply", std::ios::binary) << whole.substr(0, whole.size() - 7);
  refused("cut.ply", "truncated");
  // Counts PCL would allocate (zero-filled, 4.8 GB each) before reading a value.
  const std::string xyz = "property float x\nproperty float y\nproperty float z\nend_header\n";
  std::ofstream(dir_ / "count.ply", std::ios::binary)
      << "ply\nformat binary_little_endian 1.0\nelement vertex 400000000\n" + xyz +
             std::string(12, '\0');
  refused("count.ply", "declares 400000000 items");
  std::ofstream(dir_ / "grid.ply", std::ios::binary)
      << "ply\nformat binary_little_endian 1.0\nobj_info num_cols 20000\nobj_info num_rows 20000\n"
         "element vertex 1\n" +
             xyz + std::string(12, '\0');
  refused("grid.ply", "grid of 20000 x 20000");
  std::ofstream(dir_ / "negative.ply", std::ios::binary)
      << "ply\nformat binary_little_endian 1.0\nobj_info num_cols -1\nelement vertex 1\n" + xyz +
             std::string(12, '\0');
  refused("negative.ply", "num_cols is not a count");
  refused("missing.ply", "not found");
  EXPECT_THROW(writePly(dir_ / "nan.ply", {{0.0f, std::nanf(""), 0.0f}}), std::invalid_argument);
}

TEST_F(OutputFiles, ReportPairsReadBackAndBadOnesAreRefused) {
  const std::string identity = "[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]";
  const std::string shifted = "[[0,-1,0,4],[1,0,0,2],[0,0,1,0],[0,0,0,1]]";
  const auto report = [&](const std::string& a, const std::string& b, const std::string& T,
                          const std::string& extra = "") {
    return "{\"pairs\": [{\"a\": \"" + a + "\", \"b\": \"" + b +
           "\", \"overlap\": true, \"role\": \"tree\", \"T_a_b\": " + T +
           ", \"edges\": 3, \"structure_match\": {\"verdict\": \"match\", \"T_a_b\": " + T +
           ", \"fitness\": 9.5, \"z\": 9.5, \"r\": 0.93, \"overlap_m2\": 120, "
           "\"second_mode_ratio\": 0.1}, \"geometry_only\": \"why\"" +
           extra + "}]}";
  };
  const fs::path file = dir_ / "report.json";
  std::ofstream(file) << report("s0", "s1", shifted);
  const std::vector<PairResult> pairs = readAtlasReportPairs(file, {"s0", "s1"});
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_TRUE(pairs[0].geometry_only);
  EXPECT_EQ(pairs[0].b, 1);
  EXPECT_EQ(pairs[0].role, PairRole::kTree);
  EXPECT_DOUBLE_EQ(pairs[0].T_a_b.translation().x(), 4.0);
  EXPECT_DOUBLE_EQ(pairs[0].magnetic.r, 0.93);
  EXPECT_NEAR(pairs[0].magnetic.T_a_b.yaw_rad, M_PI / 2, 1e-12);

  const auto refusal = [&](const std::string& text, const std::vector<std::string>& ids) {
    std::ofstream(file, std::ios::trunc) << text;
    try {
      readAtlasReportPairs(file, ids);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(refusal(report("s0", "s1", "[[2,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]"), {"s0", "s1"})
                .find("pair s0+s1's T_a_b is not a rigid transform"),
            std::string::npos);
  EXPECT_NE(refusal(report("s0", "s0", identity), {"s0", "s1"}).find("paired with itself"),
            std::string::npos);
  EXPECT_NE(refusal(report("s0", "s9", identity), {"s0", "s1"}).find("names session 's9'"),
            std::string::npos);
  // A geometry-only pair without its structure match is no report this version wrote.
  std::string no_match = report("s0", "s1", identity);
  no_match.replace(no_match.find("structure_match"), 15, "something_else");
  EXPECT_NE(refusal(no_match, {"s0", "s1"}).find("not a report this version wrote"),
            std::string::npos);
  EXPECT_NE(refusal("{\"pairs\": [", {"s0"}).find(file.string()), std::string::npos);
  const std::string twice = report("s0", "s1", identity);
  const std::string entry = twice.substr(11, twice.size() - 13);  // inside "pairs": [ ... ]
  EXPECT_NE(
      refusal("{\"pairs\": [" + entry + ", " + entry + "]}", {"s0", "s1"}).find("listed twice"),
      std::string::npos);
  std::string huge = report("s0", "s1", identity);
  const std::string edges = "\"edges\": 3";
  huge.replace(huge.find(edges), edges.size(), "\"edges\": 1e300");
  EXPECT_NE(refusal(huge, {"s0", "s1"}).find("edges is not a whole number"), std::string::npos);

  // A magnetic pair as every earlier version wrote it (no geometry_only) still reads.
  std::string magnetic = report("s1", "s0", shifted);
  magnetic.replace(magnetic.find("structure_match"), 15, "magnetic");
  const std::string geometry_only = ", \"geometry_only\": \"why\"";
  magnetic.replace(magnetic.find(geometry_only), geometry_only.size(), "");
  EXPECT_EQ(refusal(magnetic, {"s0", "s1"}), "accepted");
  const std::vector<PairResult> old_pairs = readAtlasReportPairs(file, {"s0", "s1"});
  ASSERT_EQ(old_pairs.size(), 1u);
  EXPECT_FALSE(old_pairs[0].geometry_only);
  EXPECT_EQ(old_pairs[0].a, 1);
  EXPECT_EQ(old_pairs[0].edges, 3);
}

TEST_F(OutputFiles, MergedCloudPcdRoundTripsAndCarriesFusionFields) {
  const Session a = oneScanSession("a", wallScan(2.0, 0.01, 1));
  const Session b = oneScanSession("b", wallScan(2.0, 0.01, 2));
  const MergedCloud cloud =
      buildMergedCloud({a, b}, {{Eigen::Isometry3d::Identity()}, {Eigen::Isometry3d::Identity()}});
  writeMergedCloudPcd(dir_ / "merged.pcd", cloud);
  EXPECT_EQ(readPcd(dir_ / "merged.pcd"), cloud.points);
  const std::string text = readBytes(dir_ / "merged.pcd");
  EXPECT_NE(text.find("FIELDS x y z variance session sessions returns"), std::string::npos);
  EXPECT_NE(text.find("DATA binary\n"), std::string::npos);

  writeMergedCloudPcd(dir_ / "empty.pcd", MergedCloud{});
  EXPECT_TRUE(readPcd(dir_ / "empty.pcd").empty());
  MergedCloud broken = cloud;
  broken.session.pop_back();
  EXPECT_THROW(writeMergedCloudPcd(dir_ / "broken.pcd", broken), std::invalid_argument);
  EXPECT_EQ(files().size(), 2u);
}

TEST_F(OutputFiles, WritersFailCleanlyOnAnUnwritablePath) {
  std::ofstream(dir_ / "plain_file") << "x";
  const fs::path inside_file = dir_ / "plain_file";
  EXPECT_ANY_THROW(writePly(inside_file / "merged.ply", randomPoints(10, 1)));
  EXPECT_ANY_THROW(writeMergedCloudPcd(inside_file / "merged.pcd", MergedCloud{}));
  EXPECT_EQ(files(), std::vector<std::string>{"plain_file"});
  // A failed write leaves an existing file as it was.
  const PointCloud before = randomPoints(5, 2);
  writePly(dir_ / "merged.ply", before);
  EXPECT_THROW(writePly(dir_ / "merged.ply", {{std::nanf(""), 0, 0}}), std::invalid_argument);
  EXPECT_EQ(readPly(dir_ / "merged.ply"), before);
}

// ---------------------------------------------------------------------------------------------
// Fused magnetic map (Eq. 12)

// World field (µT) growing linearly with position: B_v (its z component) is linear, so the
// maps' linear interpolation reproduces it exactly.
Eigen::Vector3d linearField(const Eigen::Vector3d& p) {
  return Eigen::Vector3d(20.0, 5.0, -40.0) +
         Eigen::Matrix3d{{0.5, 0.2, 0.0}, {-0.3, 0.4, 0.0}, {0.6, -0.8, 0.0}} * p;
}

// A rig of three magnetometers 0.4 m apart driving straight from `start` to `end` (world frame)
// at `speed_mps`, readings at 20 Hz of the linear field plus `offset_uT` (body axes; on a level
// body its z is vertical). Its odometry frame is `T_world_session`.
Session drivingSession(const std::string& id, const Eigen::Vector2d& start,
                       const Eigen::Vector2d& end, double speed_mps,
                       const Eigen::Vector3d& offset_uT, const Eigen::Isometry3d& T_world_session,
                       Poses* T_world_keyframes) {
  Session s;
  s.id = id;
  s.rig.magnetometers_body = {{0.0, -0.4, 0.3}, {0.0, 0.0, 0.3}, {0.0, 0.4, 0.3}};
  const double length = (end - start).norm(),
               yaw = std::atan2(end.y() - start.y(), end.x() - start.x());
  const double duration = length / speed_mps;
  T_world_keyframes->clear();
  for (double t = 0.0; t <= duration + 1e-9; t += 1.0 / speed_mps) {  // a keyframe every metre
    const Eigen::Vector2d xy = start + (end - start) * (t / duration);
    T_world_keyframes->push_back(planarPose(xy.x(), xy.y(), yaw));
    s.keyframes.push_back({t, T_world_session.inverse() * T_world_keyframes->back()});
  }
  const double last = s.keyframes.back().time_s;
  for (double t = 0.0; t <= last; t += 0.05)
    for (int m = 0; m < 3; ++m) {
      const Eigen::Vector2d xy = start + (end - start) * (t / duration);
      const Eigen::Isometry3d T_world_body = planarPose(xy.x(), xy.y(), yaw);
      const Eigen::Vector3d field_world = linearField(T_world_body * s.rig.magnetometers_body[m]);
      s.magnetometer.push_back({t, m, T_world_body.linear().transpose() * field_world + offset_uT});
    }
  return s;
}

TEST(FusedMagneticMap, TwoSessionsAtTheirAtlasPosesGiveTheFieldBack) {
  Poses a_poses, b_poses;
  // The same corridor driven both ways, from odometry frames far apart.
  const Eigen::Vector3d none = Eigen::Vector3d::Zero();
  const Session a =
      drivingSession("a", {0, 0}, {10, 0}, 1.0, none, planarPose(5, 5, 1.0), &a_poses);
  const Session b =
      drivingSession("b", {10, 0.1}, {0, 0.1}, 1.0, none, planarPose(-8, 2, -2.0), &b_poses);
  const FusedMagneticMap fused = fuseMagneticMaps({a, b}, {a_poses, b_poses});
  const MagneticMap& map = fused.map;
  ASSERT_GT(map.coveredCells(), 1000u);
  EXPECT_NEAR(std::remainder(map.origin_m.x(), map.cell_size_m), 0.0, 1e-9);
  EXPECT_NEAR(std::remainder(map.origin_m.y(), map.cell_size_m), 0.0, 1e-9);
  std::size_t shared = 0;
  for (int iy = 0; iy < map.height; ++iy)
    for (int ix = 0; ix < map.width; ++ix) {
      if (!map.covered(ix, iy)) continue;
      const std::size_t i = map.index(ix, iy);
      const Eigen::Vector2d c = map.cellCentre(ix, iy);
      const Eigen::Vector3d truth = linearField({c.x(), c.y(), 0.3});
      ASSERT_NEAR(map.vertical_uT[i], truth.z(), 1e-3) << "cell " << c.transpose();
      ASSERT_NEAR(map.session_x_uT[i], truth.x(), 1e-3);
      ASSERT_NEAR(map.session_y_uT[i], truth.y(), 1e-3);
      ASSERT_NEAR(map.total_uT[i], truth.norm(), 0.01);
      ASSERT_GE(fused.session_count[i], 1);
      ASSERT_GT(fused.variance_uT2[i], 0.0f);
      shared += fused.session_count[i] == 2;
    }
  EXPECT_GT(shared, map.coveredCells() / 2);
}

TEST(FusedMagneticMap, InverseVarianceWeightsFavourTheBetterMap) {
  Poses slow_poses, fast_poses;
  // The same path: the slow session reads the field exactly, five times as densely; the fast one
  // is off by 1 µT on every axis. Offsets off: this is Eq. 12's weighting alone (with them, the
  // two would be brought to agree first).
  const Session slow = drivingSession("slow", {0, 0}, {6, 0}, 0.2, Eigen::Vector3d::Zero(),
                                      Eigen::Isometry3d::Identity(), &slow_poses);
  const Session fast = drivingSession("fast", {0, 0}, {6, 0}, 1.0, Eigen::Vector3d::Ones(),
                                      Eigen::Isometry3d::Identity(), &fast_poses);
  FusedMagneticMapConfig config;
  config.offsets.enabled = false;
  const MagneticLayer ls = buildMagneticLayer(slow, slow_poses, config);
  const MagneticLayer lf = buildMagneticLayer(fast, fast_poses, config);
  const FusedMagneticMap fused = fuseMagneticMaps({slow, fast}, {slow_poses, fast_poses}, config);
  ASSERT_EQ(ls.map.width, lf.map.width);
  ASSERT_EQ(ls.map.origin_m, fused.map.origin_m);

  double var_slow = 0.0, var_fast = 0.0, error = 0.0;
  std::size_t cells = 0;
  for (std::size_t i = 0; i < fused.variance_uT2.size(); ++i) {
    if (fused.session_count[i] != 2) continue;
    const double ws = 1.0 / ls.variance_uT2[i], wf = 1.0 / lf.variance_uT2[i];
    ASSERT_NEAR(fused.map.vertical_uT[i],
                (ws * ls.map.vertical_uT[i] + wf * lf.map.vertical_uT[i]) / (ws + wf), 1e-4);
    ASSERT_NEAR(fused.variance_uT2[i], 1.0 / (ws + wf), 1e-6);
    ASSERT_LT(fused.variance_uT2[i], std::min(ls.variance_uT2[i], lf.variance_uT2[i]));
    var_slow += ls.variance_uT2[i], var_fast += lf.variance_uT2[i];
    error += fused.map.vertical_uT[i] - ls.map.vertical_uT[i];  // the slow map is exact
    ++cells;
  }
  ASSERT_GT(cells, 500u);
  EXPECT_LT(var_slow, var_fast) << "denser readings give lower variance";
  EXPECT_GT(error / cells, 0.0);
  EXPECT_LT(error / cells, 0.5) << "the fused map leans to the better session";
}

// A hand-held device among robots reads the field 0.8 m higher: another field, left out of the
// fused map; the height most layers share wins, ties go to the earliest layer.
TEST(FusedMagneticMap, LayersAtAnotherHeightThanMostAreLeftOut) {
  const auto at = [](double height_m) {
    MagneticLayer l;
    l.map.cell_size_m = 0.5;
    l.map.width = l.map.height = 1;
    l.map.height_m = height_m;
    for (auto* v : {&l.map.horizontal_uT, &l.map.vertical_uT, &l.map.total_uT, &l.map.session_x_uT,
                    &l.map.session_y_uT})
      v->assign(1, 20.0f);
    l.variance_uT2.assign(1, 1.0f);
    return l;
  };
  EXPECT_EQ(layersAtOneHeight({at(1.1), at(0.3), MagneticLayer{}, at(0.32), at(0.28)}, 0.2),
            (std::vector<bool>{false, true, false, true, true}));
  EXPECT_EQ(layersAtOneHeight({at(1.1), at(0.3)}, 0.2), (std::vector<bool>{true, false}));
  EXPECT_EQ(layersAtOneHeight({at(1.1), at(0.3)}, std::numeric_limits<double>::infinity()),
            (std::vector<bool>{true, true}));
  EXPECT_EQ(layersAtOneHeight({MagneticLayer{}}, 0.2), (std::vector<bool>{false}));

  // A chain of sessions whose odometry tilts (the demo's three corridor windows): in the atlas
  // frame their magnetometers rise 0.25 m per session, above the floor they are all at 0.3 m.
  const auto floor = [&](double atlas_z, std::optional<double> above_floor) {
    MagneticLayer l = at(atlas_z);
    l.height_above_floor_m = above_floor;
    return l;
  };
  EXPECT_EQ(layersAtOneHeight({floor(0.3, 0.3), floor(0.55, 0.3), floor(0.8, 0.3)}, 0.2),
            (std::vector<bool>{true, true, true}));
  EXPECT_EQ(layerHeights({floor(0.3, 0.3), floor(0.55, 0.3), MagneticLayer{}}),
            (std::vector<double>{0.3, 0.3, 0.0}));
  // A hand-held device among them is still told apart by its height above the floor ...
  EXPECT_EQ(layersAtOneHeight({floor(0.3, 0.3), floor(0.55, 1.1), floor(0.8, 0.3)}, 0.2),
            (std::vector<bool>{true, false, true}));
  // ... and where one layer's is unknown, every layer falls back on the atlas frame's heights,
  // where the tilted chain loses two of its three sessions.
  EXPECT_EQ(layersAtOneHeight({floor(0.3, 0.3), floor(0.55, 0.3), floor(0.8, std::nullopt)}, 0.2),
            (std::vector<bool>{true, false, false}));
}

TEST(FusedMagneticMap, FusesLayersOnOneGrid) {
  const auto layer = [](double x0, int w, float value, float variance) {
    MagneticLayer l;
    l.map.origin_m = {x0, -0.5};
    l.map.cell_size_m = 0.5;
    l.map.width = w;
    l.map.height = 2;
    l.map.height_m = 0.3;
    for (auto* v : {&l.map.horizontal_uT, &l.map.vertical_uT, &l.map.total_uT, &l.map.session_x_uT,
                    &l.map.session_y_uT})
      v->assign(2 * w, value);
    l.variance_uT2.assign(2 * w, variance);
    return l;
  };
  // Layer b starts two cells to the right of a; its first column overlaps a's last two.
  const FusedMagneticMap fused =
      fuseMagneticLayers({layer(0.0, 4, 10.0f, 1.0f), MagneticLayer{}, layer(1.0, 3, 20.0f, 4.0f)});
  ASSERT_EQ(fused.map.width, 5);
  ASSERT_EQ(fused.map.height, 2);
  EXPECT_EQ(fused.map.origin_m, Eigen::Vector2d(0.0, -0.5));
  const std::vector<float> row{10.0f, 10.0f, 12.0f, 12.0f, 20.0f};
  for (int ix = 0; ix < 5; ++ix) {
    EXPECT_FLOAT_EQ(fused.map.total_uT[fused.map.index(ix, 1)], row[ix]);
    EXPECT_EQ(fused.session_count[fused.map.index(ix, 0)], ix == 2 || ix == 3 ? 2 : 1);
  }
  EXPECT_FLOAT_EQ(fused.variance_uT2[fused.map.index(2, 0)], 0.8f);
  // The seam: B_F differs by 10 µT where both layers cover a cell; no spread elsewhere.
  for (int ix = 0; ix < 5; ++ix) {
    const float spread = fused.spread_total_uT[fused.map.index(ix, 0)];
    if (ix == 2 || ix == 3)
      EXPECT_FLOAT_EQ(spread, 10.0f);
    else
      EXPECT_TRUE(std::isnan(spread)) << ix;
  }
  EXPECT_TRUE(fuseMagneticLayers({}).map.horizontal_uT.empty());

  MagneticLayer other_cells = layer(0.0, 2, 1.0f, 1.0f);
  other_cells.map.cell_size_m = 0.25;
  EXPECT_THROW(fuseMagneticLayers({layer(0.0, 2, 1.0f, 1.0f), other_cells}), std::invalid_argument);
  EXPECT_THROW(fuseMagneticLayers({layer(0.0, 2, 1.0f, 1.0f), layer(0.2, 2, 1.0f, 1.0f)}),
               std::invalid_argument);
  MagneticLayer short_variance = layer(0.0, 2, 1.0f, 1.0f);
  short_variance.variance_uT2.pop_back();
  EXPECT_THROW(fuseMagneticLayers({short_variance}), std::invalid_argument);
}

// ---------------------------------------------------------------------------------------------
// Field offsets (field_offsets.hpp): one field across sessions

// The vertical field minus the truth at every covered cell of `map`: its smallest and largest.
std::pair<double, double> verticalErrorRange(const MagneticMap& map) {
  double low = std::numeric_limits<double>::infinity(), high = -low;
  for (int iy = 0; iy < map.height; ++iy)
    for (int ix = 0; ix < map.width; ++ix) {
      if (!map.covered(ix, iy)) continue;
      const Eigen::Vector2d c = map.cellCentre(ix, iy);
      const double error =
          map.vertical_uT[map.index(ix, iy)] - linearField({c.x(), c.y(), 0.3}).z();
      low = std::min(low, error);
      high = std::max(high, error);
    }
  return {low, high};
}

// A layer over [x0, x0 + 12) x [0, 8) m on 0.1 m cells of a smooth field with measurement noise
// (sigma 0.2 uT, the variance the layer states), plus `patch_uT` on B_h inside `patch`: steel
// brought in between two sessions.
MagneticLayer syntheticLayer(double x0, std::uint64_t seed, double patch_uT,
                             const Eigen::AlignedBox2d& patch) {
  MagneticLayer layer;
  MagneticMap& m = layer.map;
  m.cell_size_m = 0.1;
  m.origin_m = {x0, 0.0};
  m.width = 120;
  m.height = 80;
  const std::size_t cells = static_cast<std::size_t>(m.width) * m.height;
  for (auto* channel : {&m.horizontal_uT, &m.vertical_uT, &m.total_uT, &m.session_x_uT,
                        &m.session_y_uT, &layer.variance_uT2})
    channel->assign(cells, 0.0f);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.2);
  for (int iy = 0; iy < m.height; ++iy)
    for (int ix = 0; ix < m.width; ++ix) {
      const std::size_t i = m.index(ix, iy);
      const Eigen::Vector2d c = m.cellCentre(ix, iy);
      const double h = 20.0 + 3.0 * std::sin(0.7 * c.x()) + (patch.contains(c) ? patch_uT : 0.0);
      const double v = -40.0 + 2.0 * std::cos(0.5 * c.y());
      m.horizontal_uT[i] = static_cast<float>(h + noise(rng));
      m.vertical_uT[i] = static_cast<float>(v + noise(rng));
      m.total_uT[i] = static_cast<float>(std::hypot(h, v));
      layer.variance_uT2[i] = 0.04f;
    }
  return layer;
}

TEST(MagneticChange, APatchOfChangedFieldIsOneRegionAndAnUnchangedPairHasNone) {
  // b's grid starts 2.05 m further along x: its cells are looked up at a's centres.
  const Eigen::AlignedBox2d patch(Eigen::Vector2d(5.0, 2.0), Eigen::Vector2d(7.0, 5.0));
  const MagneticLayer a = syntheticLayer(0.0, 1, 0.0, patch);
  const MagneticLayer changed = syntheticLayer(2.05, 2, 5.0, patch);
  const MagneticLayer same = syntheticLayer(2.05, 3, 0.0, patch);
  // The score's arithmetic at stated settings (the defaults are a tuning's choice): a 1 uT floor,
  // chi-square 13.8 (p = 0.001), regions of 1 m² or more, the whole calibration residual.
  MagneticChangeConfig config;
  config.noise_floor_uT = 1.0;
  config.min_chi2 = 13.8;
  config.min_region_area_m2 = 1.0;
  config.calibration_scale = 1.0;
  const MagneticChange change = magneticChange(a, changed, config);
  EXPECT_EQ(change.width, a.map.width);
  EXPECT_NEAR(change.compared_cells, 100u * 80u, 80u);  // x in [2.05, 12) is shared
  ASSERT_EQ(change.regions.size(), 1u);
  const MagneticChangeRegion& region = change.regions.front();
  // The patch as b's cells hold it: 21 x 30 cells of 0.01 m^2 (centres on both edges).
  std::size_t patch_cells = 0;
  for (int iy = 0; iy < changed.map.height; ++iy)
    for (int ix = 0; ix < changed.map.width; ++ix)
      patch_cells += patch.contains(changed.map.cellCentre(ix, iy));
  EXPECT_NEAR(region.area_m2, patch_cells * 0.01, 0.11) << patch_cells;
  EXPECT_LT((region.centroid_m - patch.center()).norm(), 0.1) << region.centroid_m.transpose();
  EXPECT_NEAR(region.mean_delta_uT, 5.0, 0.2);
  EXPECT_GT(region.max_delta_uT, region.mean_delta_uT);
  // The region's cells are labelled with it, and only those.
  ASSERT_EQ(change.region.size(), change.chi2.size());
  std::size_t labelled = 0;
  for (int iy = 0; iy < change.height; ++iy)
    for (int ix = 0; ix < change.width; ++ix) {
      const int label = change.region[a.map.index(ix, iy)];
      ASSERT_TRUE(label == -1 || label == 0) << label;
      if (label != 0) continue;
      ++labelled;
      EXPECT_LT(patch.exteriorDistance(a.map.cellCentre(ix, iy)), 0.11);
    }
  EXPECT_NEAR(labelled * 0.01, region.area_m2, 1e-9);
  // Not compared where b does not reach: x < 2.05.
  EXPECT_TRUE(std::isnan(change.chi2[a.map.index(5, 40)]));
  EXPECT_FALSE(std::isnan(change.chi2[a.map.index(50, 40)]));

  // A second, smaller patch met first in row order: regions are largest first, and the labels
  // follow them.
  MagneticLayer twice = changed;
  const Eigen::AlignedBox2d small(Eigen::Vector2d(8.0, 0.5), Eigen::Vector2d(10.0, 1.5));
  for (int iy = 0; iy < twice.map.height; ++iy)
    for (int ix = 0; ix < twice.map.width; ++ix)
      if (small.contains(twice.map.cellCentre(ix, iy)))
        twice.map.horizontal_uT[twice.map.index(ix, iy)] += 5.0f;
  const MagneticChange both = magneticChange(a, twice, config);
  ASSERT_EQ(both.regions.size(), 2u);
  EXPECT_NEAR(both.regions[0].area_m2, region.area_m2, 1e-9);
  EXPECT_LT((both.regions[1].centroid_m - small.center()).norm(), 0.1);
  std::array<std::size_t, 2> per_region{};
  for (const int label : both.region)
    if (label >= 0) ++per_region.at(label);
  EXPECT_NEAR(per_region[0] * 0.01, both.regions[0].area_m2, 1e-9);
  EXPECT_NEAR(per_region[1] * 0.01, both.regions[1].area_m2, 1e-9);

  const MagneticChange unchanged = magneticChange(a, same, config);
  EXPECT_TRUE(unchanged.regions.empty());
  EXPECT_TRUE(std::all_of(unchanged.region.begin(), unchanged.region.end(),
                          [](int label) { return label == -1; }));
  EXPECT_LT(unchanged.changed_cells, 10u);  // 0.1 % of the cells at p = 0.001

  // A weaker change than the uncertainty explains is none: 1 uT against a floor of 1 uT.
  const MagneticChange faint = magneticChange(a, syntheticLayer(2.05, 2, 1.0, patch), config);
  EXPECT_TRUE(faint.regions.empty());
  // Nor is the 5 uT patch where both calibrations leave 2.5 uT: 25 / (2 x 6.25 + 1 + 0.08) < 13.8.
  MagneticLayer loose_a = a, loose_b = changed;
  loose_a.calibration_uT = loose_b.calibration_uT = 2.5;
  EXPECT_TRUE(magneticChange(loose_a, loose_b, config).regions.empty());
  // calibration_scale weighs that residual: at 0.2 the 2.5 uT count as 0.5.
  MagneticChangeConfig trusting = config;
  trusting.calibration_scale = 0.2;
  EXPECT_EQ(magneticChange(loose_a, loose_b, trusting).regions.size(), 1u);
  loose_a.calibration_uT = loose_b.calibration_uT = 0.5;  // 25 / 1.58: still found
  EXPECT_EQ(magneticChange(loose_a, loose_b, config).regions.size(), 1u);

  MagneticChangeConfig bad;
  bad.min_chi2 = 0.0;
  EXPECT_THROW(magneticChange(a, changed, bad), std::invalid_argument);
  bad = config;
  bad.calibration_scale = -1.0;
  EXPECT_THROW(magneticChange(a, changed, bad), std::invalid_argument);
  MagneticLayer coarse = changed;
  coarse.map.cell_size_m = 0.2;
  EXPECT_THROW(magneticChange(a, coarse, config), std::invalid_argument);
  MagneticLayer short_variance = changed;
  short_variance.variance_uT2.pop_back();
  EXPECT_THROW(magneticChange(a, short_variance, config), std::invalid_argument);
}

// Every pair of layers that shares cells is compared, in order; a pair apart is not listed.
TEST(MagneticChange, LayerChangesComparesThePairsThatShareCells) {
  const Eigen::AlignedBox2d patch(Eigen::Vector2d(5.0, 2.0), Eigen::Vector2d(7.0, 5.0));
  const std::vector<MagneticLayer> layers{
      syntheticLayer(0.0, 1, 0.0, patch), syntheticLayer(2.05, 2, 5.0, patch),
      syntheticLayer(40.0, 3, 0.0, patch), syntheticLayer(2.05, 4, 0.0, patch)};
  const std::vector<LayerChange> changes = layerChanges(layers, MagneticChangeConfig{});
  ASSERT_EQ(changes.size(), 3u);  // 0+1, 0+3, 1+3; layer 2 lies 28 m beyond the others
  const std::vector<std::pair<int, int>> expected{{0, 1}, {0, 3}, {1, 3}};
  for (std::size_t i = 0; i < changes.size(); ++i) {
    EXPECT_EQ(std::make_pair(changes[i].a, changes[i].b), expected[i]);
    EXPECT_GT(changes[i].compared_m2, 70.0);
  }
  // The patch is in layer 1 only: the pairs with it find it, the other does not.
  EXPECT_EQ(changes[0].regions.size(), 1u);
  EXPECT_TRUE(changes[1].regions.empty());
  ASSERT_EQ(changes[2].regions.size(), 1u);
  EXPECT_LT((changes[2].regions[0].centroid_m - patch.center()).norm(), 0.1);

  // Only the pairs with a flagged layer (an add's new session): 0+3 and 1+3.
  const std::vector<LayerChange> of_last =
      layerChanges(layers, MagneticChangeConfig{}, {false, false, false, true});
  ASSERT_EQ(of_last.size(), 2u);
  EXPECT_EQ(std::make_pair(of_last[0].a, of_last[0].b), std::make_pair(0, 3));
  EXPECT_EQ(std::make_pair(of_last[1].a, of_last[1].b), std::make_pair(1, 3));
  EXPECT_EQ(of_last[1].regions.size(), 1u);
  EXPECT_THROW(layerChanges(layers, MagneticChangeConfig{}, {true, false}), std::invalid_argument);
}

// The change map: every compared pair's cells on the fused grid, the regions numbered as the
// pairs list them, the same whatever order the pairs ran in.
TEST(MagneticChange, TheChangeMapHoldsEveryComparedPairOnOneGrid) {
  const Eigen::AlignedBox2d patch(Eigen::Vector2d(5.0, 2.0), Eigen::Vector2d(7.0, 5.0));
  // On one lattice, as buildMagneticLayer snaps every session's layer.
  const std::vector<MagneticLayer> layers{
      syntheticLayer(0.0, 1, 0.0, patch), syntheticLayer(2.0, 2, 5.0, patch),
      syntheticLayer(40.0, 3, 0.0, patch), syntheticLayer(2.0, 4, 0.0, patch)};
  const MagneticMap fused = fuseMagneticLayers(layers).map;
  const auto onTheFusedGrid = [&] {
    ChangeMap cells;
    cells.origin_m = fused.origin_m;
    cells.cell_size_m = fused.cell_size_m;
    cells.width = fused.width;
    cells.height = fused.height;
    cells.height_m = 0.25;
    return cells;
  };
  ChangeMap cells = onTheFusedGrid();
  const std::vector<LayerChange> changes = layerChanges(layers, MagneticChangeConfig{}, {}, &cells);
  ASSERT_EQ(changes.size(), 3u);  // 0+1, 0+3, 1+3, as LayerChangesComparesThePairsThatShareCells
  ASSERT_EQ(changes[0].regions.size(), 1u);
  ASSERT_EQ(changes[2].regions.size(), 1u);
  const auto cellAt = [&](double x, double y) {
    return fused.index(static_cast<int>(std::floor((x - fused.origin_m.x()) / 0.1)),
                       static_cast<int>(std::floor((y - fused.origin_m.y()) / 0.1)));
  };
  // Layer 0 alone below x = 2 and layer 2 alone far off: nothing compared there.
  for (const double x : {1.0, 45.0}) {
    const std::size_t i = cellAt(x, 4.0);
    EXPECT_EQ(cells.pairs[i], 0u) << x;
    EXPECT_TRUE(std::isnan(cells.chi2[i]) && std::isnan(cells.delta_uT[i])) << x;
    EXPECT_EQ(cells.region[i], 0u) << x;
  }
  // Outside the patch three pairs compared each cell and none changed.
  const std::size_t calm = cellAt(9.0, 6.0);
  EXPECT_EQ(cells.pairs[calm], 3u);
  EXPECT_LT(cells.chi2[calm], MagneticChangeConfig{}.min_chi2);
  EXPECT_EQ(cells.region[calm], 0u);
  // Inside it, the pairs with layer 1 differ by 5 uT; the cell shows the larger chi-square and
  // the first region of the list, 0+1's (number 1; 1+3's is number 2).
  const std::size_t inside = cellAt(6.0, 3.5);
  EXPECT_EQ(cells.pairs[inside], 3u);
  EXPECT_NEAR(cells.delta_uT[inside], 5.0, 1.5);
  EXPECT_GT(cells.chi2[inside], MagneticChangeConfig{}.min_chi2);
  EXPECT_EQ(cells.region[inside], 1u);
  std::size_t labelled = 0;
  for (const std::uint32_t number : cells.region) labelled += number != 0;
  EXPECT_GE(labelled * 0.01, changes[0].regions[0].area_m2 - 1e-9);
  EXPECT_LT(labelled * 0.01, changes[0].regions[0].area_m2 + changes[2].regions[0].area_m2);
  EXPECT_EQ(cells.comparedCells(),
            static_cast<std::size_t>(std::count_if(cells.chi2.begin(), cells.chi2.end(),
                                                   [](float v) { return !std::isnan(v); })));
  const MagneticMap delta = cells.deltaMap();
  EXPECT_EQ(delta.coveredCells(), cells.comparedCells());
  EXPECT_EQ(delta.total_uT[inside], cells.delta_uT[inside]);

  // The same cells, bit for bit, in another run (the pairs finish in any order).
  ChangeMap again = onTheFusedGrid();
  layerChanges(layers, MagneticChangeConfig{}, {}, &again);
  EXPECT_EQ(again.pairs, cells.pairs);
  EXPECT_EQ(again.region, cells.region);
  EXPECT_EQ(0, std::memcmp(again.chi2.data(), cells.chi2.data(), cells.chi2.size() * 4));
  EXPECT_EQ(0,
            std::memcmp(again.delta_uT.data(), cells.delta_uT.data(), cells.delta_uT.size() * 4));

  // Only the last layer's pairs (an add): the patch is 1+3's region, now number 1.
  ChangeMap of_last = onTheFusedGrid();
  layerChanges(layers, MagneticChangeConfig{}, {false, false, false, true}, &of_last);
  EXPECT_EQ(of_last.pairs[inside], 2u);
  EXPECT_EQ(of_last.region[inside], 1u);

  // A grid off the layers' lattice by half a cell is refused.
  ChangeMap off = onTheFusedGrid();
  off.origin_m.x() += 0.05;
  EXPECT_THROW(layerChanges(layers, MagneticChangeConfig{}, {}, &off), std::invalid_argument);
}

// One session's regions on a picture: the whole place a shown region lies in, whichever pair's
// number its cells hold.
TEST(MagneticChange, APlaceIsDrawnWholeWhereverAShownRegionLies) {
  ChangeMap cells;
  cells.width = 10;
  cells.height = 3;
  cells.cell_size_m = 0.1;
  cells.region.assign(30, 0);
  for (int ix = 0; ix < 4; ++ix) cells.region[10 + ix] = 1;  // region 1, row 1
  for (int ix = 4; ix < 6; ++ix) cells.region[20 + ix] = 2;  // region 2, touching it diagonally
  cells.region[10 + 9] = 3;                                  // region 3 apart
  const auto labels = [&](std::vector<bool> shown) { return placesOfRegions(cells, shown); };
  const std::vector<std::uint32_t> of_two = labels({false, true, false});
  for (const std::size_t i : {10u, 13u, 24u, 25u}) EXPECT_EQ(of_two[i], 2u) << i;
  EXPECT_EQ(of_two[19], 0u);  // region 3's place holds no shown region
  EXPECT_EQ(of_two[0], 0u);
  const std::vector<std::uint32_t> of_all = labels({true, true, true});
  EXPECT_EQ(of_all[24], 1u);  // the first shown number in the place
  EXPECT_EQ(of_all[19], 3u);
  const std::vector<std::uint32_t> none = labels({false, false, false});
  EXPECT_TRUE(std::all_of(none.begin(), none.end(), [](std::uint32_t n) { return n == 0; }));
}

TEST(FieldOffsets, AVerticalOffsetBetweenTwoSessionsIsSolvedAndLeavesNoStep) {
  // Two passes of one corridor half a metre apart (each swath 0.8 m wide: 0.3 m shared, the rest
  // read by one session only); b's sensors read 10 µT too much along body z, vertical here.
  Poses a_poses, b_poses;
  const Session a = drivingSession("a", {0, 0}, {10, 0}, 1.0, Eigen::Vector3d::Zero(),
                                   planarPose(5, 5, 1.0), &a_poses);
  const Session b = drivingSession("b", {10, 0.5}, {0, 0.5}, 1.0, Eigen::Vector3d(0, 0, 10),
                                   planarPose(-8, 2, -2.0), &b_poses);

  FusedMagneticMapConfig off;
  off.offsets.enabled = false;
  const auto [low_before, high_before] =
      verticalErrorRange(fuseMagneticMaps({a, b}, {a_poses, b_poses}, off).map);
  EXPECT_GT(high_before - low_before, 9.5) << "without offsets, the map steps by the 10 µT";

  const FusedMagneticMap fused = fuseMagneticMaps({a, b}, {a_poses, b_poses});
  const FieldOffsets& f = fused.offsets;
  ASSERT_EQ(f.offsets.size(), 2u);
  ASSERT_TRUE(f.linked[0] && f.linked[1]);
  ASSERT_EQ(f.pairs.size(), 1u);
  EXPECT_GT(f.pairs[0].cells, 1000);
  EXPECT_NEAR(f.pairs[0].vertical_uT, -10.0, 0.2);  // a − b before
  EXPECT_NEAR(f.offsets[1].vertical_uT - f.offsets[0].vertical_uT, -10.0, 0.2);
  EXPECT_NEAR(f.offsets[0].horizontal_uT, 0.0, 0.2);
  EXPECT_NEAR(f.offsets[1].horizontal_uT, 0.0, 0.2);
  // The anchor: the offsets sum to zero, so both sessions end 5 µT above the truth, one field.
  EXPECT_NEAR(f.offsets[0].vertical_uT + f.offsets[1].vertical_uT, 0.0, 1e-9);
  const auto [low, high] = verticalErrorRange(fused.map);
  EXPECT_LT(high - low, 0.2) << "no step where one session's coverage meets the other's";
  EXPECT_NEAR((low + high) / 2, 5.0, 0.2);
}

// A 6 m x 2 m layer of one smooth field on a 0.1 m lattice read with offsets dh, dv (µT).
MagneticLayer offsetLayer(double x0, double y0, double dh, double dv) {
  MagneticLayer l;
  l.map.origin_m = {x0, y0};
  l.map.cell_size_m = 0.1;
  l.map.width = 60;
  l.map.height = 20;
  for (auto* v : {&l.map.horizontal_uT, &l.map.vertical_uT, &l.map.total_uT, &l.map.session_x_uT,
                  &l.map.session_y_uT})
    v->assign(60 * 20, 0.0f);
  l.variance_uT2.assign(60 * 20, 1.0f);
  for (int iy = 0; iy < 20; ++iy)
    for (int ix = 0; ix < 60; ++ix) {
      const Eigen::Vector2d c = l.map.cellCentre(ix, iy);
      const std::size_t i = l.map.index(ix, iy);
      l.map.horizontal_uT[i] = static_cast<float>(20 + std::sin(c.x()) + dh);
      l.map.vertical_uT[i] = static_cast<float>(-40 + 3 * std::cos(c.y()) + dv);
      l.map.total_uT[i] =
          static_cast<float>(std::hypot(l.map.horizontal_uT[i], l.map.vertical_uT[i]));
    }
  return l;
}

// The median B_v over every covered cell of `layers`, each with its offset.
double medianVertical(const std::vector<MagneticLayer>& layers, const FieldOffsets& f) {
  std::vector<double> v;
  for (std::size_t s = 0; s < layers.size(); ++s)
    for (std::size_t i = 0; i < layers[s].map.vertical_uT.size(); ++i)
      if (!std::isnan(layers[s].map.total_uT[i]))
        v.push_back(layers[s].map.vertical_uT[i] + f.offsets[s].vertical_uT);
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

TEST(FieldOffsets, ConstantOffsetsOfSeveralLayersComeBackAndUnlinkedLayersKeepNone) {
  // One smooth field, four layers: three overlapping strips read with offsets that sum to zero,
  // and one far away.
  const std::vector<MagneticLayer> layers{
      offsetLayer(0.0, 0.0, 1.0, 4.0), offsetLayer(3.0, 1.0, -2.0, -1.0),
      offsetLayer(1.0, 0.5, 1.0, -3.0), offsetLayer(50.0, 50.0, 7.0, 7.0)};
  FieldOffsetConfig config;
  config.min_shared_cells = 100;
  const FieldOffsets f = estimateFieldOffsets(layers, config);
  ASSERT_EQ(f.pairs.size(), 3u);
  const double expected_h[] = {-1.0, 2.0, -1.0}, expected_v[] = {-4.0, 1.0, 3.0};
  for (int s = 0; s < 3; ++s) {
    EXPECT_TRUE(f.linked[s]);
    EXPECT_NEAR(f.offsets[s].horizontal_uT, expected_h[s], 1e-4) << "layer " << s;
    EXPECT_NEAR(f.offsets[s].vertical_uT, expected_v[s], 1e-4) << "layer " << s;
  }
  EXPECT_FALSE(f.linked[3]);
  EXPECT_EQ(f.offsets[3].vertical_uT, 0.0);
  for (int s = 0; s < 4; ++s) EXPECT_FALSE(f.earth_anchored[s]) << "no session states the Earth";
  EXPECT_NE(f.anchor.find("sum to zero"), std::string::npos) << f.anchor;
  // Applied, every pair agrees; B_F follows B_h and B_v.
  for (const LayerDisagreement& d : f.pairs) {
    const LayerDisagreement after = layerDisagreement(withFieldOffset(layers[d.a], f.offsets[d.a]),
                                                      withFieldOffset(layers[d.b], f.offsets[d.b]));
    EXPECT_EQ(after.cells, d.cells);
    EXPECT_NEAR(after.horizontal_uT, 0.0, 1e-4);
    EXPECT_NEAR(after.vertical_uT, 0.0, 1e-4);
    EXPECT_NEAR(after.total_uT, 0.0, 1e-3);
  }
  // A stricter minimum leaves the pairs that share too little unlinked.
  config.min_shared_cells = 1000000;
  const FieldOffsets none = estimateFieldOffsets(layers, config);
  EXPECT_TRUE(none.pairs.empty());
  EXPECT_FALSE(none.linked[0]);

  config.min_shared_cells = 0;
  EXPECT_THROW(estimateFieldOffsets(layers, config), std::invalid_argument);
  MagneticLayer off_grid = layers[1];
  off_grid.map.origin_m.x() += 0.05;
  EXPECT_THROW(layerDisagreement(layers[0], off_grid), std::invalid_argument);
}

// The common constant the shared cells leave free is fixed by the Earth's vertical field where a
// session states it: the group's median B_v goes on it, the differences stay, and a layer linked
// to none is anchored alone. Without a statement the offsets keep summing to zero (above).
TEST(FieldOffsets, TheEarthsVerticalFieldAnchorsEachGroupsMedian) {
  std::vector<MagneticLayer> layers{
      offsetLayer(0.0, 0.0, 1.0, 4.0), offsetLayer(3.0, 1.0, -2.0, -1.0),
      offsetLayer(1.0, 0.5, 1.0, -3.0), offsetLayer(50.0, 50.0, 7.0, 7.0)};
  layers[1].earth_vertical_uT = -42.0;  // one session of the group states it
  layers[3].earth_vertical_uT = -41.0;
  FieldOffsetConfig config;
  config.min_shared_cells = 100;
  const FieldOffsets f = estimateFieldOffsets(layers, config);
  ASSERT_EQ(f.pairs.size(), 3u);
  for (int s = 0; s < 4; ++s) EXPECT_TRUE(f.earth_anchored[s]) << "layer " << s;
  EXPECT_FALSE(f.linked[3]);
  // The differences are the shared cells' (as without an anchor), the horizontal ones untouched.
  EXPECT_NEAR(f.offsets[1].vertical_uT - f.offsets[0].vertical_uT, 5.0, 1e-4);
  EXPECT_NEAR(f.offsets[2].vertical_uT - f.offsets[0].vertical_uT, 7.0, 1e-4);
  EXPECT_NEAR(f.offsets[0].horizontal_uT, -1.0, 1e-4);
  const std::vector<MagneticLayer> group(layers.begin(), layers.begin() + 3);
  EXPECT_NEAR(medianVertical(group, f), -42.0, 1e-4);
  EXPECT_NEAR(medianVertical({layers[3]}, FieldOffsets{{f.offsets[3]}, {}, {}, {}, "", {}}), -41.0,
              1e-4);
  EXPECT_NE(f.anchor.find("Earth"), std::string::npos) << f.anchor;

  // Applied, the layers carry the offsets; with offsets off nothing moves.
  std::vector<MagneticLayer> applied = layers;
  applyFieldOffsets(applied, config);
  EXPECT_NEAR(applied[3].map.vertical_uT[0] - layers[3].map.vertical_uT[0],
              f.offsets[3].vertical_uT, 1e-4);
  config.enabled = false;
  const FieldOffsets off = estimateFieldOffsets(layers, config);
  EXPECT_FALSE(off.earth_anchored[3]);
  EXPECT_EQ(off.offsets[3].vertical_uT, 0.0);
}

// Where no session states the Earth's field, a session that observed its own vertical hard iron
// (a tilting body's calibration) carries B_v: the group's offsets are shifted so that its offset
// is zero, the differences stay. Where the Earth's field is stated too, the two are weighed by
// the inverse of their variances.
TEST(FieldOffsets, ASessionThatObservedItsVerticalAnchorsItsGroup) {
  // Three strips of one field: the first read right (a handheld session), the others 6 and
  // -2 uT off in B_v (level robots), and a fourth far away.
  std::vector<MagneticLayer> layers{
      offsetLayer(0.0, 0.0, 0.0, 0.0), offsetLayer(3.0, 1.0, 0.0, 6.0),
      offsetLayer(1.0, 0.5, 0.0, -2.0), offsetLayer(50.0, 50.0, 0.0, 5.0)};
  layers[0].vertical_observed = true;
  layers[3].vertical_observed = true;  // alone: nothing to anchor
  FieldOffsetConfig config;
  config.min_shared_cells = 100;
  const FieldOffsets f = estimateFieldOffsets(layers, config);
  ASSERT_EQ(f.pairs.size(), 3u);
  EXPECT_NEAR(f.offsets[0].vertical_uT, 0.0, 1e-4);
  EXPECT_NEAR(f.offsets[1].vertical_uT, -6.0, 1e-4);
  EXPECT_NEAR(f.offsets[2].vertical_uT, 2.0, 1e-4);
  for (int s = 0; s < 3; ++s) EXPECT_TRUE(f.observed_anchored[s]) << "layer " << s;
  EXPECT_FALSE(f.observed_anchored[3]);
  EXPECT_EQ(f.offsets[3].vertical_uT, 0.0);
  EXPECT_NE(f.anchor.find("observed their own vertical"), std::string::npos) << f.anchor;

  // Without it the offsets sum to zero: the handheld session's right B_v moves by 4/3 uT.
  layers[0].vertical_observed = false;
  const FieldOffsets sum0 = estimateFieldOffsets(layers, config);
  EXPECT_NEAR(sum0.offsets[0].vertical_uT, 4.0 / 3.0, 1e-4);
  EXPECT_FALSE(sum0.observed_anchored[0]);

  // With no session that observed its vertical, the stated Earth field anchors the group: its
  // median B_v goes on -45 uT, 5 uT below where the handheld session's B_v would put it.
  layers[2].earth_vertical_uT = -45.0;
  const FieldOffsets earth = estimateFieldOffsets(layers, config);
  EXPECT_TRUE(earth.earth_anchored[0]);
  EXPECT_FALSE(earth.observed_anchored[0]);
  const std::vector<MagneticLayer> group(layers.begin(), layers.begin() + 3);
  EXPECT_NEAR(medianVertical(group, earth), -45.0, 1e-4);
  const double earth_shift = earth.offsets[0].vertical_uT - sum0.offsets[0].vertical_uT;

  // Both: the weighted mean of the two shifts, the differences kept. With sigma 1 for the
  // observing session and 2 for the Earth, the weights are 4 to 1.
  layers[0].vertical_observed = true;
  config.observed_vertical_sigma_uT = 1.0;
  config.earth_vertical_sigma_uT = 2.0;
  const FieldOffsets both = estimateFieldOffsets(layers, config);
  EXPECT_TRUE(both.observed_anchored[0] && both.earth_anchored[0]);
  const double observed_shift = -sum0.offsets[0].vertical_uT;
  EXPECT_NEAR(both.offsets[0].vertical_uT - sum0.offsets[0].vertical_uT,
              (4.0 * observed_shift + 1.0 * earth_shift) / 5.0, 1e-4);
  EXPECT_NEAR(both.offsets[1].vertical_uT - both.offsets[0].vertical_uT, -6.0, 1e-4);
  EXPECT_NE(both.anchor.find("combined"), std::string::npos) << both.anchor;

  // An infinite sigma leaves a reference out: either one alone, as above.
  config.earth_vertical_sigma_uT = std::numeric_limits<double>::infinity();
  EXPECT_NEAR(estimateFieldOffsets(layers, config).offsets[0].vertical_uT, 0.0, 1e-4);
  config.earth_vertical_sigma_uT = 2.0;
  config.observed_vertical_sigma_uT = std::numeric_limits<double>::infinity();
  EXPECT_NEAR(medianVertical(group, estimateFieldOffsets(layers, config)), -45.0, 1e-4);
  config.observed_vertical_sigma_uT = 0.0;
  EXPECT_THROW(estimateFieldOffsets(layers, config), std::invalid_argument);
}

TEST_F(OutputFiles, FusedMagneticMapWritesAndRejectsBadInput) {
  Poses poses;
  const Session s = drivingSession("m1", {0, 0}, {4, 0}, 1.0, Eigen::Vector3d::Zero(),
                                   Eigen::Isometry3d::Identity(), &poses);
  const FusedMagneticMap fused = fuseMagneticMaps({s}, {poses});
  writeMagneticMapPcd(dir_ / "magnetic_map.pcd", fused.map);
  EXPECT_EQ(readMagneticMapPcd(dir_ / "magnetic_map.pcd").coveredCells(), fused.map.coveredCells());
  try {
    fuseMagneticMaps({s}, {Poses(poses.begin() + 1, poses.end())});
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("session 'm1' has"), std::string::npos) << e.what();
  }
  FusedMagneticMapConfig bad;
  bad.sensor_noise_uT = -1.0;
  EXPECT_THROW(fuseMagneticMaps({s}, {poses}, bad), std::invalid_argument);
  EXPECT_THROW(buildMagneticLayer(s, {}, FusedMagneticMapConfig{}), std::invalid_argument);
}

}  // namespace
}  // namespace mm4mm
