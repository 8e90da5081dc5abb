// Point maps: voxel downsampling (density bound, geometry kept, any extent), GICP covariances and
// normals, range filtering, and a simulated session whose map must lie on the world's walls.

#include "mm4mm/geometry/point_map.hpp"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <stdexcept>

#include "mm4mm/core/pose.hpp"
#include "mm4mm/sim/simulator.hpp"

namespace mm4mm {
namespace {

using Voxel = std::array<long long, 3>;

// The voxel of a point, with the float arithmetic of PCL's VoxelGrid (grid aligned at 0).
Voxel voxelOf(const Eigen::Vector3f& p, double voxel_m) {
  const float inverse = 1.0f / static_cast<float>(voxel_m);
  return {static_cast<long long>(std::floor(p.x() * inverse)),
          static_cast<long long>(std::floor(p.y() * inverse)),
          static_cast<long long>(std::floor(p.z() * inverse))};
}

// A session with one keyframe at the identity holding `points`: the scan is then the map's input.
Session oneScanSession(const PointCloud& points) {
  Session session;
  session.id = "test";
  session.rig.magnetometers_body = {Eigen::Vector3d::Zero()};
  session.keyframes.push_back({0.0, Eigen::Isometry3d::Identity()});
  session.scans.push_back(points);
  return session;
}

// Clusters of points scattered over `extent_m`: many points share a voxel.
PointCloud clusteredCloud(int clusters, int per_cluster, double extent_m, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> where(-0.5 * extent_m, 0.5 * extent_m);
  std::uniform_real_distribution<double> height(0.0, 5.0);
  std::uniform_real_distribution<double> jitter(-0.15, 0.15);
  PointCloud cloud;
  for (int c = 0; c < clusters; ++c) {
    const Eigen::Vector3d centre(where(rng), where(rng), height(rng));
    for (int k = 0; k < per_cluster; ++k)
      cloud.push_back(
          (centre + Eigen::Vector3d(jitter(rng), jitter(rng), jitter(rng))).cast<float>());
  }
  return cloud;
}

// Checks the voxel filter's contract on `input` (already in the session frame): one point per
// occupied voxel, each the centroid of that voxel's input points, so every input point lies
// within a voxel diagonal of a kept one.
void expectVoxelCentroids(const PointCloud& input, const PointMap& map, double voxel_m) {
  std::map<Voxel, std::pair<Eigen::Vector3d, int>> expected;
  for (const Eigen::Vector3f& p : input) {
    auto& [sum, count] = expected[voxelOf(p, voxel_m)];
    if (count == 0) sum.setZero();
    sum += p.cast<double>();
    ++count;
  }
  ASSERT_EQ(map.size(), expected.size()) << "not exactly one point per occupied voxel";
  std::map<Voxel, Eigen::Vector3f> kept;
  for (const Eigen::Vector3f& p : map.points) {
    const Voxel v = voxelOf(p, voxel_m);
    ASSERT_TRUE(kept.emplace(v, p).second) << "two points in one voxel";
    const auto found = expected.find(v);
    ASSERT_NE(found, expected.end()) << "a point in an empty voxel";
    const Eigen::Vector3d centroid = found->second.first / found->second.second;
    EXPECT_LT((p.cast<double>() - centroid).norm(), 1e-3) << "not the voxel's centroid";
  }
  // Every input point has a kept point within a voxel diagonal (searching the 27 voxels around).
  const double diagonal = voxel_m * std::sqrt(3.0);
  for (std::size_t i = 0; i < input.size(); i += 7) {
    const Voxel v = voxelOf(input[i], voxel_m);
    double nearest = std::numeric_limits<double>::infinity();
    for (long long dx = -1; dx <= 1; ++dx)
      for (long long dy = -1; dy <= 1; ++dy)
        for (long long dz = -1; dz <= 1; ++dz) {
          const auto found = kept.find({v[0] + dx, v[1] + dy, v[2] + dz});
          if (found != kept.end())
            nearest = std::min(nearest, static_cast<double>((found->second - input[i]).norm()));
        }
    ASSERT_LE(nearest, diagonal) << "input point " << i << " lost";
  }
}

TEST(PointMap, VoxelFilterKeepsOneCentroidPerOccupiedVoxel) {
  const PointCloud input = clusteredCloud(300, 60, 20.0, 1);
  PointMapConfig config;
  config.voxel_size_m = 0.2;
  const PointMap map = buildPointMap(oneScanSession(input), config);
  EXPECT_EQ(map.input_points, input.size());
  EXPECT_LT(map.size(), input.size() / 3);  // it did thin the clusters
  expectVoxelCentroids(input, map, config.voxel_size_m);
}

// 2 km x 2 km at 5 cm is 1.6e12 voxels: PCL's VoxelGrid alone would warn "Leaf size is too small"
// and hand back every input point.
TEST(PointMap, VoxelFilterWorksOnExtentsBeyondPclsIndexRange) {
  const PointCloud input = clusteredCloud(2000, 40, 2000.0, 2);
  PointMapConfig config;
  config.voxel_size_m = 0.05;
  config.max_range_m = 5000.0;
  const PointMap map = buildPointMap(oneScanSession(input), config);
  EXPECT_LT(map.size(), input.size());
  expectVoxelCentroids(input, map, config.voxel_size_m);
}

TEST(PointMap, ScansAreMovedIntoTheSessionFrameByTheirKeyframePoses) {
  // A wall x = 5 m seen from three keyframes with different poses.
  Session session;
  session.rig.magnetometers_body = {Eigen::Vector3d::Zero()};
  const std::array<Eigen::Isometry3d, 3> poses = {planarPose(0.0, 0.0, 0.0),
                                                  planarPose(1.0, 2.0, 0.7),
                                                  poseFromRpy({2.0, -1.0, 0.1}, 0.05, -0.03, -1.2)};
  for (std::size_t k = 0; k < poses.size(); ++k) {
    PointCloud scan;
    for (double y = -3.0; y <= 3.0; y += 0.05)
      for (double z = 0.0; z <= 2.0; z += 0.05)
        scan.push_back((poses[k].inverse() * Eigen::Vector3d(5.0, y, z)).cast<float>());
    session.keyframes.push_back({static_cast<double>(k), poses[k]});
    session.scans.push_back(scan);
  }
  const PointMap map = buildPointMap(session, PointMapConfig{});
  ASSERT_GT(map.size(), 100u);
  for (std::size_t i = 0; i < map.size(); ++i) {
    ASSERT_NEAR(map.points[i].x(), 5.0, 1e-3) << "point " << i;
    EXPECT_GE(map.points[i].y(), -3.0 - 1e-3);
    EXPECT_LE(map.points[i].y(), 3.0 + 1e-3);
  }
}

TEST(PointMap, CovarianceOfAPlaneIsFlatAlongItsNormal) {
  // A plane through (1, 2, 3) tilted about two axes, sampled every 2.5 cm over 4 m x 4 m.
  const Eigen::Vector3d normal = Eigen::Vector3d(0.3, -0.5, 1.0).normalized();
  const Eigen::Vector3d u = normal.unitOrthogonal();
  const Eigen::Vector3d v = normal.cross(u);
  PointCloud plane;
  for (double a = -2.0; a <= 2.0; a += 0.025)
    for (double b = -2.0; b <= 2.0; b += 0.025)
      plane.push_back((Eigen::Vector3d(1, 2, 3) + a * u + b * v).cast<float>());
  PointMapConfig config;
  config.voxel_size_m = 0.1;
  const PointMap map = buildPointMap(oneScanSession(plane), config);
  ASSERT_EQ(map.covariances.size(), map.size());
  ASSERT_EQ(map.normals.size(), map.size());
  int checked = 0;
  for (std::size_t i = 0; i < map.size(); ++i) {
    const Eigen::Vector3d offset = map.points[i].cast<double>() - Eigen::Vector3d(1, 2, 3);
    if (std::abs(offset.dot(u)) > 1.5 || std::abs(offset.dot(v)) > 1.5) continue;  // not at edges
    const Eigen::Matrix3d C = map.covariances[i].cast<double>();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(C);
    EXPECT_GT(std::abs(solver.eigenvectors().col(0).dot(normal)), 0.999) << "point " << i;
    EXPECT_NEAR(solver.eigenvalues()[0], config.covariance_epsilon, 1e-5);
    EXPECT_NEAR(solver.eigenvalues()[1], 1.0, 1e-5);
    EXPECT_NEAR(solver.eigenvalues()[2], 1.0, 1e-5);
    EXPECT_NEAR(map.normals[i].norm(), 1.0f, 1e-5f);
    EXPECT_GT(std::abs(map.normals[i].cast<double>().dot(normal)), 0.999) << "point " << i;
    ++checked;
  }
  EXPECT_GT(checked, 500);
}

TEST(PointMap, ReturnsOutsideTheRangeBandAreDropped) {
  Session session = oneScanSession({});
  session.rig.T_body_lidar.translation() = Eigen::Vector3d(0.0, 0.0, 0.8);
  for (int i = 0; i < 10; ++i) {
    session.scans[0].emplace_back(3.0f + i, 0.0f, 0.8f);    // 3 to 12 m from the LiDAR: kept
    session.scans[0].emplace_back(0.2f, 0.0f, 0.8f);        // 0.2 m: the robot itself
    session.scans[0].emplace_back(200.0f + i, 0.0f, 0.8f);  // beyond max_range_m
  }
  session.scans[0].emplace_back(std::nanf(""), 0.0f, 0.0f);
  PointMapConfig config;
  config.min_range_m = 0.5;
  config.max_range_m = 100.0;
  const PointMap map = buildPointMap(session, config);
  EXPECT_EQ(map.input_points, 10u);
  ASSERT_EQ(map.size(), 10u);
  for (const Eigen::Vector3f& p : map.points) {
    EXPECT_GE(p.x(), 3.0f - 0.2f);
    EXPECT_LE(p.x(), 12.0f + 0.2f);
  }
}

TEST(PointMap, MagneticOnlySessionGivesAnEmptyMap) {
  Session session;
  session.rig.magnetometers_body = {Eigen::Vector3d::Zero()};
  session.keyframes.push_back({0.0, Eigen::Isometry3d::Identity()});
  const PointMap map = buildPointMap(session, PointMapConfig{});
  EXPECT_TRUE(map.empty());
  EXPECT_TRUE(map.covariances.empty());
  EXPECT_EQ(map.input_points, 0u);
}

TEST(PointMap, TooFewNeighboursGiveAnIsotropicCovariance) {
  const PointMap map = buildPointMap(oneScanSession({{1, 0, 0}, {2, 0, 0}}), PointMapConfig{});
  ASSERT_EQ(map.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_TRUE(map.covariances[i].isIdentity(0.0f));
    EXPECT_TRUE(map.normals[i].isZero(0.0f));
  }
}

TEST(PointMap, RejectsInvalidConfigAndMismatchedScans) {
  std::string error;
  PointMapConfig config;
  config.voxel_size_m = 0.0;
  EXPECT_FALSE(config.IsValid(&error));
  EXPECT_NE(error.find("voxel_size_m"), std::string::npos) << error;
  EXPECT_THROW(buildPointMap(oneScanSession({{1, 0, 0}}), config), std::invalid_argument);
  config = PointMapConfig{};
  config.covariance_neighbours = 2;
  EXPECT_FALSE(config.IsValid(&error));
  EXPECT_NE(error.find("covariance_neighbours"), std::string::npos) << error;
  config = PointMapConfig{};
  config.max_range_m = config.min_range_m;
  EXPECT_FALSE(config.IsValid(&error));
  EXPECT_NE(error.find("max_range_m"), std::string::npos) << error;

  Session session = oneScanSession({{1, 0, 0}});
  session.keyframes.push_back({1.0, Eigen::Isometry3d::Identity()});  // 2 keyframes, 1 scan
  EXPECT_THROW(buildPointMap(session, PointMapConfig{}), std::invalid_argument);
}

double distanceToSurface(const sim::World& world, const Eigen::Vector3d& p) {
  double best = std::min(std::abs(p.z()), std::abs(world.ceiling_height_m - p.z()));
  for (const sim::Solid& s : world.solids) {
    const double plan = s.planDistance(p.head<2>());
    const double vertical = std::max({0.0, s.z_min_m - p.z(), p.z() - s.z_max_m});
    best = std::min(best, std::hypot(plan, vertical));
  }
  return best;
}

// A short corridor session mapped at its ground-truth poses: the map then lies in the world frame,
// on the walls, pillars, floor and ceiling, with wall normals across the corridor.
TEST(PointMap, SimulatedCorridorMapLiesOnTheWalls) {
  sim::SimulationConfig config;
  config.world = "corridor";
  config.lidar.azimuth_step_deg = 4.0;
  config.layout.window_length_m = 16.0;
  std::vector<Session> sessions = sim::simulateSessions(config, 1, 11);
  Session& session = sessions.front();
  ASSERT_TRUE(session.ground_truth.has_value());
  session.keyframes = *session.ground_truth;
  const PointMap map = buildPointMap(session, PointMapConfig{});
  ASSERT_GT(map.size(), 1000u);
  EXPECT_GT(map.input_points, 2 * map.size());

  const sim::World world = sim::buildWorld(config, 11);
  const double wall_low_y = world.floor_xy.min().y(), wall_high_y = world.floor_xy.max().y();
  int off_surface = 0, on_low_wall = 0, on_high_wall = 0, wall_normals_across = 0;
  for (std::size_t i = 0; i < map.size(); ++i) {
    const Eigen::Vector3d p = map.points[i].cast<double>();
    // A voxel's centroid lies on a flat surface; 0.1 m is five sigma of the range noise.
    if (distanceToSurface(world, p) > 0.1) ++off_surface;
    const bool low = std::abs(p.y() - wall_low_y) < 0.05,
               high = std::abs(p.y() - wall_high_y) < 0.05;
    if (!(low || high) || p.z() < 0.5 || p.z() > world.ceiling_height_m - 0.5) continue;
    (low ? on_low_wall : on_high_wall)++;
    if (std::abs(map.normals[i].y()) > 0.95f) ++wall_normals_across;
  }
  EXPECT_LT(off_surface, 0.03 * map.size()) << off_surface << " of " << map.size();
  EXPECT_GT(on_low_wall, 50);
  EXPECT_GT(on_high_wall, 50);
  EXPECT_GT(wall_normals_across, 0.95 * (on_low_wall + on_high_wall));

  // The points alone are the map's points, in its order, to the bit: pair refinement uses them in
  // place of the map.
  const PointCloud points = buildVoxelisedPoints(session, PointMapConfig{});
  ASSERT_EQ(points.size(), map.size());
  for (std::size_t i = 0; i < points.size(); ++i)
    ASSERT_EQ(points[i], map.points[i]) << "point " << i;
  PointMapConfig bad;
  bad.voxel_size_m = 0.0;
  EXPECT_THROW(buildVoxelisedPoints(session, bad), std::invalid_argument);
  Session magnetic_only = session;
  magnetic_only.scans.clear();
  EXPECT_TRUE(buildVoxelisedPoints(magnetic_only, PointMapConfig{}).empty());
}

}  // namespace
}  // namespace mm4mm
